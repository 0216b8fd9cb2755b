//! One logging shim, as embassy's `fmt.rs`: with the `defmt` feature the macros forward to
//! defmt, without it they compile to nothing (their arguments are still type-checked).
#![allow(unused_macros)]

#[cfg(feature = "defmt")]
macro_rules! trace { ($($t:tt)*) => { ::defmt::trace!($($t)*) }; }
#[cfg(feature = "defmt")]
macro_rules! debug { ($($t:tt)*) => { ::defmt::debug!($($t)*) }; }
#[cfg(feature = "defmt")]
macro_rules! info { ($($t:tt)*) => { ::defmt::info!($($t)*) }; }
#[cfg(feature = "defmt")]
macro_rules! warn { ($($t:tt)*) => { ::defmt::warn!($($t)*) }; }

#[cfg(not(feature = "defmt"))]
macro_rules! trace { ($($t:tt)*) => {{ let _ = || { ::core::format_args!($($t)*); }; }}; }
#[cfg(not(feature = "defmt"))]
macro_rules! debug { ($($t:tt)*) => {{ let _ = || { ::core::format_args!($($t)*); }; }}; }
#[cfg(not(feature = "defmt"))]
macro_rules! info { ($($t:tt)*) => {{ let _ = || { ::core::format_args!($($t)*); }; }}; }
#[cfg(not(feature = "defmt"))]
macro_rules! warn { ($($t:tt)*) => {{ let _ = || { ::core::format_args!($($t)*); }; }}; }
