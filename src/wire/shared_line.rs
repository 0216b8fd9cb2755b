//! One serial line that carries both the laser's SICK LMS2xx telegrams and the host link's
//! frames (`docs/protocol.md`), split at frame boundaries: for a board with a single UART
//! (the BBC micro:bit's nRF51822), whose main computer writes the laser's telegrams onto the
//! line whole, between its own frames, never one inside the other.
//!
//! **The rule.** At a frame boundary (the start of the line, the end of a telegram, a link
//! frame's `0x00` delimiter), the first byte decides:
//! - `0x02` (SICK STX) starts a laser telegram: it and the next three bytes (address, length)
//!   go to the laser, then the length's payload and the two CRC bytes; then a boundary.
//! - Any other byte goes to the host link, up to and including the next `0x00`; then a
//!   boundary. A lone `0x00` (an empty frame, which the protocol allows and ignores) is one.
//!
//! **Why no link frame starts with `0x02`.** A frame on the wire is `COBS(header | body | crc)
//! 0x00`; the header is `version, type, seq`, with version 2 and a type that is never 0. The
//! first COBS code byte is one more than the length of the first run of non-zero bytes, and
//! that run holds at least the version and the type: the code byte is at least 3. (A code
//! byte of 2 would say "one byte, then a zero", i.e. a type 0.) So an STX at a boundary is
//! always a telegram. A future protocol version `v` keeps this as long as its header starts
//! with two non-zero bytes.
//!
//! **When the line is damaged.** A candidate whose address is not the scanner's reply address
//! (`0x80`) or whose length is 0 or above [`MAX_PAYLOAD_LEN`] was no telegram: its bytes up to
//! the bad one went to the laser (whose accumulator counts them), and the line from the bad
//! address byte (or after the bad length) up to the next `0x00` goes to the host link (whose
//! decoder counts a bad frame), where both sides are in step again; counted in
//! [`SharedLineCounters::resyncs`]. A lost byte inside a telegram
//! makes the splitter take the next bytes as the telegram's rest (the laser's CRC fails, the
//! host link loses that frame and resynchronises at its next `0x00`).
//!
//! ```
//! use terrain_pyramid::wire::shared_line::{Route, SharedLine};
//!
//! let mut line = SharedLine::new();
//! // The scanner's reply to "500 kBd", then a host frame (shortened: any bytes up to 0x00).
//! let stream = [0x02, 0x80, 0x03, 0x00, 0xA0, 0x00, 0x10, 0x16, 0x0A, 0x05, 0x02, 0x88, 0x00];
//! let (route, piece, rest) = line.split(&stream).unwrap();
//! assert_eq!((route, piece.len()), (Route::Laser, 9));
//! let (route, piece, rest) = line.split(rest).unwrap();
//! assert_eq!((route, piece), (Route::Host, &stream[9..]));
//! assert!(rest.is_empty() && line.at_boundary());
//! ```

use crate::wire::sick::{ADDRESS_REPLY, CRC_LEN, MAX_PAYLOAD_LEN, STX};

/// Where a piece of the line goes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Route {
    /// To the laser's SICK accumulator.
    Laser,
    /// To the host link's receiver.
    Host,
}

/// What the splitter has seen since it was made. Counters saturate at `u32::MAX`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct SharedLineCounters {
    /// Telegrams routed whole to the laser (their CRC is the accumulator's to check).
    pub telegrams: u32,
    /// Link frames routed to the host, each up to its `0x00` (empty ones included).
    pub frames: u32,
    /// Telegram candidates that were no telegram (address, length): the line was taken back
    /// to the host link up to its next `0x00`.
    pub resyncs: u32,
    /// Bytes routed to the laser.
    pub laser_bytes: u32,
    /// Bytes routed to the host link.
    pub host_bytes: u32,
}

/// Where the splitter is in the line.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum State {
    /// Between frames: the next byte decides.
    Boundary,
    /// Inside a telegram's header: `have` of its 4 bytes seen (1 ..= 3), the
    /// length's low byte once seen.
    Header { have: u8, len_low: u8 },
    /// Inside a telegram's payload and CRC: bytes left.
    Body { left: u16 },
    /// Inside a link frame (or a damaged stretch): up to the next `0x00`.
    Frame,
}

/// The splitter: hand it the line's bytes in any chunks, it hands back pieces and where
/// they go. 6 bytes of state; never panics, on any input.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SharedLine {
    state: State,
    counters: SharedLineCounters,
}

impl Default for SharedLine {
    fn default() -> Self {
        Self::new()
    }
}

impl SharedLine {
    /// A splitter at a frame boundary (the start of the line).
    #[must_use]
    pub const fn new() -> Self {
        Self {
            state: State::Boundary,
            counters: SharedLineCounters {
                telegrams: 0,
                frames: 0,
                resyncs: 0,
                laser_bytes: 0,
                host_bytes: 0,
            },
        }
    }

    /// Whether the splitter is between frames (nothing of a telegram or frame is pending).
    #[must_use]
    pub const fn at_boundary(&self) -> bool {
        matches!(self.state, State::Boundary)
    }

    /// The counters.
    #[must_use]
    pub const fn counters(&self) -> SharedLineCounters {
        self.counters
    }

    /// Splits off the first piece of `bytes` that goes one way: `(route, piece, rest)`, the
    /// piece never empty; `None` when `bytes` is empty. Call it again on `rest` until `None`.
    pub fn split<'a>(&mut self, bytes: &'a [u8]) -> Option<(Route, &'a [u8], &'a [u8])> {
        let &first = bytes.first()?;
        let (route, n) = match self.state {
            State::Boundary if first == STX => {
                self.state = State::Header {
                    have: 1,
                    len_low: 0,
                };
                (
                    Route::Laser,
                    1 + self.telegram(bytes.get(1..).unwrap_or(&[])),
                )
            }
            State::Header { .. } | State::Body { .. } => match self.telegram(bytes) {
                // The first byte was a bad address: it and what follows go to the host link.
                0 => (Route::Host, self.frame(bytes)),
                n => (Route::Laser, n),
            },
            State::Boundary | State::Frame => (Route::Host, self.frame(bytes)),
        };
        // `n` ≥ 1 and ≤ `bytes.len()` on every arm; the fallback only keeps this panic-free.
        let n = n.clamp(1, bytes.len());
        let (piece, rest) = bytes.split_at_checked(n)?;
        let taken = u32::try_from(n).unwrap_or(u32::MAX);
        let count = match route {
            Route::Laser => &mut self.counters.laser_bytes,
            Route::Host => &mut self.counters.host_bytes,
        };
        *count = count.saturating_add(taken);
        Some((route, piece, rest))
    }

    /// Takes the bytes of a link frame (or of a damaged stretch) from `bytes`, up to and
    /// including the next `0x00`; returns how many.
    fn frame(&mut self, bytes: &[u8]) -> usize {
        match bytes.iter().position(|&b| b == 0) {
            Some(at) => {
                self.state = State::Boundary;
                bump(&mut self.counters.frames);
                at + 1
            }
            None => {
                self.state = State::Frame;
                bytes.len()
            }
        }
    }

    /// Takes the bytes of the telegram under way from `bytes` (the state is [`State::Header`]
    /// or [`State::Body`]); returns how many. Moves on to a boundary at the telegram's end, or
    /// back to the host link for a candidate that is no telegram.
    fn telegram(&mut self, bytes: &[u8]) -> usize {
        let mut taken = 0;
        while let (State::Header { have, len_low }, Some(&b)) = (self.state, bytes.get(taken)) {
            taken += 1;
            match have {
                1 if b != ADDRESS_REPLY => {
                    // Not the scanner's: this byte goes to the host link (a 0x00 ends it).
                    taken -= 1;
                    self.resync();
                }
                1 => self.state = State::Header { have: 2, len_low },
                2 => {
                    self.state = State::Header {
                        have: 3,
                        len_low: b,
                    }
                }
                _ => {
                    let payload = u16::from_le_bytes([len_low, b]);
                    if payload == 0 || usize::from(payload) > MAX_PAYLOAD_LEN {
                        self.resync();
                    } else {
                        // At most 812 + 2: no overflow.
                        let crc = u16::try_from(CRC_LEN).unwrap_or(2);
                        self.state = State::Body {
                            left: payload.saturating_add(crc),
                        };
                    }
                }
            }
        }
        if let State::Body { left } = self.state {
            let rest = bytes.len().saturating_sub(taken);
            let n = usize::from(left).min(rest);
            taken += n;
            let left = left.saturating_sub(u16::try_from(n).unwrap_or(u16::MAX));
            if left == 0 {
                self.state = State::Boundary;
                bump(&mut self.counters.telegrams);
            } else {
                self.state = State::Body { left };
            }
        }
        taken
    }

    fn resync(&mut self) {
        self.state = State::Frame;
        bump(&mut self.counters.resyncs);
    }
}

fn bump(counter: &mut u32) {
    *counter = counter.saturating_add(1);
}

#[cfg(test)]
mod tests {
    extern crate std;
    use super::*;
    use crate::wire::link::{encode, Message, PanAngle, MAX_ENCODED_FRAME};
    use crate::wire::sick::{MeasuredValues, Unit};
    use std::vec;
    use std::vec::Vec;

    /// Splits `stream` fed in chunks of `chunk` bytes; returns what went to the laser and to
    /// the host, concatenated.
    fn split_all(stream: &[u8], chunk: usize) -> (Vec<u8>, Vec<u8>, SharedLine) {
        let mut line = SharedLine::new();
        let (mut laser, mut host) = (Vec::new(), Vec::new());
        for mut part in stream.chunks(chunk) {
            while let Some((route, piece, rest)) = line.split(part) {
                assert!(!piece.is_empty());
                match route {
                    Route::Laser => laser.extend_from_slice(piece),
                    Route::Host => host.extend_from_slice(piece),
                }
                part = rest;
            }
        }
        (laser, host, line)
    }

    fn frame(seq: u16, message: &Message<'_>) -> Vec<u8> {
        let mut buf = [0_u8; MAX_ENCODED_FRAME];
        let n = encode(seq, message, &mut buf).unwrap();
        buf[..n].to_vec()
    }

    fn measured(n: usize, mm: u16) -> Vec<u8> {
        let mut values = Vec::new();
        for i in 0..n {
            values.extend_from_slice(&(mm + i as u16).to_le_bytes());
        }
        let m = MeasuredValues::new(Unit::Millimetre, 0, &values, None, 0x10).unwrap();
        let mut buf = vec![0_u8; m.buffer_len()];
        let len = m.emit(&mut buf).unwrap();
        buf.truncate(len);
        buf
    }

    #[test]
    fn interleaved_telegrams_and_frames_split_exactly_in_any_chunks() {
        // The manual's own reply to "500 kBd" (docs/sick-lms2xx.md: 02 80 03 00 A0 00 10, CRC
        // 0A16), measured values of 361 and 181 beams, and host frames between them, with
        // sequence numbers that put zeros right after the header's first two bytes.
        let reply = vec![0x02, 0x80, 0x03, 0x00, 0xA0, 0x00, 0x10, 0x16, 0x0A];
        let telegrams = [reply, measured(361, 500), measured(181, 0x0200)];
        let pan = Message::PanAngle(PanAngle {
            turns: 0x0200,
            timestamp_ms: 2,
        });
        let frames = [
            frame(0, &Message::Ping),
            frame(0x0200, &pan),
            frame(2, &Message::RequestStats),
            vec![0x00],
            frame(0xFFFF, &Message::EndObservation),
        ];
        let mut stream = Vec::new();
        let (mut want_laser, mut want_host) = (Vec::new(), Vec::new());
        for (i, f) in frames.iter().enumerate() {
            stream.extend_from_slice(f);
            want_host.extend_from_slice(f);
            if let Some(t) = telegrams.get(i) {
                stream.extend_from_slice(t);
                want_laser.extend_from_slice(t);
            }
        }
        for chunk in [1, 2, 3, 5, 7, 64, 733, stream.len()] {
            let (laser, host, line) = split_all(&stream, chunk);
            assert_eq!(laser, want_laser, "chunks of {chunk}");
            assert_eq!(host, want_host, "chunks of {chunk}");
            let c = line.counters();
            assert_eq!((c.telegrams, c.frames, c.resyncs), (3, 5, 0));
            assert_eq!(c.laser_bytes as usize + c.host_bytes as usize, stream.len());
            assert!(line.at_boundary());
        }
    }

    #[test]
    fn no_host_frame_starts_with_stx() {
        // Every command type of version 2, at every sequence number.
        let pan = Message::PanAngle(PanAngle {
            turns: 0,
            timestamp_ms: 0,
        });
        let messages = [
            Message::Ping,
            Message::RequestStats,
            Message::Reset,
            Message::Shutdown,
            Message::EndObservation,
            pan,
        ];
        for m in &messages {
            for seq in 0..=u16::MAX {
                let f = frame(seq, m);
                assert!(f[0] >= 3, "{m:?} at seq {seq} starts with {:#04x}", f[0]);
            }
        }
    }

    #[test]
    fn a_candidate_that_is_no_telegram_goes_back_to_the_host_link() {
        let ping = frame(7, &Message::Ping);
        let t = measured(5, 100);
        // (candidate, bytes of it the laser takes, resyncs)
        let cases: [(&[u8], usize, u32); 3] = [
            // A request (address 0, docs/sick-lms2xx.md): STX to the laser; its address byte
            // 0x00 ends a (bad) host frame; then "02 00" is a candidate again, and so on.
            (&[0x02, 0x00, 0x02, 0x00, 0x20, 0x24, 0x34, 0x08], 2, 2),
            (&[0x02, 0x80, 0x00, 0x00, 0x11, 0x22], 4, 1), // length 0
            (&[0x02, 0x80, 0x2D, 0x03, 0x11, 0x22], 4, 1), // length 813
        ];
        for (bad, to_laser, resyncs) in cases {
            let mut stream = bad.to_vec();
            stream.push(0x00);
            stream.extend_from_slice(&ping);
            stream.extend_from_slice(&t);
            for chunk in [1, 4, stream.len()] {
                let (laser, host, line) = split_all(&stream, chunk);
                assert_eq!(laser.len(), to_laser + t.len(), "{bad:02x?}");
                assert!(laser.ends_with(&t) && host.ends_with(&ping));
                assert_eq!(laser.len() + host.len(), stream.len());
                let c = line.counters();
                assert_eq!((c.telegrams, c.resyncs), (1, resyncs), "{bad:02x?}");
                assert!(line.at_boundary());
            }
        }
    }

    #[test]
    fn the_largest_telegram_and_any_bytes_never_panic() {
        let mut big = vec![0x02, 0x80, 0x2C, 0x03];
        big.extend(std::iter::repeat_n(0xAB, 812 + 2));
        let (laser, host, line) = split_all(&big, 100);
        assert_eq!((laser.len(), host.len()), (big.len(), 0));
        assert!(line.at_boundary());
        // Pseudo-random bytes: every byte goes somewhere, exactly once.
        let mut x: u32 = 1;
        let noise: Vec<u8> = (0..20_000)
            .map(|_| {
                x = x.wrapping_mul(1_103_515_245).wrapping_add(12_345);
                (x >> 16) as u8
            })
            .collect();
        let (laser, host, _) = split_all(&noise, 37);
        assert_eq!(laser.len() + host.len(), noise.len());
    }
}
