//! What the tests of `pyramid listen`'s live outputs share: the Python readers, a running
//! `pyramid` child's output as it comes, and the check of a fused grid against `fused.pgm`.
use super::support::{wait_or_kill, PATIENCE};
use serde_json::Value;
use std::io::{BufRead, BufReader, Read};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output};
use std::sync::mpsc;
use std::time::Instant;

/// The Python readers' folder, `host/tests/py`.
pub fn py_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/py")
}

/// Python with the readers installed, or a failure that says how to install them.
pub fn python() -> &'static str {
    let ok = Command::new("python3")
        .args([
            "-c",
            "import mcap, mcap_ros2, mcap_protobuf, websockets, cyclonedds",
        ])
        .status()
        .is_ok_and(|s| s.success());
    assert!(
        ok,
        "the Python readers are missing: run host/tests/py/setup.sh (pip install -r host/tests/py/requirements.txt)"
    );
    "python3"
}

/// Stderr lines as they come, and the collected output at the end.
pub struct Running {
    /// The `pyramid` process.
    pub child: Child,
    lines: mpsc::Receiver<String>,
    stderr: std::thread::JoinHandle<String>,
    stdout: std::thread::JoinHandle<Vec<u8>>,
}

/// Starts collecting a spawned `pyramid` child's stderr (line by line) and stdout.
pub fn running(mut child: Child) -> Running {
    let err = child.stderr.take().unwrap();
    let mut out = child.stdout.take().unwrap();
    let (tx, rx) = mpsc::channel();
    let stderr = std::thread::spawn(move || {
        let mut all = String::new();
        for line in BufReader::new(err).lines() {
            let Ok(line) = line else { break };
            let _ = tx.send(line.clone());
            all.push_str(&line);
            all.push('\n');
        }
        all
    });
    let stdout = std::thread::spawn(move || {
        let mut v = Vec::new();
        let _ = out.read_to_end(&mut v);
        v
    });
    Running {
        child,
        lines: rx,
        stderr,
        stdout,
    }
}

impl Running {
    /// Waits for a stderr line containing `needle`; returns it.
    pub fn wait_for(&self, needle: &str) -> String {
        let start = Instant::now();
        loop {
            let left = PATIENCE.saturating_sub(start.elapsed());
            match self.lines.recv_timeout(left) {
                Ok(line) if line.contains(needle) => return line,
                Ok(_) => {}
                Err(_) => panic!("no line with {needle:?} on stderr"),
            }
        }
    }

    /// Sends the child SIGINT (as Ctrl-C would).
    pub fn interrupt(&self) {
        let pid = self.child.id().to_string();
        assert!(Command::new("kill")
            .args(["-INT", &pid])
            .status()
            .unwrap()
            .success());
    }

    /// Waits for the child (killing it after [`PATIENCE`]) and returns all it wrote.
    pub fn finish(mut self) -> Output {
        let status = wait_or_kill(&mut self.child);
        Output {
            status,
            stdout: self.stdout.join().unwrap(),
            stderr: self.stderr.join().unwrap().into_bytes(),
        }
    }
}

/// All a child's stderr (taken from it, read to its end).
pub fn stderr_of(child: &mut Child) -> String {
    let mut err = String::new();
    child
        .stderr
        .take()
        .unwrap()
        .read_to_string(&mut err)
        .unwrap();
    err
}

/// The MCAP file `mcap` as `read_mcap.py` (run with `py`) reads it back, its JSON; fails the
/// test when the reader fails or reports an error.
pub fn read_mcap(py: &str, mcap: &Path) -> Value {
    let read = super::common::succeeded(
        Command::new(py)
            .arg(py_dir().join("read_mcap.py"))
            .arg(mcap),
        "read_mcap.py: ",
    );
    let m: Value = serde_json::from_slice(&read.stdout).unwrap();
    assert_eq!(m["errors"], Value::Array(vec![]), "{}", m["errors"]);
    m
}

/// An `OccupancyGrid` message as `read_mcap.py` gives it.
pub struct FusedGrid {
    /// Cells a row.
    pub width: usize,
    /// The cell's side, metres.
    pub resolution_m: f64,
    /// The lowest corner (x, y), metres.
    pub origin: (f64, f64),
    /// The occupancy values (−1 unknown, 0 ..= 100), rows from the lowest y.
    pub cells: Vec<i64>,
}

impl FusedGrid {
    /// Checks this grid against `dir`'s `fused.pgm` ([`assert_fused_matches_pgm`]); how many
    /// cells both cover.
    pub fn assert_matches_pgm(&self, dir: &Path) -> usize {
        assert_fused_matches_pgm(dir, self.origin, self.resolution_m, self.width, &self.cells)
    }
}

/// The grid of the `OccupancyGrid` message `f`.
#[allow(clippy::cast_possible_truncation)]
pub fn fused_grid(f: &Value) -> FusedGrid {
    FusedGrid {
        width: f["width"].as_u64().unwrap() as usize,
        resolution_m: f["resolution"].as_f64().unwrap(),
        origin: (
            f["origin"][0].as_f64().unwrap(),
            f["origin"][1].as_f64().unwrap(),
        ),
        cells: ints(&f["data"]),
    }
}

/// The JSON summary `pyramid` printed on stdout; fails the test when it failed.
pub fn summary(out: &Output) -> Value {
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "pyramid listen failed: {stderr}");
    serde_json::from_slice(out.stdout.trim_ascii()).unwrap()
}

/// A binary PGM's pixels, rows from the lowest y (as the grids are).
pub fn pgm_rows_bottom_up(path: &Path) -> (usize, usize, Vec<u8>) {
    let bytes = std::fs::read(path).unwrap();
    let text_end = {
        // "P5\nW H\n255\n"
        let mut newlines = 0;
        let mut at = 0;
        for (i, &b) in bytes.iter().enumerate() {
            if b == b'\n' {
                newlines += 1;
                if newlines == 3 {
                    at = i + 1;
                    break;
                }
            }
        }
        at
    };
    let header = std::str::from_utf8(&bytes[..text_end]).unwrap();
    let mut it = header.split_whitespace().skip(1);
    let w: usize = it.next().unwrap().parse().unwrap();
    let h: usize = it.next().unwrap().parse().unwrap();
    let pixels = &bytes[text_end..];
    assert_eq!(pixels.len(), w * h);
    let mut rows = Vec::with_capacity(w * h);
    for row in pixels.chunks(w).rev() {
        rows.extend_from_slice(row);
    }
    (w, h, rows)
}

/// The PGM value of an OccupancyGrid value of the fused map.
pub fn grey(v: i64) -> u8 {
    match v {
        100 => 0,
        0 => 254,
        -1 => 205,
        other => panic!("fused value {other}"),
    }
}

/// A JSON array of whole numbers.
pub fn ints(v: &Value) -> Vec<i64> {
    v.as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_i64().unwrap())
        .collect()
}

/// Checks a bounded fused grid (OccupancyGrid or foxglove.Grid as decoded) against `fused.pgm`
/// and its YAML: same cell size, lattices that coincide, equal cells where both lie, unknown
/// elsewhere. Returns how many cells both cover.
pub fn assert_fused_matches_pgm(
    dir: &Path,
    origin: (f64, f64),
    r: f64,
    width: usize,
    cells: &[i64],
) -> usize {
    let (pw, ph, pixels) = pgm_rows_bottom_up(&dir.join("fused.pgm"));
    let yaml = std::fs::read_to_string(dir.join("fused.yaml")).unwrap();
    let field = |key: &str| -> String {
        yaml.lines()
            .find_map(|l| l.strip_prefix(key))
            .unwrap()
            .trim()
            .to_string()
    };
    let pr: f64 = field("resolution:").parse().unwrap();
    let o = field("origin:");
    let o: Vec<f64> = o
        .trim_matches(|c| c == '[' || c == ']')
        .split(',')
        .map(|s| s.trim().parse().unwrap())
        .collect();
    assert!((pr - r).abs() < 1e-6, "resolution {r} against {pr}");
    let height = cells.len() / width;
    let mut both = 0;
    for j in 0..height {
        for i in 0..width {
            let v = cells[j * width + i];
            let x = origin.0 + (i as f64 + 0.5) * r;
            let y = origin.1 + (j as f64 + 0.5) * r;
            let fx = (x - o[0]) / r;
            let fy = (y - o[1]) / r;
            assert!(
                (fx - fx.floor() - 0.5).abs() < 1e-3,
                "lattices differ: {fx}"
            );
            let (pi, pj) = (fx.floor(), fy.floor());
            if pi >= 0.0 && pj >= 0.0 && (pi as usize) < pw && (pj as usize) < ph {
                both += 1;
                assert_eq!(
                    grey(v),
                    pixels[pj as usize * pw + pi as usize],
                    "fused cell ({i}, {j})"
                );
            } else {
                assert_eq!(v, -1, "outside the coarsest window: unknown");
            }
        }
    }
    both
}
