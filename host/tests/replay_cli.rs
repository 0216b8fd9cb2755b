//! `pyramid replay` as scripts use it: a synthetic scan, the real 3DTK scan (when present), and
//! the refusals.
use serde_json::Value;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::Output;

mod common;

/// Runs `pyramid replay ARGS`.
fn pyramid(args: &[&str]) -> Output {
    common::pyramid(&[&["replay"], args].concat())
}

/// A fresh directory for one test.
fn scratch(name: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("replay-{name}"));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn path(p: &Path) -> &str {
    p.to_str().expect("UTF-8 path")
}

/// Runs `pyramid replay --json ARGS`, checks it succeeded, and parses stdout as one object
/// whose first keys are the required ones, in order.
fn replay_json(args: &[&str]) -> Value {
    let (value, stdout) = common::json_object("replay", args);
    assert_eq!(stdout.trim().lines().count(), 1, "one line: {stdout}");
    let positions: Vec<usize> = [
        "{\"points_read\":",
        ",\"points_used\":",
        ",\"no_return\":",
        ",\"layers\":[{\"index\":0,\"resolution_m\":",
        ",\"fused\":{\"observed_cells\":",
        ",\"overflow_points\":",
    ]
    .iter()
    .map(|key| {
        stdout
            .find(key)
            .unwrap_or_else(|| panic!("{key} in {stdout}"))
    })
    .collect();
    assert_eq!(positions[0], 0);
    assert!(positions.windows(2).all(|w| w[0] < w[1]), "{stdout}");
    value
}

/// A map as `map_server` reads it.
struct Map {
    width: usize,
    height: usize,
    /// Rows as stored: the first is the top (largest y).
    pixels: Vec<u8>,
    resolution: f64,
    origin: (f64, f64),
}

impl Map {
    fn read(dir: &Path, stem: &str) -> Self {
        let yaml = std::fs::read_to_string(dir.join(format!("{stem}.yaml"))).unwrap();
        let field = |name: &str| -> String {
            yaml.lines()
                .find_map(|l| l.strip_prefix(&format!("{name}: ")))
                .unwrap_or_else(|| panic!("{stem}.yaml has no {name}: {yaml}"))
                .to_string()
        };
        assert_eq!(field("image"), format!("{stem}.pgm"));
        assert_eq!(field("negate"), "0");
        assert_eq!(field("occupied_thresh"), "0.65");
        assert_eq!(field("free_thresh"), "0.196");
        let resolution: f64 = field("resolution").parse().unwrap();
        let origin = field("origin");
        let origin: Vec<f64> = origin
            .trim_start_matches('[')
            .trim_end_matches(']')
            .split(',')
            .map(|v| v.trim().parse().unwrap())
            .collect();
        assert_eq!(origin.len(), 3);
        assert_eq!(origin[2], 0.0);

        let bytes = std::fs::read(dir.join(format!("{stem}.pgm"))).unwrap();
        // "P5\n<w> <h>\n255\n" then w·h bytes.
        let text = String::from_utf8_lossy(&bytes[..bytes.len().min(40)]).to_string();
        let mut parts = text.splitn(5, |c: char| c.is_ascii_whitespace());
        assert_eq!(parts.next(), Some("P5"));
        let width: usize = parts.next().unwrap().parse().unwrap();
        let height: usize = parts.next().unwrap().parse().unwrap();
        assert_eq!(parts.next(), Some("255"));
        let header = format!("P5\n{width} {height}\n255\n");
        assert!(bytes.starts_with(header.as_bytes()));
        let pixels = bytes[header.len()..].to_vec();
        assert_eq!(pixels.len(), width * height, "{stem}.pgm size");
        assert!(pixels.iter().all(|p| [0, 205, 254].contains(p)));
        Self {
            width,
            height,
            pixels,
            resolution,
            origin: (origin[0], origin[1]),
        }
    }

    /// The value of the cell that contains world point (x, y).
    fn at(&self, x: f64, y: f64) -> u8 {
        let col = ((x - self.origin.0) / self.resolution).floor() as usize;
        let row_up = ((y - self.origin.1) / self.resolution).floor() as usize;
        assert!(
            col < self.width && row_up < self.height,
            "({x}, {y}) outside"
        );
        self.pixels[(self.height - 1 - row_up) * self.width + col]
    }

    fn count(&self, value: u8) -> usize {
        self.pixels.iter().filter(|&&p| p == value).count()
    }
}

const OBSTACLE: u8 = 0;
const FREE: u8 = 254;
const UNKNOWN: u8 = 205;

/// One point in the project's frame (x forward, y left, z up, metres) as a 3DTK line (cm;
/// x right, y up, z forward).
fn line(out: &mut String, x: f64, y: f64, z: f64) {
    let _ = writeln!(out, "{} {} {}", -y * 100.0, z * 100.0, x * 100.0);
}

/// A flat floor 0.4 m below the sensor over x 0.3..4.5 m, y −2..2 m (every 5 cm), a box 30 cm
/// high on it at x 2.05..2.35 m, y 0.25..0.55 m (its top and its four faces), three "no echo"
/// points (the SICK's 3276.7 cm) and two far returns (40 m and 33 m away, as a longer-ranged
/// laser gives them).
fn synthetic_scan() -> (String, usize) {
    synthetic_scan_seen_by(|p| p)
}

/// [`synthetic_scan`] as a scanner mounted otherwise sees it: `to_scanner` takes each point
/// from the robot's frame to the scanner's.
fn synthetic_scan_seen_by(to_scanner: impl Fn([f64; 3]) -> [f64; 3]) -> (String, usize) {
    let line = |out: &mut String, x: f64, y: f64, z: f64| {
        let [x, y, z] = to_scanner([x, y, z]);
        line(out, x, y, z);
    };
    let mut s = String::from("100 x 100\n\n");
    let mut n = 0;
    let in_box = |x: f64, y: f64| (2.05..=2.35).contains(&x) && (0.25..=0.55).contains(&y);
    for i in 0..=84 {
        for j in 0..=80 {
            let (x, y) = (0.3 + 0.05 * f64::from(i), -2.0 + 0.05 * f64::from(j));
            if !in_box(x, y) {
                line(&mut s, x, y, -0.4);
                n += 1;
            }
        }
    }
    for i in 0..=6 {
        for j in 0..=6 {
            let (x, y) = (2.05 + 0.05 * f64::from(i), 0.25 + 0.05 * f64::from(j));
            line(&mut s, x, y, -0.1);
            n += 1;
        }
        for k in 0..6 {
            let z = -0.4 + 0.05 * f64::from(k);
            let t = 0.05 * f64::from(i);
            for (x, y) in [
                (2.05, 0.25 + t),
                (2.35, 0.25 + t),
                (2.05 + t, 0.25),
                (2.05 + t, 0.55),
            ] {
                line(&mut s, x, y, z);
                n += 1;
            }
        }
    }
    s.push('\n');
    for no_echo in ["0 0 3276.7", "3276.7 0 0", "-2317 0 2317.01"] {
        s.push_str(no_echo);
        s.push('\n');
        n += 1;
    }
    for far in ["0 -40 4000", "0 -40 3300"] {
        s.push_str(far);
        s.push('\n');
        n += 1;
    }
    (s, n)
}

#[test]
fn a_synthetic_floor_with_a_box() {
    let dir = scratch("synthetic");
    let (text, lines) = synthetic_scan();
    let file = dir.join("box.3d");
    std::fs::write(&file, text).unwrap();
    let out = dir.join("out");
    let v = replay_json(&["--points", path(&file), "--out", path(&out)]);

    assert_eq!(v["points_read"], lines);
    assert_eq!(v["no_return"], 3);
    // The far returns are points, beyond the default design's 10 m, not "no echo".
    assert_eq!(v["points_beyond_max_range"], 2);
    assert_eq!(v["overflow_points"], 0);
    let used = v["points_used"].as_u64().unwrap();
    assert!(used > 0 && used <= lines as u64 - 3, "{used}");
    // The summary on disk is the one printed.
    let on_disk: Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    assert_eq!(on_disk, v);

    let layers = v["layers"].as_array().unwrap();
    assert!(layers.len() >= 2);
    for (k, l) in layers.iter().enumerate() {
        assert_eq!(l["index"], k);
        let observed = l["observed_cells"].as_u64().unwrap();
        let obstacle = l["obstacle_cells"].as_u64().unwrap();
        let free = l["free_cells"].as_u64().unwrap();
        assert!(obstacle + free <= observed);
        let map = Map::read(&out, &format!("layer-{k}"));
        assert_eq!((map.width, map.height), (64, 64));
        assert_eq!(map.count(OBSTACLE) as u64, obstacle, "layer {k}");
        assert_eq!(map.count(FREE) as u64, free, "layer {k}");
        let r = l["resolution_m"].as_f64().unwrap();
        assert!(
            (map.resolution - r).abs() < 1e-4,
            "layer {k}: {}",
            map.resolution
        );
        // The window is centred on the sensor's cell.
        assert!((map.origin.0 + 32.0 * map.resolution).abs() <= map.resolution);
    }

    let fused = Map::read(&out, "fused");
    // The default design: 64 cells of 1.4 m at 0.1 m.
    assert_eq!((fused.width, fused.height), (896, 896));
    assert_eq!(fused.count(OBSTACLE) as u64, v["fused"]["obstacle_cells"]);
    assert_eq!(
        (fused.count(OBSTACLE) + fused.count(FREE)) as u64,
        v["fused"]["observed_cells"]
    );
    // The box, and not its mirror image across y = 0 (the rows are top first).
    for (x, y) in [(2.1, 0.3), (2.2, 0.4), (2.3, 0.5)] {
        assert_eq!(fused.at(x, y), OBSTACLE, "box at ({x}, {y})");
    }
    for (x, y) in [
        (2.2, -0.4),
        (1.0, 0.0),
        (1.0, 1.0),
        (3.0, -1.5),
        (4.0, 1.2),
        (0.6, -0.3),
    ] {
        assert_eq!(fused.at(x, y), FREE, "floor at ({x}, {y})");
    }
    // Behind the sensor nothing was seen.
    assert_eq!(fused.at(-1.0, 0.0), UNKNOWN);
    assert!(out.join("maps.png").metadata().unwrap().len() > 10_000);
}

/// A noise-free revolution of a car's ring laser (h 1.3 m, beams every 0.4° from −24.8°, 0.2°
/// azimuth steps from 0.1°, 20 m) over a flat road with a kerb `kerb_m` high along y = 3.5 m
/// (y > 0), written beam by beam (a whole revolution of one beam, then the next), as some
/// point files hold a spinning laser's returns.
fn kerb_scan_beam_by_beam(kerb_m: f64) -> String {
    let (h, kerb_y) = (1.3, 3.5);
    let mut s = String::new();
    for k in 0..62 {
        let a = (-24.8 + 0.4 * f64::from(k)).to_radians();
        for j in 0..1800 {
            // Half a step off the multiples of ψ, where the sort's steps begin.
            let th = (0.1 + 0.2 * f64::from(j)).to_radians();
            let d = [a.cos() * th.cos(), a.cos() * th.sin(), a.sin()];
            let at = |t: f64| [t * d[0], t * d[1], t * d[2]];
            let mut p = at(h / -d[2]);
            if p[1] >= kerb_y {
                // The face where the ray meets y = 3.5 m below the kerb's top, else the top.
                let face = at(kerb_y / d[1]);
                p = if face[2] < kerb_m - h {
                    face
                } else {
                    at((h - kerb_m) / -d[2])
                };
            }
            if p[0].hypot(p[1]) <= 20.0 {
                line(&mut s, p[0], p[1], p[2]);
            }
        }
    }
    s
}

#[test]
fn a_far_kerb_held_beam_by_beam_is_found_in_firing_order() {
    let dir = scratch("kerb-order");
    let file = dir.join("kerb.3d");
    std::fs::write(&file, kerb_scan_beam_by_beam(0.12)).unwrap();
    let design = [
        "--max-range-m",
        "20",
        "--gamma",
        "3",
        "--height-m",
        "1.3",
        "--phi-deg",
        "0.4",
        "--psi-deg",
        "0.2",
        "--sigma-m",
        "0.02",
        "--cells",
        "128",
    ];
    // Kerb samples every 0.1 m along x in 10..19 m, marked when an obstacle cell of the fused
    // map lies within 0.2 m.
    let marked = |order: &str| {
        let out = dir.join(order);
        let v = replay_json(
            &[
                &[
                    "--points",
                    path(&file),
                    "--out",
                    path(&out),
                    "--order",
                    order,
                ][..],
                &design[..],
            ]
            .concat(),
        );
        assert_eq!(v["order"], order);
        let fused = Map::read(&out, "fused");
        let near = |x: f64| {
            (-2..=2).any(|i: i32| {
                (-2..=2).any(|j: i32| {
                    i * i + j * j <= 4
                        && fused.at(x + 0.1 * f64::from(i), 3.5 + 0.1 * f64::from(j)) == OBSTACLE
                })
            })
        };
        (0..90)
            .filter(|&i| near(10.05 + 0.1 * f64::from(i)))
            .count()
    };
    // In firing order the two beams that stand on the kerb's face follow each other in their
    // cell (the pair test); beam by beam they are a revolution apart, and far out the kerb is
    // a ramp within each beam.
    let (firing, file_order) = (marked("firing"), marked("file"));
    assert_eq!(firing, 90, "firing order");
    assert!(file_order < 80, "file order: {file_order} of 90");
    // By default the order is found: the file holds whole revolutions of one beam.
    let v = replay_json(&["--points", path(&file), "--out", path(&dir.join("default"))]);
    assert_eq!(v["order_asked"], "auto");
    assert_eq!(v["order"], "firing");
}

/// The real scan: `../shared/data` next to the project (or `$PYRAMID_SHARED_DATA`).
fn real_scan() -> Option<PathBuf> {
    let dir = std::env::var_os("PYRAMID_SHARED_DATA").map_or_else(
        || PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/../../shared/data")),
        PathBuf::from,
    );
    let file = dir.join("3dtk-tilt-scan/scan000.3d");
    if file.is_file() {
        Some(file)
    } else {
        println!(
            "note: {} is absent (the recorded data lives in ../shared/data, never in the project; \
             set PYRAMID_SHARED_DATA to its folder): the real-scan test is skipped",
            file.display()
        );
        None
    }
}

#[test]
fn the_real_tilt_scan() {
    let Some(scan) = real_scan() else {
        return;
    };
    let pose = scan.with_extension("pose");
    let out = scratch("real");
    let v = replay_json(&[
        "--points",
        path(&scan),
        "--pose",
        path(&pose),
        "--sensor-origin-m",
        "0,0,0",
        "--out",
        path(&out),
    ]);
    assert_eq!(v["points_read"], 81_360);
    // A tilting 2-D laser's lines: the file's own order, found by default.
    assert_eq!(
        (v["order_asked"].as_str(), v["order"].as_str()),
        (Some("auto"), Some("file"))
    );
    let no_return = v["no_return"].as_u64().unwrap();
    assert!(no_return > 0 && no_return < 5_000, "{no_return}");
    let used = v["points_used"].as_u64().unwrap();
    assert!(used > 70_000 && used <= 81_360 - no_return, "{used}");
    assert_eq!(v["overflow_points"], 0);
    let fused = Map::read(&out, "fused");
    // The floor just in front of the sensor.
    assert_eq!(fused.at(1.0, 0.0), FREE);
    assert!(v["fused"]["obstacle_cells"].as_u64().unwrap() > 100);
    assert!(v["fused"]["free_cells"].as_u64().unwrap() > 100);
    // The wall on the right of the walkway, about 1 m away at x = 2 m.
    assert!(
        (0..5).any(|k| fused.at(2.2, -1.3 + 0.1 * f64::from(k)) == OBSTACLE),
        "the wall at x = 2.2 m, y = -1.3 .. -0.9 m"
    );
    // Every layer saw something, the finest mostly floor.
    for l in v["layers"].as_array().unwrap() {
        assert!(l["observed_cells"].as_u64().unwrap() > 0, "{l}");
    }
    let l0 = &v["layers"][0];
    assert!(l0["free_cells"].as_u64().unwrap() > l0["obstacle_cells"].as_u64().unwrap());
    // The scanner stands 0.4 m above the walkway's floor (the guide's `--height-m 0.4`); the
    // default height of 1 m is called out.
    let found = v["ground_found_m"].as_f64().unwrap();
    assert!((found - 0.4).abs() < 0.05, "{found}");
    let warnings = v["warnings"].as_array().unwrap();
    assert_eq!(warnings.len(), 1, "{warnings:?}");
    assert!(warnings[0]
        .as_str()
        .unwrap()
        .contains("higher than it stands"));
}

#[test]
fn the_scans_ground_is_checked_against_the_height() {
    let dir = scratch("ground");
    let file = dir.join("box.3d");
    std::fs::write(&file, synthetic_scan().0).unwrap();
    // The synthetic floor lies 0.4 m below the sensor. Each run writes its own folder.
    let replay = |height: &str, json: bool| {
        let out_dir = dir.join(format!("out-{height}-{json}"));
        let mut args = vec![
            "--points",
            path(&file),
            "--out",
            path(&out_dir),
            "--height-m",
            height,
        ];
        if json {
            args.push("--json");
        }
        let out = pyramid(&args);
        assert!(out.status.success(), "{out:?}");
        out
    };
    let described = |height: &str| {
        let out = replay(height, true);
        let v: Value = serde_json::from_slice(&out.stdout).unwrap();
        (v, String::from_utf8(out.stderr).unwrap())
    };
    let (v, stderr) = described("0.4");
    let found = v["ground_found_m"].as_f64().unwrap();
    assert!((found - 0.4).abs() < 0.03, "{found}");
    assert_eq!(v["warnings"], serde_json::json!([]));
    assert!(!stderr.contains("warning"), "{stderr}");
    // A laser described 0.3 m higher than the scan puts it: named on stderr and in the summary.
    let (v, stderr) = described("0.7");
    let warnings = v["warnings"].as_array().unwrap();
    assert_eq!(warnings.len(), 1, "{warnings:?}");
    let text = warnings[0].as_str().unwrap();
    assert!(text.contains("higher than it stands") && text.contains("--height-m says 0.7 m"));
    assert!(stderr.contains(&format!("warning: {text}")), "{stderr}");
    // The table printed without --json says both depths.
    let out = replay("0.7", false);
    let table = String::from_utf8(out.stdout).unwrap();
    let line = table
        .lines()
        .find(|l| l.trim_start().starts_with("ground "))
        .unwrap_or_else(|| panic!("no ground line: {table}"));
    assert!(line.trim_start().starts_with("ground 0.4"), "{line}");
    assert!(
        line.ends_with("the design's ground plane 0.70 m below"),
        "{line}"
    );
}

#[test]
fn a_missing_point_file_is_named() {
    let out = scratch("missing");
    let missing = out.join("no-such-scan.3d");
    let r = pyramid(&["--points", path(&missing), "--out", path(&out.join("o"))]);
    assert_eq!(r.status.code(), Some(1));
    let stderr = String::from_utf8_lossy(&r.stderr);
    assert_eq!(stderr.lines().count(), 1, "{stderr}");
    assert!(stderr.contains("no-such-scan.3d"), "{stderr}");
    assert!(stderr.contains("../shared/data"), "{stderr}");
    assert!(r.stdout.is_empty());
    assert!(!out.join("o").exists(), "nothing is written");
}

#[test]
fn a_malformed_line_is_named_by_its_number() {
    let dir = scratch("malformed");
    let file = dir.join("bad.3d");
    std::fs::write(&file, "2 x 2\n0 -40 100\n\n0 -40 oops\n").unwrap();
    let r = pyramid(&["--points", path(&file), "--out", path(&dir.join("o"))]);
    assert_eq!(r.status.code(), Some(1));
    let stderr = String::from_utf8_lossy(&r.stderr);
    assert_eq!(stderr.lines().count(), 1, "{stderr}");
    assert!(
        stderr.contains("bad.3d") && stderr.contains("line 4"),
        "{stderr}"
    );
}

#[test]
fn a_rotated_pose_is_refused_and_a_translation_moves_the_maps() {
    let dir = scratch("pose");
    let file = dir.join("scan.3d");
    let (text, _) = synthetic_scan();
    std::fs::write(&file, text).unwrap();
    let pose = dir.join("scan.pose");
    std::fs::write(&pose, "0 0 0\n0 90 0\n").unwrap();
    let r = pyramid(&[
        "--points",
        path(&file),
        "--pose",
        path(&pose),
        "--out",
        path(&dir.join("o")),
    ]);
    assert_eq!(r.status.code(), Some(1));
    let stderr = String::from_utf8_lossy(&r.stderr);
    assert!(
        stderr.contains("scan.pose") && stderr.contains("rotation"),
        "{stderr}"
    );

    // 500 cm forward in the file's frame (its z) is 5 m along x: the sensor and the box move.
    std::fs::write(&pose, "0 0 500\n0 0 0\n").unwrap();
    let out = dir.join("moved");
    let v = replay_json(&[
        "--points",
        path(&file),
        "--pose",
        path(&pose),
        "--out",
        path(&out),
    ]);
    assert_eq!(v["sensor_m"][0], 5.0);
    let fused = Map::read(&out, "fused");
    assert_eq!(fused.at(7.2, 0.4), OBSTACLE);
    assert_eq!(fused.at(6.0, 0.0), FREE);
}

/// A scanner mounted turned (yaw 90°: its x to the robot's left) or upside down (roll
/// 180°): its points, turned back by `--mount-rpy-deg`, map the box where it stands; without
/// the flag, elsewhere. An angle beyond ±360° is refused, naming the flag.
#[test]
fn a_turned_scanner_maps_the_box_where_it_stands() {
    let dir = scratch("mount");
    type Turn = fn([f64; 3]) -> [f64; 3];
    let cases: [(&str, Turn); 3] = [
        ("0,0,90", |[x, y, z]| [y, -x, z]),
        ("180,0,0", |[x, y, z]| [x, -y, -z]),
        ("0,0,-90", |[x, y, z]| [-y, x, z]),
    ];
    for (k, (rpy, to_scanner)) in cases.into_iter().enumerate() {
        let file = dir.join(format!("turned-{k}.3d"));
        std::fs::write(&file, synthetic_scan_seen_by(to_scanner).0).unwrap();
        let out = dir.join(format!("turned-{k}"));
        let v = replay_json(&[
            "--points",
            path(&file),
            "--mount-rpy-deg",
            rpy,
            "--out",
            path(&out),
        ]);
        assert_eq!(v["overflow_points"], 0);
        let fused = Map::read(&out, "fused");
        for (x, y) in [(2.1, 0.3), (2.2, 0.4), (2.3, 0.5)] {
            assert_eq!(fused.at(x, y), OBSTACLE, "{rpy}: box at ({x}, {y})");
        }
        for (x, y) in [(1.0, 0.0), (3.0, -1.5), (4.0, 1.2)] {
            assert_eq!(fused.at(x, y), FREE, "{rpy}: floor at ({x}, {y})");
        }
        if k == 0 {
            // Without the flag the scan is mapped as the scanner saw it: the box to the right.
            let plain = dir.join("unturned");
            replay_json(&["--points", path(&file), "--out", path(&plain)]);
            let fused = Map::read(&plain, "fused");
            assert_ne!(fused.at(2.2, 0.4), OBSTACLE);
            assert_eq!(fused.at(0.4, -2.2), OBSTACLE);
        }
    }
    let r = pyramid(&[
        "--points",
        "whatever.3d",
        "--mount-rpy-deg",
        "0,400,0",
        "--out",
        path(&dir.join("bad")),
    ]);
    assert_eq!(r.status.code(), Some(2));
    let stderr = String::from_utf8_lossy(&r.stderr);
    assert!(stderr.contains("--mount-rpy-deg"), "{stderr}");
}

#[test]
fn an_invalid_design_exits_2_like_pyramid_design() {
    let dir = scratch("design");
    for (args, flag) in [
        (["--gamma", "1"], "--gamma"),
        (["--cells", "66"], "--cells"),
    ] {
        refused_by_flag(
            &["--points", "whatever.3d", "--out", path(&dir)],
            &args,
            flag,
        );
    }
}

/// `pyramid replay` with `args` then `bad` exits 2 with one line on stderr naming `flag`.
fn refused_by_flag(args: &[&str], bad: &[&str], flag: &str) {
    let all = [args, bad].concat();
    let r = pyramid(&all);
    assert_eq!(r.status.code(), Some(2), "{all:?}");
    let stderr = String::from_utf8_lossy(&r.stderr);
    assert_eq!(stderr.lines().count(), 1, "{stderr}");
    assert!(stderr.contains(flag), "{stderr}");
}

#[test]
fn a_bad_inverse_sensor_model_is_refused_by_its_flag() {
    let dir = scratch("model");
    let (scan, _) = synthetic_scan();
    let points = dir.join("scan.3d");
    std::fs::write(&points, scan).unwrap();
    // A model the library takes makes maps (`host/tests/rule_hash.rs` pins what it changes).
    let v = replay_json(&[
        "--points",
        path(&points),
        "--out",
        path(&dir.join("out")),
        "--p-obstacle",
        "0.9",
        "--p-free",
        "0.3",
    ]);
    assert!(v["points_used"].as_u64().unwrap_or(0) > 0, "{v}");
    // A probability on the wrong side of the prior, or out of range, is refused by its flag.
    for (args, flag) in [
        (["--p-obstacle", "0.4"], "--p-obstacle"),
        (["--p-free", "0.6"], "--p-free"),
        (["--p-obstacle", "1.0"], "--p-obstacle"),
    ] {
        refused_by_flag(
            &["--points", path(&points), "--out", path(&dir)],
            &args,
            flag,
        );
    }
}
