//! On-target tests of the core's arithmetic: `fmath`, `logodds`, and the `grid` index maths,
//! run in QEMU on the emulated Cortex-M (ARMv7E-M with its FPU, and ARMv6-M soft float).
//!
//! Expected values are literals computed independently (Python's `math`, f64), not by the
//! library.
#![no_std]
#![no_main]

use qemu_mps2 as _; // defmt logger, panic and HardFault handlers, semihosting exit

/// `|actual − expected| ≤ rel · |expected|`, in f64.
fn close(actual: f32, expected: f64, rel: f64) -> bool {
    let error = (f64::from(actual) - expected).abs();
    error <= rel * expected.abs()
}

#[defmt_test::tests]
mod tests {
    use super::close;
    use defmt::{assert, assert_eq};
    use terrain_pyramid::fmath;
    use terrain_pyramid::grid::{cell_of, entering, slot, start_of, window_offset, Entering};
    use terrain_pyramid::logodds::{gated, round_to_log_odds};
    use terrain_pyramid::{
        Cell, CellClass, Clamp, InverseSensorModel, Layer, LogOddsFixed, Meters, Resolution, Weight,
    };

    /// fmath's documented bound is 2·10⁻⁶ relative against f64.
    const REL: f64 = 2e-6;

    #[test]
    fn fmath_sqrt() {
        assert!(close(fmath::sqrt(2.0), core::f64::consts::SQRT_2, REL));
        assert!(close(fmath::sqrt(0.0123), 0.110_905_365_064_094_17, REL));
        assert!(close(fmath::sqrt(10_000.0), 100.0, REL));
        assert_eq!(fmath::sqrt(-1.0), 0.0);
    }

    #[test]
    fn fmath_atan() {
        assert!(close(fmath::atan(0.5), 0.463_647_609_000_806_1, REL));
        assert!(close(fmath::atan(2.0), 1.107_148_717_794_090_4, REL));
        // atan(ψ/2) for ψ = 2°, as the bound δ(d) uses it.
        let half_psi = 2.0_f32.to_radians() * 0.5;
        assert!(close(fmath::atan(half_psi), 0.017_451_520_651_465_824, REL));
        assert!(close(fmath::atan(-0.3), -0.291_456_794_477_867_1, REL));
    }

    #[test]
    fn fmath_exp() {
        assert!(close(fmath::exp(-0.5), 0.606_530_659_712_633_4, REL));
        assert!(close(fmath::exp(1.0), core::f64::consts::E, REL));
        assert!(close(fmath::exp(-20.0), 2.061_153_622_438_558e-9, REL));
        assert!(close(fmath::exp(3.7), 40.447_304_360_067_4, REL));
        assert_eq!(fmath::exp(-100.0), 0.0);
    }

    #[test]
    fn fmath_ln() {
        assert!(close(fmath::ln(2.0 / 3.0), -0.405_465_108_108_164_44, REL));
        assert!(close(fmath::ln(7.0 / 3.0), 0.847_297_860_387_203_7, REL));
        assert!(close(fmath::ln(10.0), core::f64::consts::LN_10, REL));
        assert!(close(fmath::ln(0.001 / 0.999), -6.906_754_778_648_554, REL));
        assert!(fmath::ln(0.0).is_nan());
    }

    #[test]
    fn logodds_gated_rounds_half_up() {
        let obstacle = LogOddsFixed::from_bits(217);
        let free = LogOddsFixed::from_bits(-104);
        let w = Weight::from_bits;
        assert_eq!(gated(obstacle, Weight::ONE), 217);
        assert_eq!(gated(free, Weight::ONE), -104);
        assert_eq!(gated(obstacle, w(16_384)), 109); // 108.5 rounds up
        assert_eq!(gated(free, w(16_384)), -52);
        assert_eq!(gated(obstacle, w(24_576)), 163);
        assert_eq!(gated(free, w(24_576)), -78);
        assert_eq!(gated(free, w(10_923)), -35);
        assert_eq!(gated(obstacle, Weight::ZERO), 0);
        assert_eq!(gated(obstacle, w(1)), 0);
    }

    #[test]
    fn logodds_cell_updated() {
        let zero = LogOddsFixed::ZERO;
        // An unknown cell starts from the prior's log-odds.
        let c = Cell::UNKNOWN.updated(217, zero, Clamp::OCTOMAP);
        assert_eq!(c.to_raw(), 217);
        assert_eq!(c.class(), CellClass::Obstacle);
        // A zero increment leaves even an unknown cell unknown.
        assert!(!Cell::UNKNOWN.updated(0, zero, Clamp::OCTOMAP).is_observed());
        // OctoMap clamping: 3.5 nats = raw 896, −2 nats = raw −512.
        let mut c = Cell::UNKNOWN;
        for _ in 0..10 {
            c = c.updated(217, zero, Clamp::OCTOMAP);
        }
        assert_eq!(c.to_raw(), 896);
        for _ in 0..20 {
            c = c.updated(-104, zero, Clamp::OCTOMAP);
        }
        assert_eq!(c.to_raw(), -512);
        assert_eq!(c.class(), CellClass::Navigable);
        // Without clamping the sum saturates and never reaches the unknown marker.
        let high = Cell::from_raw(32_700).updated(217, zero, Clamp::Off);
        assert_eq!(high.to_raw(), i16::MAX);
        let low = Cell::from_raw(-32_700).updated(-104, zero, Clamp::Off);
        assert_eq!(low.to_raw(), -i16::MAX);
        assert!(low.is_observed());
        // Back to zero is "observed, undecided", not unknown.
        let undecided = Cell::from_raw(104).updated(-104, zero, Clamp::Off);
        assert_eq!(undecided.class(), CellClass::Undecided);
    }

    #[test]
    fn logodds_default_increments() {
        // logit(0.7) · 256 = 216.908 → 217; logit(0.4) · 256 = −103.799 → −104; logit(0.5) = 0.
        let inc = InverseSensorModel::default().increments().unwrap();
        assert_eq!(inc.obstacle.to_bits(), 217);
        assert_eq!(inc.free.to_bits(), -104);
        assert_eq!(inc.initial.to_bits(), 0);
        assert_eq!(round_to_log_odds(0.847_297_9).to_bits(), 217);
        assert_eq!(round_to_log_odds(-0.405_465_1).to_bits(), -104);
    }

    #[test]
    fn grid_cell_of_floors() {
        let r = Resolution::from_m(0.1).unwrap();
        assert_eq!(r.to_bits(), 6554); // round(0.1 · 2¹⁶)
        assert_eq!(cell_of(0, 6554), 0);
        assert_eq!(cell_of(6553, 6554), 0);
        assert_eq!(cell_of(6554, 6554), 1);
        assert_eq!(cell_of(-1, 6554), -1);
        assert_eq!(cell_of(-6554, 6554), -1);
        assert_eq!(cell_of(-6555, 6554), -2);
        assert_eq!(cell_of(i32::MIN, 6554), -327_661);
        assert_eq!(cell_of(123, 0), 0);
        assert_eq!(r.cell_of(Meters::from_num(0.35)), 3);
        assert_eq!(r.cell_of(Meters::from_num(-0.05)), -1);
    }

    #[test]
    fn grid_window_offset_and_slot() {
        assert_eq!(window_offset(-32, -32, 64), Some(0));
        assert_eq!(window_offset(-32, 31, 64), Some(63));
        assert_eq!(window_offset(-32, 32, 64), None);
        assert_eq!(window_offset(-32, -33, 64), None);
        assert_eq!(window_offset(i32::MIN, i32::MAX, 64), None);
        assert_eq!(slot(60, 10, 64), 6);
        assert_eq!(slot(0, 63, 64), 63);
        assert_eq!(slot(63, 1, 64), 0);
        assert_eq!(start_of(-32, 64), 32);
        assert_eq!(start_of(-1, 64), 63);
        assert_eq!(start_of(130, 64), 2);
    }

    #[test]
    fn grid_entering() {
        assert_eq!(entering(0, 0, 5, 8), Entering::None);
        assert_eq!(entering(0, 3, 5, 8), Entering::Slots { first: 5, count: 3 });
        assert_eq!(
            entering(0, -2, 5, 8),
            Entering::Slots { first: 3, count: 2 }
        );
        assert_eq!(
            entering(0, -2, 1, 8),
            Entering::Slots { first: 7, count: 2 }
        );
        assert_eq!(entering(0, 8, 5, 8), Entering::All);
        assert_eq!(entering(0, -9, 5, 8), Entering::All);
        assert_eq!(entering(i32::MIN, i32::MAX, 0, 8), Entering::All);
    }

    #[test]
    fn grid_layer_moves_without_copying() {
        let zero = LogOddsFixed::ZERO;
        let mut layer: Layer<8> = Layer::new();
        layer.reset(Resolution::from_m(0.1).unwrap());
        assert_eq!(layer.origin(), (-4, -4));
        assert!(layer.update(-4, -4, 217, zero, Clamp::Off));
        assert!(layer.update(3, 3, -104, zero, Clamp::Off));
        assert!(!layer.update(4, 0, 217, zero, Clamp::Off));
        assert_eq!(layer.counts().observed, 2);

        // Two columns enter on the right: 2 × 8 cells reset, (−4, −4) leaves the window.
        assert_eq!(layer.move_origin(-2, -4), 16);
        assert_eq!(layer.get(-4, -4), None);
        assert_eq!(layer.get(3, 3).map(Cell::to_raw), Some(-104));
        assert_eq!(layer.get(5, 3), Some(Cell::UNKNOWN));
        assert_eq!(layer.counts().observed, 1);

        // One row and one column at once: 8 + 7 cells.
        assert_eq!(layer.move_origin(-1, -3), 15);
        assert_eq!(layer.get(3, 3).map(Cell::to_raw), Some(-104));

        // Back where it was: the cells that come back are unknown, (3, 3) is kept.
        assert_eq!(layer.move_origin(-4, -4), 8 + 3 * 7);
        assert_eq!(layer.get(-4, -4), Some(Cell::UNKNOWN));
        assert_eq!(layer.get(3, 3).map(Cell::to_raw), Some(-104));

        // A whole window or more: everything resets.
        assert_eq!(layer.move_origin(100, -4), 64);
        assert_eq!(layer.counts().observed, 0);

        // Recentring on a robot at (1.05 m, −0.35 m) puts it in the centre cell.
        layer.recentre(Meters::from_num(1.05), Meters::from_num(-0.35));
        assert_eq!(layer.origin(), (10 - 4, -4 - 4));
    }
}
