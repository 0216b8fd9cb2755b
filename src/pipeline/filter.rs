//! Masks and filters on the returns, before any geometry: up to [`MAX_SECTORS`] masked
//! sectors of the sensor's own angle (the robot's body, a cable, a bumper), a minimum and a
//! maximum range, and a minimum quality for the sensors that report one.
//!
//! Each test is an integer comparison per return: a sector is a start angle and a width
//! (FineAngle bits), and an angle lies in it when `angle − start` (wrapping) is below the
//! width; the ranges are millimetres; the quality is the sensor's byte (LD06/LD19 intensity,
//! RPLIDAR quality, YDLIDAR intensity where its format has one; a SICK reports none, and a
//! return without a quality always passes the quality test). A return refused is counted
//! under its first reason, in the order mask, too near, too far, low quality
//! ([`super::FrontendStats`]).
//!
//! The angle is the sensor's own: a spinning lidar's clockwise angle from its 0° as its
//! manual defines it ([`crate::wire::LaserReturn::angle`]), a SICK's beam angle θ (0° its
//! right, 90° its centre beam, 180° its left).

use crate::angle::FineAngle;

/// The most masked sectors a [`ReturnFilter`] holds.
pub const MAX_SECTORS: usize = 8;

/// Why a return was refused before geometry.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Refusal {
    /// Its angle lies in a masked sector.
    Masked,
    /// Nearer than the minimum range.
    TooNear,
    /// Farther than the maximum range.
    TooFar,
    /// Its quality is below the minimum.
    LowQuality,
}

/// A masked sector of the sensor's own angle: from `start` through `width` in the angle's
/// growing sense (for a spinning lidar clockwise seen from its top), `[start, start + width)`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Sector {
    /// The sector's first angle, FineAngle bits (2⁻³² turn).
    pub start: u32,
    /// The sector's width, 2⁻³² turn; 0 masks nothing (a whole turn is not a sector).
    pub width: u32,
}

impl Sector {
    /// The sector from `start` to `end` in the angle's growing sense (wrapping past 0° when
    /// `end` < `start`); `start == end` is empty.
    #[must_use]
    pub const fn between(start: FineAngle, end: FineAngle) -> Self {
        Self {
            start: start.to_bits(),
            width: end.wrapping_sub(start).to_bits(),
        }
    }

    /// Whether `angle` lies in the sector: one wrapping subtraction and a comparison.
    #[must_use]
    #[inline]
    pub const fn contains(&self, angle: FineAngle) -> bool {
        angle.to_bits().wrapping_sub(self.start) < self.width
    }
}

/// The masks and filters applied to each return before geometry (see the
/// [module documentation](self)). [`ReturnFilter::NONE`] passes everything.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ReturnFilter {
    sectors: [Sector; MAX_SECTORS],
    /// How many of `sectors` are in use, 0 ..= [`MAX_SECTORS`].
    sector_count: u8,
    /// The smallest range kept, millimetres; 0 = off.
    min_range_mm: u32,
    /// The largest range kept, millimetres; 0 = off (so that [`ReturnFilter::NONE`] is all
    /// zero bits and an unconfigured pipeline's `static` stays in `.bss`).
    max_range_mm: u32,
    /// The smallest quality kept; 0 = off.
    min_quality: u8,
    /// Any test is on (a return may be refused): [`ReturnFilter::NONE`]'s is not, and costs
    /// a return one test.
    active: bool,
}

impl Default for ReturnFilter {
    fn default() -> Self {
        Self::NONE
    }
}

impl ReturnFilter {
    /// No mask, no filter: every return passes.
    pub const NONE: Self = Self {
        sectors: [Sector { start: 0, width: 0 }; MAX_SECTORS],
        sector_count: 0,
        min_range_mm: 0,
        max_range_mm: 0,
        min_quality: 0,
        active: false,
    };

    /// A filter of the given sectors (at most [`MAX_SECTORS`]: more gives `None`), a minimum
    /// and a maximum range in millimetres (0 = off each) and a minimum quality (0 = off).
    #[must_use]
    pub fn new(
        sectors: &[Sector],
        min_range_mm: u32,
        max_range_mm: u32,
        min_quality: u8,
    ) -> Option<Self> {
        if sectors.len() > MAX_SECTORS {
            return None;
        }
        let mut all = [Sector::default(); MAX_SECTORS];
        for (slot, s) in all.iter_mut().zip(sectors) {
            *slot = *s;
        }
        Some(Self {
            sectors: all,
            sector_count: u8::try_from(sectors.len()).unwrap_or(0),
            min_range_mm,
            max_range_mm,
            min_quality,
            active: !sectors.is_empty()
                || min_range_mm != 0
                || max_range_mm != 0
                || min_quality != 0,
        })
    }

    /// The sectors in use.
    #[must_use]
    pub fn sectors(&self) -> &[Sector] {
        self.sectors
            .get(..usize::from(self.sector_count))
            .unwrap_or(&[])
    }

    /// The smallest range kept, millimetres; 0 = off.
    #[must_use]
    pub const fn min_range_mm(&self) -> u32 {
        self.min_range_mm
    }

    /// The largest range kept, millimetres; 0 = off.
    #[must_use]
    pub const fn max_range_mm(&self) -> u32 {
        self.max_range_mm
    }

    /// The smallest quality kept; 0 = off.
    #[must_use]
    pub const fn min_quality(&self) -> u8 {
        self.min_quality
    }

    /// Whether any test is on: a return may be refused (false for [`ReturnFilter::NONE`] and
    /// for a filter of no sector and every bound 0, which passes every return).
    #[must_use]
    #[inline]
    pub const fn active(&self) -> bool {
        self.active
    }

    /// Whether any sector is masked (a SICK line computes its beams' angles only then).
    #[must_use]
    #[inline]
    pub const fn masks(&self) -> bool {
        self.sector_count != 0
    }

    /// Whether `angle` lies in a masked sector.
    #[must_use]
    #[inline]
    pub fn masked(&self, angle: FineAngle) -> bool {
        self.sectors().iter().any(|s| s.contains(angle))
    }

    /// Why a return at `angle` (the sensor's own), `range_mm` (> 0: a sample without a return
    /// is not judged) and `quality` is refused, or `None` when it passes: per sector one
    /// subtraction and a comparison, then two range comparisons (the maximum's as
    /// `range − 1 > max − 1` wrapping, so that a maximum of 0, off, refuses nothing) and one of
    /// the quality.
    #[must_use]
    #[inline]
    pub fn judge(&self, angle: FineAngle, range_mm: u32, quality: Option<u8>) -> Option<Refusal> {
        if self.masked(angle) {
            Some(Refusal::Masked)
        } else if range_mm < self.min_range_mm {
            Some(Refusal::TooNear)
        } else if range_mm.wrapping_sub(1) > self.max_range_mm.wrapping_sub(1) {
            Some(Refusal::TooFar)
        } else if quality.is_some_and(|q| q < self.min_quality) {
            Some(Refusal::LowQuality)
        } else {
            None
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn deg(d: u32) -> FineAngle {
        FineAngle::from_quarter_degrees(4 * d)
    }

    #[test]
    fn sectors_wrap_and_exclude_their_end() {
        let s = Sector::between(deg(350), deg(10));
        assert!(s.contains(deg(350)));
        assert!(s.contains(deg(0)));
        assert!(s.contains(deg(9)));
        assert!(!s.contains(deg(10)));
        assert!(!s.contains(deg(349)));
        assert!(!Sector::between(deg(5), deg(5)).contains(deg(5)));
    }

    #[test]
    fn each_reason_in_order() {
        let f = ReturnFilter::new(&[Sector::between(deg(90), deg(100))], 100, 5_000, 10).unwrap();
        assert_eq!(f.judge(deg(95), 50, Some(0)), Some(Refusal::Masked));
        assert_eq!(f.judge(deg(0), 99, Some(200)), Some(Refusal::TooNear));
        assert_eq!(f.judge(deg(0), 5_001, Some(200)), Some(Refusal::TooFar));
        assert_eq!(f.judge(deg(0), 5_000, Some(9)), Some(Refusal::LowQuality));
        assert_eq!(f.judge(deg(0), 100, Some(10)), None);
        assert_eq!(f.judge(deg(0), 100, None), None);
        assert_eq!(ReturnFilter::NONE.judge(deg(0), u32::MAX, Some(0)), None);
        assert_eq!(ReturnFilter::NONE.judge(deg(0), 1, Some(0)), None);
        assert_eq!(f.max_range_mm(), 5_000);
        assert_eq!(ReturnFilter::NONE.max_range_mm(), 0);
        assert!(ReturnFilter::new(&[Sector::default(); MAX_SECTORS + 1], 0, 0, 0).is_none());
    }
}
