//! The LMS2xx telegram CRC.
//!
//! Not a table CRC-16: each step shifts the register left by one, folds the polynomial 0x8005
//! in when the bit shifted out was set, then XORs in the current byte together with the
//! previous one as the high byte:
//!
//! ```text
//! crc = 0; prev = 0
//! for each byte b:
//!     crc = (crc << 1) ^ (0x8005 if crc & 0x8000 else 0)     (16 bits)
//!     crc ^= b | (prev << 8)
//!     prev = b
//! ```
//!
//! It runs over every byte from STX to the end of the payload and is sent little-endian.
//!
//! # Four bytes a step
//! The step `L(x) = (x << 1) ^ (0x8005 if x & 0x8000)` is linear over GF(2), so four steps
//! over bytes `b0 .. b3` (previous byte `p`, words `w_i = b_{i−1} << 8 | b_i`) give
//!
//! ```text
//! crc' = L⁴(crc) ^ L³(w0) ^ L²(w1) ^ L(w2) ^ w3
//!      = L⁴(crc) ^ L³(p << 8) ^ [L³(b0) ^ L²(b0 << 8)] ^ [L²(b1) ^ L(b1 << 8)]
//!        ^ [L(b2) ^ b2 << 8] ^ b3
//! ```
//!
//! and `L⁴(crc) = L⁴(crc_hi << 8) ^ crc_lo << 4` (a byte shifted by four never reaches the
//! top bit). [`Crc::update`] takes each bracket from a 256-entry table built at compile time
//! from `L` itself (five tables, 2.5 KiB of flash): five loads and XORs per four bytes where
//! the bit-serial form takes four shifts, masks and XORs per byte. The bytes left over (fewer
//! than four) go one at a time.

/// The CRC register and the previous byte, for computing the CRC over pieces of a telegram.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Crc {
    crc: u16,
    prev: u8,
}

impl Crc {
    /// A CRC over no bytes yet (register 0, previous byte 0).
    #[must_use]
    pub const fn new() -> Self {
        Self { crc: 0, prev: 0 }
    }

    /// Folds `bytes` into the CRC, in order: four at a time by the tables, the rest one by
    /// one.
    pub fn update(&mut self, bytes: &[u8]) {
        let (mut crc, mut prev) = (self.crc, self.prev);
        let mut blocks = bytes.chunks_exact(4);
        for block in &mut blocks {
            if let &[b0, b1, b2, b3] = block {
                let [lo, hi] = crc.to_le_bytes();
                let t = &TABLES;
                crc = entry(&t.crc_high, hi)
                    ^ (u16::from(lo) << 4)
                    ^ entry(&t.previous, prev)
                    ^ entry(&t.first, b0)
                    ^ entry(&t.second, b1)
                    ^ entry(&t.third, b2)
                    ^ u16::from(b3);
                prev = b3;
            }
        }
        for &b in blocks.remainder() {
            crc = step(crc) ^ u16::from_le_bytes([b, prev]);
            prev = b;
        }
        self.crc = crc;
        self.prev = prev;
    }

    /// The CRC of the bytes folded in so far.
    #[must_use]
    pub const fn value(&self) -> u16 {
        self.crc
    }
}

/// One step of the register: shift left by one, fold 0x8005 in when the top bit was set.
#[inline]
const fn step(x: u16) -> u16 {
    let fold = if x & 0x8000 != 0 { 0x8005 } else { 0 };
    (x << 1) ^ fold
}

/// A table's entry for a byte (every byte has one: the bound check compiles away).
#[inline(always)]
fn entry(table: &[u16; 256], byte: u8) -> u16 {
    table.get(usize::from(byte)).copied().unwrap_or(0)
}

/// `step` applied `n` times.
const fn steps(mut x: u16, n: u32) -> u16 {
    let mut i = 0;
    while i < n {
        x = step(x);
        i += 1;
    }
    x
}

/// The tables of a four-byte step (module docs), each indexed by a byte.
struct Tables {
    /// `L⁴(x << 8)`: the register's high byte.
    crc_high: [u16; 256],
    /// `L³(x << 8)`: the byte before the block.
    previous: [u16; 256],
    /// `L³(x) ^ L²(x << 8)`: the block's first byte.
    first: [u16; 256],
    /// `L²(x) ^ L(x << 8)`: its second.
    second: [u16; 256],
    /// `L(x) ^ x << 8`: its third (the fourth enters as itself).
    third: [u16; 256],
}

/// The tables, built at compile time from [`step`]. Indexing in a constant's evaluation cannot
/// panic at run time: an index out of bounds would fail the build.
#[allow(clippy::indexing_slicing)]
static TABLES: Tables = {
    let mut t = Tables {
        crc_high: [0; 256],
        previous: [0; 256],
        first: [0; 256],
        second: [0; 256],
        third: [0; 256],
    };
    let mut x = 0;
    while x < 256 {
        let (low, high) = (x as u16, (x as u16) << 8);
        t.crc_high[x] = steps(high, 4);
        t.previous[x] = steps(high, 3);
        t.first[x] = steps(low, 3) ^ steps(high, 2);
        t.second[x] = steps(low, 2) ^ steps(high, 1);
        t.third[x] = steps(low, 1) ^ high;
        x += 1;
    }
    t
};

/// The CRC of `bytes` (a telegram from STX to the last payload byte), as a u16; it is sent
/// little-endian after the payload.
#[must_use]
pub fn crc16(bytes: &[u8]) -> u16 {
    let mut crc = Crc::new();
    crc.update(bytes);
    crc.value()
}

#[cfg(test)]
mod tests {
    use super::*;
    extern crate std;

    /// The protocol notes' vectors: telegram bytes without CRC -> CRC bytes on the wire.
    const VECTORS: &[(&[u8], [u8; 2])] = &[
        (&[0x02, 0x00, 0x02, 0x00, 0x20, 0x24], [0x34, 0x08]),
        (&[0x02, 0x00, 0x02, 0x00, 0x20, 0x25], [0x35, 0x08]),
        (&[0x02, 0x00, 0x02, 0x00, 0x20, 0x48], [0x58, 0x08]),
        (&[0x02, 0x00, 0x02, 0x00, 0x20, 0x42], [0x52, 0x08]),
        (&[0x02, 0x00, 0x02, 0x00, 0x20, 0x40], [0x50, 0x08]),
        (&[0x02, 0x00, 0x01, 0x00, 0x31], [0x15, 0x12]),
        (
            &[0x02, 0x00, 0x05, 0x00, 0x3B, 0xB4, 0x00, 0x32, 0x00],
            [0x3B, 0x1F],
        ),
        (&[0x02, 0x00, 0x02, 0x00, 0x41, 0x00], [0xD2, 0x69]),
        (&[0x02, 0x00, 0x03, 0x00, 0x45, 0x01, 0x00], [0xA6, 0xD2]),
    ];

    #[test]
    fn documented_vectors() {
        for (bytes, wire) in VECTORS {
            assert_eq!(crc16(bytes).to_le_bytes(), *wire, "{bytes:02x?}");
        }
    }

    #[test]
    fn incremental_equals_one_shot_at_every_split() {
        for (bytes, wire) in VECTORS {
            for split in 0..=bytes.len() {
                let (a, b) = bytes.split_at(split);
                let mut crc = Crc::new();
                crc.update(a);
                crc.update(b);
                assert_eq!(crc.value().to_le_bytes(), *wire);
            }
        }
    }

    /// The bit-serial definition (module docs), one byte at a time.
    fn serial(bytes: &[u8]) -> u16 {
        let (mut crc, mut prev) = (0_u16, 0_u8);
        for &b in bytes {
            let fold = if crc & 0x8000 != 0 { 0x8005 } else { 0 };
            crc = (crc << 1) ^ fold;
            crc ^= u16::from(b) | (u16::from(prev) << 8);
            prev = b;
        }
        crc
    }

    #[test]
    fn four_bytes_a_step_is_the_serial_crc_at_every_length_and_split() {
        let mut x = crate::test_rng::XorShift(0x51C4_0000_2545_F491);
        for len in 0..64 {
            for _ in 0..50 {
                let bytes: std::vec::Vec<u8> = (0..len).map(|_| (x.next() >> 56) as u8).collect();
                let want = serial(&bytes);
                assert_eq!(crc16(&bytes), want, "{bytes:02x?}");
                for split in 0..=len {
                    let mut crc = Crc::new();
                    crc.update(&bytes[..split]);
                    crc.update(&bytes[split..]);
                    assert_eq!(crc.value(), want, "{bytes:02x?} at {split}");
                }
            }
        }
        // Every byte value in every position of a block, after every register high byte.
        for hi in 0..=255_u8 {
            for b in 0..=255_u8 {
                let bytes = [0x02, hi, 0x80, b, hi ^ b, 0xFF, b];
                assert_eq!(crc16(&bytes), serial(&bytes));
            }
        }
    }

    #[test]
    fn empty_input_is_zero() {
        assert_eq!(crc16(&[]), 0);
    }
}
