//! `pyramid decode --sensor ld06|rplidar|ydlidar --json` end to end: the makers' own example
//! bytes where the manuals give them, streams built with the library's emitters, damaged on
//! purpose, decoded by the binary; every value checked against the manual's formula computed
//! here in f64.
mod common;

use common::pyramid;
use serde_json::{json, Value};
use std::path::PathBuf;
use terrain_pyramid::wire::ld06::{Ld06Point, Ld06Repr};
use terrain_pyramid::wire::rplidar::{RplidarCapsuleRepr, RplidarDescriptorRepr, RplidarNodeRepr};
use terrain_pyramid::wire::ydlidar::YdlidarRepr;

/// The LD06 manual's reference example (§3.3).
const LD06_EXAMPLE: [u8; 47] = [
    0x54, 0x2C, 0x68, 0x08, 0xAB, 0x7E, 0xE0, 0x00, 0xE4, 0xDC, 0x00, 0xE2, 0xD9, 0x00, 0xE5, 0xD5,
    0x00, 0xE3, 0xD3, 0x00, 0xE4, 0xD0, 0x00, 0xE9, 0xCD, 0x00, 0xE4, 0xCA, 0x00, 0xE2, 0xC7, 0x00,
    0xE9, 0xC5, 0x00, 0xE5, 0xC2, 0x00, 0xE5, 0xC0, 0x00, 0xE5, 0xBE, 0x82, 0x3A, 0x1A, 0x50,
];

/// A fresh temporary file holding `bytes`.
fn temp_file(tag: &str, bytes: &[u8]) -> PathBuf {
    common::temp_file("decode", tag, bytes)
}

/// Decodes `bytes` as `sensor` with `extra` flags; the JSON object.
fn decode(tag: &str, sensor: &str, bytes: &[u8], extra: &[&str]) -> Value {
    let path = temp_file(tag, bytes);
    let mut args = vec![
        "decode",
        "--sensor",
        sensor,
        path.to_str().unwrap(),
        "--json",
    ];
    args.extend_from_slice(extra);
    let out = pyramid(&args);
    std::fs::remove_file(&path).ok();
    assert_eq!(out.status.code(), Some(0), "{out:?}");
    let text = String::from_utf8(out.stdout).unwrap();
    assert_eq!(text.lines().count(), 1, "exactly one object: {text}");
    serde_json::from_str(&text).unwrap()
}

/// `field` of every return of `packet`, in order.
fn each_return<T>(packet: &Value, field: impl Fn(&Value) -> T) -> Vec<T> {
    packet["returns"]
        .as_array()
        .unwrap()
        .iter()
        .map(field)
        .collect()
}

fn angles(packet: &Value) -> Vec<f64> {
    each_return(packet, |r| r["angle_deg"].as_f64().unwrap())
}

fn ranges(packet: &Value) -> Vec<u64> {
    each_return(packet, |r| r["range_mm"].as_u64().unwrap())
}

#[test]
fn ld06_the_manuals_example_and_a_damaged_stream() {
    let mut stream = vec![0xFF, 0x54];
    stream.extend_from_slice(&LD06_EXAMPLE);
    let mut bad = LD06_EXAMPLE;
    bad[10] ^= 0x01;
    stream.extend_from_slice(&bad);
    // A packet crossing 0°: 359.00° → 1.20°.
    let crossing = Ld06Repr {
        speed_deg_per_s: 3_600,
        start_angle_centideg: 35_900,
        end_angle_centideg: 120,
        timestamp_ms: 7,
        points: [Ld06Point {
            distance_mm: 0,
            intensity: 0,
        }; 12],
    };
    let mut buf = [0_u8; 47];
    crossing.emit(&mut buf).unwrap();
    stream.extend_from_slice(&buf);
    stream.extend_from_slice(&LD06_EXAMPLE[..20]);
    let v = decode("ld06", "ld06", &stream, &[]);
    assert_eq!(v["sensor"], "ld06");
    // A refused candidate accounts for its first byte; the bytes after it are hunted
    // through again (garbage here): 2 before the example, 46 of the damaged packet, 19 of the
    // cut one.
    assert_eq!(
        v["errors"],
        json!({"checksum": 1, "garbage_bytes": 2 + 46 + 19, "truncated": 1})
    );
    let packets = v["packets"].as_array().unwrap();
    assert_eq!(packets.len(), 2);
    let p = &packets[0];
    assert_eq!(p["start_of_revolution"], false);
    // §3.2: start 324.27°, end 334.70°, point k at start + k·(end − start)/11.
    for (k, a) in angles(p).iter().enumerate() {
        let want = 324.27 + k as f64 * (334.70 - 324.27) / 11.0;
        assert!((a - want).abs() < 1e-6, "{k}: {a} vs {want}");
    }
    let r = ranges(p);
    assert_eq!(
        r,
        [224, 220, 217, 213, 211, 208, 205, 202, 199, 197, 194, 192]
    );
    assert_eq!(p["returns"][0]["quality"], 228);
    assert_eq!(p["returns"][11]["quality"], 229);
    // The crossing packet: angles wrap, no return is range 0, and a revolution starts.
    let c = &packets[1];
    assert_eq!(c["start_of_revolution"], true);
    let a = angles(c);
    assert!((a[0] - 359.0).abs() < 1e-9 && (a[5] - 0.0).abs() < 1e-9 && (a[11] - 1.2).abs() < 1e-9);
    assert!(ranges(c).iter().all(|&r| r == 0));
}

fn node(quality: u8, start: bool, angle_q6: u16, distance_q2: u16) -> [u8; 5] {
    let mut b = [0_u8; 5];
    RplidarNodeRepr {
        quality,
        start,
        angle_q6,
        distance_q2,
    }
    .emit(&mut b)
    .unwrap();
    b
}

#[test]
fn rplidar_nodes_with_and_without_the_descriptor() {
    let mut nodes = Vec::new();
    // The node worked by hand in the library's tests: quality 15, S, 90.5°, 1 234.5 mm.
    nodes.extend_from_slice(&[0x3D, 0x41, 0x2D, 0x4A, 0x13]);
    for k in 1..20_u16 {
        nodes.extend_from_slice(&node(47, false, 5_792 + 64 * k, 4 * (1_000 + k)));
    }
    let mut with = Vec::new();
    let mut d = [0_u8; 7];
    RplidarDescriptorRepr::SCAN.emit(&mut d).unwrap();
    assert_eq!(d, [0xA5, 0x5A, 0x05, 0x00, 0x00, 0x40, 0x81]);
    with.extend_from_slice(&d);
    with.extend_from_slice(&nodes);
    for (tag, bytes) in [("with", &with), ("without", &nodes)] {
        let v = decode(tag, "rplidar", bytes, &[]);
        assert_eq!(v["sensor"], "rplidar");
        let packets = v["packets"].as_array().unwrap();
        assert_eq!(packets.len(), 20, "{tag}");
        let first = &packets[0];
        assert_eq!(first["start_of_revolution"], true);
        assert_eq!(
            first["returns"],
            json!([{"angle_deg": 90.5, "range_mm": 1235, "quality": 15}])
        );
        for (k, p) in packets.iter().enumerate().skip(1) {
            assert_eq!(p["start_of_revolution"], false);
            let want = (5_792.0 + 64.0 * k as f64) / 64.0;
            assert!((angles(p)[0] - want).abs() < 1e-9);
            assert_eq!(ranges(p)[0], 1_000 + k as u64);
            assert_eq!(p["returns"][0]["quality"], 47);
        }
        assert_eq!(v["errors"]["garbage_bytes"], 0);
        assert_eq!(v["errors"]["node_check"], 0);
    }
}

#[test]
fn rplidar_express_capsules_follow_the_sdks_formula() {
    let mut stream = Vec::new();
    let mut d = [0_u8; 7];
    RplidarDescriptorRepr::EXPRESS_SCAN.emit(&mut d).unwrap();
    stream.extend_from_slice(&d);
    let starts = [100 * 64_u16, 110 * 64, 120 * 64];
    for (c, &start) in starts.iter().enumerate() {
        let mut repr = RplidarCapsuleRepr {
            start_angle_q6: start,
            ..RplidarCapsuleRepr::default()
        };
        for k in 0..32 {
            repr.distances_mm[k] = 2_000 + (c * 32 + k) as u16;
            repr.angle_offsets_q3[k] = (k % 16) as u8;
        }
        let mut b = [0_u8; 84];
        repr.emit(&mut b).unwrap();
        stream.extend_from_slice(&b);
    }
    // Without --rplidar-mode the descriptor decides; forcing express agrees.
    for extra in [&[][..], &["--rplidar-mode", "express"][..]] {
        let v = decode("express", "rplidar", &stream, extra);
        let packets = v["packets"].as_array().unwrap();
        // The last capsule has no successor to place it.
        assert_eq!(packets.len(), 2);
        assert_eq!(v["errors"]["capsules_unpaired"], 1);
        for (c, p) in packets.iter().enumerate() {
            let (w, next) = (f64::from(starts[c]) / 64.0, f64::from(starts[c + 1]) / 64.0);
            let a = angles(p);
            assert_eq!(a.len(), 32);
            for (k, &got) in a.iter().enumerate() {
                // θ = ω + k·(ω' − ω)/32 − dθ, dθ in degrees·8.
                let want = w + k as f64 * (next - w) / 32.0 - (k % 16) as f64 / 8.0;
                assert!((got - want).abs() < 1e-6, "{c} {k}: {got} vs {want}");
            }
            assert_eq!(ranges(p)[31], 2_000 + (c * 32 + 31) as u64);
            assert!(p["returns"][0]["quality"].is_null());
        }
    }
}

#[test]
fn ydlidar_first_and_second_level_angles() {
    // The manuals' example: LSN 40, FSA 0x6FE5 (223.78125°), LSA 0x79BD (243.46875°); every
    // sample 1 000 mm (S = 4 000), where the second-level correction is −6.7622°.
    let samples = [4_000_u16; 40];
    let repr = YdlidarRepr {
        packet_type: 0,
        first_angle_q6: 0x6FE5 >> 1,
        last_angle_q6: 0x79BD >> 1,
        samples: &samples,
    };
    let mut packet = vec![0_u8; repr.buffer_len()];
    repr.emit(&mut packet).unwrap();
    assert_eq!(&packet[3..8], &[0x28, 0xE5, 0x6F, 0xBD, 0x79]);
    let zero = YdlidarRepr {
        packet_type: 1,
        first_angle_q6: 0,
        last_angle_q6: 0,
        samples: &[0],
    };
    let mut z = vec![0_u8; zero.buffer_len()];
    zero.emit(&mut z).unwrap();
    let mut stream = vec![0xA5, 0x5A, 0x05, 0x00, 0x00, 0x40, 0x81];
    stream.extend_from_slice(&z);
    stream.extend_from_slice(&packet);
    let mut bad = packet.clone();
    bad[30] ^= 0x02;
    stream.extend_from_slice(&bad);
    let correction = (21.8_f64 * (155.3 - 1_000.0) / (155.3 * 1_000.0))
        .atan()
        .to_degrees();
    assert!((correction + 6.7622).abs() < 1e-4);
    for (model, offset) in [("x4", correction), ("x2", correction), ("uncorrected", 0.0)] {
        let v = decode(model, "ydlidar", &stream, &["--ydlidar-model", model]);
        assert_eq!(v["sensor"], "ydlidar");
        assert_eq!(
            v["errors"],
            json!({"bad_length": 0, "check_bits": 0, "checksum": 1, "garbage_bytes": 89, "truncated": 0})
        );
        let packets = v["packets"].as_array().unwrap();
        assert_eq!(packets.len(), 2);
        assert_eq!(packets[0]["start_of_revolution"], true);
        assert_eq!(ranges(&packets[0]), [0]);
        let p = &packets[1];
        assert_eq!(p["start_of_revolution"], false);
        for (i, a) in angles(p).iter().enumerate() {
            let first = 223.78125 + i as f64 * (243.46875 - 223.78125) / 39.0;
            // The library's table-driven arctangent is within 8·10⁻⁵° of atan.
            assert!((a - (first + offset)).abs() < 1e-4, "{model} {i}: {a}");
        }
        assert!(ranges(p).iter().all(|&r| r == 1_000));
        assert!(p["returns"][0]["quality"].is_null());
    }
}

#[test]
fn sick_keeps_its_format_and_the_alias_decodes_lidars_too() {
    let path = temp_file("alias", &LD06_EXAMPLE);
    let [a, b] = ["sick-decode", "decode"].map(|command| {
        let path = path.to_str().unwrap();
        pyramid(&[command, "--sensor", "ld06", path, "--json"])
    });
    let sick = pyramid(&["decode", path.to_str().unwrap(), "--json"]);
    let human = pyramid(&["decode", "--sensor", "ld06", path.to_str().unwrap()]);
    std::fs::remove_file(&path).ok();
    assert_eq!(a.stdout, b.stdout);
    // The default sensor is SICK, with the SICK format: the LD06 bytes are garbage to it.
    let v: Value = serde_json::from_slice(&sick.stdout).unwrap();
    assert_eq!(v["telegrams"], json!([]));
    assert_eq!(v["errors"]["garbage_bytes"], 47);
    assert!(v.get("sensor").is_none());
    let text = String::from_utf8(human.stdout).unwrap();
    assert!(text.contains("1 ld06 packets (12 returns"), "{text}");
    assert!(text.contains("324.2700° 224 mm"), "{text}");
}
