//! The f64 reference of the scan geometry, written from the conventions (the library's
//! `geometry` module documentation and `docs/sick-lms2xx.md`), not from the fixed-point code:
//! plain rotation matrices multiplied out with `f64::sin`/`f64::cos`.
//!
//! - Frames: right-handed, x forward, y left, z up, metres.
//! - Beam angle θ: 0° right, 90° ahead, 180° left. The 180° field starts at 0°, the 100° field
//!   at 40°; beam k is at `start + k·step`.
//! - Panned vertical plane: sensor direction `(sin θ, 0, −cos θ)`, then `R_z(p)`.
//! - Tilted horizontal plane: sensor direction `(sin θ, −cos θ, 0)`, then `R_y(τ)` (positive τ
//!   looks down).
//! - The scan centre sits at the mount position in the robot frame.
//! - World = T + `R_z(yaw)·R_y(pitch)·R_x(roll)`·robot.
//!
//! # The bound the fixed-point library is held to
//! A world point (and the horizontal distance) of `terrain_pyramid::geometry` is within
//! [`error_bound_m`]`(r) = 0.03 mm + 3.1·10⁻⁵ · r` of this reference for the same inputs:
//! 0.28 mm at 8 m, 0.96 mm at 30 m, 2.57 mm at 81.91 m. Nearly all of it is the Q1.15
//! rounding of the beam table (≤ 2⁻¹⁵ of the range). The property tests in
//! `tests/geometry.rs` check it; `examples/geometry_error.rs` measures the actual figures.

use terrain_pyramid::geometry as lib;

/// A 3-vector, metres or unitless.
pub type Vec3 = [f64; 3];
/// A 3 × 3 matrix, row-major.
pub type Mat3 = [[f64; 3]; 3];

/// The bound of the fixed-point world point's error against this reference, metres, for a
/// range of `range_m` metres: `0.03 mm + 3.1·10⁻⁵ · range`.
#[must_use]
pub fn error_bound_m(range_m: f64) -> f64 {
    3.0e-5 + 3.1e-5 * range_m
}

/// How the scan plane is mounted and swept.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Plane {
    /// Vertical scan plane, panned about z.
    PannedVertical,
    /// Horizontal scan plane, tilted about y (positive looks down).
    TiltedHorizontal,
}

/// The scanner on the robot.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Mount {
    /// The scan plane and actuator.
    pub plane: Plane,
    /// The scan centre in the robot frame, metres.
    pub position: Vec3,
}

/// The robot's pose: metres and radians, world = T + `R_z(yaw)·R_y(pitch)·R_x(roll)`·robot
/// (the library's convention).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Pose {
    /// x, metres.
    pub x: f64,
    /// y, metres.
    pub y: f64,
    /// z of the robot frame's origin (the simulator's trajectories: the ground contact
    /// point), metres.
    pub z: f64,
    /// Roll about x, radians.
    pub roll: f64,
    /// Pitch about y, radians (positive: nose down).
    pub pitch: f64,
    /// Yaw about z, radians (positive: nose left).
    pub yaw: f64,
}

/// A SICK LMS2xx field of view and step: `(first beam, step, beam count)` in degrees.
#[must_use]
pub fn variant_angles(field_deg: u32, step_deg: f64) -> (f64, f64, usize) {
    let start = if field_deg == 180 { 0.0 } else { 40.0 };
    // The field over the step, plus one: exact for the five variants.
    #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
    let count = (f64::from(field_deg) / step_deg).round() as usize + 1;
    (start, step_deg, count)
}

/// The angle of beam `index`, radians: `start + index·step` (degrees in).
#[must_use]
pub fn beam_angle_rad(start_deg: f64, step_deg: f64, index: usize) -> f64 {
    #[allow(clippy::cast_precision_loss)]
    let k = index as f64;
    (start_deg + k * step_deg).to_radians()
}

/// Rotation about x by `a` radians.
#[must_use]
pub fn rot_x(a: f64) -> Mat3 {
    let (s, c) = a.sin_cos();
    [[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]]
}

/// Rotation about y by `a` radians: `x' = x cos a + z sin a`, `z' = −x sin a + z cos a`.
#[must_use]
pub fn rot_y(a: f64) -> Mat3 {
    let (s, c) = a.sin_cos();
    [[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]]
}

/// Rotation about z by `a` radians.
#[must_use]
pub fn rot_z(a: f64) -> Mat3 {
    let (s, c) = a.sin_cos();
    [[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]]
}

/// The matrix product `a·b`.
#[must_use]
pub fn mat_mul(a: &Mat3, b: &Mat3) -> Mat3 {
    let mut out = [[0.0; 3]; 3];
    for (i, row) in out.iter_mut().enumerate() {
        for (j, cell) in row.iter_mut().enumerate() {
            *cell = (0..3).map(|k| a[i][k] * b[k][j]).sum();
        }
    }
    out
}

/// The product `m·v`.
#[must_use]
pub fn mat_vec(m: &Mat3, v: Vec3) -> Vec3 {
    [0, 1, 2].map(|i| m[i][0] * v[0] + m[i][1] * v[1] + m[i][2] * v[2])
}

/// The pose's rotation `R_z(yaw)·R_y(pitch)·R_x(roll)`.
#[must_use]
pub fn pose_rotation(pose: &Pose) -> Mat3 {
    mat_mul(
        &rot_z(pose.yaw),
        &mat_mul(&rot_y(pose.pitch), &rot_x(pose.roll)),
    )
}

/// The unit direction of beam θ in the robot frame, after the actuator (pan or tilt angle
/// `actuator_rad`).
#[must_use]
pub fn beam_direction_robot(plane: Plane, theta_rad: f64, actuator_rad: f64) -> Vec3 {
    let (s, c) = theta_rad.sin_cos();
    match plane {
        Plane::PannedVertical => mat_vec(&rot_z(actuator_rad), [s, 0.0, -c]),
        Plane::TiltedHorizontal => mat_vec(&rot_y(actuator_rad), [s, -c, 0.0]),
    }
}

/// The scanner's centre in the world.
#[must_use]
pub fn sensor_origin(mount: &Mount, pose: &Pose) -> Vec3 {
    let r = mat_vec(&pose_rotation(pose), mount.position);
    [pose.x + r[0], pose.y + r[1], pose.z + r[2]]
}

/// The world point of a return: beam angle θ, actuator angle, range in metres.
#[must_use]
pub fn world_point(
    mount: &Mount,
    pose: &Pose,
    actuator_rad: f64,
    theta_rad: f64,
    range_m: f64,
) -> Vec3 {
    let d = beam_direction_robot(mount.plane, theta_rad, actuator_rad);
    let robot = [0, 1, 2].map(|i| mount.position[i] + range_m * d[i]);
    let w = mat_vec(&pose_rotation(pose), robot);
    [pose.x + w[0], pose.y + w[1], pose.z + w[2]]
}

/// The actuator's axis of a [`GeneralMount`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Axis {
    /// About z: `R_z(a)`.
    Pan,
    /// About y: `R_y(a)` (positive looks down ahead).
    Tilt,
    /// No actuator.
    Fixed,
}

/// Any mount (`docs/lidars.md`, "The mount"): the sensor's frame (x its 0°, z its top; beam θ
/// along `(sin θ, −cos θ, 0)`) rotated by `R_z(yaw)·R_y(pitch)·R_x(roll)` relative to the
/// actuator's frame at zero, on an actuator about `axis` whose geometric angle is
/// `sense·(reported − zero)`; the scan centre at `position` in the robot frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GeneralMount {
    /// Roll, pitch, yaw, radians.
    pub rpy_rad: Vec3,
    /// The actuator's axis.
    pub axis: Axis,
    /// The reported angle that is the geometry's 0, radians.
    pub zero_rad: f64,
    /// +1 or −1.
    pub sense: f64,
    /// The scan centre in the robot frame, metres.
    pub position: Vec3,
}

/// The unit direction of beam θ in the robot frame on a [`GeneralMount`] at the reported
/// actuator angle: `A(a)·M·(sin θ, −cos θ, 0)`.
#[must_use]
pub fn general_direction_robot(mount: &GeneralMount, theta_rad: f64, reported_rad: f64) -> Vec3 {
    let a = mount.sense * (reported_rad - mount.zero_rad);
    let actuator = match mount.axis {
        Axis::Pan => rot_z(a),
        Axis::Tilt => rot_y(a),
        Axis::Fixed => rot_z(0.0),
    };
    let [roll, pitch, yaw] = mount.rpy_rad;
    let m = mat_mul(&rot_z(yaw), &mat_mul(&rot_y(pitch), &rot_x(roll)));
    let (s, c) = theta_rad.sin_cos();
    mat_vec(&mat_mul(&actuator, &m), [s, -c, 0.0])
}

/// The world point of a return on a [`GeneralMount`].
#[must_use]
pub fn general_world_point(
    mount: &GeneralMount,
    pose: &Pose,
    reported_rad: f64,
    theta_rad: f64,
    range_m: f64,
) -> Vec3 {
    let d = general_direction_robot(mount, theta_rad, reported_rad);
    let robot = [0, 1, 2].map(|i| mount.position[i] + range_m * d[i]);
    let w = mat_vec(&pose_rotation(pose), robot);
    [pose.x + w[0], pose.y + w[1], pose.z + w[2]]
}

/// The horizontal distance between two points, `√(Δx² + Δy²)`.
#[must_use]
pub fn horizontal_distance(a: Vec3, b: Vec3) -> f64 {
    (a[0] - b[0]).hypot(a[1] - b[1])
}

/// The Euclidean distance between two points.
#[must_use]
pub fn distance(a: Vec3, b: Vec3) -> f64 {
    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
}

/// One comparison of the fixed-point library against this reference: the library's inputs,
/// in the form the host and the wire give them.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Case {
    /// The beam index within the table's variant.
    pub beam: usize,
    /// The range, millimetres.
    pub range_mm: u32,
    /// The scan plane.
    pub plane: lib::ScanPlane,
    /// The scan centre in the robot frame, raw Q16.16 metres.
    pub mount_bits: [i32; 3],
    /// The pan or tilt angle, raw Q0.32 turn.
    pub actuator_bits: u32,
    /// The pose as the host sends it: x, y, z (m), roll, pitch, yaw (rad).
    pub pose: [f32; 6],
}

/// The errors of one [`Case`], metres.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CaseError {
    /// The range, metres.
    pub range_m: f64,
    /// |world point − reference|.
    pub point_m: f64,
    /// |horizontal distance − reference|.
    pub horizontal_m: f64,
    /// |sensor origin − reference|.
    pub origin_m: f64,
}

/// A raw Q16.16 value in metres.
#[must_use]
pub fn q16(bits: i32) -> f64 {
    f64::from(bits) / 65_536.0
}

/// A library point as a reference vector.
#[must_use]
pub fn vec_of(p: terrain_pyramid::Point3) -> Vec3 {
    [q16(p.x.to_bits()), q16(p.y.to_bits()), q16(p.z.to_bits())]
}

/// Runs `case` through the library (with `table`, built for its variant) and through this
/// reference, from the same inputs: the library's raw fixed-point inputs read exactly, the
/// pose's `f32` values widened exactly. `None` when the library refuses the pose or the beam.
#[must_use]
pub fn evaluate(table: &lib::BeamTable, case: &Case) -> Option<CaseError> {
    let [x, y, z, roll, pitch, yaw] = case.pose;
    let pose = lib::Pose::from_f32(x, y, z, roll, pitch, yaw).ok()?;
    let [mx, my, mz] = case.mount_bits;
    let mount = lib::Mount::new(
        case.plane,
        terrain_pyramid::Point3 {
            x: terrain_pyramid::Meters::from_bits(mx),
            y: terrain_pyramid::Meters::from_bits(my),
            z: terrain_pyramid::Meters::from_bits(mz),
        },
    );
    let actuator = terrain_pyramid::angle::FineAngle::from_bits(case.actuator_bits);
    let line = lib::LineTransform::from_pose(table, &mount, actuator, &pose);
    let got = line.locate(case.beam, case.range_mm)?;

    let variant = table.variant();
    let (start, step, count) = variant_angles(
        u32::from(variant.scan_angle_deg()),
        f64::from(variant.resolution_centideg()) / 100.0,
    );
    if case.beam >= count {
        return None;
    }
    let ref_mount = reference_mount(case.plane, [mx, my, mz]);
    let ref_pose = reference_pose([x, y, z, roll, pitch, yaw]);
    let actuator_rad = f64::from(case.actuator_bits) / 4_294_967_296.0 * std::f64::consts::TAU;
    let theta = beam_angle_rad(start, step, case.beam);
    let range_m = f64::from(case.range_mm) / 1_000.0;
    let want = world_point(&ref_mount, &ref_pose, actuator_rad, theta, range_m);
    let origin = sensor_origin(&ref_mount, &ref_pose);
    Some(CaseError {
        range_m,
        point_m: distance(vec_of(got.point), want),
        horizontal_m: (q16(got.horizontal.to_bits()) - horizontal_distance(want, origin)).abs(),
        origin_m: distance(vec_of(line.sensor_origin()), origin),
    })
}

/// The bound of a spinning lidar's world point against this reference, metres: the library
/// places a return from its own angle in Q2.30 (`geometry::sweep`), so only the outputs' and
/// the pose's roundings remain: `0.03 mm + 10⁻⁸ · range`.
#[must_use]
pub fn lidar_error_bound_m(range_m: f64) -> f64 {
    3.0e-5 + 1.0e-8 * range_m
}

/// The geometry's beam angle θ of a spinning lidar's own angle φ (clockwise from its 0°, seen
/// from its top), radians: `θ = 90° − φ`, written from the mounting the library documents
/// (`geometry::beam_angle_of_clockwise`: lying flat, top up, 0° ahead on the tilt unit; on its
/// side, top facing right, 0° ahead on the pan unit).
#[must_use]
pub fn lidar_theta_rad(clockwise_rad: f64) -> f64 {
    std::f64::consts::FRAC_PI_2 - clockwise_rad
}

/// One LD06 packet placed by the library, against this reference: every return's world point
/// and horizontal distance. `packet` is the packet's 47 bytes; the reference angle of return k
/// is the manual's `start + k·(end − start)/11` (centidegrees, the 360° wrap taken), in f64.
/// `None` when the library refuses the pose or the bytes.
#[must_use]
pub fn evaluate_ld06(
    packet: &[u8],
    plane: lib::ScanPlane,
    mount_bits: [i32; 3],
    actuator_bits: u32,
    pose: [f32; 6],
) -> Option<Vec<CaseError>> {
    use terrain_pyramid::wire::ld06::Ld06Packet;
    let [x, y, z, roll, pitch, yaw] = pose;
    let lib_pose = lib::Pose::from_f32(x, y, z, roll, pitch, yaw).ok()?;
    let [mx, my, mz] = mount_bits;
    let mount = lib::Mount::new(
        plane,
        terrain_pyramid::Point3 {
            x: terrain_pyramid::Meters::from_bits(mx),
            y: terrain_pyramid::Meters::from_bits(my),
            z: terrain_pyramid::Meters::from_bits(mz),
        },
    );
    let actuator = terrain_pyramid::angle::FineAngle::from_bits(actuator_bits);
    let view = Ld06Packet::new_checked(packet).ok()?;
    let sweep = lib::SweepTransform::new(&mount, &lib_pose.frame());
    let at = sweep.at(actuator);

    let ref_mount = reference_mount(plane, [mx, my, mz]);
    let ref_pose = reference_pose([x, y, z, roll, pitch, yaw]);
    let actuator_rad = f64::from(actuator_bits) / 4_294_967_296.0 * std::f64::consts::TAU;
    let origin = sensor_origin(&ref_mount, &ref_pose);
    let start = f64::from(view.start_angle_centideg() % 36_000);
    let mut end = f64::from(view.end_angle_centideg() % 36_000);
    if end < start {
        end += 36_000.0;
    }
    let mut out = Vec::new();
    for (k, ret) in view.returns().enumerate() {
        #[allow(clippy::cast_precision_loss)]
        let phi_deg = (start + k as f64 * (end - start) / 11.0) / 100.0;
        let theta = lidar_theta_rad(phi_deg.to_radians());
        let range_m = f64::from(ret.range_mm) / 1_000.0;
        let want = world_point(&ref_mount, &ref_pose, actuator_rad, theta, range_m);
        let got = at.locate(lib::beam_angle_of_clockwise(ret.angle), ret.range_mm)?;
        out.push(CaseError {
            range_m,
            point_m: distance(vec_of(got.point), want),
            horizontal_m: (q16(got.horizontal.to_bits()) - horizontal_distance(want, origin)).abs(),
            origin_m: distance(vec_of(sweep.sensor_origin()), origin),
        });
    }
    Some(out)
}

/// The reference's mount for the library's scan plane and mount position bits (2⁻¹⁶ m).
fn reference_mount(plane: lib::ScanPlane, [mx, my, mz]: [i32; 3]) -> Mount {
    Mount {
        plane: match plane {
            lib::ScanPlane::PannedVertical => Plane::PannedVertical,
            lib::ScanPlane::TiltedHorizontal => Plane::TiltedHorizontal,
        },
        position: [q16(mx), q16(my), q16(mz)],
    }
}

/// The reference's pose for a pose as the host sends it (x, y, z in m, roll, pitch, yaw in
/// rad, `f32`).
fn reference_pose([x, y, z, roll, pitch, yaw]: [f32; 6]) -> Pose {
    Pose {
        x: f64::from(x),
        y: f64::from(y),
        z: f64::from(z),
        roll: f64::from(roll),
        pitch: f64::from(pitch),
        yaw: f64::from(yaw),
    }
}

/// The maximum and the 99.9th percentile of a sample of errors in metres, both in mm
/// (`(0, 0)` for no sample); sorts the sample.
#[must_use]
pub fn max_and_p999_mm(errors: &mut [f64]) -> (f64, f64) {
    if errors.is_empty() {
        return (0.0, 0.0);
    }
    errors.sort_by(f64::total_cmp);
    let n = errors.len();
    let p999 = errors[((n as f64 * 0.999).ceil() as usize).clamp(1, n) - 1];
    (errors[n - 1] * 1e3, p999 * 1e3)
}

/// The world-point and horizontal-distance errors of many returns, metres, gathered under each
/// range limit at or above the return's range: the figures the error examples print.
#[derive(Debug, Clone, Default)]
pub struct ErrorsByRange {
    /// The range limits, metres, ascending.
    limits_m: Vec<f64>,
    /// Per limit, the world-point errors of the returns within it, metres.
    point_m: Vec<Vec<f64>>,
    /// Per limit, the horizontal-distance errors of the returns within it, metres.
    horizontal_m: Vec<Vec<f64>>,
}

impl ErrorsByRange {
    /// No returns yet, for the range limits `limits_m` (metres, ascending).
    #[must_use]
    pub fn new(limits_m: &[f64]) -> Self {
        Self {
            limits_m: limits_m.to_vec(),
            point_m: vec![Vec::new(); limits_m.len()],
            horizontal_m: vec![Vec::new(); limits_m.len()],
        }
    }

    /// Counts one return's errors under every limit at or above its range.
    pub fn add(&mut self, e: &CaseError) {
        for (k, &limit) in self.limits_m.iter().enumerate() {
            if e.range_m <= limit {
                self.point_m[k].push(e.point_m);
                self.horizontal_m[k].push(e.horizontal_m);
            }
        }
    }

    /// Prints a table with a row per limit: the returns within it, the maximum and the 99.9th
    /// percentile of both errors (mm), and the bound at the limit, `bound_m(limit)` (in mm).
    pub fn print(&mut self, bound_m: impl Fn(f64) -> f64) {
        println!(
            "{:<14} {:>9} {:>14} {:>14} {:>16} {:>16} {:>10}",
            "ranges", "returns", "point max", "point p99.9", "horiz. max", "horiz. p99.9", "bound"
        );
        for (k, &limit) in self.limits_m.iter().enumerate() {
            let n = self.point_m[k].len();
            let (pmax, p999) = max_and_p999_mm(&mut self.point_m[k]);
            let (hmax, h999) = max_and_p999_mm(&mut self.horizontal_m[k]);
            println!(
                "{:<14} {:>9} {:>11.4} mm {:>11.4} mm {:>13.4} mm {:>13.4} mm {:>7.4} mm",
                format!("<= {limit} m"),
                n,
                pmax,
                p999,
                hmax,
                h999,
                bound_m(limit) * 1e3
            );
        }
    }
}

/// A random scan-centre position in the robot frame, as the library's fixed-point bits
/// (2⁻¹⁶ m): x and y within ±2 m, z 0 ..= 3 m.
#[allow(clippy::cast_possible_truncation)]
pub fn draw_mount_bits(rng: &mut crate::workload::Rng) -> [i32; 3] {
    [
        rng.range(-131_072.0, 131_072.0) as i32,
        rng.range(-131_072.0, 131_072.0) as i32,
        rng.range(0.0, 196_608.0) as i32,
    ]
}

/// A random pose as the host sends it: x and y within ±29 999 m, z within ±999 m, roll and
/// pitch within ±30°, yaw within ±20 rad.
#[allow(clippy::cast_possible_truncation)]
pub fn draw_pose(rng: &mut crate::workload::Rng) -> [f32; 6] {
    let thirty = 30_f64.to_radians();
    [
        rng.range(-29_999.0, 29_999.0) as f32,
        rng.range(-29_999.0, 29_999.0) as f32,
        rng.range(-999.0, 999.0) as f32,
        rng.range(-thirty, thirty) as f32,
        rng.range(-thirty, thirty) as f32,
        rng.range(-20.0, 20.0) as f32,
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: Vec3, b: Vec3) -> bool {
        distance(a, b) < 1e-12
    }

    #[test]
    fn conventions_hold() {
        let panned = Mount {
            plane: Plane::PannedVertical,
            position: [0.0, 0.0, 1.0],
        };
        let id = Pose::default();
        let q = std::f64::consts::FRAC_PI_2;
        assert!(close(
            world_point(&panned, &id, 0.0, 0.0, 1.0),
            [0.0, 0.0, 0.0]
        ));
        assert!(close(
            world_point(&panned, &id, 0.0, q, 1.0),
            [1.0, 0.0, 1.0]
        ));
        assert!(close(world_point(&panned, &id, q, q, 1.0), [0.0, 1.0, 1.0]));
        let tilted = Mount {
            plane: Plane::TiltedHorizontal,
            position: [0.0; 3],
        };
        assert!(close(
            world_point(&tilted, &id, 0.0, 0.0, 1.0),
            [0.0, -1.0, 0.0]
        ));
        assert!(world_point(&tilted, &id, 0.3, q, 1.0)[2] < 0.0);
        let yawed = Pose {
            yaw: q,
            ..Pose::default()
        };
        assert!(close(
            world_point(&panned, &yawed, 0.0, q, 1.0),
            [0.0, 1.0, 1.0]
        ));
        assert_eq!(variant_angles(100, 0.25), (40.0, 0.25, 401));
        assert_eq!(variant_angles(180, 0.5), (0.0, 0.5, 361));
    }
}
