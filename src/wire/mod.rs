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

mod feed;
pub mod laser;
pub mod ld06;
pub mod link;
pub mod recording;
pub mod rplidar;
pub mod shared_line;
pub mod sick;
mod window;
pub mod ydlidar;

pub use feed::FeedResult;
pub use laser::LaserReturn;
