//! `pyramid sick-decode` end to end: a stream built with the library's emitters, damaged on
//! purpose, decoded by the binary.
mod common;

use common::pyramid;
use serde_json::{json, Value};
use std::path::PathBuf;
use terrain_pyramid::wire::sick::{
    emit_telegram, MeasuredValues, OperatingModeReply, Unit, ADDRESS_REPLY,
};

fn emit(m: &MeasuredValues<'_>) -> Vec<u8> {
    let mut buf = vec![0u8; m.buffer_len()];
    m.emit(&mut buf).unwrap();
    buf
}

fn le(values: &[u16]) -> Vec<u8> {
    values.iter().flat_map(|v| v.to_le_bytes()).collect()
}

/// The raw values of the first scan: 2251 mm with bit 13 set, and no echo at 10 and 20.
fn first_values() -> Vec<u16> {
    (0..361u16)
        .map(|i| match i {
            10 => 0x1FFF,
            20 => 0xFFFF,
            _ => 0x2000 | 2251,
        })
        .collect()
}

struct Built {
    bytes: Vec<u8>,
    first_offset: u64,
    second_offset: u64,
}

fn stream() -> Built {
    let v1 = le(&first_values());
    let t1 = emit(&MeasuredValues::new(Unit::Millimetre, 0, &v1, None, 0x10).unwrap());
    let v2 = le(&(0..181u16).map(|i| 100 + i).collect::<Vec<_>>());
    let t2 = emit(&MeasuredValues::new(Unit::Centimetre, 1, &v2, Some(9), 0x12).unwrap());
    let mut bad_crc = t1.clone();
    let last = bad_crc.len() - 1;
    bad_crc[last] ^= 0x55;
    let mut a0 = [0u8; 9];
    OperatingModeReply {
        result: 0,
        status: 0x10,
    }
    .emit(&mut a0)
    .unwrap();
    // A well-framed 0xB0 with unit code 10: refused, not listed.
    let mut bad_unit = [0u8; 12];
    let n = emit_telegram(
        ADDRESS_REPLY,
        &[0xB0, 0x01, 0x80, 0x34, 0x12, 0x00],
        &mut bad_unit,
    )
    .unwrap();

    let mut bytes = vec![0xFF, 0x00, 0x13, 0x06];
    let first_offset = bytes.len() as u64;
    bytes.extend_from_slice(&t1);
    bytes.extend_from_slice(&bad_crc);
    bytes.extend_from_slice(&[0x02, 0x80, 0x00, 0x00]);
    bytes.extend_from_slice(&t2[..50]);
    let second_offset = bytes.len() as u64;
    bytes.extend_from_slice(&t2);
    bytes.extend_from_slice(&a0);
    bytes.extend_from_slice(&bad_unit[..n]);
    bytes.extend_from_slice(&[0xAA, 0xBB]);
    Built {
        bytes,
        first_offset,
        second_offset,
    }
}

/// A fresh temporary file holding `bytes`.
fn temp_file(tag: &str, bytes: &[u8]) -> PathBuf {
    common::temp_file("sick-decode", tag, bytes)
}

#[test]
fn json_lists_valid_measured_values_and_counts_errors() {
    let built = stream();
    let path = temp_file("json", &built.bytes);
    let out = pyramid(&["sick-decode", path.to_str().unwrap(), "--json"]);
    std::fs::remove_file(&path).ok();
    assert_eq!(out.status.code(), Some(0), "{out:?}");
    let v: Value = serde_json::from_slice(&out.stdout).unwrap();

    assert_eq!(
        v["errors"],
        json!({"crc": 1, "length": 1, "truncated": 1, "garbage_bytes": 5})
    );
    let telegrams = v["telegrams"].as_array().unwrap();
    assert_eq!(telegrams.len(), 2);

    let t = &telegrams[0];
    assert_eq!(t["offset"], built.first_offset);
    assert_eq!(t["command"], "b0");
    assert_eq!(t["count"], 361);
    assert_eq!(t["unit"], "mm");
    assert_eq!(t["partial_index"], 0);
    assert_eq!(t["status"], 16);
    let ranges = t["ranges_mm"].as_array().unwrap();
    assert_eq!(ranges.len(), 361);
    for (i, r) in ranges.iter().enumerate() {
        if i == 10 || i == 20 {
            assert!(r.is_null(), "value {i}: {r}");
        } else {
            assert_eq!(r, 2251, "value {i}");
        }
    }

    let t = &telegrams[1];
    assert_eq!(t["offset"], built.second_offset);
    assert_eq!(t["count"], 181);
    assert_eq!(t["unit"], "cm");
    assert_eq!(t["partial_index"], 1);
    assert_eq!(t["status"], 0x12);
    let ranges = t["ranges_mm"].as_array().unwrap();
    assert_eq!(ranges[0], 1000);
    assert_eq!(ranges[180], 2800);

    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(stderr.contains("refused"), "{stderr}");
}

#[test]
fn measuring_mode_changes_the_mask() {
    let built = stream();
    let path = temp_file("mode", &built.bytes);
    // The mode in hex and in decimal.
    let [out, dec] = ["0x0F", "15"].map(|mode| {
        let path = path.to_str().unwrap();
        pyramid(&["sick-decode", path, "--measuring-mode", mode, "--json"])
    });
    std::fs::remove_file(&path).ok();
    assert_eq!(out.status.code(), Some(0), "{out:?}");
    assert_eq!(out.stdout, dec.stdout);
    let v: Value = serde_json::from_slice(&out.stdout).unwrap();
    let ranges = v["telegrams"][0]["ranges_mm"].as_array().unwrap();
    assert_eq!(ranges[0], 0x2000 | 2251);
    assert_eq!(ranges[10], 0x1FFF);
    assert!(ranges[20].is_null());
}

#[test]
fn human_summary() {
    let built = stream();
    let path = temp_file("human", &built.bytes);
    let out = pyramid(&["sick-decode", path.to_str().unwrap()]);
    std::fs::remove_file(&path).ok();
    assert_eq!(out.status.code(), Some(0), "{out:?}");
    let stdout = String::from_utf8_lossy(&out.stdout);
    let lines: Vec<&str> = stdout.lines().collect();
    assert_eq!(lines.len(), 3, "{stdout}");
    assert!(lines[0].contains("count 361 unit mm"), "{stdout}");
    assert!(
        lines[0].contains("[2251, 2251, 2251, 2251, 2251, ...]"),
        "{stdout}"
    );
    assert!(
        lines[2].contains("crc 1, length 1, truncated 1, garbage bytes 5"),
        "{stdout}"
    );
}

#[test]
fn unreadable_file_fails_and_bad_mode_is_refused() {
    let missing = std::env::temp_dir().join(format!(
        "pyramid-sick-decode-missing-{}.bin",
        std::process::id()
    ));
    let out = pyramid(&["sick-decode", missing.to_str().unwrap(), "--json"]);
    assert_eq!(out.status.code(), Some(1));
    assert!(out.stdout.is_empty());
    assert!(!out.stderr.is_empty());

    let path = temp_file("badmode", &[0x06]);
    let out = pyramid(&[
        "sick-decode",
        path.to_str().unwrap(),
        "--measuring-mode",
        "7",
    ]);
    std::fs::remove_file(&path).ok();
    assert_ne!(out.status.code(), Some(0));
    assert!(String::from_utf8_lossy(&out.stderr).contains("measuring mode"));
}

#[test]
fn empty_and_garbage_only_files_decode_to_nothing() {
    let path = temp_file("empty", &[]);
    let out = pyramid(&["sick-decode", path.to_str().unwrap(), "--json"]);
    std::fs::remove_file(&path).ok();
    assert_eq!(out.status.code(), Some(0));
    let v: Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(
        v,
        json!({"telegrams": [], "errors": {"crc": 0, "length": 0, "truncated": 0, "garbage_bytes": 0}})
    );

    let path = temp_file("garbage", &[0x02, 0x80, 0x10]);
    let out = pyramid(&["sick-decode", path.to_str().unwrap(), "--json"]);
    std::fs::remove_file(&path).ok();
    let v: Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["errors"]["truncated"], 1);
}
