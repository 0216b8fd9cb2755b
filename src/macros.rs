//! The crate's declarative helpers: [`byte_enum!`] for the enums a wire or Setup byte codes,
//! and `defmt_raw!` for the defmt `Format` of types whose fields are fixed-point numbers.

/// A fieldless enum coded by one byte: the variants and their bytes are written once, in the
/// enum, and give the `#[repr(u8)]` discriminants, the named decoder `const fn(u8) ->
/// Option<Self>` (`None` for a byte no variant has) and, where one is named, the encoder
/// `const fn(self) -> u8`. The enum is a plain value: `Debug`, `Clone`, `Copy`, `PartialEq`,
/// `Eq`, `Hash` and (with the `defmt` feature) `defmt::Format`; further attributes go on it as
/// written. In the style of smoltcp's `enum_with_unknown!`.
macro_rules! byte_enum {
    (
        $(#[$enum_attr:meta])*
        $enum_vis:vis enum $name:ident {
            $( $(#[$variant_attr:meta])* $variant:ident = $byte:literal, )+
        }
        $(#[$decode_attr:meta])*
        $decode_vis:vis fn $decode:ident;
        $( $(#[$encode_attr:meta])* $encode_vis:vis fn $encode:ident; )?
    ) => {
        $(#[$enum_attr])*
        #[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
        #[cfg_attr(feature = "defmt", derive(defmt::Format))]
        #[repr(u8)]
        $enum_vis enum $name {
            $( $(#[$variant_attr])* $variant = $byte, )+
        }

        impl $name {
            $(#[$decode_attr])*
            #[must_use]
            $decode_vis const fn $decode(byte: u8) -> Option<Self> {
                match byte {
                    $( $byte => Some(Self::$variant), )+
                    _ => None,
                }
            }

            $(
                $(#[$encode_attr])*
                #[must_use]
                $encode_vis const fn $encode(self) -> u8 {
                    self as u8
                }
            )?
        }
    };
}

/// `defmt::Format` for a type whose fields print as their raw fixed-point bits: the format
/// string's parameters take, in order, `self.field.to_bits()` of each field in the first list,
/// then `self.field` of each in the second.
#[cfg(feature = "defmt")]
macro_rules! defmt_raw {
    ($ty:ty, $format:tt, [$($raw:ident),+] $(, [$($plain:ident),+])?) => {
        impl defmt::Format for $ty {
            fn format(&self, f: defmt::Formatter<'_>) {
                defmt::write!(f, $format, $(self.$raw.to_bits()),+ $(, $(self.$plain),+)?);
            }
        }
    };
}
