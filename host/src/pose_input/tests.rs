use super::*;
use crate::clock_sync::{Exchange, ResetReason};
use crate::publish::ros_msgs;
use std::f64::consts::{FRAC_PI_2, PI};

/// The Hamilton product, to build a quaternion from its elementary rotations (independent of
/// the conversion under test).
fn mul(a: [f64; 4], b: [f64; 4]) -> [f64; 4] {
    let [ax, ay, az, aw] = a;
    let [bx, by, bz, bw] = b;
    [
        aw * bx + ax * bw + ay * bz - az * by,
        aw * by - ax * bz + ay * bw + az * bx,
        aw * bz + ax * by - ay * bx + az * bw,
        aw * bw - ax * bx - ay * by - az * bz,
    ]
}

/// `Rz(yaw) Ry(pitch) Rx(roll)` as a quaternion `[x, y, z, w]`.
fn from_rpy(roll: f64, pitch: f64, yaw: f64) -> [f64; 4] {
    let rx = [(roll / 2.0).sin(), 0.0, 0.0, (roll / 2.0).cos()];
    let ry = [0.0, (pitch / 2.0).sin(), 0.0, (pitch / 2.0).cos()];
    let rz = [0.0, 0.0, (yaw / 2.0).sin(), (yaw / 2.0).cos()];
    mul(rz, mul(ry, rx))
}

#[test]
fn quaternions_give_rep103_roll_pitch_yaw() {
    // 90° about z: facing +y.
    let h = FRAC_PI_2 / 2.0;
    let (r, p, y) = quaternion_to_rpy(0.0, 0.0, h.sin(), h.cos()).unwrap();
    assert!(r.abs() < 1e-12 && p.abs() < 1e-12 && (y - FRAC_PI_2).abs() < 1e-12);
    for &(roll, pitch, yaw) in &[
        (0.1, -0.2, 2.5),
        (-0.4, 0.3, -3.0),
        (0.0, 1.2, 0.7),
        (3.0, -1.0, -0.1),
    ] {
        let [x, y, z, w] = from_rpy(roll, pitch, yaw);
        let (r, p, yy) = quaternion_to_rpy(x, y, z, w).unwrap();
        assert!((r - roll).abs() < 1e-9, "roll {r} vs {roll}");
        assert!((p - pitch).abs() < 1e-9, "pitch {p} vs {pitch}");
        assert!((yy - yaw).abs() < 1e-9, "yaw {yy} vs {yaw}");
        // A quaternion 5 % off unit norm is normalised; its negation is the same rotation.
        let (_, _, y2) = quaternion_to_rpy(-1.05 * x, -1.05 * y, -1.05 * z, -1.05 * w).unwrap();
        assert!((y2 - yaw).abs() < 1e-9);
    }
    // Yaw π stays ±π.
    let (_, _, y) = quaternion_to_rpy(0.0, 0.0, 1.0, 0.0).unwrap();
    assert!((y.abs() - PI).abs() < 1e-12);
    assert_eq!(quaternion_to_rpy(0.0, 0.0, 0.0, 0.0), None);
    assert_eq!(quaternion_to_rpy(0.0, 0.0, 0.0, 1.2), None);
    assert_eq!(quaternion_to_rpy(f64::NAN, 0.0, 0.0, 1.0), None);
}

#[test]
fn lines_with_angles_or_a_quaternion_parse() {
    let p = parse_line(
        r#"{"t": 1700000000.25, "frame": "odom", "x": 1.5, "y": -2, "z": 0.1, "roll": 0.01, "pitch": -0.02, "yaw": 3.0}"#,
    )
    .unwrap();
    assert_eq!(p.stamp_ns, 1_700_000_000_250_000_000);
    assert_eq!(p.frame, "odom");
    assert_eq!(
        (p.x, p.y, p.z, p.roll, p.pitch, p.yaw),
        (1.5, -2.0, 0.1, 0.01, -0.02, 3.0)
    );
    // Yaw alone; no frame, no z.
    let p = parse_line(r#"{"t": 10, "x": 0, "y": 0, "yaw": -1}"#).unwrap();
    assert_eq!((p.frame.as_str(), p.z, p.roll, p.yaw), ("", 0.0, 0.0, -1.0));
    let h: f64 = 0.25;
    let line = format!(
        r#"{{"t": 5.5, "x": 1, "y": 2, "qx": 0, "qy": 0, "qz": {}, "qw": {}}}"#,
        h.sin(),
        h.cos()
    );
    let p = parse_line(&line).unwrap();
    assert!((p.yaw - 0.5).abs() < 1e-12 && p.roll.abs() < 1e-12);
}

#[test]
fn bad_lines_are_refused_by_reason() {
    let cases = [
        ("not json", BadInput::NotJson),
        ("[1, 2]", BadInput::NotJson),
        (r#"{"x": 1, "y": 2, "yaw": 0}"#, BadInput::Fields),
        (
            r#"{"t": "now", "x": 1, "y": 2, "yaw": 0}"#,
            BadInput::Fields,
        ),
        (r#"{"t": 1, "x": 1, "y": 2}"#, BadInput::Fields),
        (r#"{"t": 1, "x": 1, "y": 2, "roll": 0.1}"#, BadInput::Fields),
        (
            r#"{"t": 1, "x": 1, "y": 2, "yaw": 0, "qw": 1}"#,
            BadInput::Fields,
        ),
        (
            r#"{"t": 1, "x": 1, "y": 2, "qx": 0, "qy": 0, "qz": 0}"#,
            BadInput::Fields,
        ),
        (
            r#"{"t": 1, "x": 1e999, "y": 2, "yaw": 0}"#,
            BadInput::NotJson,
        ),
        (
            r#"{"t": 1e13, "x": 1, "y": 2, "yaw": 0}"#,
            BadInput::NotFinite,
        ),
        (
            r#"{"t": 1, "x": 1, "y": 2, "qx": 0, "qy": 0, "qz": 0, "qw": 0}"#,
            BadInput::Quaternion,
        ),
    ];
    for (line, reason) in cases {
        assert_eq!(parse_line(line), Err(reason), "{line}");
    }
    // A datagram of several lines: blank ones skipped, each other line one event.
    let events = datagram_events(b"{\"t\":1,\"x\":0,\"y\":0,\"yaw\":0}\n\n  \nnope\n\xff\n");
    assert_eq!(events.len(), 3);
    assert!(matches!(events[0], SourceEvent::Pose(_)));
    assert_eq!(events[1], SourceEvent::Bad(BadInput::NotJson));
    assert_eq!(events[2], SourceEvent::Bad(BadInput::NotJson));
}

/// An Odometry message as DDS carries it, written out byte by byte from the `.msg`
/// definitions and CDR's alignment rules (each primitive aligned to its size from the start of
/// the body; strings as u32 length with the NUL, then the bytes).
fn odometry_cdr(sec: i32, nanosec: u32, frame: &str, q: [f64; 4], xyz: [f64; 3]) -> Vec<u8> {
    let mut b: Vec<u8> = Vec::new();
    let align = |b: &mut Vec<u8>, n: usize| {
        while !b.len().is_multiple_of(n) {
            b.push(0);
        }
    };
    let string = |b: &mut Vec<u8>, s: &str| {
        align(b, 4);
        b.extend_from_slice(&(s.len() as u32 + 1).to_le_bytes());
        b.extend_from_slice(s.as_bytes());
        b.push(0);
    };
    b.extend_from_slice(&sec.to_le_bytes());
    b.extend_from_slice(&nanosec.to_le_bytes());
    string(&mut b, frame);
    string(&mut b, "base_link");
    let f64s = |b: &mut Vec<u8>, values: &[f64]| {
        align(b, 8);
        for v in values {
            b.extend_from_slice(&v.to_le_bytes());
        }
    };
    f64s(&mut b, &xyz);
    f64s(&mut b, &q);
    f64s(&mut b, &[0.5; 36]); // pose covariance
    f64s(&mut b, &[0.25; 6]); // twist
    f64s(&mut b, &[0.125; 36]); // twist covariance
    b
}

#[test]
fn an_odometry_message_gives_its_stamp_frame_and_pose() {
    let q = from_rpy(0.05, -0.1, -2.0);
    let bytes = odometry_cdr(1_700_000_123, 456_789_000, "odom", q, [3.0, -4.0, 0.5]);
    let (message, used): (ros_msgs::Odometry, usize) =
        cdr_encoding::from_bytes::<ros_msgs::Odometry, byteorder::LittleEndian>(&bytes).unwrap();
    assert_eq!(used, bytes.len());
    assert_eq!(message.child_frame_id, "base_link");
    assert_eq!(message.twist.twist.angular.z, 0.25);
    assert_eq!(message.twist.covariance[5][5], 0.125);
    let p = odometry_pose(&message).unwrap();
    assert_eq!(p.stamp_ns, 1_700_000_123_456_789_000);
    assert_eq!(p.frame, "odom");
    assert_eq!((p.x, p.y, p.z), (3.0, -4.0, 0.5));
    assert!((p.roll - 0.05).abs() < 1e-9);
    assert!((p.pitch + 0.1).abs() < 1e-9);
    assert!((p.yaw + 2.0).abs() < 1e-9);
    // An uninitialised orientation (all zeros) is refused.
    let mut zero = message.clone();
    zero.pose.pose.orientation = ros_msgs::Quaternion {
        x: 0.0,
        y: 0.0,
        z: 0.0,
        w: 0.0,
    };
    assert_eq!(odometry_pose(&zero), Err(BadInput::Quaternion));
    let mut nan = message;
    nan.pose.pose.position.x = f64::NAN;
    assert_eq!(odometry_pose(&nan), Err(BadInput::NotFinite));
}

#[test]
fn topic_names_split_into_namespace_and_base() {
    assert!(topic_name("/odom").is_ok());
    assert!(topic_name("odom").is_ok());
    assert!(topic_name("/robot1/odom").is_ok());
    assert!(topic_name("/bad name").is_err());
}

#[test]
fn the_wall_anchor_follows_slew_and_counts_jumps() {
    let mut a = WallAnchor::new();
    assert_eq!(a.to_monotonic(5), None);
    assert!(!a.observe(1_000_000_000, 0));
    assert_eq!(a.to_monotonic(1_000_500_000), Some(500_000));
    // Slewed by 2 ms: followed, not a jump.
    assert!(!a.observe(1_001_002_000, 1_000_000));
    assert_eq!(a.to_monotonic(1_001_002_000), Some(1_000_000));
    // Set back by 5 s: a jump, and the anchor moves to it.
    assert!(a.observe(996_002_000 + 1_000_000, 2_000_000));
    assert_eq!(a.jumps(), 1);
    assert_eq!(a.to_monotonic(997_002_000), Some(2_000_000));
    assert_eq!(a.to_wall(2_000_000), Some(997_002_000));
}

/// A mapping with device = host + 7 000 000 µs (exact: symmetric delays).
fn synced_clock() -> ClockSync {
    let mut c = ClockSync::new();
    for i in 0..10_u64 {
        let t = i * 100_000;
        c.add(Exchange {
            host_sent_us: t,
            device_us: (t + 500 + 7_000_000) as u32,
            host_received_us: t + 1_000,
            queued_ahead: 0,
        });
    }
    assert!(c.is_synced());
    c
}

fn pose_at(stamp_us: i128, x: f64) -> SourceEvent {
    SourceEvent::Pose(PoseInput {
        stamp_ns: stamp_us * 1_000,
        frame: "odom".into(),
        x,
        y: 0.0,
        z: 0.0,
        roll: 0.0,
        pitch: 0.0,
        yaw: 0.25,
    })
}

#[test]
fn poses_are_checked_limited_to_100_hz_and_stamped_in_device_time() {
    // Wall = monotonic + 1.7e15 µs.
    const WALL: i128 = 1_700_000_000_000_000;
    let mut wall = WallAnchor::new();
    wall.observe(WALL, 0);
    let clock = synced_clock();
    let mut f = PoseForwarder::new();
    let now = 3_000_000_u64;
    // 30 ms old: taken, forwarded at once with the device's time of its stamp.
    f.take(pose_at(WALL + 2_970_000, 1.0), now, &wall, &clock);
    let p = f.poll(now, &clock).unwrap();
    assert_eq!(p.stamp_us, 2_970_000 + 7_000_000);
    assert_eq!((p.x, p.yaw), (1.0, 0.25));
    // Three more within the next 10 ms: only the newest goes, 10 ms after the last.
    f.take(pose_at(WALL + 2_975_000, 2.0), now + 1_000, &wall, &clock);
    f.take(pose_at(WALL + 2_978_000, 3.0), now + 2_000, &wall, &clock);
    assert_eq!(f.poll(now + 2_000, &clock), None);
    f.take(pose_at(WALL + 2_979_000, 4.0), now + 9_000, &wall, &clock);
    assert_eq!(f.poll(now + 9_999, &clock), None);
    let p = f.poll(now + 10_000, &clock).unwrap();
    assert_eq!((p.x, p.stamp_us), (4.0, 2_979_000 + 7_000_000));
    assert_eq!(f.poll(now + 30_000, &clock), None);
    // Out of order (older, and equal), stale, from the future, out of range, other frame.
    f.take(pose_at(WALL + 2_979_000, 5.0), now + 40_000, &wall, &clock);
    f.take(pose_at(WALL + 2_950_000, 5.0), now + 40_000, &wall, &clock);
    f.take(pose_at(WALL + 1_000_000, 5.0), now + 40_000, &wall, &clock);
    f.take(pose_at(WALL + 4_100_000, 5.0), now + 40_000, &wall, &clock);
    f.take(
        pose_at(WALL + 3_000_000, 40_000.0),
        now + 40_000,
        &wall,
        &clock,
    );
    let mut other = pose_at(WALL + 3_010_000, 5.0);
    if let SourceEvent::Pose(p) = &mut other {
        p.frame = "map".into();
    }
    f.take(other, now + 40_000, &wall, &clock);
    f.take(SourceEvent::Bad(BadInput::NotJson), now, &wall, &clock);
    assert_eq!(f.poll(now + 50_000, &clock), None);
    let c = f.counters();
    assert_eq!(
        (
            c.received,
            c.forwarded,
            c.coalesced,
            c.out_of_order,
            c.stale,
            c.from_future,
            c.out_of_range,
            c.other_frame,
            c.bad_not_json
        ),
        (11, 2, 2, 2, 1, 1, 1, 1, 1)
    );
    assert_eq!(c.dropped(), 7);
    assert_eq!(f.frame(), Some("odom"));
    // 600 ms later: a gap.
    f.take(pose_at(WALL + 3_600_000, 6.0), now + 620_000, &wall, &clock);
    assert!(f.poll(now + 620_000, &clock).is_some());
    assert_eq!(f.counters().gaps, 1);
}

#[test]
fn no_pose_goes_without_the_clock_mapping() {
    const WALL: i128 = 1_000_000_000_000;
    let mut wall = WallAnchor::new();
    wall.observe(WALL, 0);
    let mut clock = ClockSync::new();
    let mut f = PoseForwarder::new();
    f.take(pose_at(WALL + 990_000, 1.0), 1_000_000, &wall, &clock);
    assert_eq!(f.poll(1_000_000, &clock), None);
    assert_eq!(f.counters().unsynced, 1);
    // Taken while synced, then the device reboots before it goes: dropped, counted.
    let synced = synced_clock();
    f.take(pose_at(WALL + 995_000, 1.0), 1_000_000, &wall, &synced);
    clock.reset(ResetReason::DeviceBoot);
    assert_eq!(f.poll(1_000_000, &clock), None);
    assert_eq!(f.counters().unsynced, 2);
    assert_eq!(f.counters().forwarded, 0);
}
