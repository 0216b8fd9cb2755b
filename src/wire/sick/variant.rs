//! The scanner variants of the SICK LMS2xx (command 0x3B): the field of view and the angular
//! step, their beam angles, and the mapping of interlaced partial scans.
//!
//! # Beam angles
//! θ is the scanner's own angle in its scan plane: 0° = the scanner's right, 90° = straight
//! out of its front, 180° = its left. Beam k of a variant lies at `θ_k = θ_0 + k·Δθ`:
//!
//! | variant | θ_0 | Δθ | beams |
//! | --- | --- | --- | --- |
//! | [`Variant::Fov180Step1`] | 0° | 1° | 181 |
//! | [`Variant::Fov180StepHalf`] | 0° | 0.5° | 361 |
//! | [`Variant::Fov100Step1`] | 40° | 1° | 101 |
//! | [`Variant::Fov100StepHalf`] | 40° | 0.5° | 201 |
//! | [`Variant::Fov100StepQuarter`] | 40° | 0.25° | 401 |
//!
//! (The 100° field's start at 40° is marked "unverified" in `docs/sick-lms2xx.md`.) Every
//! angle is a multiple of 0.25°, held exactly as a count of quarter degrees.
//!
//! # Interlaced partial scans (our reading)
//! At 0.5° and 0.25° the scanner interlaces several 1° sweeps. A telegram that carries the
//! variant's full beam count is the whole scan in angle order: value k is beam k. A telegram
//! that carries a *partial* scan (bits 11–12 of the count word, the partial-scan index p =
//! 0 ..= 3) holds one 1° sweep whose first value lies p·0.25° past θ_0 (the reading of the
//! public drivers, which place value j at `θ_0 + j·1° + p·0.25°`): value j is beam
//! `(4j + p)/(Δθ/0.25°)` of the full table. [`Variant::partial_scan_beam`] does this
//! mapping, and refuses an index p that is not a multiple of the variant's step (p = 1 or 3
//! at 0.5°, p ≠ 0 at 1°) and a value past the last beam (a sweep offset by p has one value
//! fewer).

use core::fmt;

use super::Error;
use crate::angle::FineAngle;

/// The most beams a scan line has: 401 (100° at 0.25°).
pub const MAX_BEAMS: usize = 401;

/// A SICK LMS2xx scan variant: the field of view and the angular step (command 0x3B).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Variant {
    /// 180° field, 1° step: 181 beams from 0° to 180°.
    Fov180Step1,
    /// 180° field, 0.5° step: 361 beams from 0° to 180° (two interlaced 1° sweeps).
    Fov180StepHalf,
    /// 100° field, 1° step: 101 beams from 40° to 140°.
    Fov100Step1,
    /// 100° field, 0.5° step: 201 beams from 40° to 140° (two interlaced 1° sweeps).
    Fov100StepHalf,
    /// 100° field, 0.25° step: 401 beams from 40° to 140° (four interlaced 1° sweeps).
    Fov100StepQuarter,
}

impl Variant {
    /// The variant command 0x3B's fields describe: the scan angle in degrees (100 or 180) and
    /// the resolution in hundredths of a degree (25, 50 or 100).
    ///
    /// # Errors
    /// [`Error::UnknownScanAngle`], [`Error::UnknownResolution`], or
    /// [`Error::UnsupportedVariant`] for 180° at 0.25° (721 values do not fit a telegram).
    pub const fn from_fields(degrees: u16, centideg: u16) -> Result<Self, Error> {
        if degrees != 100 && degrees != 180 {
            return Err(Error::UnknownScanAngle { degrees });
        }
        if centideg != 25 && centideg != 50 && centideg != 100 {
            return Err(Error::UnknownResolution { centideg });
        }
        match Self::from_sick(degrees, centideg) {
            Some(variant) => Ok(variant),
            None => Err(Error::UnsupportedVariant { degrees, centideg }),
        }
    }

    /// Every variant, in the order of the table in the module documentation.
    pub const ALL: [Self; 5] = [
        Self::Fov180Step1,
        Self::Fov180StepHalf,
        Self::Fov100Step1,
        Self::Fov100StepHalf,
        Self::Fov100StepQuarter,
    ];

    /// The variant the scanner reports (or is set to) with command 0x3B: the scan angle in
    /// degrees (100 or 180) and the resolution in hundredths of a degree (25, 50 or 100).
    /// `None` for any other pair (the LMS2xx has no 180° field at 0.25°).
    #[must_use]
    pub const fn from_sick(scan_angle_deg: u16, resolution_centideg: u16) -> Option<Self> {
        match (scan_angle_deg, resolution_centideg) {
            (180, 100) => Some(Self::Fov180Step1),
            (180, 50) => Some(Self::Fov180StepHalf),
            (100, 100) => Some(Self::Fov100Step1),
            (100, 50) => Some(Self::Fov100StepHalf),
            (100, 25) => Some(Self::Fov100StepQuarter),
            _ => None,
        }
    }

    /// The scan angle as command 0x3B gives it, degrees: 180 or 100.
    #[must_use]
    pub const fn scan_angle_deg(self) -> u16 {
        match self {
            Self::Fov180Step1 | Self::Fov180StepHalf => 180,
            Self::Fov100Step1 | Self::Fov100StepHalf | Self::Fov100StepQuarter => 100,
        }
    }

    /// The angular step as command 0x3B gives it, hundredths of a degree: 100, 50 or 25.
    #[must_use]
    pub const fn resolution_centideg(self) -> u16 {
        self.step_quarter_degrees() * 25
    }

    /// The angle of the first beam, θ_0, in quarter degrees: 0 (180° field) or 160 (40°).
    #[must_use]
    pub const fn first_quarter_degrees(self) -> u16 {
        // The field is centred on 90°: it starts (180° − the scan angle)/2 in, 2 quarter
        // degrees a degree of the difference.
        (180 - self.scan_angle_deg()) * 2
    }

    /// The step between beams, Δθ, in quarter degrees: 4 (1°), 2 (0.5°) or 1 (0.25°).
    #[must_use]
    pub const fn step_quarter_degrees(self) -> u16 {
        match self {
            Self::Fov180Step1 | Self::Fov100Step1 => 4,
            Self::Fov180StepHalf | Self::Fov100StepHalf => 2,
            Self::Fov100StepQuarter => 1,
        }
    }

    /// The number of beams of a full scan: 181, 361, 101, 201 or 401 (≤ [`MAX_BEAMS`]).
    #[must_use]
    pub const fn beam_count(self) -> usize {
        match self {
            Self::Fov180Step1 => 181,
            Self::Fov180StepHalf => 361,
            Self::Fov100Step1 => 101,
            Self::Fov100StepHalf => 201,
            Self::Fov100StepQuarter => 401,
        }
    }

    /// The number of values in a sweep at 1°, the unit of an interlaced partial scan: 181 or
    /// 101 (one fewer for a sweep offset by p > 0, see [`Variant::partial_scan_beam`]).
    #[must_use]
    pub const fn sweep_count(self) -> usize {
        self.scan_angle_deg() as usize + 1
    }

    /// The angle θ_k of beam `index` in quarter degrees, `0 ..= 720`; `None` past the last
    /// beam.
    #[must_use]
    pub const fn beam_quarter_degrees(self, index: usize) -> Option<u16> {
        if index >= self.beam_count() {
            return None;
        }
        // index ≤ 400 and the step ≤ 4, so the angle is ≤ 160 + 400 = 720.
        Some(self.first_quarter_degrees() + index as u16 * self.step_quarter_degrees())
    }

    /// The angle θ_k of beam `index` as a [`FineAngle`]; `None` past the last beam.
    #[must_use]
    pub const fn beam_angle(self, index: usize) -> Option<FineAngle> {
        match self.beam_quarter_degrees(index) {
            Some(q) => Some(FineAngle::from_quarter_degrees(q as u32)),
            None => None,
        }
    }

    /// The beam of the full table that value `value_index` of an interlaced partial scan with
    /// partial-scan index `partial_index` (the start offset in 0.25° steps, 0 ..= 3) lies on:
    /// `(4·value_index + partial_index) / step`, with step the variant's Δθ in quarter
    /// degrees.
    ///
    /// `None` when `partial_index` > 3 or is not a multiple of the step (1 or 3 at 0.5°,
    /// anything but 0 at 1°), or when the value lies past the last beam.
    #[must_use]
    pub const fn partial_scan_beam(self, partial_index: u8, value_index: usize) -> Option<usize> {
        let step = self.step_quarter_degrees() as usize;
        let p = partial_index as usize;
        if p > 3 || !p.is_multiple_of(step) || value_index >= self.sweep_count() {
            return None;
        }
        // value_index ≤ 180, so 4·value_index + 3 cannot overflow.
        let beam = (4 * value_index + p) / step;
        if beam < self.beam_count() {
            Some(beam)
        } else {
            None
        }
    }

    /// The beam angle of value `index` of a measured-values reply with `count` values and
    /// partial-scan index `partial_index`, hundredths of a degree in the scanner's 0°..180°
    /// frame (90° straight ahead):
    ///
    /// `start + index · (angle · 100) / (count − 1) + 25 · partial_index`
    ///
    /// - `start` is 0° for 180° and 40° for 100° (unverified);
    /// - the step is the scan angle over `count − 1`, so a full scan (181 values at 1°, 361 at
    ///   0.5°, 401 at 0.25° over 100°) steps by the resolution, and a 1° partial scan of an
    ///   interlaced 0.5°/0.25° mode (181 or 101 values) steps by 1°; the integer division is
    ///   exact for every count a variant produces, and rounds down otherwise;
    /// - an interlaced partial scan is offset by its index times 0.25° (as the public ROS
    ///   drivers read it; unverified), so indexes 0..=3 cover the four 0.25° phases; a full
    ///   scan carries index 0.
    ///
    /// `None` when `index >= count`, when `count < 2`, or when `partial_index > 3`.
    #[must_use]
    pub fn beam_angle_centideg(self, count: u16, partial_index: u8, index: u16) -> Option<u32> {
        if index >= count || count < 2 || partial_index > 3 {
            return None;
        }
        let span = u32::from(self.scan_angle_deg()) * 100;
        let step = u32::from(index).checked_mul(span)? / u32::from(count - 1);
        Some(u32::from(self.first_quarter_degrees()) * 25 + step + 25 * u32::from(partial_index))
    }
}

impl fmt::Display for Variant {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let step = match self.step_quarter_degrees() {
            4 => "1",
            2 => "0.5",
            _ => "0.25",
        };
        write!(f, "{}°/{}°", self.scan_angle_deg(), step)
    }
}

#[cfg(test)]
mod tests {
    extern crate std;
    use super::*;
    #[test]
    fn variants_match_the_sick_facts() {
        for v in Variant::ALL {
            assert_eq!(
                Variant::from_sick(v.scan_angle_deg(), v.resolution_centideg()),
                Some(v)
            );
            let last = v.beam_quarter_degrees(v.beam_count() - 1).unwrap();
            if v.scan_angle_deg() == 180 {
                assert_eq!(v.beam_quarter_degrees(0), Some(0));
                assert_eq!(last, 720);
            } else {
                assert_eq!(v.beam_quarter_degrees(0), Some(160));
                assert_eq!(last, 560);
            }
            assert!(v.beam_count() <= MAX_BEAMS);
        }
        assert_eq!(Variant::from_sick(180, 25), None);
        assert_eq!(Variant::from_sick(90, 100), None);
        assert_eq!(std::format!("{}", Variant::Fov100StepQuarter), "100°/0.25°");
    }

    #[test]
    fn partial_scans_map_onto_the_full_table() {
        use Variant::*;
        // 1°: only p = 0, the identity.
        assert_eq!(Fov180Step1.partial_scan_beam(0, 17), Some(17));
        assert_eq!(Fov180Step1.partial_scan_beam(0, 180), Some(180));
        assert_eq!(Fov180Step1.partial_scan_beam(0, 181), None);
        assert_eq!(Fov180Step1.partial_scan_beam(2, 0), None);
        // 0.5°: p = 0 → even beams, p = 2 → odd beams (0.5° later); 180.5° does not exist.
        assert_eq!(Fov180StepHalf.partial_scan_beam(0, 180), Some(360));
        assert_eq!(Fov180StepHalf.partial_scan_beam(2, 0), Some(1));
        assert_eq!(Fov180StepHalf.partial_scan_beam(2, 179), Some(359));
        assert_eq!(Fov180StepHalf.partial_scan_beam(2, 180), None);
        assert_eq!(Fov180StepHalf.partial_scan_beam(1, 0), None);
        assert_eq!(Fov180StepHalf.partial_scan_beam(3, 0), None);
        // 0.25°: four sweeps cover the 401 beams exactly once.
        let mut seen = [0_u8; MAX_BEAMS];
        for p in 0..4 {
            for j in 0..Fov100StepQuarter.sweep_count() {
                if let Some(k) = Fov100StepQuarter.partial_scan_beam(p, j) {
                    seen[k] += 1;
                    let angle = u32::from(Fov100StepQuarter.beam_quarter_degrees(k).unwrap());
                    assert_eq!(angle, 160 + 4 * j as u32 + u32::from(p));
                }
            }
        }
        assert!(seen.iter().all(|&n| n == 1));
        assert_eq!(Fov100StepQuarter.partial_scan_beam(4, 0), None);
        assert_eq!(Fov100StepQuarter.partial_scan_beam(u8::MAX, 0), None);
    }
}
