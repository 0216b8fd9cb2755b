//! What the SICK modules' tests share.

extern crate std;

use super::Error;
use std::vec::Vec;

/// The bytes `emit` (a unit's `emit`) writes into a buffer with room to spare, checked to be
/// the `len` bytes the unit announces (its `buffer_len`).
pub(super) fn emitted(len: usize, emit: impl FnOnce(&mut [u8]) -> Result<usize, Error>) -> Vec<u8> {
    let mut buf = std::vec![0_u8; len + 16];
    let n = emit(&mut buf).unwrap();
    assert_eq!(n, len);
    buf.truncate(n);
    buf
}
