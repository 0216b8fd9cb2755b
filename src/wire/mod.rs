//! Pure, zero-copy wire formats.
