//! The f64 reference.
pub mod classify;
