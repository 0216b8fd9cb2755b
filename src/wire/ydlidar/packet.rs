//! The point-cloud packet: a zero-copy view and its emitter.

use super::{
    laser_return, read_u16_le, ydlidar_angle_correction, YdlidarAngleCorrection, YdlidarError,
    YDLIDAR_PACKET_HEADER, YDLIDAR_PACKET_HEADER_LEN, YDLIDAR_PACKET_HEADER_WORD,
    YDLIDAR_Q6_PER_TURN,
};
use crate::angle::FineAngle;
use crate::wire::check;
use crate::wire::laser::{turn_fraction, TurnSteps};
use crate::wire::LaserReturn;

mod field {
    pub const PH: usize = 0;
    pub const CT: usize = 2;
    pub const LSN: usize = 3;
    pub const FSA: usize = 4;
    pub const LSA: usize = 6;
    pub const CS: usize = 8;
    pub const SAMPLES: usize = 10;
}

/// The XOR of the 16-bit little-endian words of `packet` (a whole packet, header included),
/// the check-code word at bytes 8..10 excluded: what CS must equal. A trailing odd byte is
/// ignored.
#[must_use]
pub fn ydlidar_checksum(packet: &[u8]) -> u16 {
    packet
        .chunks_exact(2)
        .enumerate()
        .filter(|&(i, _)| i != field::CS / 2)
        .fold(0, |acc, (_, pair)| match *pair {
            [lo, hi] => acc ^ u16::from_le_bytes([lo, hi]),
            _ => acc,
        })
}

/// A zero-copy view over one point-cloud packet held in `T`.
///
/// Made with [`YdlidarPacket::new_checked`], the buffer holds the whole packet (10 + 2·LSN
/// bytes, LSN ≥ 1), starts `AA 55`, FSA and LSA have their check bit set and the check code
/// matches; bytes after the packet are ignored. Made with [`YdlidarPacket::new_unchecked`],
/// the accessors still never panic: absent bytes read as zero.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct YdlidarPacket<T: AsRef<[u8]>> {
    buffer: T,
}

impl<T: AsRef<[u8]>> YdlidarPacket<T> {
    /// Wraps a buffer without checking it.
    pub const fn new_unchecked(buffer: T) -> Self {
        Self { buffer }
    }

    /// Wraps a buffer after [`check_len`](Self::check_len), the header check, the check-bit
    /// check and the check-code check.
    ///
    /// # Errors
    /// [`YdlidarError::Truncated`], [`YdlidarError::NoSamples`], [`YdlidarError::BadHeader`],
    /// [`YdlidarError::BadCheckBit`] or [`YdlidarError::BadChecksum`].
    pub fn new_checked(buffer: T) -> Result<Self, YdlidarError> {
        let packet = Self::new_unchecked(buffer);
        packet.check_len()?;
        packet.check_header()?;
        packet.check_angles()?;
        packet.check_checksum()?;
        Ok(packet)
    }

    /// Checks that the buffer holds the header, that LSN ≥ 1 and that it holds the whole
    /// packet LSN announces.
    ///
    /// # Errors
    /// [`YdlidarError::Truncated`] for a short buffer, [`YdlidarError::NoSamples`] for LSN 0.
    pub fn check_len(&self) -> Result<(), YdlidarError> {
        let len = self.buffer.as_ref().len();
        if len < YDLIDAR_PACKET_HEADER_LEN {
            return Err(YdlidarError::Truncated);
        }
        if self.sample_count() == 0 {
            return Err(YdlidarError::NoSamples);
        }
        if len < self.total_len() {
            return Err(YdlidarError::Truncated);
        }
        Ok(())
    }

    /// Checks the header `AA 55`.
    ///
    /// # Errors
    /// [`YdlidarError::Truncated`] for fewer than 2 bytes, [`YdlidarError::BadHeader`].
    pub fn check_header(&self) -> Result<(), YdlidarError> {
        match self.buffer.as_ref().first_chunk::<2>() {
            None => Err(YdlidarError::Truncated),
            Some(&pair) if pair == YDLIDAR_PACKET_HEADER => Ok(()),
            Some(&found) => Err(YdlidarError::BadHeader { found }),
        }
    }

    /// Checks bit 0 of FSA and LSA, which the manuals fix at 1.
    ///
    /// # Errors
    /// [`YdlidarError::Truncated`] when the fields are absent, [`YdlidarError::BadCheckBit`].
    pub fn check_angles(&self) -> Result<(), YdlidarError> {
        if self.buffer.as_ref().len() < field::CS {
            return Err(YdlidarError::Truncated);
        }
        for field in [self.first_angle_raw(), self.last_angle_raw()] {
            if field & 1 == 0 {
                return Err(YdlidarError::BadCheckBit { field });
            }
        }
        Ok(())
    }

    /// Checks CS against the XOR of the packet's words.
    ///
    /// # Errors
    /// [`YdlidarError::Truncated`] when the buffer does not hold the packet,
    /// [`YdlidarError::BadChecksum`] on a mismatch.
    pub fn check_checksum(&self) -> Result<(), YdlidarError> {
        if self.buffer.as_ref().len() < self.total_len() || self.total_len() < field::SAMPLES {
            return Err(YdlidarError::Truncated);
        }
        let (stored, computed) = (self.checksum(), self.computed_checksum());
        check::stored_matches(stored, computed, |stored, computed| {
            YdlidarError::BadChecksum { stored, computed }
        })
    }

    /// Unwraps the buffer.
    #[must_use]
    pub fn into_inner(self) -> T {
        self.buffer
    }

    /// The packet's bytes, header through the last sample (the whole buffer when shorter).
    pub fn as_bytes(&self) -> &[u8] {
        let data = self.buffer.as_ref();
        data.get(..self.total_len()).unwrap_or(data)
    }

    /// The packet's length as LSN announces it: 10 + 2·LSN bytes (10 ..= 520).
    pub fn total_len(&self) -> usize {
        YDLIDAR_PACKET_HEADER_LEN + 2 * usize::from(self.sample_count())
    }

    /// PH as a little-endian word (0x55AA in a valid packet); 0 if absent.
    pub fn header(&self) -> u16 {
        read_u16_le(self.buffer.as_ref(), field::PH).unwrap_or(0)
    }

    /// CT, the packet type byte; 0 if absent.
    pub fn packet_type(&self) -> u8 {
        self.byte(field::CT)
    }

    /// Whether CT bit 0 is set: this packet (the "zero packet", one sample) starts a
    /// revolution.
    pub fn starts_revolution(&self) -> bool {
        self.packet_type() & 1 != 0
    }

    /// LSN, the number of samples (1..=255 in a valid packet); 0 if absent.
    pub fn sample_count(&self) -> u8 {
        self.byte(field::LSN)
    }

    /// FSA as sent (angle·64 in bits 15..1, check bit 0); 0 if absent.
    pub fn first_angle_raw(&self) -> u16 {
        read_u16_le(self.buffer.as_ref(), field::FSA).unwrap_or(0)
    }

    /// LSA as sent (angle·64 in bits 15..1, check bit 0); 0 if absent.
    pub fn last_angle_raw(&self) -> u16 {
        read_u16_le(self.buffer.as_ref(), field::LSA).unwrap_or(0)
    }

    /// The angle of the first sample before correction, degrees·64 (`FSA >> 1`, 0..=32 767;
    /// below 23 040 from a sound sensor).
    pub fn first_angle_q6(&self) -> u16 {
        self.first_angle_raw() >> 1
    }

    /// The angle of the last sample before correction, degrees·64 (`LSA >> 1`).
    pub fn last_angle_q6(&self) -> u16 {
        self.last_angle_raw() >> 1
    }

    /// CS, the check code carried by the packet; 0 if absent.
    pub fn checksum(&self) -> u16 {
        read_u16_le(self.buffer.as_ref(), field::CS).unwrap_or(0)
    }

    /// The XOR of the packet's words as LSN announces them (over the bytes present when the
    /// buffer is short).
    pub fn computed_checksum(&self) -> u16 {
        let data = self.buffer.as_ref();
        ydlidar_checksum(data.get(..self.total_len()).unwrap_or(data))
    }

    /// Sample `i` (0-based) as sent: distance·4 in millimetres, 0 = no return; `None` for
    /// `i ≥ LSN`. Absent bytes read as 0.
    pub fn sample(&self, i: usize) -> Option<u16> {
        if i >= usize::from(self.sample_count()) {
            return None;
        }
        Some(read_u16_le(self.buffer.as_ref(), field::SAMPLES + 2 * i).unwrap_or(0))
    }

    /// The LSN samples in order.
    pub fn samples(&self) -> impl Iterator<Item = u16> + '_ {
        (0..usize::from(self.sample_count())).filter_map(|i| self.sample(i))
    }

    /// The first-level angle of sample `i`: `FSA + i·diff/(LSN − 1)` with `diff` the
    /// clockwise difference FSA → LSA (across 360°), exact to the [`FineAngle`] LSB; FSA for
    /// LSN = 1; `None` for `i ≥ LSN`. Wire angles above 359.98° are taken modulo one turn.
    pub fn first_level_angle(&self, i: usize) -> Option<FineAngle> {
        let n = u64::from(self.sample_count());
        let i = u64::try_from(i).ok().filter(|&i| i < n)?;
        let turn = u64::from(YDLIDAR_Q6_PER_TURN);
        let first = u64::from(self.first_angle_q6()) % turn;
        let last = u64::from(self.last_angle_q6()) % turn;
        let diff = (last + turn - first) % turn;
        let steps = n.saturating_sub(1).max(1);
        Some(turn_fraction(steps * first + i * diff, steps * turn))
    }

    /// The first-level angles of samples 0, 1, 2, … in order, each exactly
    /// [`first_level_angle`](Self::first_level_angle), by two divisions per packet rather
    /// than one per sample.
    pub(crate) fn first_level_angle_steps(&self) -> Option<TurnSteps> {
        let n = u64::from(self.sample_count());
        let turn = u64::from(YDLIDAR_Q6_PER_TURN);
        let first = u64::from(self.first_angle_q6()) % turn;
        let last = u64::from(self.last_angle_q6()) % turn;
        let diff = (last + turn - first) % turn;
        let steps = n.saturating_sub(1).max(1);
        TurnSteps::new(steps * first, diff, steps * turn)
    }

    /// The angle of sample `i` with `correction` applied; `None` for `i ≥ LSN`.
    pub fn angle(&self, i: usize, correction: YdlidarAngleCorrection) -> Option<FineAngle> {
        let first = self.first_level_angle(i)?;
        Some(corrected(first, self.sample(i)?, correction))
    }

    /// The LSN returns with the manuals' second-level correction
    /// ([`YdlidarAngleCorrection::SecondLevel`], the X4 and X2).
    pub fn returns(&self) -> impl Iterator<Item = LaserReturn> + '_ {
        self.returns_with(YdlidarAngleCorrection::SecondLevel)
    }

    /// The LSN returns with the given correction: angle as [`angle`](Self::angle), range
    /// Si/4 rounded to the millimetre (0 = no return), no quality.
    pub fn returns_with(
        &self,
        correction: YdlidarAngleCorrection,
    ) -> impl Iterator<Item = LaserReturn> + '_ {
        let mut steps = self.first_level_angle_steps();
        (0..usize::from(self.sample_count())).filter_map(move |i| {
            let sample = self.sample(i)?;
            let first = match steps.as_mut() {
                Some(steps) => steps.next_angle(),
                None => self.first_level_angle(i)?,
            };
            Some(laser_return(corrected(first, sample, correction), sample))
        })
    }

    fn byte(&self, at: usize) -> u8 {
        self.buffer.as_ref().get(at).copied().unwrap_or(0)
    }
}

/// A first-level angle with `correction` for a sample of `si` (distance·4 mm) applied.
pub(crate) fn corrected(
    first: FineAngle,
    si: u16,
    correction: YdlidarAngleCorrection,
) -> FineAngle {
    match correction {
        YdlidarAngleCorrection::Off => first,
        YdlidarAngleCorrection::SecondLevel => first.wrapping_add(ydlidar_angle_correction(si)),
    }
}

/// The fields of one packet to [`emit`](YdlidarRepr::emit) (test streams, the simulator).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct YdlidarRepr<'a> {
    /// CT: bit 0 set for the packet that starts a revolution.
    pub packet_type: u8,
    /// Angle of the first sample, degrees·64 (0..=32 767; a sensor sends 0..23 040).
    pub first_angle_q6: u16,
    /// Angle of the last sample, degrees·64.
    pub last_angle_q6: u16,
    /// The samples, distance·4 in millimetres (1..=255 of them).
    pub samples: &'a [u16],
}

impl YdlidarRepr<'_> {
    /// Bytes of the emitted packet: 10 + 2·samples.
    #[must_use]
    pub const fn buffer_len(&self) -> usize {
        YDLIDAR_PACKET_HEADER_LEN + 2 * self.samples.len()
    }

    /// Writes the packet (check bits set, check code computed) to the front of `out` and
    /// returns its length.
    ///
    /// # Errors
    /// [`YdlidarError::NoSamples`] for no samples, [`YdlidarError::OutOfRange`] for more than
    /// 255 samples or an angle above 32 767, [`YdlidarError::BufferTooSmall`]; nothing is
    /// written then.
    pub fn emit(&self, out: &mut [u8]) -> Result<usize, YdlidarError> {
        if self.samples.is_empty() {
            return Err(YdlidarError::NoSamples);
        }
        let Ok(lsn) = u8::try_from(self.samples.len()) else {
            return Err(YdlidarError::OutOfRange);
        };
        if self.first_angle_q6 > 0x7FFF || self.last_angle_q6 > 0x7FFF {
            return Err(YdlidarError::OutOfRange);
        }
        let len = self.buffer_len();
        let available = out.len();
        let Some(dst) = out.get_mut(..len) else {
            return Err(YdlidarError::BufferTooSmall {
                needed: len,
                available,
            });
        };
        let words = [
            YDLIDAR_PACKET_HEADER_WORD,
            u16::from_le_bytes([self.packet_type, lsn]),
            (self.first_angle_q6 << 1) | 1,
            (self.last_angle_q6 << 1) | 1,
            0,
        ];
        for (pair, word) in dst
            .chunks_exact_mut(2)
            .zip(words.iter().chain(self.samples))
        {
            pair.copy_from_slice(&word.to_le_bytes());
        }
        let cs = ydlidar_checksum(dst);
        if let Some(slot) = dst.get_mut(field::CS..field::SAMPLES) {
            slot.copy_from_slice(&cs.to_le_bytes());
        }
        Ok(len)
    }
}

#[cfg(test)]
mod tests {
    extern crate std;

    use super::*;
    use crate::wire::ydlidar::correction::YDLIDAR_CORRECTION_MAX_ERROR_DEG;
    use std::vec;
    use std::vec::Vec;

    fn degrees(a: FineAngle) -> f64 {
        f64::from(a.to_bits()) * 360.0 / 4_294_967_296.0
    }

    /// The X4 manual's example header (bytes 4 to 8 of the packet: `28 E5 6F BD 79`), with 40
    /// samples of 1 000 mm (`A0 0F`) and CT 0.
    fn manual_packet() -> Vec<u8> {
        // CS = PH ⊕ (CT | LSN << 8) ⊕ FSA ⊕ LSA ⊕ S1 ⊕ … ⊕ S40; the 40 equal samples cancel:
        // 0x55AA ⊕ 0x2800 = 0x7DAA; ⊕ 0x6FE5 = 0x124F; ⊕ 0x79BD = 0x6BF2.
        let mut p = vec![0xAA, 0x55, 0x00, 0x28, 0xE5, 0x6F, 0xBD, 0x79, 0xF2, 0x6B];
        for _ in 0..40 {
            p.extend_from_slice(&[0xA0, 0x0F]);
        }
        p
    }

    #[test]
    fn manual_example() {
        let bytes = manual_packet();
        let p = YdlidarPacket::new_checked(&bytes[..]).unwrap();
        assert_eq!(p.checksum(), 0x6BF2);
        assert_eq!(p.sample_count(), 40);
        assert!(!p.starts_revolution());
        // FSA: 0x6FE5 >> 1 = 0x37F2 = 14 322 → 14 322/64 = 223.781 25°.
        // LSA: 0x79BD >> 1 = 0x3CDE = 15 582 → 243.468 75°.
        assert_eq!((p.first_angle_q6(), p.last_angle_q6()), (14_322, 15_582));
        // Step: (15 582 − 14 322)/39 = 1 260/39 = 32.307… q6 = 0.504 807 7°.
        let off = YdlidarAngleCorrection::Off;
        assert_eq!(p.first_level_angle(0), Some(turn_fraction(14_322, 23_040)));
        assert_eq!(p.first_level_angle(39), Some(turn_fraction(15_582, 23_040)));
        let a10 = degrees(p.angle(10, off).unwrap());
        assert!(
            (a10 - (223.781_25 + 10.0 * 0.504_807_692)).abs() < 1e-7,
            "{a10}"
        );
        // Second level, Distance = 1 000 mm: AngCorrect = −6.762 19° (correction.rs), so
        // sample 0 lies at 223.781 25 − 6.762 19 = 217.019 06°.
        let a0 = degrees(p.angle(0, YdlidarAngleCorrection::SecondLevel).unwrap());
        assert!((a0 - 217.019_064).abs() < 1e-4, "{a0}");
        let r: Vec<_> = p.returns().collect();
        assert_eq!(r.len(), 40);
        assert_eq!(r[0].range_mm, 1000);
        assert_eq!(r[0].quality, None);
        assert_eq!(
            r[0].angle,
            p.angle(0, YdlidarAngleCorrection::SecondLevel).unwrap()
        );
        // The distance example: Si = 0x6FE5 → 7 161.25 mm → 7 161 mm.
        let mut q = bytes.clone();
        q[10] = 0xE5;
        q[11] = 0x6F;
        q[12] = 0xE5;
        q[13] = 0x6F;
        let p = YdlidarPacket::new_checked(&q[..]).unwrap();
        assert_eq!(p.returns().next().map(|r| r.range_mm), Some(7161));
    }

    /// YDLIDAR's SDK, transcribed for one sample (`YDlidarDriver.cpp`, `parsePoints`):
    /// `sa = (FSA >> 1)/64`, `ea = (LSA >> 1)/64`, `ea += 360` when below `sa`,
    /// `step = |ea − sa|/(count − 1)`, `a = sa + step·i + ca` with
    /// `ca = atan(21.8·(155.3 − d/4)/155.3/(d/4))·180/π` for `d ≠ 0`, `a −= 360` above 360.
    fn sdk_angle(fsa: u16, lsa: u16, count: usize, i: usize, d: u16) -> f64 {
        let sa = f64::from(fsa >> 1) / 64.0;
        let mut ea = f64::from(lsa >> 1) / 64.0;
        if ea < sa {
            ea += 360.0;
        }
        let step = if count > 1 {
            (ea - sa).abs() / (count - 1) as f64
        } else {
            0.0
        };
        let mut a = sa + step * i as f64;
        if d != 0 {
            let q = f64::from(d) / 4.0;
            a += ((21.8 * (155.3 - q)) / 155.3 / q).atan() * 180.0 / core::f64::consts::PI;
        }
        if a > 360.0 {
            a -= 360.0;
        }
        a
    }

    #[test]
    fn agrees_with_the_sdk_formula() {
        let cases: [(u16, u16, Vec<u16>); 4] = [
            (14_322, 15_582, (0..40).map(|i| 400 + 97 * i).collect()),
            // Across 360°: 355.0° → 3.0°.
            (
                22_720,
                192,
                (0..25)
                    .map(|i| if i % 7 == 0 { 0 } else { 1 + 2_600 * i })
                    .collect(),
            ),
            (100, 100, vec![621, 622, 65_535, 1]),
            (23_000, 23_000, vec![12_345]),
        ];
        for (fsa, lsa, samples) in cases {
            let repr = YdlidarRepr {
                packet_type: 0,
                first_angle_q6: fsa,
                last_angle_q6: lsa,
                samples: &samples,
            };
            let mut buf = vec![0; repr.buffer_len()];
            repr.emit(&mut buf).unwrap();
            let p = YdlidarPacket::new_checked(&buf[..]).unwrap();
            for (i, r) in p.returns().enumerate() {
                let want = sdk_angle((fsa << 1) | 1, (lsa << 1) | 1, samples.len(), i, samples[i])
                    .rem_euclid(360.0);
                let got = degrees(r.angle);
                let diff = (got - want + 180.0).rem_euclid(360.0) - 180.0;
                assert!(
                    diff.abs() <= YDLIDAR_CORRECTION_MAX_ERROR_DEG + 1e-6,
                    "{fsa} {lsa} {i}: {got} vs {want}"
                );
                assert_eq!(r.range_mm, (u32::from(samples[i]) + 2) / 4);
            }
        }
    }

    #[test]
    fn checks_and_emit_errors() {
        let good = manual_packet();
        let mut bad = good.clone();
        bad[20] ^= 0x40;
        assert!(matches!(
            YdlidarPacket::new_checked(&bad[..]),
            Err(YdlidarError::BadChecksum { stored: 0x6BF2, .. })
        ));
        bad = good.clone();
        bad[4] &= !1;
        assert_eq!(
            YdlidarPacket::new_checked(&bad[..]),
            Err(YdlidarError::BadCheckBit { field: 0x6FE4 })
        );
        bad = good.clone();
        bad[1] = 0x56;
        assert_eq!(
            YdlidarPacket::new_checked(&bad[..]),
            Err(YdlidarError::BadHeader {
                found: [0xAA, 0x56]
            })
        );
        bad = good.clone();
        bad[3] = 0;
        assert_eq!(
            YdlidarPacket::new_checked(&bad[..]),
            Err(YdlidarError::NoSamples)
        );
        assert_eq!(
            YdlidarPacket::new_checked(&good[..good.len() - 1]),
            Err(YdlidarError::Truncated)
        );
        assert_eq!(
            YdlidarPacket::new_checked(&good[..9]),
            Err(YdlidarError::Truncated)
        );
        let empty = YdlidarPacket::new_unchecked(&[][..]);
        assert_eq!(empty.returns().count(), 0);
        assert_eq!(empty.first_level_angle(0), None);
        assert_eq!(empty.check_angles(), Err(YdlidarError::Truncated));
        assert_eq!(empty.check_checksum(), Err(YdlidarError::Truncated));

        let mut out = [0; 16];
        let repr = YdlidarRepr {
            packet_type: 1,
            first_angle_q6: 0,
            last_angle_q6: 0,
            samples: &[],
        };
        assert_eq!(repr.emit(&mut out), Err(YdlidarError::NoSamples));
        let many = [0_u16; 256];
        let repr = YdlidarRepr {
            samples: &many,
            ..repr
        };
        assert_eq!(repr.emit(&mut out), Err(YdlidarError::OutOfRange));
        let repr = YdlidarRepr {
            samples: &[5, 6, 7],
            ..repr
        };
        assert_eq!(
            repr.emit(&mut out[..15]),
            Err(YdlidarError::BufferTooSmall {
                needed: 16,
                available: 15
            })
        );
        assert_eq!(repr.emit(&mut out), Ok(16));
        let repr = YdlidarRepr {
            first_angle_q6: 0x8000,
            ..repr
        };
        assert_eq!(repr.emit(&mut out), Err(YdlidarError::OutOfRange));
        // A zero packet: one sample, CT bit 0.
        let zero = YdlidarRepr {
            packet_type: 1,
            first_angle_q6: 0,
            last_angle_q6: 0,
            samples: &[800],
        };
        let mut buf = [0; 12];
        assert_eq!(zero.emit(&mut buf), Ok(12));
        let p = YdlidarPacket::new_checked(&buf[..]).unwrap();
        assert!(p.starts_revolution());
        assert_eq!(p.first_level_angle(0), Some(FineAngle::ZERO));
    }
}
