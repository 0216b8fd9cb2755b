//! The response descriptor the Slamtec RPLIDAR and the YDLIDAR protocols share: two sync
//! bytes, a little-endian word with the response length in bits 29..0 and the response mode
//! in bits 31..30, and the data type: 7 bytes.

/// The two bytes every descriptor starts with, `A5 5A`.
pub(crate) const SYNC: [u8; 2] = [0xA5, 0x5A];

/// The largest response length a descriptor carries, bytes (30 bits).
const MAX_RESPONSE_LEN: u32 = 0x3FFF_FFFF;

/// The response length (bytes, below 2³⁰) and the response mode (0 ..= 3) of the descriptor
/// at the front of `bytes`; 0 and 0 when its word is absent.
pub(crate) fn len_and_mode(bytes: &[u8]) -> (u32, u8) {
    let word = match bytes.get(2..6) {
        Some(&[a, b, c, d]) => u32::from_le_bytes([a, b, c, d]),
        _ => 0,
    };
    (
        word & MAX_RESPONSE_LEN,
        u8::try_from(word >> 30).unwrap_or(0),
    )
}

/// The 7 bytes of a descriptor: [`SYNC`], `response_len` (bytes) and `mode` in the word,
/// then `data_type`; `None` for a length of 2³⁰ or more or a mode above 3.
pub(crate) fn encode(response_len: u32, mode: u8, data_type: u8) -> Option<[u8; 7]> {
    if response_len > MAX_RESPONSE_LEN || mode > 3 {
        return None;
    }
    let [a, b, c, d] = (response_len | (u32::from(mode) << 30)).to_le_bytes();
    let [s0, s1] = SYNC;
    Some([s0, s1, a, b, c, d, data_type])
}

/// What `known` gives the descriptor `descriptor`: the value of the entry whose bytes are
/// its bytes 2..7, when it starts with [`SYNC`]; `None` for any other.
pub(crate) fn lookup<V: Copy>(descriptor: &[u8; 7], known: &[([u8; 5], V)]) -> Option<V> {
    let (sync, tail) = descriptor.split_first_chunk::<2>()?;
    if *sync != SYNC {
        return None;
    }
    known
        .iter()
        .find(|(bytes, _)| bytes == tail)
        .map(|&(_, value)| value)
}
