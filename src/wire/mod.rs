//! Pure, zero-copy wire formats.
pub mod recording;
