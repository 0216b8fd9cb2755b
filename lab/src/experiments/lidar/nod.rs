//! Each nodding rig's nod: its servo's sweep, the rate its plan gives, and the nod's period.
//! The tilt between two revolutions, φ = [`RIG_PHI_DEG`] = 1.5°, is the largest (to a tenth of
//! a degree) for which every riser of [`PLANNED_STEP_M`] has a line close enough before it in
//! each sweep from [`SURE_FROM_M`] in (`pyramid design --revolution-hz F --step-m 0.17
//! --sure-from-m 4`; `docs/lidars.md`, "What the laser gave"); the nod's rate is φ times the
//! revolutions per second. The sweep's 33° then holds 22 revolutions, so a nod is a whole
//! number of them for every rig.

use terrain_pyramid_host_tests::sim::lidar::LidarKind;

/// The servo's lowest and highest tilt, degrees (positive looks down).
pub const SERVO_ENDS_DEG: (f64, f64) = (2.0, 35.0);
/// How far the servo lags its command, ms.
pub const SERVO_LATENCY_MS: f64 = 20.0;
/// The step every rig's nod is planned for, metres: the stairs' riser.
pub const PLANNED_STEP_M: f64 = 0.17;
/// The distance from which every rig's nod makes each such step sure, metres: the goal's.
pub const SURE_FROM_M: f64 = 4.0;
/// φ of every rig's nod, degrees: the largest tilt between two revolutions that makes every
/// step of [`PLANNED_STEP_M`] sure from [`SURE_FROM_M`] at [`super::HEIGHT_M`] (1.574°),
/// rounded down to a tenth of a degree. A test derives it from `pyramid design`'s plan.
pub const RIG_PHI_DEG: f64 = 1.5;

/// Rig `kind`'s servo: lowest and highest tilt (degrees), rate (°/s), latency (ms). The rate
/// is [`RIG_PHI_DEG`] times the lidar's revolutions per second.
#[must_use]
pub const fn rig_servo(kind: LidarKind) -> (f64, f64, f64, f64) {
    (
        SERVO_ENDS_DEG.0,
        SERVO_ENDS_DEG.1,
        RIG_PHI_DEG * kind.rotation_hz(),
        SERVO_LATENCY_MS,
    )
}

/// The LD19's servo: 2°..35° at 15 °/s, 20 ms behind its command.
pub const SERVO: (f64, f64, f64, f64) = rig_servo(LidarKind::Ld19);

/// Rig `kind`'s nod period, seconds: up and down between the servo's limits (LD19 4.4 s,
/// RPLIDAR A1 standard scan 8 s, YDLIDAR X4 6.29 s): 44 revolutions of every rig.
#[must_use]
pub fn nod_period_s(kind: LidarKind) -> f64 {
    let (lo, hi, rate, _) = rig_servo(kind);
    2.0 * (hi - lo) / rate
}

#[cfg(test)]
mod tests {
    use super::super::{on_board::BOARD_RIGS, HEIGHT_M};
    use super::*;

    /// Every rig's nod is `pyramid design`'s plan for the stairs' risers from 4 m, its φ
    /// rounded down to a tenth of a degree, and a nod is a whole number of revolutions.
    #[test]
    fn every_rig_nods_as_its_plan_says() {
        use terrain_pyramid_host::design::nod::{plan, NodArgs};
        let grade = terrain_pyramid::classify::PlaneRule::DEFAULT
            .max_grade
            .to_num::<f64>();
        for (kind, name) in BOARD_RIGS {
            let (lo, hi, rate, latency) = rig_servo(kind);
            assert_eq!((lo, hi, latency), (2.0, 35.0, 20.0), "{name}");
            let hz = kind.rotation_hz();
            let args = NodArgs {
                revolution_hz: Some(hz),
                step_m: Some(PLANNED_STEP_M),
                sure_from_m: Some(SURE_FROM_M),
            };
            let p = plan(&args, rate / hz, HEIGHT_M, 12.0, grade)
                .unwrap()
                .unwrap();
            let sure = p.sure_from.unwrap();
            // φ is the plan's largest to a tenth of a degree, and the nod no faster than it.
            assert!((sure.max_phi_deg - 1.574).abs() < 1e-3, "{name}: {sure:?}");
            assert!(
                ((sure.max_phi_deg * 10.0).floor() / 10.0 - RIG_PHI_DEG).abs() < 1e-12,
                "{name}"
            );
            assert!(rate <= sure.max_nod_deg_s, "{name}: {rate} °/s");
            assert!(
                p.sure_within_m >= SURE_FROM_M,
                "{name}: {}",
                p.sure_within_m
            );
            // 44 revolutions a nod.
            let revolutions = nod_period_s(kind) * hz;
            assert!((revolutions - 44.0).abs() < 1e-9, "{name}: {revolutions}");
        }
        assert_eq!(SERVO, (2.0, 35.0, 15.0, 20.0));
    }
}
