//! Plausibility of standard-scan nodes: a node whose angle cannot follow its neighbours is
//! refused ([`RplidarError::Implausible`](super::RplidarError::Implausible)).
//!
//! A standard-scan node has two check bits (S ≠ !S, C = 1) and an angle range: damaged or
//! misaligned bytes pass them about one time in six. Its angle is the second check. The head
//! turns at a constant rate and the sensor measures at a constant rate, one node per sample,
//! in order: between two nodes that lie `n` node slots (5 bytes each) apart in the byte
//! stream, the angle advances by about `n` sample steps of `360° · f / R` (rotation rate
//! `f`, sample rate `R`). Slamtec's standard scan measures at least 2 000 samples/s and its
//! heads turn at most 20 Hz (A1 10 Hz, A2 15 Hz, A3 20 Hz): a step is at most 3.6°, taken
//! as [`RPLIDAR_NODE_STEP_MAX_Q6`] = 4°. A node with a distance is **plausible** against a reference node
//! `n` slots before it when its angle lies from [`RPLIDAR_NODE_BACK_Q6`] (4°) behind the reference to
//! `(n + 1) · 4°` ahead of it, wrapping at 360° (the extra slot covers up to four bytes lost
//! unseen on the line); once `(n + 1) · 4°` reaches a turn, any angle is. A node with the
//! start flag S must also lie where a revolution starts: within that window of 0°.
//!
//! The reference is the last node accepted with a distance, or, when the last node with a
//! distance was refused, that refused node too (a node plausible against either is
//! accepted): a real jump (bytes lost over a longer stretch) or an accepted damaged node costs
//! at most one good node. Nodes without a distance (0: no return, whose angle the sensor
//! does not always fill in) are neither checked nor used as a reference. A descriptor (a new
//! scan) forgets both references.
//!
//! Bound: a damaged node whose angle is uniformly random passes with probability
//! `(RPLIDAR_NODE_BACK_Q6 + (n + 1) · RPLIDAR_NODE_STEP_MAX_Q6) / 23 040`: 12/360 = 3.3 % right after its neighbour.
//! Damage in the distance or the quality cannot be seen by the angle.

use super::RPLIDAR_Q6_PER_TURN;

/// The largest angle step between two consecutive standard-scan samples, degrees·64 (4°:
/// 360° · 20 Hz / 2 000 samples/s = 3.6°, rounded up).
pub const RPLIDAR_NODE_STEP_MAX_Q6: u32 = 4 * 64;
/// How far a node may lie behind its reference, degrees·64 (4°, one step).
pub const RPLIDAR_NODE_BACK_Q6: u32 = 4 * 64;
/// Bytes of a node.
const NODE_BYTES: u64 = 5;

/// A node a later one is judged against: its angle (degrees·64) and its stream position.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Reference {
    angle_q6: u32,
    offset: u64,
}

impl Reference {
    /// Whether a node at `offset` with `angle_q6` and start flag `start` can follow this one.
    fn admits(self, angle_q6: u32, start: bool, offset: u64) -> bool {
        let slots = offset.wrapping_sub(self.offset).div_ceil(NODE_BYTES);
        let ahead = slots
            .saturating_add(1)
            .saturating_mul(u64::from(RPLIDAR_NODE_STEP_MAX_Q6));
        if ahead.saturating_add(u64::from(RPLIDAR_NODE_BACK_Q6)) >= u64::from(RPLIDAR_Q6_PER_TURN) {
            return true;
        }
        // ahead < a turn: it fits a u32.
        let ahead = u32::try_from(ahead).unwrap_or(RPLIDAR_Q6_PER_TURN);
        let turn = RPLIDAR_Q6_PER_TURN;
        let step = (angle_q6 % turn + turn - self.angle_q6 % turn) % turn;
        let follows = step <= ahead || step >= turn - RPLIDAR_NODE_BACK_Q6;
        // A revolution starts within the window: 0° lies between the reference (less the
        // tolerance behind) and the node.
        let starts_here = !start || {
            let from = (self.angle_q6 % turn + turn - RPLIDAR_NODE_BACK_Q6) % turn;
            let to_node = (angle_q6 % turn + turn - from) % turn;
            let to_zero = (turn - from) % turn;
            to_zero <= to_node
        };
        follows && starts_here
    }
}

/// The references of the node stream ([module documentation](self)).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub(super) struct NodeFollower {
    accepted: Option<Reference>,
    refused: Option<Reference>,
}

impl NodeFollower {
    /// No reference yet: the next node is accepted.
    pub(super) const NEW: Self = Self {
        accepted: None,
        refused: None,
    };

    /// Judges a node that passed its check bits: its angle (degrees·64), start flag, distance
    /// (0 = none) and stream position. `true` when it is accepted.
    pub(super) fn judge(
        &mut self,
        angle_q6: u16,
        start: bool,
        distance_q2: u16,
        offset: u64,
    ) -> bool {
        if distance_q2 == 0 {
            return true;
        }
        let angle_q6 = u32::from(angle_q6);
        let node = Reference { angle_q6, offset };
        let admitted = match (self.accepted, self.refused) {
            (None, None) => true,
            (a, r) => [a, r]
                .into_iter()
                .flatten()
                .any(|reference| reference.admits(angle_q6, start, offset)),
        };
        if admitted {
            self.accepted = Some(node);
            self.refused = None;
        } else {
            self.refused = Some(node);
        }
        admitted
    }

    /// Forgets both references (a new scan starts).
    pub(super) fn forget(&mut self) {
        *self = Self::NEW;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const DEG: u32 = 64;

    /// Nodes every `step` degrees·64 from `start`, each 5 bytes after the last.
    fn run(f: &mut NodeFollower, from: u32, step: u32, count: u32, at: &mut u64) -> u32 {
        let mut accepted = 0;
        for k in 0..count {
            let angle = (from + k * step) % RPLIDAR_Q6_PER_TURN;
            let prev = (from + (k.max(1) - 1) * step) % RPLIDAR_Q6_PER_TURN;
            let start = k > 0 && angle < prev;
            if f.judge(angle as u16, start, 4000, *at) {
                accepted += 1;
            }
            *at += 5;
        }
        accepted
    }

    #[test]
    fn every_node_of_an_intact_stream_at_any_rate_is_accepted() {
        // 0.05° to 3.6° a step (the fastest head at the slowest sampling), three turns each.
        for step in [3, 64, 100, 200, 230] {
            let mut f = NodeFollower::NEW;
            let mut at = 0;
            let count = 3 * RPLIDAR_Q6_PER_TURN / step;
            assert_eq!(run(&mut f, 17, step, count, &mut at), count, "step {step}");
        }
    }

    #[test]
    fn a_node_far_from_its_neighbour_is_refused_and_a_real_jump_costs_one() {
        let mut f = NodeFollower::NEW;
        let mut at = 0;
        assert_eq!(run(&mut f, 0, DEG, 20, &mut at), 20);
        // A damaged angle 90° ahead.
        assert!(!f.judge((110 * DEG) as u16, false, 4000, at));
        at += 5;
        // The stream goes on: accepted against the last good node.
        assert!(f.judge((21 * DEG) as u16, false, 4000, at));
        at += 5;
        // 10° behind: refused.
        assert!(!f.judge((12 * DEG) as u16, false, 4000, at));
        at += 5;
        // A start flag in the middle of the revolution: refused.
        assert!(!f.judge((23 * DEG) as u16, true, 4000, at));
        at += 5;
        // Bytes lost: 100 bytes (20 slots) later the head is 20° on: accepted.
        at += 100;
        assert!(f.judge((44 * DEG) as u16, false, 4000, at));
        at += 5;
        // A real jump seen right away (a node 60° on): the first is refused, the second,
        // following it, accepted.
        assert!(!f.judge((104 * DEG) as u16, false, 4000, at));
        at += 5;
        assert!(f.judge((105 * DEG) as u16, false, 4000, at));
        at += 5;
        // Without a distance: never refused, never a reference.
        assert!(f.judge((300 * DEG) as u16, true, 0, at));
        at += 5;
        assert!(f.judge((106 * DEG) as u16, false, 4000, at));
        // Across 0° with the start flag.
        let mut g = NodeFollower::NEW;
        assert!(g.judge((359 * DEG) as u16, false, 4000, 0));
        assert!(g.judge((DEG / 2) as u16, true, 4000, 5));
        assert!(!g.judge((180 * DEG) as u16, true, 4000, 10));
        // Long after the last node, any angle.
        assert!(g.judge((180 * DEG) as u16, false, 4000, 10 + 5 * 100));
    }
}
