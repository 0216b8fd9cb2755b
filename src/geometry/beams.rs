//! The beam angles of a SICK LMS2xx scan line: the scanner variants ([`Variant`]), the
//! mapping of interlaced partial scans, and the per-beam (cos θ, sin θ) table
//! ([`BeamTable`]) the per-point path reads.
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
//!
//! # The table
//! Each beam's (cos θ, sin θ) is computed with [`FineAngle::sin_cos`] (integer arithmetic)
//! and rounded to signed Q1.15: the error is at most 2⁻¹⁶ ≈ 1.5·10⁻⁵ per component, except
//! for values above 1 − 2⁻¹⁶ (cos θ within 0.33° of 0°, sin θ within 0.33° of 90°), which
//! Q1.15 cannot round up to 1 and saturate at 1 − 2⁻¹⁵ (error ≤ 2⁻¹⁵ ≈ 3.05·10⁻⁵). The
//! direction as a whole is within 2⁻¹⁵ of the unit vector for every beam (the unit tests
//! check all five tables). That rounding is the largest term in the error of a world point:
//! at most 3.05·10⁻⁵ of the range (0.24 mm at 8 m, 2.5 mm at 81.91 m). [`BeamTable::new`] is a `const fn`, so a table
//! can live in flash as a `static`; it takes 1.6 KiB.

use core::fmt;

use fixed::types::I1F15;

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
        match self {
            Self::Fov180Step1 | Self::Fov180StepHalf => 0,
            Self::Fov100Step1 | Self::Fov100StepHalf | Self::Fov100StepQuarter => 160,
        }
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

/// The unit direction of one beam in the scan plane: (cos θ, sin θ), signed Q1.15.
///
/// Each component is within 2⁻¹⁶ of the exact value, except values above 1 − 2⁻¹⁶, which
/// saturate at 1 − 2⁻¹⁵; the vector is within 2⁻¹⁵ of the exact unit direction.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct BeamDir {
    cos: i16,
    sin: i16,
}

impl BeamDir {
    /// The direction of a beam at angle `theta` (any angle), rounded to Q1.15 (+1 saturates to
    /// 1 − 2⁻¹⁵).
    #[must_use]
    pub const fn new(theta: FineAngle) -> Self {
        let sc = theta.sin_cos();
        Self {
            cos: q15_from_q30(sc.cos.to_bits()),
            sin: q15_from_q30(sc.sin.to_bits()),
        }
    }

    /// cos θ, signed Q1.15.
    #[must_use]
    pub const fn cos(self) -> I1F15 {
        I1F15::from_bits(self.cos)
    }

    /// sin θ, signed Q1.15.
    #[must_use]
    pub const fn sin(self) -> I1F15 {
        I1F15::from_bits(self.sin)
    }

    /// (cos θ, sin θ) as raw Q1.15 bits.
    #[must_use]
    pub const fn to_bits(self) -> (i16, i16) {
        (self.cos, self.sin)
    }
}

/// A Q2.30 value rounded to Q1.15, saturating at the bounds of `i16`.
const fn q15_from_q30(raw: i32) -> i16 {
    let rounded = (raw as i64 + (1 << 14)) >> 15;
    if rounded > i16::MAX as i64 {
        i16::MAX
    } else if rounded < i16::MIN as i64 {
        i16::MIN
    } else {
        rounded as i16
    }
}

#[cfg(feature = "defmt")]
impl defmt::Format for BeamDir {
    fn format(&self, f: defmt::Formatter<'_>) {
        defmt::write!(
            f,
            "BeamDir(cos {=i16}, sin {=i16}) raw Q1.15",
            self.cos,
            self.sin
        );
    }
}

/// The directions of every beam of one [`Variant`], built once per configuration (or at
/// compile time: [`BeamTable::new`] is `const`). Fixed size, 401 entries (1.6 KiB).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct BeamTable {
    variant: Variant,
    dirs: [BeamDir; MAX_BEAMS],
}

impl BeamTable {
    /// A table of zero directions (for the first variant), all zero bits: the placeholder of
    /// an unconfigured pipeline, which uses no beam until it is configured.
    pub const EMPTY: Self = Self {
        variant: Variant::Fov180Step1,
        dirs: [BeamDir { cos: 0, sin: 0 }; MAX_BEAMS],
    };

    /// The table of `variant`: entry k is [`BeamDir::new`] of θ_k.
    #[must_use]
    pub const fn new(variant: Variant) -> Self {
        let mut dirs = [BeamDir { cos: 0, sin: 0 }; MAX_BEAMS];
        let mut k = 0;
        while k < variant.beam_count() {
            if let (Some(theta), Some((_, rest))) =
                (variant.beam_angle(k), dirs.split_at_mut_checked(k))
            {
                if let Some(slot) = rest.first_mut() {
                    *slot = BeamDir::new(theta);
                }
            }
            k += 1;
        }
        Self { variant, dirs }
    }

    /// The variant this table was built for.
    #[must_use]
    pub const fn variant(&self) -> Variant {
        self.variant
    }

    /// The number of beams, [`Variant::beam_count`].
    #[must_use]
    pub const fn len(&self) -> usize {
        self.variant.beam_count()
    }

    /// Always `false`: every variant has beams.
    #[must_use]
    pub const fn is_empty(&self) -> bool {
        false
    }

    /// The direction of beam `index`; `None` past the last beam.
    #[must_use]
    pub fn get(&self, index: usize) -> Option<BeamDir> {
        self.as_slice().get(index).copied()
    }

    /// The directions of the beams, in beam order ([`BeamTable::len`] entries).
    #[must_use]
    pub fn as_slice(&self) -> &[BeamDir] {
        self.dirs.get(..self.len()).unwrap_or(&[])
    }
}

#[cfg(feature = "defmt")]
impl defmt::Format for BeamTable {
    fn format(&self, f: defmt::Formatter<'_>) {
        defmt::write!(f, "BeamTable({}, {=usize} beams)", self.variant, self.len());
    }
}

#[cfg(test)]
mod tests {
    extern crate std;
    use super::*;

    const ONE: i16 = i16::MAX;

    /// A table in flash: `new` is `const`.
    static QUARTER: BeamTable = BeamTable::new(Variant::Fov100StepQuarter);

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
    fn cardinal_beams() {
        let t = BeamTable::new(Variant::Fov180StepHalf);
        assert_eq!(t.len(), 361);
        assert_eq!(t.get(0).unwrap().to_bits(), (ONE, 0));
        assert_eq!(t.get(180).unwrap().to_bits(), (0, ONE));
        assert_eq!(t.get(360).unwrap().to_bits(), (-32_768, 0));
        // 100° field: beam 0 at 40°, beam 200 (of 401) at 90°.
        let (c, s) = QUARTER.get(200).unwrap().to_bits();
        assert_eq!((c, s), (0, ONE));
        let (c, s) = QUARTER.get(0).unwrap().to_bits();
        let th = 40_f64.to_radians();
        assert!((f64::from(c) / 32_768.0 - th.cos()).abs() <= 0.5 / 32_768.0);
        assert!((f64::from(s) / 32_768.0 - th.sin()).abs() <= 0.5 / 32_768.0);
    }

    #[test]
    fn every_entry_is_within_half_an_lsb() {
        for v in Variant::ALL {
            let t = BeamTable::new(v);
            assert_eq!(t.as_slice().len(), v.beam_count());
            for (k, dir) in t.as_slice().iter().enumerate() {
                let th = (f64::from(v.beam_quarter_degrees(k).unwrap()) / 4.0).to_radians();
                let (c, s) = dir.to_bits();
                let (ce, se) = (th.cos() * 32_768.0, th.sin() * 32_768.0);
                // Within half an LSB, except where saturation at 1 − 2⁻¹⁵ takes over.
                let bound = |exact: f64| if exact > 32_767.5 { 1.0 } else { 0.5 + 1e-3 };
                assert!((f64::from(c) - ce).abs() <= bound(ce), "{v} {k} cos");
                assert!((f64::from(s) - se).abs() <= bound(se), "{v} {k} sin");
                // The direction is within 2⁻¹⁵ (one LSB) of the unit vector.
                assert!(
                    (f64::from(c) - ce).hypot(f64::from(s) - se) <= 1.0,
                    "{v} {k}"
                );
            }
        }
    }

    #[test]
    fn out_of_range_beams_are_none() {
        for v in Variant::ALL {
            let t = BeamTable::new(v);
            for index in v.beam_count()..=MAX_BEAMS + 2 {
                assert_eq!(t.get(index), None);
                assert_eq!(v.beam_angle(index), None);
            }
            assert_eq!(t.get(usize::MAX), None);
            assert_eq!(v.beam_quarter_degrees(usize::MAX), None);
            assert_eq!(v.partial_scan_beam(0, usize::MAX), None);
        }
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
