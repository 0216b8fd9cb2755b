//! The SICK `LMS2xx` over a UART: telegrams out of any [`embedded_io::Read`].
//!
//! [`SickUart`] owns the reader, a small read buffer of `C` bytes and an
//! [`SickAccumulator`]. A board's main loop calls [`SickUart::poll`]: it hands out the next event
//! the bytes already read complete, and only when they complete none does it call
//! [`Read::read`] once, so one poll blocks at most as long as one read. (`embedded_io::Read`
//! blocks until at least one byte is available; a board that must never wait checks
//! `embedded_io::ReadReady` before polling, or reads from an interrupt-fed buffer.)
//!
//! Requests go the other way through the same UART: [`SickUart::reader_mut`] gives the
//! reader (or the serial port, when it also implements `Write`) to send
//! [`crate::wire::sick::Request`] bytes with.

use crate::wire::sick::{
    SickAccumulator, SickCounters, SickFrameError, SickItem, Telegram, DEFAULT_CAPACITY,
};
use crate::wire::FeedResult;
use core::fmt;
use embedded_io::{Error as _, ErrorKind, Read};

/// The default read buffer, bytes: one `read` call takes up to this many.
pub const DEFAULT_CHUNK: usize = 32;

/// An event of the byte stream.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Event<'a> {
    /// A valid reply telegram (header `02 80`, CRC checked), borrowing the accumulator's
    /// buffer until the next poll.
    Telegram(Telegram<&'a [u8]>),
    /// A lone ACK byte (0x06): the scanner accepted a request; its reply follows.
    Ack,
    /// A lone NAK byte (0x15): the scanner refused a request.
    Nak,
    /// A candidate telegram was rejected (and counted in [`SickCounters`]).
    Rejected(SickFrameError),
}

/// Why a poll could not proceed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum UartError {
    /// `Read::read` failed; the error's kind.
    Read(ErrorKind),
    /// `Read::read` returned no bytes: the reader is at its end (a file or a closed port).
    EndOfStream,
}

impl fmt::Display for UartError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Read(kind) => write!(f, "UART read failed: {kind:?}"),
            Self::EndOfStream => f.write_str("UART stream ended"),
        }
    }
}

impl core::error::Error for UartError {}

// embedded-io 0.6 formats `ErrorKind` for defmt 0.3 only: print it through `Debug`.
#[cfg(feature = "defmt")]
impl defmt::Format for UartError {
    fn format(&self, f: defmt::Formatter<'_>) {
        match self {
            Self::Read(kind) => defmt::write!(f, "UART read failed: {}", defmt::Debug2Format(kind)),
            Self::EndOfStream => defmt::write!(f, "UART stream ended"),
        }
    }
}

/// What a drained event was, without the borrow.
#[derive(Clone, Copy)]
enum Kind {
    Telegram,
    Ack,
    Nak,
    Rejected(SickFrameError),
}

/// `LMS2xx` telegrams from a reader: a read buffer of `C` bytes (default [`DEFAULT_CHUNK`])
/// feeding an [`SickAccumulator`] of `N` bytes (default [`DEFAULT_CAPACITY`], the largest
/// telegram). No allocation; about `N + C` bytes of RAM plus the reader.
#[derive(Debug)]
pub struct SickUart<R, const N: usize = DEFAULT_CAPACITY, const C: usize = DEFAULT_CHUNK> {
    reader: R,
    accumulator: SickAccumulator<N>,
    chunk: [u8; C],
    /// Unfed bytes of `chunk`: `head..tail`.
    head: usize,
    tail: usize,
}

impl<R: Read, const N: usize, const C: usize> SickUart<R, N, C> {
    const CHUNK_OK: () = assert!(C > 0, "the read buffer needs at least one byte");

    /// Wraps a reader.
    pub fn new(reader: R) -> Self {
        let () = Self::CHUNK_OK;
        Self {
            reader,
            accumulator: SickAccumulator::new(),
            chunk: [0; C],
            head: 0,
            tail: 0,
        }
    }

    /// The next event: from the bytes already read if they complete one, otherwise after one
    /// `read`. `Ok(None)` when the bytes read so far complete nothing yet: poll again.
    ///
    /// # Errors
    /// [`UartError::Read`] with the kind of the reader's error, [`UartError::EndOfStream`]
    /// when `read` returns 0 bytes. The bytes already buffered are kept; polling again retries.
    pub fn poll(&mut self) -> Result<Option<Event<'_>>, UartError> {
        let kind = if let Some(kind) = self.drain() {
            kind
        } else {
            self.fill()?;
            let Some(kind) = self.drain() else {
                return Ok(None);
            };
            kind
        };
        Ok(Some(match kind {
            Kind::Telegram => Event::Telegram(self.delivered()),
            Kind::Ack => Event::Ack,
            Kind::Nak => Event::Nak,
            Kind::Rejected(error) => Event::Rejected(error),
        }))
    }

    /// Polls until a telegram arrives, skipping (and counting) everything else.
    ///
    /// # Errors
    /// As [`poll`](Self::poll).
    pub fn next_telegram(&mut self) -> Result<Telegram<&[u8]>, UartError> {
        loop {
            let Some(kind) = self.drain() else {
                self.fill()?;
                continue;
            };
            if matches!(kind, Kind::Telegram) {
                return Ok(self.delivered());
            }
        }
    }

    /// The accumulator's counters.
    #[must_use]
    pub fn stats(&self) -> SickCounters {
        self.accumulator.stats()
    }

    /// Bytes fed to the accumulator so far (wrapping at 2⁶⁴): every byte `read` returned,
    /// once the poll that read it has handed out its events.
    #[must_use]
    pub const fn position(&self) -> u64 {
        self.accumulator.position()
    }

    /// The accumulator, to flush it at the end of a stream, reset it after a baud-rate change,
    /// or clear its counters.
    pub fn accumulator_mut(&mut self) -> &mut SickAccumulator<N> {
        &mut self.accumulator
    }

    /// The reader, to send requests through it when it is the serial port.
    pub fn reader_mut(&mut self) -> &mut R {
        &mut self.reader
    }

    /// Unwraps the reader; bytes read and not yet resolved are dropped.
    pub fn into_inner(self) -> R {
        self.reader
    }

    /// Feeds the unfed bytes until an event, and records how far it got.
    fn drain(&mut self) -> Option<Kind> {
        let window = self.chunk.get(self.head..self.tail).unwrap_or(&[]);
        let result = self.accumulator.feed(window);
        let left = result.remaining().len();
        let kind = match result {
            FeedResult::Consumed => None,
            FeedResult::Item { item, .. } => Some(match item {
                SickItem::Telegram(_) => Kind::Telegram,
                SickItem::Ack => Kind::Ack,
                SickItem::Nak => Kind::Nak,
            }),
            FeedResult::Rejected { error, .. } => Some(Kind::Rejected(error)),
        };
        self.head = self.tail.saturating_sub(left);
        kind
    }

    /// Reads once into the (fully fed) read buffer.
    fn fill(&mut self) -> Result<(), UartError> {
        let n = self
            .reader
            .read(&mut self.chunk)
            .map_err(|e| UartError::Read(e.kind()))?;
        if n == 0 {
            return Err(UartError::EndOfStream);
        }
        self.head = 0;
        self.tail = n.min(C);
        Ok(())
    }

    /// The telegram the last drain delivered (an empty view if none, which cannot happen).
    fn delivered(&self) -> Telegram<&[u8]> {
        self.accumulator
            .telegram()
            .unwrap_or(Telegram::new_unchecked(&[]))
    }
}

#[cfg(test)]
mod tests {
    extern crate std;

    use super::*;
    use crate::wire::sick::{MeasuredValues, OperatingModeReply, Unit, VariantReply};
    use std::vec;
    use std::vec::Vec;

    #[derive(Debug)]
    struct FakeError;

    impl embedded_io::Error for FakeError {
        fn kind(&self) -> ErrorKind {
            ErrorKind::TimedOut
        }
    }

    /// Serves a byte slice in chunks of the given sizes (cycled), then an error if asked,
    /// then end of stream.
    struct FakeReader<'a> {
        data: &'a [u8],
        sizes: Vec<usize>,
        calls: usize,
        fail_at_end: bool,
    }

    impl embedded_io::ErrorType for FakeReader<'_> {
        type Error = FakeError;
    }

    impl Read for FakeReader<'_> {
        fn read(&mut self, buf: &mut [u8]) -> Result<usize, FakeError> {
            if self.data.is_empty() {
                if self.fail_at_end {
                    self.fail_at_end = false;
                    return Err(FakeError);
                }
                return Ok(0);
            }
            let want = self.sizes[self.calls % self.sizes.len()];
            self.calls += 1;
            let n = want.min(buf.len()).min(self.data.len());
            buf[..n].copy_from_slice(&self.data[..n]);
            self.data = &self.data[n..];
            Ok(n)
        }
    }

    fn stream() -> (Vec<u8>, Vec<Vec<u8>>) {
        let mut a0 = vec![0u8; 9];
        OperatingModeReply {
            result: 0,
            status: 0x10,
        }
        .emit(&mut a0)
        .unwrap();
        let mut bb = vec![0u8; 13];
        VariantReply {
            result: 1,
            angle_deg: 180,
            resolution_centideg: 50,
            status: 0x10,
        }
        .emit(&mut bb)
        .unwrap();
        let values: Vec<u8> = (0..361u16)
            .flat_map(|i| (0x2000 | i).to_le_bytes())
            .collect();
        let m = MeasuredValues::new(Unit::Millimetre, 0, &values, None, 0x10).unwrap();
        let mut b0 = vec![0u8; m.buffer_len()];
        m.emit(&mut b0).unwrap();
        let mut s = vec![0x55, 0x06];
        s.extend_from_slice(&a0);
        s.extend_from_slice(&[0x02, 0x80, 0x00, 0x00, 0x06]);
        s.extend_from_slice(&bb);
        s.extend_from_slice(&[0x15, 0x99]);
        s.extend_from_slice(&b0[..200]);
        s.extend_from_slice(&b0);
        (s, vec![a0, bb, b0])
    }

    #[derive(Debug, PartialEq)]
    enum Seen {
        T(Vec<u8>),
        Ack,
        Nak,
        R(SickFrameError),
    }

    fn poll_all<const C: usize>(sizes: &[usize]) -> (Vec<Seen>, SickCounters, UartError) {
        let (data, _) = stream();
        let reader = FakeReader {
            data: &data,
            sizes: sizes.to_vec(),
            calls: 0,
            fail_at_end: false,
        };
        let mut uart: SickUart<_, DEFAULT_CAPACITY, C> = SickUart::new(reader);
        let mut seen = Vec::new();
        loop {
            match uart.poll() {
                Ok(None) => {}
                Ok(Some(Event::Telegram(t))) => seen.push(Seen::T(t.as_bytes().to_vec())),
                Ok(Some(Event::Ack)) => seen.push(Seen::Ack),
                Ok(Some(Event::Nak)) => seen.push(Seen::Nak),
                Ok(Some(Event::Rejected(e))) => seen.push(Seen::R(e)),
                Err(e) => return (seen, uart.stats(), e),
            }
        }
    }

    #[test]
    fn polls_every_event_in_order_whatever_the_chunking() {
        let (_, telegrams) = stream();
        let expected = vec![
            Seen::Ack,
            Seen::T(telegrams[0].clone()),
            Seen::R(SickFrameError::BadLength { len: 0 }),
            Seen::Ack,
            Seen::T(telegrams[1].clone()),
            Seen::Nak,
            Seen::R(SickFrameError::Truncated),
            Seen::T(telegrams[2].clone()),
        ];
        for sizes in [&[1][..], &[3, 1, 7], &[64], &[usize::MAX]] {
            let (seen, stats, end) = poll_all::<DEFAULT_CHUNK>(sizes);
            assert_eq!(seen, expected, "{sizes:?}");
            assert_eq!(end, UartError::EndOfStream);
            assert_eq!(stats.telegrams_ok, 3);
            assert_eq!(stats.length_errors, 1);
            assert_eq!(stats.truncated, 1);
            assert_eq!(stats.garbage_bytes, 2);
            let (seen, _, _) = poll_all::<1>(sizes);
            assert_eq!(seen, expected, "{sizes:?}, one-byte buffer");
        }
    }

    #[test]
    fn next_telegram_skips_everything_else() {
        let (data, telegrams) = stream();
        let reader = FakeReader {
            data: &data,
            sizes: vec![5],
            calls: 0,
            fail_at_end: true,
        };
        let mut uart: SickUart<_> = SickUart::new(reader);
        for t in &telegrams {
            assert_eq!(uart.next_telegram().unwrap().as_bytes(), &t[..]);
        }
        assert_eq!(
            uart.next_telegram().map(|t| t.as_bytes().len()),
            Err(UartError::Read(ErrorKind::TimedOut))
        );
        assert_eq!(
            uart.next_telegram().map(|t| t.as_bytes().len()),
            Err(UartError::EndOfStream)
        );
        assert_eq!(uart.stats().ack, 2);
        assert_eq!(uart.stats().nak, 1);
    }

    #[test]
    fn read_errors_keep_the_buffered_bytes() {
        let (_, telegrams) = stream();
        let a0 = &telegrams[0];
        let reader = FakeReader {
            data: &a0[..4],
            sizes: vec![4, 16],
            calls: 0,
            fail_at_end: true,
        };
        let mut uart: SickUart<_> = SickUart::new(reader);
        assert_eq!(uart.poll().map(|e| e.is_some()), Ok(false));
        assert_eq!(
            uart.poll().map(|e| e.is_some()),
            Err(UartError::Read(ErrorKind::TimedOut))
        );
        // The rest arrives later on the same port.
        uart.reader_mut().data = &a0[4..];
        let got = match uart.poll() {
            Ok(Some(Event::Telegram(t))) => t.as_bytes().to_vec(),
            other => panic!("{other:?}"),
        };
        assert_eq!(&got, a0);
        assert_eq!(uart.accumulator_mut().stats().telegrams_ok, 1);
        let _ = uart.into_inner();
    }

    #[test]
    fn errors_display() {
        use std::string::ToString;
        assert_eq!(UartError::EndOfStream.to_string(), "UART stream ended");
        assert_eq!(
            UartError::Read(ErrorKind::TimedOut).to_string(),
            "UART read failed: TimedOut"
        );
    }
}
