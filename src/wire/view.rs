//! What the fixed-length wire views share (an LD06 packet, an RPLIDAR node, capsule or
//! response descriptor): a struct over a buffer `T: AsRef<[u8]>` whose unit is a known number
//! of bytes, with the same constructors and accessors.

/// A fixed-length view, written once: the struct `$name<T: AsRef<[u8]>>` over its `buffer`
/// (with the docs given), and `new_unchecked`, `new_checked` (with the docs given: the buffer
/// checked by `check_len`, then by each of the view's `$check` methods in turn),
/// `check_len` (refusing a buffer shorter than `$len` bytes with `$error::Truncated`),
/// `into_inner`, `as_bytes` (the first `$len` bytes, or the whole buffer when it is shorter)
/// and the private `byte` (a byte of the buffer, 0 when absent). `$unit` names the view's
/// unit in the docs. The view's own accessors go in an `impl` block of their own.
macro_rules! fixed_view {
    (
        $(#[$attr:meta])*
        pub struct $name:ident: $len:ident bytes, a $unit:literal, refused with $error:ident;
        $(#[$checked_attr:meta])*
        fn new_checked: $($check:ident),+;
    ) => {
        $(#[$attr])*
        #[derive(Debug, Clone, Copy, PartialEq, Eq)]
        #[cfg_attr(feature = "defmt", derive(defmt::Format))]
        pub struct $name<T: AsRef<[u8]>> {
            buffer: T,
        }

        impl<T: AsRef<[u8]>> $name<T> {
            /// Wraps a buffer without checking it.
            pub const fn new_unchecked(buffer: T) -> Self {
                Self { buffer }
            }

            $(#[$checked_attr])*
            pub fn new_checked(buffer: T) -> Result<Self, $error> {
                let view = Self::new_unchecked(buffer);
                view.check_len()?;
                $(view.$check()?;)+
                Ok(view)
            }

            #[doc = concat!(
                "Checks that the buffer holds a whole ", $unit, " ([`", stringify!($len),
                "`] bytes)."
            )]
            ///
            /// # Errors
            #[doc = concat!("[`", stringify!($error), "::Truncated`] when it is shorter.")]
            pub fn check_len(&self) -> Result<(), $error> {
                $crate::wire::check::at_least(self.buffer.as_ref(), $len, $error::Truncated)
            }

            /// Unwraps the buffer.
            #[must_use]
            pub fn into_inner(self) -> T {
                self.buffer
            }

            #[doc = concat!(
                "The ", $unit, "'s [`", stringify!($len), "`] bytes (the whole buffer when ",
                "shorter)."
            )]
            pub fn as_bytes(&self) -> &[u8] {
                let data = self.buffer.as_ref();
                data.get(..$len).unwrap_or(data)
            }

            /// Byte `at` of the buffer; 0 when absent.
            fn byte(&self, at: usize) -> u8 {
                self.buffer.as_ref().get(at).copied().unwrap_or(0)
            }
        }
    };
}
pub(crate) use fixed_view;
