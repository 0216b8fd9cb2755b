//! The figures of `lab live` from what the relay timed: the device's clock against the wall
//! clock ([`ClockTruth`]), the error of the stamps listen gave the poses, and the poses'
//! latency to the board ([`PoseLatency`]), each as a [`Spread`].
use super::relay::Tap;
use crate::experiments::timing::LatePose;
use serde::Serialize;
use std::collections::HashMap;

/// The median, the 95th percentile and the largest of a set of figures.
#[derive(Debug, Clone, Copy, Default, Serialize, PartialEq)]
pub struct Spread {
    /// How many.
    pub n: usize,
    /// The median.
    pub median: f64,
    /// The 95th percentile.
    pub p95: f64,
    /// The smallest.
    pub min: f64,
    /// The largest.
    pub max: f64,
}

impl Spread {
    pub(super) fn of(mut v: Vec<f64>) -> Self {
        v.sort_by(f64::total_cmp);
        let at = |q: f64| {
            #[allow(
                clippy::cast_possible_truncation,
                clippy::cast_sign_loss,
                clippy::cast_precision_loss
            )]
            let i = ((v.len().saturating_sub(1)) as f64 * q).round() as usize;
            v.get(i).copied().map_or(0.0, round2)
        };
        Self {
            n: v.len(),
            median: at(0.5),
            p95: at(0.95),
            min: at(0.0),
            max: at(1.0),
        }
    }
}

fn round2(v: f64) -> f64 {
    (v * 100.0).round() / 100.0
}

/// The device's clock against the wall clock, and the stamps listen gave the poses against it.
///
/// The emulated board's µs clock follows the host's wall clock (QEMU's virtual clock runs in
/// real time). The relay between listen and the board times each time exchange as it passes:
/// the request read from listen at `w1`, the reply read from the board at `w2`; the device
/// took the request between them, so its clock minus the wall clock lies within
/// `[device_us − w2, device_us − w1]`. A line through the middles of the tightest exchanges
/// is the truth each pose's stamp is held against.
#[derive(Debug, Clone, Default, Serialize, PartialEq)]
pub struct ClockTruth {
    /// Time exchanges the relay saw whole.
    pub exchanges: usize,
    /// Of them, those the line goes through (round trip at the relay ≤ the tightest's + 200 µs).
    pub tight_exchanges: usize,
    /// The tightest exchange's round trip at the relay, µs: the truth's error is within ± half
    /// of it (plus the line's residual).
    pub best_round_trip_us: u64,
    /// The device's clock rate against the wall clock, ppm.
    pub drift_ppm: f64,
    /// The largest distance of a tight exchange's middle from the line, µs.
    pub max_residual_us: f64,
    /// Each stamped Pose's `stamp_us` minus the device's clock at the pose's time (its
    /// Odometry stamp on the wall clock mapped by the line), µs: the clock error the pose
    /// stamps carry to the device.
    pub stamp_error_us: Spread,
    /// The same, absolute values.
    pub stamp_error_abs_us: Spread,
}

/// How late the poses reach the board.
#[derive(Debug, Clone, Default, Serialize, PartialEq)]
pub struct PoseLatency {
    /// From the pose's stamp (the robot was there) to its Pose frame leaving listen (read by
    /// the relay once the board's UART has taken the relay's earlier bytes), ms.
    pub stamp_to_board_ms: Spread,
    /// From the publisher's write to the same moment, ms: what DDS and listen add.
    pub publish_to_board_ms: Spread,
}

/// Time fields of the poses as given to the publisher: the key (x, y, z bits) of each pose
/// met exactly once, → its index.
fn unique_poses(poses: &[LatePose]) -> HashMap<[u32; 3], usize> {
    let mut seen: HashMap<[u32; 3], Option<usize>> = HashMap::new();
    for (i, p) in poses.iter().enumerate() {
        let key = [
            p.pose[0].to_bits(),
            p.pose[1].to_bits(),
            p.pose[2].to_bits(),
        ];
        seen.entry(key).and_modify(|v| *v = None).or_insert(Some(i));
    }
    seen.into_iter()
        .filter_map(|(k, v)| Some((k, v?)))
        .collect()
}

/// The clock truth and the poses' latency from what the relay timed. `poses` in stamp order,
/// as the publisher was given them; `start_us` the wall clock of the recording's t = 0;
/// `published_us` when the publisher wrote each (when known).
#[allow(clippy::cast_precision_loss, clippy::cast_possible_wrap)]
pub(super) fn clock_figures(
    tap: &Tap,
    poses: &[LatePose],
    start_us: u64,
    published_us: &[Option<u64>],
) -> (ClockTruth, PoseLatency) {
    let mut truth = ClockTruth {
        exchanges: tap.exchanges.len(),
        ..ClockTruth::default()
    };
    let Some(&(w0, _, d0)) = tap.exchanges.first() else {
        return (truth, PoseLatency::default());
    };
    // Offsets (device − wall) relative to the first exchange's, wrapping-safe.
    let base = d0.wrapping_sub(w0 as u32);
    let rel = |device: u32, wall: u64| -> f64 {
        f64::from(device.wrapping_sub(wall as u32).wrapping_sub(base) as i32)
    };
    let best = tap
        .exchanges
        .iter()
        .map(|&(a, b, _)| b.saturating_sub(a))
        .min()
        .unwrap_or(0);
    truth.best_round_trip_us = best;
    let tight: Vec<(f64, f64)> = tap
        .exchanges
        .iter()
        .filter(|&&(a, b, _)| b.saturating_sub(a) <= best + 200)
        .map(|&(a, b, d)| {
            let mid = a + (b - a) / 2;
            ((mid - w0) as f64, rel(d, mid))
        })
        .collect();
    truth.tight_exchanges = tight.len();
    let n = tight.len() as f64;
    let (mx, my) = (
        tight.iter().map(|p| p.0).sum::<f64>() / n,
        tight.iter().map(|p| p.1).sum::<f64>() / n,
    );
    let sxx: f64 = tight.iter().map(|p| (p.0 - mx).powi(2)).sum();
    let sxy: f64 = tight.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
    let slope = if sxx > 0.0 { sxy / sxx } else { 0.0 };
    let line = |x: f64| my + slope * (x - mx);
    truth.drift_ppm = round2(slope * 1e6);
    truth.max_residual_us = round2(
        tight
            .iter()
            .map(|p| (p.1 - line(p.0)).abs())
            .fold(0.0, f64::max),
    );
    let index = unique_poses(poses);
    let (mut errors, mut to_board, mut from_publish) = (Vec::new(), Vec::new(), Vec::new());
    for (at, p) in &tap.poses {
        let key = [p.x_m.to_bits(), p.y_m.to_bits(), p.z_m.to_bits()];
        let Some(&k) = index.get(&key) else {
            continue;
        };
        let Some(pose) = poses.get(k) else {
            continue;
        };
        let wall = start_us + pose.stamp_us;
        let expected = line(wall as f64 - w0 as f64);
        errors.push(rel(p.stamp_us, wall) - expected);
        to_board.push((*at as f64 - wall as f64) * 1e-3);
        if let Some(Some(w)) = published_us.get(k) {
            from_publish.push((*at as f64 - *w as f64) * 1e-3);
        }
    }
    truth.stamp_error_abs_us = Spread::of(errors.iter().map(|e| e.abs()).collect());
    truth.stamp_error_us = Spread::of(errors);
    (
        truth,
        PoseLatency {
            stamp_to_board_ms: Spread::of(to_board),
            publish_to_board_ms: Spread::of(from_publish),
        },
    )
}
