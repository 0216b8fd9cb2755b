//! The per-beam (cos θ, sin θ) table ([`BeamTable`]) of a SICK LMS2xx scanner variant
//! ([`Variant`], with its beam angles and partial scans), which the per-point path reads.
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

use fixed::types::I1F15;

use crate::angle::FineAngle;
use crate::wire::sick::{Variant, MAX_BEAMS};

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

    /// Rebuilds the table for `variant` in place: the same table as [`BeamTable::new`], without
    /// a second 1.6 KiB table on the stack (`*table = BeamTable::new(v)` builds one there and
    /// copies it; a 16 KiB part has no room for that).
    pub fn rebuild(&mut self, variant: Variant) {
        self.variant = variant;
        for (k, slot) in self.dirs.iter_mut().enumerate() {
            *slot = match variant.beam_angle(k) {
                Some(theta) if k < variant.beam_count() => BeamDir::new(theta),
                _ => BeamDir { cos: 0, sin: 0 },
            };
        }
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
    fn rebuild_in_place_is_new() {
        // From every variant to every other (a larger table leaves no stale entries behind).
        for from in Variant::ALL {
            for to in Variant::ALL {
                let mut t = BeamTable::new(from);
                t.rebuild(to);
                assert_eq!(t, BeamTable::new(to), "{from:?} -> {to:?}");
            }
        }
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
}
