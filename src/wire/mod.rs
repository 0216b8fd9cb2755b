//! Pure, zero-copy wire formats.
//!
//! Each format is a view over a byte buffer (`Telegram<T: AsRef<[u8]>>`, as smoltcp's
//! `Packet`) plus validated representations (`Repr`-style types with `parse`, `emit` and
//! `buffer_len`), and, where bytes arrive in chunks, an accumulator that reassembles them.
//! Nothing here touches a peripheral, a clock or an allocator.
//!
//! - [`sick`]: the SICK LMS2xx serial telegrams (framing, CRC, measured values, the commands
//!   that bring a scanner up) and the stream reassembly over UART chunks.
//! - [`link`]: the framed, checksummed, versioned host link (`docs/protocol.md`).
//! - [`recording`]: the recording file format (`docs/recording.md`).
//! - [`ld06`], [`rplidar`], [`ydlidar`]: the spinning UART lidars (LDROBOT LD06/LD19/STL-19P,
//!   Slamtec RPLIDAR A1/A2/A3/C1/S, YDLIDAR X4/X2): packet views, commands and resynchronising
//!   accumulators, all decoding to [`LaserReturn`]s in the sensor's own (clockwise) angle
//!   convention ([`laser`]).
//! - [`shared_line`]: one UART carrying both the SICK telegrams and the host link, split at
//!   frame boundaries (a board with a single UART).
//!
//! Every accumulator hands out a [`FeedResult`].
//!
//! # Panic contract
//! No function in this module panics, on any input and on any buffer:
//! - `new_checked` validates a buffer once (length, limits, checksum) and returns an error
//!   instead of a view that could misread;
//! - a view made with `new_unchecked` over a buffer that is too short never panics either: its
//!   accessors read absent bytes as zero and absent slices as empty, so its values are
//!   meaningless until `check_len` (or `new_checked`) has passed;
//! - `parse` returns an error for every field it cannot represent, and `emit` returns an error
//!   when the output buffer is shorter than `buffer_len()`, writing nothing in that case;
//! - the accumulators are bounded by a const generic capacity, count every rejected byte or
//!   frame, and make progress on every call.
//!
//! Clippy denies `unwrap`, `expect`, `panic!`, `unreachable!` and unchecked indexing outside
//! tests, and every arithmetic on a value read from the wire is checked or saturating.

mod check;
mod descriptor;
mod feed;
pub mod laser;
pub mod ld06;
pub mod link;
pub mod recording;
mod resync;
pub mod rplidar;
pub mod shared_line;
pub mod sick;
mod view;
mod window;
pub mod ydlidar;

pub use feed::FeedResult;
pub use laser::LaserReturn;

/// Copies `src` into the start of `dst` (as many bytes as both hold).
///
/// An accumulator copies each UART chunk into its buffer once, and the link's queue each
/// frame on ARMv7-M; the chunk and the buffer's end are at any byte alignment, where the
/// library's `memcpy` takes its misaligned path (shifts and merges of words: about 3.4
/// instructions a byte on a Cortex-M4, 5.5 on a Cortex-M0). ARMv7-M loads and stores a word
/// at any address in one instruction each, so there the bytes go four at a time. ARMv6-M
/// faults on an unaligned word: there `memcpy` keeps the copies whose ends are equally
/// aligned (its word path), and the others go four bytes a step as byte loads and stores,
/// still cheaper than its misaligned path. Same bytes as `copy_from_slice`.
#[inline]
pub(crate) fn copy_bytes(dst: &mut [u8], src: &[u8]) {
    let n = dst.len().min(src.len());
    let (Some(dst), Some(src)) = (dst.get_mut(..n), src.get(..n)) else {
        return;
    };
    // The addresses' low bits only (reading a pointer's address is safe).
    let misaligned = (dst.as_ptr() as usize ^ src.as_ptr() as usize) & 3 != 0;
    if crate::wide::HALVES && !misaligned {
        dst.copy_from_slice(src);
        return;
    }
    let mut to = dst.chunks_exact_mut(4);
    let mut from = src.chunks_exact(4);
    for (d, s) in (&mut to).zip(&mut from) {
        let word = s.first_chunk::<4>().map_or(0, |w| u32::from_ne_bytes(*w));
        if let Some(d) = d.first_chunk_mut::<4>() {
            *d = word.to_ne_bytes();
        }
    }
    // At most three bytes, written out: a loop here becomes a `memcpy` call.
    let (d, s) = (to.into_remainder(), from.remainder());
    for k in [0, 1, 2] {
        if let (Some(d), Some(s)) = (d.get_mut(k), s.get(k)) {
            *d = *s;
        }
    }
}

#[cfg(test)]
mod copy_tests {
    extern crate std;

    use super::copy_bytes;

    #[test]
    fn copy_bytes_is_copy_from_slice_at_every_alignment_and_length() {
        let source: std::vec::Vec<u8> = (0..96_u8).map(|b| b.wrapping_mul(37) ^ 0x5A).collect();
        for from in 0..8 {
            for to in 0..8 {
                for len in 0..40 {
                    let mut got = [0xEE_u8; 64];
                    let mut want = [0xEE_u8; 64];
                    let src = &source[from..from + len];
                    copy_bytes(&mut got[to..to + len], src);
                    want[to..to + len].copy_from_slice(src);
                    assert_eq!(got, want, "{from} {to} {len}");
                    // A shorter destination takes what fits; a shorter source fills the start.
                    let mut short = [0xEE_u8; 64];
                    copy_bytes(&mut short[to..to + len / 2], src);
                    assert_eq!(short[to..to + len / 2], src[..len / 2]);
                    assert!(short[to + len / 2..].iter().all(|&b| b == 0xEE));
                    let mut long = [0xEE_u8; 64];
                    copy_bytes(&mut long[to..to + len + 3], src);
                    assert_eq!(long[to..to + len], *src);
                    assert!(long[to + len..].iter().all(|&b| b == 0xEE));
                }
            }
        }
    }
}
