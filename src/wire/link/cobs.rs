//! Consistent Overhead Byte Stuffing, as `docs/protocol.md` section 3 specifies it: a streaming
//! encoder that writes into a slice, and a streaming decoder that takes one byte at a time.

/// The most bytes that `len` bytes encode to, without the delimiter: `len + ⌊len/254⌋ + 1`.
#[must_use]
pub const fn max_encoded_len(len: usize) -> usize {
    len + len / 254 + 1
}

/// A COBS encoder over an output slice. Bytes that do not fit are counted as overflow, never
/// written out of bounds.
#[derive(Debug)]
pub struct Encoder<'a> {
    out: &'a mut [u8],
    /// Where the current block's code byte goes.
    code_pos: usize,
    /// Where the next data byte goes.
    pos: usize,
    /// The current block's code: 1 + its data bytes so far.
    code: u8,
    overflow: bool,
}

impl<'a> Encoder<'a> {
    /// Starts encoding into `out`.
    pub fn new(out: &'a mut [u8]) -> Self {
        Self {
            out,
            code_pos: 0,
            pos: 1,
            code: 1,
            overflow: false,
        }
    }

    fn write(&mut self, at: usize, byte: u8) {
        match self.out.get_mut(at) {
            Some(slot) => *slot = byte,
            None => self.overflow = true,
        }
    }

    fn close_block(&mut self) {
        self.write(self.code_pos, self.code);
        self.code_pos = self.pos;
        self.pos = self.pos.saturating_add(1);
        self.code = 1;
    }

    /// Encodes one byte.
    #[inline]
    pub fn push(&mut self, byte: u8) {
        if byte == 0 {
            self.close_block();
        } else {
            self.write(self.pos, byte);
            self.pos = self.pos.saturating_add(1);
            self.code += 1;
            if self.code == 0xFF {
                self.close_block();
            }
        }
    }

    /// Encodes bytes.
    pub fn push_all(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.push(b);
        }
    }

    /// Closes the last block and appends the `0x00` delimiter. Returns the bytes written, or
    /// `Err(needed)` when the output was too small.
    ///
    /// # Errors
    /// The output slice could not hold the frame; the value is the length it needed.
    pub fn finish(mut self) -> Result<usize, usize> {
        self.write(self.code_pos, self.code);
        self.write(self.pos, 0);
        let len = self.pos.saturating_add(1);
        if self.overflow {
            Err(len)
        } else {
            Ok(len)
        }
    }
}

/// What one byte did to a [`Decoder`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Step {
    /// Nothing to output.
    None,
    /// One decoded byte.
    Byte(u8),
    /// The delimiter ended a well-formed frame.
    End,
    /// The delimiter ended a frame whose last block was cut short.
    Error,
}

/// A streaming COBS decoder: feed it every byte, delimiters included.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Decoder {
    /// Data bytes left in the current block.
    remaining: u8,
    /// The current block's code (0 before the first block of a frame).
    code: u8,
}

impl Decoder {
    /// A decoder at the start of a frame.
    #[must_use]
    pub const fn new() -> Self {
        Self {
            remaining: 0,
            code: 0,
        }
    }

    /// Whether the decoder is at the very start of a frame (nothing seen since a delimiter).
    #[must_use]
    pub const fn is_idle(&self) -> bool {
        self.code == 0
    }

    /// Takes one encoded byte. A decoded zero between blocks comes out as `Byte(0)` when the
    /// next block's code byte arrives.
    #[inline]
    pub fn step(&mut self, byte: u8) -> Step {
        if byte == 0 {
            let cut_short = self.remaining != 0;
            *self = Self::new();
            return if cut_short { Step::Error } else { Step::End };
        }
        if self.remaining > 0 {
            self.remaining -= 1;
            return Step::Byte(byte);
        }
        let implied_zero = self.code != 0 && self.code != 0xFF;
        self.code = byte;
        self.remaining = byte - 1;
        if implied_zero {
            Step::Byte(0)
        } else {
            Step::None
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    extern crate std;
    use std::vec::Vec;

    fn encode(data: &[u8]) -> Vec<u8> {
        let mut out = [0_u8; 1200];
        let mut enc = Encoder::new(&mut out);
        enc.push_all(data);
        let n = enc.finish().unwrap();
        out[..n].to_vec()
    }

    fn decode(encoded: &[u8]) -> Result<Vec<u8>, ()> {
        let mut dec = Decoder::new();
        let mut out = Vec::new();
        for &b in encoded {
            match dec.step(b) {
                Step::None => {}
                Step::Byte(x) => out.push(x),
                Step::End => return Ok(out),
                Step::Error => return Err(()),
            }
        }
        Err(())
    }

    #[test]
    fn the_papers_examples() {
        assert_eq!(encode(&[]), [0x01, 0x00]);
        assert_eq!(encode(&[0x00]), [0x01, 0x01, 0x00]);
        assert_eq!(encode(&[0x00, 0x00]), [0x01, 0x01, 0x01, 0x00]);
        assert_eq!(
            encode(&[0x11, 0x22, 0x00, 0x33]),
            [0x03, 0x11, 0x22, 0x02, 0x33, 0x00]
        );
        assert_eq!(
            encode(&[0x11, 0x00, 0x00, 0x00]),
            [0x02, 0x11, 0x01, 0x01, 0x01, 0x00]
        );
    }

    #[test]
    fn long_runs_cut_at_254() {
        let run: Vec<u8> = (1..=254).collect();
        let enc = encode(&run);
        assert_eq!(enc[0], 0xFF);
        assert_eq!(enc.len(), 254 + 1 + 1 + 1); // FF block, final empty 01 block, delimiter
        assert_eq!(&enc[255..], &[0x01, 0x00]);
        assert_eq!(decode(&enc).unwrap(), run);
        // A decoder accepts the frame without the final empty block as well.
        let mut short = enc[..255].to_vec();
        short.push(0);
        assert_eq!(decode(&short).unwrap(), run);
        let mut longer: Vec<u8> = (0..600).map(|i| (i % 255 + 1) as u8).collect();
        longer[300] = 0;
        let enc = encode(&longer);
        assert!(enc.len() - 1 <= max_encoded_len(longer.len()));
        assert_eq!(decode(&enc).unwrap(), longer);
    }

    #[test]
    fn a_block_cut_by_the_delimiter_is_an_error() {
        assert_eq!(decode(&[0x05, 0x11, 0x22, 0x00]), Err(()));
    }

    #[test]
    fn too_small_output_reports_the_length_needed() {
        let mut out = [0_u8; 3];
        let mut enc = Encoder::new(&mut out);
        enc.push_all(&[1, 2, 3]);
        assert_eq!(enc.finish(), Err(5));
    }
}
