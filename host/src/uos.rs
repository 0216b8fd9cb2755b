//! A streaming reader of 3DTK's `uos` point files (`scanNNN.3d`) and their pose files
//! (`scanNNN.pose`).
//!
//! A point file is text: an optional header line `W x H` (the scan's shape, e.g. `360 x 225`),
//! then one point per line, `x y z` in centimetres, separated by blanks. Further numeric
//! columns (the reflectance of `uosr`, the colour of `uos_rgb`) are accepted and ignored.
//! Blank lines are skipped. The frame is 3DTK's: left-handed, x right, y up, z forward; this
//! module does not convert it (see `replay`).
//!
//! A pose file is two lines: the translation `x y z` (cm) and the rotation `rx ry rz`
//! (degrees), both in the point file's frame.
use std::fmt;
use std::io::BufRead;

/// One point as the file gives it, centimetres in the file's frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RawPoint {
    /// x (right), cm.
    pub x: f64,
    /// y (up), cm.
    pub y: f64,
    /// z (forward), cm.
    pub z: f64,
    /// The 1-based line number the point was read from.
    pub line: usize,
}

/// Why a line could not be read.
#[derive(Debug)]
pub enum UosError {
    /// Reading failed (I/O, or the text is not UTF-8) at this 1-based line.
    Io {
        /// The line that could not be read.
        line: usize,
        /// What went wrong.
        source: std::io::Error,
    },
    /// The line is not a point (nor the optional header).
    Malformed {
        /// The 1-based line number.
        line: usize,
        /// What is wrong with it.
        reason: String,
    },
}

impl fmt::Display for UosError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Io { line, source } => write!(f, "line {line}: cannot read: {source}"),
            Self::Malformed { line, reason } => write!(f, "line {line}: {reason}"),
        }
    }
}

impl std::error::Error for UosError {}

/// Whether a line is a scan-shape header `W x H` (two unsigned integers around an `x`).
fn is_header(line: &str) -> bool {
    let fields: Vec<&str> = line.split_whitespace().collect();
    match fields.as_slice() {
        [w, x, h] => {
            x.eq_ignore_ascii_case("x") && w.parse::<u64>().is_ok() && h.parse::<u64>().is_ok()
        }
        // `360x225`
        [one] => one
            .split_once(['x', 'X'])
            .is_some_and(|(w, h)| w.parse::<u64>().is_ok() && h.parse::<u64>().is_ok()),
        _ => false,
    }
}

/// Parses the first three blank-separated numbers of `text`, requiring at least three, all
/// finite; further columns must be numbers too.
fn parse_numbers(text: &str, what: &str) -> Result<[f64; 3], String> {
    let mut values = [0.0_f64; 3];
    let mut count = 0_usize;
    for field in text.split_whitespace() {
        let value: f64 = field
            .parse()
            .map_err(|_| format!("{what}: {field:?} is not a number"))?;
        if !value.is_finite() {
            return Err(format!("{what}: {field:?} is not a finite number"));
        }
        if let Some(slot) = values.get_mut(count) {
            *slot = value;
        }
        count += 1;
    }
    if count < 3 {
        return Err(format!(
            "{what}: expected 3 numbers \"x y z\", found {count} in {:?}",
            text.trim()
        ));
    }
    Ok(values)
}

/// Streams the points of a `uos` file, one line at a time.
#[derive(Debug)]
pub struct UosReader<R> {
    input: R,
    buffer: String,
    line: usize,
    /// Whether a non-blank line has been seen (the header may only be the first).
    started: bool,
    /// Point lines returned so far.
    points: usize,
    failed: bool,
}

impl<R: BufRead> UosReader<R> {
    /// A reader of `input`.
    pub fn new(input: R) -> Self {
        Self {
            input,
            buffer: String::new(),
            line: 0,
            started: false,
            points: 0,
            failed: false,
        }
    }

    /// The point lines read so far.
    #[must_use]
    pub fn points_read(&self) -> usize {
        self.points
    }
}

impl<R: BufRead> Iterator for UosReader<R> {
    type Item = Result<RawPoint, UosError>;

    /// The next point; `Some(Err(..))` once on the first bad line, then `None`.
    fn next(&mut self) -> Option<Self::Item> {
        if self.failed {
            return None;
        }
        loop {
            self.buffer.clear();
            self.line += 1;
            let line = self.line;
            match self.input.read_line(&mut self.buffer) {
                Ok(0) => return None,
                Ok(_) => {}
                Err(source) => {
                    self.failed = true;
                    return Some(Err(UosError::Io { line, source }));
                }
            }
            let text = self.buffer.trim();
            if text.is_empty() {
                continue;
            }
            let first = !self.started;
            self.started = true;
            if first && is_header(text) {
                continue;
            }
            return match parse_numbers(text, "point") {
                Ok([x, y, z]) => {
                    self.points += 1;
                    Some(Ok(RawPoint { x, y, z, line }))
                }
                Err(reason) => {
                    self.failed = true;
                    Some(Err(UosError::Malformed { line, reason }))
                }
            };
        }
    }
}

/// A 3DTK pose: the scan's translation (cm) and rotation (degrees) in the file's frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pose {
    /// Translation x y z, centimetres.
    pub translation_cm: [f64; 3],
    /// Rotation rx ry rz, degrees.
    pub rotation_deg: [f64; 3],
}

/// Parses a pose file's text: two non-blank lines of three numbers each (anything after them
/// must be blank).
///
/// # Errors
/// A line that is missing or malformed, named by its number.
pub fn parse_pose(text: &str) -> Result<Pose, UosError> {
    let mut rows = Vec::with_capacity(2);
    let mut last = 0;
    for (index, line) in text.lines().enumerate() {
        let number = index + 1;
        last = number;
        if line.trim().is_empty() {
            continue;
        }
        let what = match rows.len() {
            0 => "translation",
            1 => "rotation",
            _ => {
                return Err(UosError::Malformed {
                    line: number,
                    reason: "a pose has two lines (translation, rotation); this one is extra"
                        .to_string(),
                })
            }
        };
        let values = parse_numbers(line, what).map_err(|reason| UosError::Malformed {
            line: number,
            reason,
        })?;
        rows.push(values);
    }
    match rows.as_slice() {
        [translation_cm, rotation_deg] => Ok(Pose {
            translation_cm: *translation_cm,
            rotation_deg: *rotation_deg,
        }),
        _ => Err(UosError::Malformed {
            line: last + 1,
            reason: format!(
                "a pose has two lines (translation x y z in cm, rotation rx ry rz in degrees); found {}",
                rows.len()
            ),
        }),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn read(text: &str) -> Vec<Result<RawPoint, UosError>> {
        UosReader::new(text.as_bytes()).collect()
    }

    #[test]
    fn header_blank_lines_and_extra_columns() {
        let points = read("360 x 225\n\n1 2 3\n  \n-4.5 5e1 6 99\n");
        let points: Vec<RawPoint> = points.into_iter().map(Result::unwrap).collect();
        assert_eq!(points.len(), 2);
        assert_eq!((points[0].x, points[0].y, points[0].z), (1.0, 2.0, 3.0));
        assert_eq!(points[0].line, 3);
        assert_eq!((points[1].x, points[1].y, points[1].z), (-4.5, 50.0, 6.0));
        assert_eq!(points[1].line, 5);
    }

    #[test]
    fn no_header_is_fine_and_a_header_later_is_not() {
        assert_eq!(read("1 2 3\n").len(), 1);
        assert!(is_header("360x225"));
        let r = read("1 2 3\n360 x 225\n");
        match &r[1] {
            Err(UosError::Malformed { line, .. }) => assert_eq!(*line, 2),
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn a_malformed_line_is_named_and_ends_the_stream() {
        let r = read("1 2 3\n1 2\n4 5 6\n");
        assert_eq!(r.len(), 2);
        let e = r[1].as_ref().unwrap_err();
        assert!(e.to_string().starts_with("line 2:"), "{e}");
        let r = read("1 2 nan\n");
        assert!(r[0].as_ref().unwrap_err().to_string().contains("finite"));
        let r = read("1 2 z\n");
        assert!(r[0].as_ref().unwrap_err().to_string().contains("\"z\""));
    }

    #[test]
    fn the_count_of_point_lines() {
        let mut reader = UosReader::new("2 x 1\n1 2 3\n\n4 5 6\n".as_bytes());
        assert_eq!(reader.by_ref().count(), 2);
        assert_eq!(reader.points_read(), 2);
    }

    #[test]
    fn poses() {
        let p = parse_pose("10 -20 30.5\n0 0 0\n").unwrap();
        assert_eq!(p.translation_cm, [10.0, -20.0, 30.5]);
        assert_eq!(p.rotation_deg, [0.0; 3]);
        assert_eq!(
            parse_pose("0 0 0\n-0 0 -0\n\n").unwrap().rotation_deg[2],
            0.0
        );
        let e = parse_pose("0 0 0\n").unwrap_err().to_string();
        assert!(e.contains("found 1"), "{e}");
        let e = parse_pose("0 0 0\n0 x 0\n").unwrap_err().to_string();
        assert!(e.starts_with("line 2:"), "{e}");
    }
}
