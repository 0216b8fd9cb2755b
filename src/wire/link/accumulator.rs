//! Reassembles frames from byte chunks, after postcard's `accumulator.rs`: feed it whatever the
//! UART delivered, get back at most one frame (or one error) and the bytes it did not consume.

use super::cobs::{Decoder, Step};
use super::message::decode;
use super::{DecodeError, Header, Message};
use crate::wire::FeedResult;

/// Counters of what a [`FrameAccumulator`] saw. They saturate.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct RxCounters {
    /// Frames decoded whole.
    pub frames_ok: u32,
    /// Frames with bad COBS.
    pub cobs: u32,
    /// Frames with a CRC mismatch.
    pub crc: u32,
    /// Frames shorter than a header and a CRC.
    pub too_short: u32,
    /// Frames longer than the buffer.
    pub too_long: u32,
    /// Frames of another protocol version.
    pub unknown_version: u32,
    /// Frames of an unknown type.
    pub unknown_type: u32,
    /// Frames whose body length does not fit their type.
    pub bad_body: u32,
    /// Frames with a field out of range.
    pub out_of_range: u32,
}

impl RxCounters {
    /// Counts one error by its kind.
    pub fn count(&mut self, error: &DecodeError) {
        let counter = match error {
            DecodeError::Cobs => &mut self.cobs,
            DecodeError::Crc { .. } => &mut self.crc,
            DecodeError::TooShort { .. } => &mut self.too_short,
            DecodeError::TooLong { .. } => &mut self.too_long,
            DecodeError::UnknownVersion(_) => &mut self.unknown_version,
            DecodeError::UnknownType(_) => &mut self.unknown_type,
            DecodeError::BadBody { .. } => &mut self.bad_body,
            DecodeError::OutOfRange { .. } => &mut self.out_of_range,
        };
        *counter = counter.saturating_add(1);
    }

    /// Every bad frame, whatever its kind.
    #[must_use]
    pub const fn errors(&self) -> u32 {
        self.cobs
            .saturating_add(self.crc)
            .saturating_add(self.too_short)
            .saturating_add(self.too_long)
            .saturating_add(self.unknown_version)
            .saturating_add(self.unknown_type)
            .saturating_add(self.bad_body)
            .saturating_add(self.out_of_range)
    }
}

/// A frame that decoded whole: its header and its message, borrowing the accumulator's
/// buffer until the next call.
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Decoded<'a> {
    /// Its header.
    pub header: Header,
    /// Its message.
    pub message: Message<'a>,
}

/// A frame that ended and was refused (and counted).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Undecoded {
    /// Why.
    pub error: DecodeError,
    /// Its header, when the CRC and version were good.
    pub header: Option<Header>,
}

/// What one [`FrameAccumulator::feed`] did: the generic [`FeedResult`] with [`Decoded`]
/// frames and [`Undecoded`] refusals; `offset` is the stream position of the frame's first
/// byte, `remaining` the input after its delimiter.
pub type FrameFeed<'a, 'b> = FeedResult<'b, Decoded<'a>, Undecoded>;

/// Reassembles frames of at most `N` decoded bytes (header, body, CRC) from a byte stream,
/// decoding COBS as the bytes arrive. A frame that outgrows `N` is refused as too long when
/// its delimiter comes; every error resynchronises on the next `0x00`.
#[derive(Debug, Clone)]
pub struct FrameAccumulator<const N: usize> {
    buf: [u8; N],
    len: usize,
    overflow: bool,
    cobs: Decoder,
    counters: RxCounters,
    /// Bytes taken so far (wrapping): the stream position of the next byte.
    consumed: u64,
    /// The stream position of the current frame's first byte.
    frame_start: u64,
}

impl<const N: usize> Default for FrameAccumulator<N> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const N: usize> FrameAccumulator<N> {
    /// An empty accumulator. `const`, for a `static`.
    #[must_use]
    pub const fn new() -> Self {
        Self {
            buf: [0; N],
            len: 0,
            overflow: false,
            cobs: Decoder::new(),
            counters: RxCounters {
                frames_ok: 0,
                cobs: 0,
                crc: 0,
                too_short: 0,
                too_long: 0,
                unknown_version: 0,
                unknown_type: 0,
                bad_body: 0,
                out_of_range: 0,
            },
            consumed: 0,
            frame_start: 0,
        }
    }

    /// What it has seen so far.
    #[must_use]
    pub const fn counters(&self) -> RxCounters {
        self.counters
    }

    /// Forgets a partial frame (e.g. after the port was reopened).
    pub fn reset(&mut self) {
        self.len = 0;
        self.overflow = false;
        self.cobs = Decoder::new();
    }

    /// Bytes taken since the accumulator was made (wrapping at 2⁶⁴): the stream position of
    /// the next byte fed.
    #[must_use]
    pub const fn position(&self) -> u64 {
        self.consumed
    }

    /// Takes bytes until a frame ends or the input runs out. Call again with `remaining`
    /// until it answers [`FeedResult::Consumed`].
    pub fn feed<'a, 'b>(&'a mut self, input: &'b [u8]) -> FrameFeed<'a, 'b> {
        for (i, &byte) in input.iter().enumerate() {
            let idle = self.cobs.is_idle();
            if idle {
                self.frame_start = self.consumed;
            }
            self.consumed = self.consumed.wrapping_add(1);
            match self.cobs.step(byte) {
                Step::None => {}
                Step::Byte(b) => match self.buf.get_mut(self.len) {
                    Some(slot) => {
                        *slot = b;
                        self.len += 1;
                    }
                    None => self.overflow = true,
                },
                Step::End if idle => {
                    // An empty frame: a spare delimiter, not an error.
                }
                end @ (Step::End | Step::Error) => {
                    let remaining = input.get(i + 1..).unwrap_or(&[]);
                    let len = core::mem::take(&mut self.len);
                    let overflow = core::mem::take(&mut self.overflow);
                    let Self { buf, counters, .. } = self;
                    let result = if overflow {
                        Err((DecodeError::TooLong { max: N }, None))
                    } else if end == Step::Error {
                        Err((DecodeError::Cobs, None))
                    } else {
                        decode(buf.get(..len).unwrap_or(&[]))
                    };
                    let offset = self.frame_start;
                    return match result {
                        Ok((header, message)) => {
                            counters.frames_ok = counters.frames_ok.saturating_add(1);
                            FeedResult::Item {
                                item: Decoded { header, message },
                                offset,
                                remaining,
                            }
                        }
                        Err((error, header)) => {
                            counters.count(&error);
                            FeedResult::Rejected {
                                error: Undecoded { error, header },
                                offset,
                                remaining,
                            }
                        }
                    };
                }
            }
        }
        FeedResult::Consumed
    }
}
