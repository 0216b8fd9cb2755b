//! The legacy express-scan capsule and the placement of its points.

use super::{
    read_u16_le, write_all, RplidarError, RPLIDAR_CABINS, RPLIDAR_CAPSULE_LEN,
    RPLIDAR_CAPSULE_POINTS,
};
use crate::angle::FineAngle;
use crate::wire::laser::{signed_turn_fraction, turn_fraction_45ths};
use crate::wire::LaserReturn;
use crate::wire::{check, view};

/// High nibble of byte 0.
const SYNC1: u8 = 0xA;
/// High nibble of byte 1.
const SYNC2: u8 = 0x5;
/// Offset of the first cabin.
const CABINS_AT: usize = 4;
/// Bytes per cabin.
const CABIN_LEN: usize = 5;
/// One turn in the SDK's degrees·2¹⁶.
const TURN_Q16: i64 = 360 << 16;

/// `signed_turn_fraction(q16, 360·2¹⁶)`, exactly, in 32-bit words for every angle a capsule
/// gives (degrees·2¹⁶ within ±2³¹; others take the 64-bit way): the angle reduced to one turn
/// (at most a few turns away, so by adding or subtracting turns), then a turn being
/// 360·2¹⁶ = 45·2¹⁹ units, [`turn_fraction_45ths`]: no 64-bit division.
fn turn_of_q16_degrees(q16: i64) -> FineAngle {
    const TURN: i32 = 360 << 16;
    let Ok(mut r) = i32::try_from(q16) else {
        return signed_turn_fraction(q16, TURN_Q16.unsigned_abs());
    };
    // |q16| < 2³¹ and a turn is 2²⁴·⁵: at most 92 steps; a capsule's angles take one or two.
    while r < 0 {
        r += TURN;
    }
    while r >= TURN {
        r -= TURN;
    }
    // 0 ≤ r < 360·2¹⁶: a < 2¹⁹ and the sum below reaches 2³² only where the angle rounds up
    // to a whole turn, which wraps to 0 as a FineAngle does.
    turn_fraction_45ths(r.unsigned_abs(), 13)
}

/// The XOR of bytes 2..84 of a capsule (over the bytes present).
fn xor_body(bytes: &[u8]) -> u8 {
    bytes
        .get(2..RPLIDAR_CAPSULE_LEN)
        .or_else(|| bytes.get(2..))
        .unwrap_or(&[])
        .iter()
        .fold(0, |acc, b| acc ^ b)
}

view::fixed_view! {
    /// A zero-copy view over one 84-byte legacy express-scan capsule (Figures 4-11 to 4-13):
    ///
    /// ```text
    /// byte 0: sync1 0xA (bits 7..4) | checksum bits 3..0
    /// byte 1: sync2 0x5 (bits 7..4) | checksum bits 7..4
    /// bytes 2..4: start_angle_q6 (bits 14..0, degrees·64) | S (bit 15) (u16 LE)
    /// 16 cabins of 5 bytes: distance_angle_1 (u16 LE: distance1 mm in bits 15..2, dθ1 bits 5..4
    ///   in bits 1..0), distance_angle_2 (likewise), dθ1 bits 3..0 | dθ2 bits 3..0 << 4
    /// ```
    ///
    /// The checksum is the XOR of bytes 2..84. Made with [`RplidarCapsule::new_checked`], the
    /// buffer holds 84 bytes, the sync nibbles and the checksum are right; made with
    /// [`RplidarCapsule::new_unchecked`], absent bytes read as 0. A capsule's points are placed
    /// with the next capsule's start angle: [`RplidarExpressScan`].
    pub struct RplidarCapsule: RPLIDAR_CAPSULE_LEN bytes, a "capsule",
        refused with RplidarError;

    /// Wraps a buffer after [`check_len`](Self::check_len), the sync check and the checksum
    /// check.
    ///
    /// # Errors
    /// [`RplidarError::Truncated`], [`RplidarError::BadSync`] or
    /// [`RplidarError::BadChecksum`].
    fn new_checked: check_sync, check_checksum;
}

impl<T: AsRef<[u8]>> RplidarCapsule<T> {
    /// Checks the sync nibbles 0xA and 0x5.
    ///
    /// # Errors
    /// [`RplidarError::Truncated`] for fewer than 2 bytes, [`RplidarError::BadSync`].
    pub fn check_sync(&self) -> Result<(), RplidarError> {
        match self.buffer.as_ref().first_chunk::<2>() {
            None => Err(RplidarError::Truncated),
            Some(&[a, b]) if a >> 4 == SYNC1 && b >> 4 == SYNC2 => Ok(()),
            Some(&found) => Err(RplidarError::BadSync { found }),
        }
    }

    /// Checks the checksum against the XOR of bytes 2..84.
    ///
    /// # Errors
    /// [`RplidarError::Truncated`] for a short buffer, [`RplidarError::BadChecksum`].
    pub fn check_checksum(&self) -> Result<(), RplidarError> {
        self.check_len()?;
        let (stored, computed) = (self.checksum(), self.computed_checksum());
        check::stored_matches(stored, computed, |stored, computed| {
            RplidarError::BadChecksum { stored, computed }
        })
    }

    /// The checksum the capsule carries (its two low nibbles).
    pub fn checksum(&self) -> u8 {
        (self.byte(0) & 0x0F) | (self.byte(1) << 4)
    }

    /// The XOR of bytes 2..84 (of the bytes present).
    pub fn computed_checksum(&self) -> u8 {
        xor_body(self.buffer.as_ref())
    }

    fn start_word(&self) -> u16 {
        read_u16_le(self.buffer.as_ref(), 2).unwrap_or(0)
    }

    /// ωᵢ, the reference angle of the capsule's points, degrees·64 (0..=32 767; below
    /// 23 040 from a sound sensor).
    pub fn start_angle_q6(&self) -> u16 {
        self.start_word() & 0x7FFF
    }

    /// S: the first capsule of a new scan (set on the first capsule after EXPRESS_SCAN, or
    /// when the device restarts its angle reference); the previous capsule cannot be placed.
    pub fn start_flag(&self) -> bool {
        self.start_word() & 0x8000 != 0
    }

    /// The two 16-bit words and the offsets byte of the cabin holding point `k`.
    fn cabin(&self, k: usize) -> Option<(u16, u8)> {
        if k >= RPLIDAR_CAPSULE_POINTS {
            return None;
        }
        let at = CABINS_AT + (k / 2) * CABIN_LEN;
        let word = read_u16_le(self.buffer.as_ref(), at + 2 * (k % 2)).unwrap_or(0);
        Some((word, self.byte(at + 4)))
    }

    /// The distance of point `k` (0..32, two per cabin, the first sampled first),
    /// millimetres (0..=16 383; 0 = no return); `None` for `k ≥ 32`.
    pub fn distance_mm(&self, k: usize) -> Option<u16> {
        self.cabin(k).map(|(word, _)| word >> 2)
    }

    /// dθ of point `k`, degrees·8, as the SDK reads it: six bits, unsigned (0..=63, i.e. 0 to
    /// 7.875°; see the [module documentation](super)); `None` for `k ≥ 32`.
    pub fn angle_offset_q3(&self, k: usize) -> Option<u8> {
        let (word, offsets) = self.cabin(k)?;
        let low = if k.is_multiple_of(2) {
            offsets & 0x0F
        } else {
            offsets >> 4
        };
        let high = u8::try_from(word & 0x3).unwrap_or(0);
        Some((high << 4) | low)
    }
}

/// The fields of one capsule, to [`emit`](RplidarCapsuleRepr::emit) or as parsed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct RplidarCapsuleRepr {
    /// ωᵢ, degrees·64 (0..=32 767; a sensor sends 0..23 040).
    pub start_angle_q6: u16,
    /// S: the first capsule of a new scan.
    pub start_flag: bool,
    /// The 32 distances, millimetres (0..=16 383).
    pub distances_mm: [u16; RPLIDAR_CAPSULE_POINTS],
    /// The 32 dθ, degrees·8 (0..=63).
    pub angle_offsets_q3: [u8; RPLIDAR_CAPSULE_POINTS],
}

impl Default for RplidarCapsuleRepr {
    fn default() -> Self {
        Self {
            start_angle_q6: 0,
            start_flag: false,
            distances_mm: [0; RPLIDAR_CAPSULE_POINTS],
            angle_offsets_q3: [0; RPLIDAR_CAPSULE_POINTS],
        }
    }
}

impl RplidarCapsuleRepr {
    /// The fields of a capsule view.
    pub fn parse<T: AsRef<[u8]>>(capsule: &RplidarCapsule<T>) -> Self {
        let mut repr = Self {
            start_angle_q6: capsule.start_angle_q6(),
            start_flag: capsule.start_flag(),
            ..Self::default()
        };
        for k in 0..RPLIDAR_CAPSULE_POINTS {
            if let (Some(d), Some(o)) = (
                repr.distances_mm.get_mut(k),
                repr.angle_offsets_q3.get_mut(k),
            ) {
                *d = capsule.distance_mm(k).unwrap_or(0);
                *o = capsule.angle_offset_q3(k).unwrap_or(0);
            }
        }
        repr
    }

    /// Bytes of the emitted capsule: 84.
    #[must_use]
    pub const fn buffer_len(&self) -> usize {
        RPLIDAR_CAPSULE_LEN
    }

    /// Writes the capsule (sync nibbles, checksum computed) to the front of `out`.
    ///
    /// # Errors
    /// [`RplidarError::OutOfRange`] for an angle above 32 767, a distance above 16 383 or a
    /// dθ above 63; [`RplidarError::BufferTooSmall`]; nothing is written then.
    pub fn emit(&self, out: &mut [u8]) -> Result<usize, RplidarError> {
        if self.start_angle_q6 > 0x7FFF
            || self.distances_mm.iter().any(|&d| d > 0x3FFF)
            || self.angle_offsets_q3.iter().any(|&o| o > 63)
        {
            return Err(RplidarError::OutOfRange);
        }
        let mut bytes = [0_u8; RPLIDAR_CAPSULE_LEN];
        let start = self.start_angle_q6 | if self.start_flag { 0x8000 } else { 0 };
        if let Some(slot) = bytes.get_mut(2..4) {
            slot.copy_from_slice(&start.to_le_bytes());
        }
        for c in 0..RPLIDAR_CABINS {
            let at = CABINS_AT + c * CABIN_LEN;
            let point = |k: usize| {
                let d = self.distances_mm.get(k).copied().unwrap_or(0);
                let o = self.angle_offsets_q3.get(k).copied().unwrap_or(0);
                ((d << 2) | u16::from(o >> 4), o & 0x0F)
            };
            let (w1, lo1) = point(2 * c);
            let (w2, lo2) = point(2 * c + 1);
            let [a, b] = w1.to_le_bytes();
            let [d, e] = w2.to_le_bytes();
            if let Some(slot) = bytes.get_mut(at..at + CABIN_LEN) {
                slot.copy_from_slice(&[a, b, d, e, lo1 | (lo2 << 4)]);
            }
        }
        let checksum = xor_body(&bytes);
        if let Some([b0, b1]) = bytes.first_chunk_mut::<2>() {
            *b0 = (SYNC1 << 4) | (checksum & 0x0F);
            *b1 = (SYNC2 << 4) | (checksum >> 4);
        }
        write_all(out, &bytes)
    }
}

/// A capsule paired with the start angle of the capsule that followed it: what places its 32
/// points (the protocol document's formula by Figure 4-23, the SDK's `_capsuleToNormal`).
///
/// With ωᵢ this capsule's start angle, ωᵢ₊₁ the next one's and
/// `AngleDiff = ωᵢ₊₁ − ωᵢ (+ 360° when ωᵢ₊₁ < ωᵢ)`, point k lies at
/// `θₖ = ωᵢ + k·AngleDiff/32 − dθₖ`, computed exactly as the SDK's integer intermediate
/// (degrees·2¹⁶: `ωᵢ·2¹⁸ + k·AngleDiff_q8·2³ − dθₖ·2¹³`) and rounded once to the
/// [`FineAngle`] LSB.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct RplidarExpressScan<'a> {
    capsule: RplidarCapsule<&'a [u8]>,
    next_start_angle_q6: u16,
    wraps_at_start: bool,
}

impl<'a> RplidarExpressScan<'a> {
    /// Pairs `capsule` with the start angle of the capsule that followed it (degrees·64; the
    /// S bit, if passed along, is ignored).
    #[must_use]
    pub fn new(capsule: RplidarCapsule<&'a [u8]>, next_start_angle_q6: u16) -> Self {
        Self {
            capsule,
            next_start_angle_q6: next_start_angle_q6 & 0x7FFF,
            wraps_at_start: false,
        }
    }

    /// Marks that the previous capsule's points ended exactly at 360°, so this capsule's
    /// point 0 starts a revolution (the accumulator tracks it).
    #[must_use]
    pub(super) fn wrapping_at_start(mut self, wraps: bool) -> Self {
        self.wraps_at_start = wraps;
        self
    }

    /// The capsule whose points this places.
    #[must_use]
    pub fn capsule(&self) -> RplidarCapsule<&'a [u8]> {
        self.capsule
    }

    /// ωᵢ₊₁, the next capsule's start angle, degrees·64.
    #[must_use]
    pub fn next_start_angle_q6(&self) -> u16 {
        self.next_start_angle_q6
    }

    /// The uncompensated angle of point `k` (0 ..= 32), degrees·2¹⁶, not reduced modulo a
    /// turn: the SDK's `currentAngle_raw_q16`.
    fn raw_q16(&self, k: usize) -> i64 {
        let start_q8 = i64::from(self.capsule.start_angle_q6()) << 2;
        let next_q8 = i64::from(self.next_start_angle_q6) << 2;
        let mut diff_q8 = next_q8 - start_q8;
        if start_q8 > next_q8 {
            diff_q8 += 360 << 8;
        }
        let k = i64::try_from(k).unwrap_or(0);
        (start_q8 << 8) + k * (diff_q8 << 3)
    }

    /// The angle of point `k` (0..32), clockwise seen from above; `None` for `k ≥ 32`.
    #[must_use]
    pub fn angle(&self, k: usize) -> Option<FineAngle> {
        let offset = i64::from(self.capsule.angle_offset_q3(k)?);
        Some(turn_of_q16_degrees(self.raw_q16(k) - (offset << 13)))
    }

    /// The 32 returns in sampling order: angle as [`angle`](Self::angle), range the distance
    /// in millimetres (0 = no return), no quality (capsules carry none).
    pub fn returns(&self) -> impl Iterator<Item = LaserReturn> + '_ {
        (0..RPLIDAR_CAPSULE_POINTS).filter_map(|k| {
            Some(LaserReturn {
                angle: self.angle(k)?,
                range_mm: u32::from(self.capsule.distance_mm(k)?),
                quality: None,
            })
        })
    }

    /// The index of the point that starts a new revolution, if one does: the first point
    /// whose uncompensated angle has passed 360° (the document: "a new scan starts at a
    /// measurement point whose raw angle is smaller than the previous one"), or 0 when the
    /// previous capsule's points ended exactly there.
    #[must_use]
    pub fn revolution_start(&self) -> Option<usize> {
        if self.wraps_at_start {
            return Some(0);
        }
        // The raw angle never decreases along a capsule (its step is ≥ 0), so the first
        // point past a multiple of 360° is the first at or beyond the next one after point 0:
        // one division instead of two per point.
        let next_turn = (self.raw_q16(0).div_euclid(TURN_Q16) + 1) * TURN_Q16;
        (1..RPLIDAR_CAPSULE_POINTS).find(|&k| self.raw_q16(k) >= next_turn)
    }

    /// Whether a new revolution starts among this capsule's points.
    #[must_use]
    pub fn starts_revolution(&self) -> bool {
        self.revolution_start().is_some()
    }

    /// Whether the raw angle passes a multiple of 360° between points `k − 1` and `k`.
    fn crosses(&self, k: usize) -> bool {
        let before = self.raw_q16(k.saturating_sub(1)).div_euclid(TURN_Q16);
        self.raw_q16(k).div_euclid(TURN_Q16) > before
    }

    /// Whether the next capsule's point 0 starts a revolution: the raw angle passes 360°
    /// between this capsule's last point and the next capsule's first.
    pub(super) fn wraps_at_end(&self) -> bool {
        self.crosses(RPLIDAR_CAPSULE_POINTS)
    }
}

#[cfg(test)]
mod tests {
    extern crate std;

    use super::*;
    use crate::test_rng::XorShift;
    use std::vec::Vec;

    /// Degrees of a FineAngle; its LSB is 8.4·10⁻⁸°, so exact values agree within 1e-7.
    fn degrees(a: FineAngle) -> f64 {
        f64::from(a.to_bits()) * 360.0 / 4_294_967_296.0
    }

    /// A capsule by hand: ω = 10.0° (640 q6 = 0x0280, S = 0), cabin 0 holds point 0 at
    /// 1 000 mm with dθ = 1.5° (12 q3 = 0b00_1100) and point 1 at 2 000 mm with dθ = 5.0°
    /// (40 q3 = 0b10_1000); every other cabin zero.
    fn by_hand() -> [u8; 84] {
        let mut c = [0_u8; 84];
        // Start angle word 0x0280: bytes 80 02.
        c[2] = 0x80;
        c[3] = 0x02;
        // distance_angle_1 = 1 000 << 2 | (12 >> 4 = 0) = 4 000 = 0x0FA0: bytes A0 0F.
        c[4] = 0xA0;
        c[5] = 0x0F;
        // distance_angle_2 = 2 000 << 2 | (40 >> 4 = 2) = 8 002 = 0x1F42: bytes 42 1F.
        c[6] = 0x42;
        c[7] = 0x1F;
        // Offsets byte: dθ1 low nibble 0xC | dθ2 low nibble 0x8 << 4 = 0x8C.
        c[8] = 0x8C;
        // XOR of bytes 2..84: 80 ⊕ 02 ⊕ A0 ⊕ 0F ⊕ 42 ⊕ 1F ⊕ 8C
        // = 82 ⊕ A0 = 22; ⊕ 0F = 2D; ⊕ 42 = 6F; ⊕ 1F = 70; ⊕ 8C = FC.
        c[0] = 0xA0 | 0x0C;
        c[1] = 0x50 | 0x0F;
        c
    }

    #[test]
    fn a_capsule_by_hand() {
        let bytes = by_hand();
        let c = RplidarCapsule::new_checked(&bytes[..]).unwrap();
        assert_eq!((c.checksum(), c.computed_checksum()), (0xFC, 0xFC));
        assert_eq!((c.start_angle_q6(), c.start_flag()), (640, false));
        assert_eq!(
            (c.distance_mm(0), c.angle_offset_q3(0)),
            (Some(1000), Some(12))
        );
        assert_eq!(
            (c.distance_mm(1), c.angle_offset_q3(1)),
            (Some(2000), Some(40))
        );
        assert_eq!(c.distance_mm(2), Some(0));
        assert_eq!(c.distance_mm(32), None);
        // Next capsule at ω = 12.0° (768 q6): AngleDiff = 2°, 2/32 = 0.0625° per point.
        let scan = RplidarExpressScan::new(c, 768);
        // θ0 = 10 + 0 − 1.5 = 8.5°; θ1 = 10 + 0.0625 − 5.0 = 5.0625°; θ2 = 10.125°.
        let a: Vec<f64> = scan.returns().map(|r| degrees(r.angle)).collect();
        assert_eq!(a.len(), 32);
        assert!((a[0] - 8.5).abs() < 1e-7, "{}", a[0]);
        assert!((a[1] - 5.0625).abs() < 1e-7, "{}", a[1]);
        assert!((a[2] - 10.125).abs() < 1e-7, "{}", a[2]);
        assert!((a[31] - (10.0 + 31.0 * 0.0625)).abs() < 1e-7);
        let r0 = scan.returns().next().unwrap();
        assert_eq!((r0.range_mm, r0.quality), (1000, None));
        assert_eq!(scan.revolution_start(), None);
        assert!(!scan.wraps_at_end());
        assert_eq!(RplidarCapsuleRepr::parse(&c).distances_mm[1], 2000);
        let mut out = [0; 84];
        RplidarCapsuleRepr::parse(&c).emit(&mut out).unwrap();
        assert_eq!(out, bytes);
        // Across 360°: ω = 359° (22 976 q6), next 1° (64 q6): AngleDiff = 2°; the raw angle of
        // point k is 359 + k/16 degrees, which passes 360° at k = 16.
        let mut wrap = RplidarCapsuleRepr::parse(&c);
        wrap.start_angle_q6 = 22_976;
        wrap.emit(&mut out).unwrap();
        let scan = RplidarExpressScan::new(RplidarCapsule::new_checked(&out[..]).unwrap(), 64);
        assert_eq!(scan.revolution_start(), Some(16));
        assert!((degrees(scan.angle(20).unwrap()) - 0.25).abs() < 1e-7);
        // Point 0: 359 − 1.5 = 357.5°.
        assert!((degrees(scan.angle(0).unwrap()) - 357.5).abs() < 1e-7);
        // Ending exactly at 360°: ω = 358°, next 0°: raw of point 32 is 360°.
        wrap.start_angle_q6 = 358 * 64;
        wrap.emit(&mut out).unwrap();
        let scan = RplidarExpressScan::new(RplidarCapsule::new_checked(&out[..]).unwrap(), 0);
        assert_eq!(scan.revolution_start(), None);
        assert!(scan.wraps_at_end());
        assert_eq!(scan.wrapping_at_start(true).revolution_start(), Some(0));
    }

    /// Slamtec's `_capsuleToNormal` (sl_lidar_driver.cpp), transcribed with C's `int`
    /// arithmetic for one capsule and its successor: the angle_q6 and distance_q2 of the 32
    /// nodes it produces. Field extraction follows the SDK's packed struct: the cabin's
    /// `distance_angle_1/2` words and its `offset_angles_q3` byte.
    fn sdk_capsule_to_normal(prev: &[u8; 84], capsule: &[u8; 84]) -> Vec<(i32, i32)> {
        let word = |b: &[u8; 84], at: usize| i32::from(u16::from_le_bytes([b[at], b[at + 1]]));
        let current_start_q8 = (word(capsule, 2) & 0x7FFF) << 2;
        let prev_start_q8 = (word(prev, 2) & 0x7FFF) << 2;
        let mut diff_q8 = current_start_q8 - prev_start_q8;
        if prev_start_q8 > current_start_q8 {
            diff_q8 += 360 << 8;
        }
        let inc_q16 = diff_q8 << 3;
        let mut raw_q16 = prev_start_q8 << 8;
        let mut out = Vec::new();
        for pos in 0..16 {
            let at = 4 + 5 * pos;
            let da1 = word(prev, at);
            let da2 = word(prev, at + 2);
            let off = i32::from(prev[at + 4]);
            let dist = [da1 & 0xFFFC, da2 & 0xFFFC];
            let off1 = (off & 0xF) | ((da1 & 0x3) << 4);
            let off2 = (off >> 4) | ((da2 & 0x3) << 4);
            let mut a = [0; 2];
            a[0] = (raw_q16 - (off1 << 13)) >> 10;
            raw_q16 += inc_q16;
            a[1] = (raw_q16 - (off2 << 13)) >> 10;
            raw_q16 += inc_q16;
            for c in 0..2 {
                let mut q6 = a[c];
                if q6 < 0 {
                    q6 += 360 << 6;
                }
                if q6 >= 360 << 6 {
                    q6 -= 360 << 6;
                }
                out.push((q6, dist[c]));
            }
        }
        out
    }

    #[test]
    fn agrees_with_the_sdk_bit_for_bit() {
        let mut rng = XorShift(0x0123_4567_89AB_CDEF);
        for case in 0..2000 {
            let mut repr = RplidarCapsuleRepr {
                start_angle_q6: (rng.next() % 23_040) as u16,
                ..RplidarCapsuleRepr::default()
            };
            for k in 0..32 {
                repr.distances_mm[k] = (rng.next() % 0x4000) as u16;
                repr.angle_offsets_q3[k] = (rng.next() % 64) as u8;
            }
            // The next capsule a typical step ahead (up to 20°), across 360° at times.
            let next = ((u64::from(repr.start_angle_q6) + rng.next() % 1280) % 23_040) as u16;
            let mut prev = [0; 84];
            repr.emit(&mut prev).unwrap();
            let mut succ = [0; 84];
            RplidarCapsuleRepr {
                start_angle_q6: next,
                ..RplidarCapsuleRepr::default()
            }
            .emit(&mut succ)
            .unwrap();
            let sdk = sdk_capsule_to_normal(&prev, &succ);
            let scan =
                RplidarExpressScan::new(RplidarCapsule::new_checked(&prev[..]).unwrap(), next);
            for (k, r) in scan.returns().enumerate() {
                let (q6, dist_q2) = sdk[k];
                assert_eq!(r.range_mm, (dist_q2 / 4) as u32, "case {case} point {k}");
                // The SDK truncates the same value to degrees·64: ours lies in
                // [q6, q6 + 1)/64 degrees, up to our rounding to the FineAngle LSB
                // (2⁻³² turn = 5.4·10⁻⁶ in these units).
                let ours = f64::from(r.angle.to_bits()) * 23_040.0 / 4_294_967_296.0;
                let lo = f64::from(q6);
                let d = (ours - lo).rem_euclid(23_040.0);
                assert!(
                    !(1.0 + 1e-5..=23_040.0 - 1e-5).contains(&d),
                    "case {case} point {k}: ours {ours} q6, SDK {q6}"
                );
            }
        }
    }

    #[test]
    fn the_32_bit_angle_is_the_64_bit_division() {
        // Every angle a capsule can produce lies in (−2²¹, 2²⁷) degrees·2¹⁶: a stride through
        // it (every residue mod 45 and near every turn), the edges, and random values.
        let mut rng = XorShift(0xDEAD_BEEF_0BAD_F00D);
        let turn = TURN_Q16;
        let mut values: Vec<i64> = (-(1_i64 << 21)..(1 << 27)).step_by(997).collect();
        for m in -1..=6 {
            for d in -50..=50 {
                values.push(m * turn + d);
            }
        }
        for _ in 0..200_000 {
            values.push((rng.next() % (1 << 32)) as i64 - (1 << 31));
        }
        values.extend([
            i64::from(i32::MIN),
            i64::from(i32::MAX),
            1 << 40,
            -(1 << 40),
        ]);
        for q16 in values {
            assert_eq!(
                turn_of_q16_degrees(q16),
                signed_turn_fraction(q16, turn.unsigned_abs()),
                "{q16}"
            );
        }
    }

    #[test]
    fn the_revolution_start_is_the_first_crossing() {
        let mut rng = XorShift(0x5555_AAAA_1234_5678);
        for case in 0..20_000 {
            let repr = RplidarCapsuleRepr {
                start_angle_q6: (rng.next() % 32_768) as u16,
                ..RplidarCapsuleRepr::default()
            };
            let mut bytes = [0; 84];
            repr.emit(&mut bytes).unwrap();
            let next = (rng.next() % 32_768) as u16;
            let scan =
                RplidarExpressScan::new(RplidarCapsule::new_checked(&bytes[..]).unwrap(), next);
            let by_pairs = (1..RPLIDAR_CAPSULE_POINTS).find(|&k| scan.crosses(k));
            assert_eq!(scan.revolution_start(), by_pairs, "case {case}");
        }
    }

    #[test]
    fn checks_and_emit_errors() {
        let good = by_hand();
        let mut bad = good;
        bad[50] ^= 0x01;
        assert_eq!(
            RplidarCapsule::new_checked(&bad[..]),
            Err(RplidarError::BadChecksum {
                stored: 0xFC,
                computed: 0xFD
            })
        );
        bad = good;
        bad[1] = 0x6F;
        assert_eq!(
            RplidarCapsule::new_checked(&bad[..]),
            Err(RplidarError::BadSync {
                found: [0xAC, 0x6F]
            })
        );
        assert_eq!(
            RplidarCapsule::new_checked(&good[..83]),
            Err(RplidarError::Truncated)
        );
        let empty = RplidarCapsule::new_unchecked(&[][..]);
        assert_eq!(empty.check_sync(), Err(RplidarError::Truncated));
        assert_eq!(RplidarExpressScan::new(empty, 5).returns().count(), 32);
        let mut repr = RplidarCapsuleRepr::default();
        repr.distances_mm[3] = 0x4000;
        assert_eq!(repr.emit(&mut [0; 84]), Err(RplidarError::OutOfRange));
        repr.distances_mm[3] = 0;
        repr.angle_offsets_q3[0] = 64;
        assert_eq!(repr.emit(&mut [0; 84]), Err(RplidarError::OutOfRange));
        repr.angle_offsets_q3[0] = 0;
        assert_eq!(
            repr.emit(&mut [0; 83]),
            Err(RplidarError::BufferTooSmall {
                needed: 84,
                available: 83
            })
        );
    }
}
