//! CRC-32/ISO-HDLC (the CRC of Ethernet, zlib and PNG): poly 0x04C11DB7 reflected, init and
//! xorout 0xFFFFFFFF; check value 0xCBF43926 over `"123456789"`. Table-driven, with the
//! 256-entry table built at compile time (1 KiB of flash). See `docs/protocol.md`, section 2.

/// The reflected polynomial.
const POLY: u32 = 0xEDB8_8320;

/// One table entry per byte value.
#[allow(clippy::indexing_slicing)] // const evaluation: an out-of-bounds index fails the build
const fn make_table() -> [u32; 256] {
    let mut table = [0_u32; 256];
    let mut i = 0;
    while i < 256 {
        #[allow(clippy::cast_possible_truncation)]
        let mut c = i as u32;
        let mut k = 0;
        while k < 8 {
            c = if c & 1 == 1 { POLY ^ (c >> 1) } else { c >> 1 };
            k += 1;
        }
        table[i] = c;
        i += 1;
    }
    table
}

static TABLE: [u32; 256] = make_table();

/// A running CRC-32 over bytes fed in any number of pieces.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Crc32(u32);

impl Crc32 {
    /// A CRC over no bytes yet.
    #[must_use]
    pub const fn new() -> Self {
        Self(0xFFFF_FFFF)
    }

    /// Feeds one byte.
    #[inline]
    pub fn update_byte(&mut self, byte: u8) {
        let index = usize::from((self.0 as u8) ^ byte);
        let entry = TABLE.get(index).copied().unwrap_or(0);
        self.0 = entry ^ (self.0 >> 8);
    }

    /// Feeds bytes.
    pub fn update(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.update_byte(b);
        }
    }

    /// The CRC of everything fed so far.
    #[must_use]
    pub const fn finish(self) -> u32 {
        self.0 ^ 0xFFFF_FFFF
    }
}

impl Default for Crc32 {
    fn default() -> Self {
        Self::new()
    }
}

/// The CRC-32/ISO-HDLC of `bytes`.
#[must_use]
pub fn crc32(bytes: &[u8]) -> u32 {
    let mut crc = Crc32::new();
    crc.update(bytes);
    crc.finish()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn check_value_of_the_catalogue() {
        assert_eq!(crc32(b"123456789"), 0xCBF4_3926);
        assert_eq!(crc32(b""), 0);
        let mut split = Crc32::new();
        split.update(b"1234");
        split.update(b"56789");
        assert_eq!(split.finish(), 0xCBF4_3926);
    }

    #[test]
    fn protocol_examples() {
        // docs/protocol.md, section 10: Ping with seq 1.
        assert_eq!(crc32(&[0x01, 0x86, 0x01, 0x00]), 0x655B_EE0A);
    }
}
