//! The fixed-point number types of the crate, with their units, ranges and resolutions.
//!
//! Every quantity on the per-point path is one of these; floats (`f32`, through `micromath`)
//! appear only where a configuration changes.

use fixed::types::{I16F16, I8F8, U1F15};

/// A length or a coordinate in metres: signed Q16.16.
///
/// Range −32 768 m ..= +32 767.99998 m, resolution 2⁻¹⁶ m ≈ 15.3 µm. Robot-frame and
/// world-frame coordinates of a robot that drives tens of kilometres fit; arithmetic on
/// the hot path saturates instead of wrapping.
pub type Meters = I16F16;

/// A log-odds value in natural-log units (nats): signed Q8.8.
///
/// Range −128 ..= +127.996, resolution 2⁻⁸ ≈ 0.0039 nats. The raw value `i16::MIN` is
/// reserved by [`crate::logodds::Cell`] for "unknown", so a stored value lies in
/// −127.996 ..= +127.996 (a probability within 10⁻⁵⁵ of 0 or 1).
pub type LogOddsFixed = I8F8;

/// A gate weight `w_k(d)` in 0 ..= 1: unsigned Q1.15.
///
/// Resolution 2⁻¹⁵ ≈ 3.05·10⁻⁵; 1.0 is exact (raw 32 768), so the hard gate is lossless.
pub type Weight = U1F15;

/// Converts an `f32` number of metres to [`Meters`], saturating at the type's bounds.
///
/// NaN maps to zero; callers validate their inputs before converting (see
/// [`crate::design::SensorModel::validate`]), so this is a last line of defence, not a policy.
#[must_use]
pub fn meters_from_f32(value: f32) -> Meters {
    if value.is_nan() {
        Meters::ZERO
    } else {
        Meters::saturating_from_num(value)
    }
}

/// A point in a right-handed frame (x forward, y left, z up), metres.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Point3 {
    /// x, metres (forward in the robot frame; east or map-x in the world frame).
    pub x: Meters,
    /// y, metres (left in the robot frame; north or map-y in the world frame).
    pub y: Meters,
    /// z, metres (up).
    pub z: Meters,
}

#[cfg(feature = "defmt")]
defmt_raw!(
    Point3,
    "Point3({=i32}, {=i32}, {=i32}) raw Q16.16",
    [x, y, z]
);

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn meters_conversion_saturates_and_maps_nan_to_zero() {
        assert_eq!(meters_from_f32(f32::NAN), Meters::ZERO);
        assert_eq!(meters_from_f32(f32::INFINITY), Meters::MAX);
        assert_eq!(meters_from_f32(f32::NEG_INFINITY), Meters::MIN);
        assert_eq!(meters_from_f32(1.5), Meters::from_num(1.5));
    }

    #[test]
    fn weight_represents_one_exactly() {
        assert_eq!(Weight::ONE.to_bits(), 1 << 15);
    }
}
