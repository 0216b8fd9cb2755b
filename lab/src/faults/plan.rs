//! What each fault kind sends: the recording cut to its first lines, and per line the
//! commands and the (damaged or intact) laser bytes the harness writes to the board.

use super::*;

/// One line of the recording: the angle and pose in force, and its telegram.
#[derive(Clone)]
pub(super) struct Line {
    pub(super) angle: Option<u16>,
    pub(super) pose: Option<[f32; 6]>,
    pub(super) telegram: Vec<u8>,
}

/// A command the harness sends before a line's laser bytes.
#[derive(Clone)]
pub(super) enum Cmd {
    Angle(u16),
    Pose([f32; 6]),
    Configure(Box<Configure>),
    Setup(Setup),
}

/// What goes to the board for one line.
#[derive(Clone, Default)]
pub(super) struct Step {
    pub(super) cmds: Vec<Cmd>,
    /// Bytes written to UART0 (garbage, the possibly damaged telegram, more garbage).
    pub(super) chunk: Vec<u8>,
    /// Where the original telegram starts in `chunk`, if the fault left its bytes untouched.
    pub(super) intact_at: Option<usize>,
    /// The link phase this line belongs to.
    pub(super) phase: Phase,
}

#[derive(Clone, Copy, Default, PartialEq, Eq)]
pub(super) enum Phase {
    #[default]
    Normal,
    /// The host does not listen: UART1's bytes reach a tap, not the mirror.
    Deaf,
    /// UART1 is closed; nothing is sent to the device.
    Disconnected,
}
/// A small deterministic generator (xorshift64*), one seed per kind.
pub(super) struct Rng(pub(super) u64);

impl Rng {
    pub(super) fn new(name: &str) -> Self {
        let mut h: u64 = 0xcbf2_9ce4_8422_2325;
        for b in name.bytes() {
            h ^= u64::from(b);
            h = h.wrapping_mul(0x0100_0000_01b3);
        }
        Self(h | 1)
    }
    pub(super) fn next(&mut self) -> u64 {
        let mut x = self.0;
        x ^= x >> 12;
        x ^= x << 25;
        x ^= x >> 27;
        self.0 = x;
        x.wrapping_mul(0x2545_f491_4f6c_dd1d)
    }
    /// Uniform in [0, 1).
    #[allow(clippy::cast_precision_loss)]
    pub(super) fn unit(&mut self) -> f64 {
        (self.next() >> 11) as f64 / (1_u64 << 53) as f64
    }
    /// Uniform in lo ..= hi.
    #[allow(clippy::cast_possible_truncation)]
    pub(super) fn range(&mut self, lo: usize, hi: usize) -> usize {
        lo + (self.next() % (hi - lo + 1) as u64) as usize
    }
    pub(super) fn chance(&mut self, p: f64) -> bool {
        self.unit() < p
    }
    pub(super) fn bytes(&mut self, n: usize) -> Vec<u8> {
        (0..n).map(|_| self.next() as u8).collect()
    }
    /// Overwrites a run of `body` with random bytes: its length uniform in 1 ..= `longest`
    /// (at most `body`'s length), its start uniform over the places it fits.
    pub(super) fn overwrite(&mut self, body: &mut [u8], longest: usize) {
        let len = self.range(1, longest.min(body.len()));
        let at = self.range(0, body.len() - len);
        let noise = self.bytes(len);
        body[at..at + len].copy_from_slice(&noise);
    }
    /// Flips each bit of `body` with probability `ber` (a bit error rate).
    pub(super) fn flip_bits(&mut self, body: &mut [u8], ber: f64) {
        for byte in body {
            for bit in 0..8 {
                if self.chance(ber) {
                    *byte ^= 1 << bit;
                }
            }
        }
    }
    /// Garbage around and over one unit of a stream: with chance 0.25, 1 ..= `longest_before`
    /// random bytes before it, half the time ending in a false `header` and 0 ..= 4 random
    /// bytes (a length that claims the unit that follows); with chance 0.1, noise over the
    /// unit itself (see [`Self::overwrite`], runs of up to `longest_over` bytes); with chance
    /// 0.1, 1 ..= 40 random bytes after it. The bytes before and after the unit.
    pub(super) fn garbage(
        &mut self,
        body: &mut [u8],
        header: &[u8],
        longest_before: usize,
        longest_over: usize,
    ) -> (Vec<u8>, Vec<u8>) {
        let (mut pre, mut post) = (Vec::new(), Vec::new());
        if self.chance(0.25) {
            let k = self.range(1, longest_before);
            pre = self.bytes(k);
            if self.chance(0.5) {
                pre.extend_from_slice(header);
                let k = self.range(0, 4);
                pre.extend(self.bytes(k));
            }
        }
        if self.chance(0.1) {
            self.overwrite(body, longest_over);
        }
        if self.chance(0.1) {
            let k = self.range(1, 40);
            post = self.bytes(k);
        }
        (pre, post)
    }
}

/// A unit of a recording with what is in force when it arrives: the angle (2⁻¹⁶ turn) and
/// the pose (x, y, z m, roll, pitch, yaw rad) sent since the unit before it, and its bytes.
pub(super) type InForce = (Option<u16>, Option<[f32; 6]>, Vec<u8>);

/// The first `n` units (at least one) of `steps` that `unit` takes (it gives their bytes),
/// each with the angle and the pose in force: the last of each that came since the unit
/// before it.
pub(super) fn in_force<'a>(
    steps: &'a [PlayStep],
    n: usize,
    unit: impl Fn(&'a PlayStep) -> Option<&'a Vec<u8>>,
) -> Vec<InForce> {
    let (mut angle, mut pose) = (None, None);
    steps
        .iter()
        .filter_map(move |step| {
            match step {
                PlayStep::Angle(t) => angle = Some(*t),
                PlayStep::Pose(p) => pose = Some(*p),
                _ => {}
            }
            unit(step).map(|bytes| (angle.take(), pose.take(), bytes.clone()))
        })
        .take(n.max(1))
        .collect()
}

/// The recording: the simulated stairs drive (as the demo's), its setup and first lines,
/// decoded by the host tool's player.
pub(super) fn recording(lines: usize) -> Result<(SetupEvent, Vec<Line>), String> {
    let sim = simulate(&SimConfig::paper_stairs(0.5, 0.5, 1.0)).map_err(|e| e.0)?;
    let decoded = steps(&sim.bytes)?;
    let setup = decoded.setup().ok_or("the recording has no setup")?;
    let out = in_force(&decoded.steps, lines, |step| match step {
        PlayStep::Telegram {
            bytes,
            measured: true,
            ..
        } => Some(bytes),
        _ => None,
    })
    .into_iter()
    .map(|(angle, pose, telegram)| Line {
        angle,
        pose,
        telegram,
    })
    .collect();
    Ok((setup, out))
}

/// The steps of one fault kind: the lines with their commands and damaged bytes.
#[allow(clippy::too_many_lines)]
pub(super) fn plan(kind: &str, lines: &[Line], setup: &Setup) -> Vec<Step> {
    let mut rng = Rng::new(kind);
    let n = lines.len();
    // The first lines and the last three stay clean.
    let damageable = |i: usize| i >= 2 && i + 3 < n;
    let mut steps = Vec::with_capacity(n);
    for (i, line) in lines.iter().enumerate() {
        let mut step = Step::default();
        if let Some(a) = line.angle {
            step.cmds.push(Cmd::Angle(a));
        }
        if let Some(p) = line.pose {
            step.cmds.push(Cmd::Pose(p));
        }
        let t = &line.telegram;
        let mut pre = Vec::new();
        let mut body = t.clone();
        let mut post = Vec::new();
        if damageable(i) {
            match kind {
                "bit_flips_1e-4" | "bit_flips_1e-3" => {
                    let ber = if kind.ends_with("1e-4") { 1e-4 } else { 1e-3 };
                    rng.flip_bits(&mut body, ber);
                }
                "dropped_bytes" if rng.chance(0.2) => {
                    for _ in 0..rng.range(1, 3) {
                        let at = rng.range(0, body.len() - 1);
                        body.remove(at);
                    }
                }
                "garbage_bursts" => {
                    // Noise between telegrams, sometimes ending in a false `02 80` and a
                    // length that claims the telegram that follows; noise over a telegram.
                    (pre, post) = rng.garbage(&mut body, &[0x02, 0x80], 200, 64);
                }
                "truncated" if rng.chance(0.2) => {
                    let keep = rng.range(1, body.len() - 1);
                    body.truncate(keep);
                }
                "lone_ack_nak" => {
                    let ack_nak = |rng: &mut Rng| {
                        let k = rng.range(1, 3);
                        (0..k)
                            .map(|_| if rng.chance(0.5) { 0x06 } else { 0x15 })
                            .collect::<Vec<u8>>()
                    };
                    if rng.chance(0.3) {
                        pre = ack_nak(&mut rng);
                    }
                    if rng.chance(0.1) {
                        // One inside a telegram: it damages that telegram.
                        let at = rng.range(1, body.len() - 1);
                        let b = ack_nak(&mut rng);
                        body.splice(at..at, b);
                    }
                }
                _ => {}
            }
        }
        let untouched = body == *t;
        step.intact_at = untouched.then_some(pre.len());
        step.chunk = pre;
        step.chunk.extend_from_slice(&body);
        step.chunk.extend_from_slice(&post);
        steps.push(step);
    }
    match kind {
        "pose_gaps_jumps" => plan_pose_gaps_jumps(&mut steps, &mut rng),
        "bad_pose" => plan_bad_poses(&mut steps, &mut rng),
        "bad_config" => plan_bad_configs(&mut steps, setup),
        "link_disconnect" => {
            // Deaf for a sixth of the run, then a stretch of normal lines (the host notices
            // the gap and asks for a snapshot), then disconnected for a sixth.
            let s = n / 6;
            for (i, step) in steps.iter_mut().enumerate() {
                if (s..2 * s).contains(&i) {
                    step.phase = Phase::Deaf;
                } else if (3 * s..4 * s).contains(&i) {
                    step.phase = Phase::Disconnected;
                }
            }
        }
        _ => {}
    }
    steps
}

/// Leaves poses out for runs of lines, and makes the robot jump and come back.
pub(super) fn plan_pose_gaps_jumps(steps: &mut [Step], rng: &mut Rng) {
    let n = steps.len();
    let mut i = 3;
    let mut jumps = [
        [100.0_f32, 0.0, 0.0, 0.0, 0.0, 0.0],
        [0.0, -3.2, 0.0, 0.0, 0.0, 1.5],
        [5000.0, 2000.0, 0.5, 0.1, 0.0, -3.0],
        [0.0, 0.0, 0.0, 0.0, 0.0, 3.0],
        [-25_000.0, 25_000.0, 0.0, 0.0, 0.0, 0.0],
    ]
    .into_iter()
    .cycle();
    while i + 4 < n {
        if rng.chance(0.5) {
            // A gap: no pose for a run of lines (the device keeps the last one).
            let len = rng.range(2, 12).min(n - 4 - i);
            for step in &mut steps[i..i + len] {
                step.cmds.retain(|c| !matches!(c, Cmd::Pose(_)));
            }
            i += len;
        } else {
            // A jump for one to three lines, then back to the recording's poses.
            let delta = jumps.next().unwrap_or_default();
            let len = rng.range(1, 3);
            let last = steps[..i]
                .iter()
                .rev()
                .flat_map(|s| s.cmds.iter().rev())
                .find_map(|c| match c {
                    Cmd::Pose(p) => Some(*p),
                    _ => None,
                })
                .unwrap_or_default();
            for step in &mut steps[i..(i + len).min(n - 4)] {
                let base = step
                    .cmds
                    .iter()
                    .find_map(|c| match c {
                        Cmd::Pose(p) => Some(*p),
                        _ => None,
                    })
                    .unwrap_or(last);
                step.cmds.retain(|c| !matches!(c, Cmd::Pose(_)));
                let mut p = base;
                for (v, d) in p.iter_mut().zip(delta) {
                    *v += d;
                }
                step.cmds.push(Cmd::Pose(p));
            }
            i += len;
            // Back at the recording's pose for the next line.
            if i < n && !steps[i].cmds.iter().any(|c| matches!(c, Cmd::Pose(_))) {
                steps[i].cmds.push(Cmd::Pose(last));
            }
        }
        i += rng.range(3, 10);
    }
}

/// Every kind of bad pose, one before every few lines.
pub(super) fn plan_bad_poses(steps: &mut [Step], rng: &mut Rng) {
    let bad: Vec<(usize, f32)> = vec![
        (0, f32::NAN),
        (1, f32::INFINITY),
        (2, f32::NEG_INFINITY),
        (3, f32::NAN),
        (4, f32::INFINITY),
        (5, f32::NAN),
        (0, 30_000.0),
        (1, -1e9),
        (2, 1_000.0),
        (2, -5_000.0),
        (3, f32::MAX),
        (4, -32_768.0),
        (5, 40_000.0),
        (5, 32_768.0),
        (3, 1e30),
        (0, -f32::MAX),
    ];
    let n = steps.len();
    let mut next = bad.iter().cycle();
    let mut i = 3;
    while i + 3 < n {
        let base = [1.0_f32, 2.0, 0.0, 0.0, 0.0, 0.5];
        for _ in 0..rng.range(1, 2) {
            let (field, value) = *next.next().unwrap_or(&(0, f32::NAN));
            let mut p = base;
            p[field] = value;
            // Before the line's own (good) pose, so that the refusal is what is tested.
            steps[i].cmds.insert(0, Cmd::Pose(p));
        }
        // And one after it: the line must be integrated with the good pose.
        let (field, value) = *next.next().unwrap_or(&(0, f32::NAN));
        let mut p = base;
        p[field] = value;
        steps[i].cmds.push(Cmd::Pose(p));
        i += rng.range(3, 8);
    }
}

/// Invalid configurations and setups, mid-run.
pub(super) fn plan_bad_configs(steps: &mut [Step], setup: &Setup) {
    let good = configure_of_design(&default_design(), &Config::default());
    let c = |f: &dyn Fn(&mut Configure)| {
        let mut m = good;
        f(&mut m);
        Cmd::Configure(Box::new(m))
    };
    let s = |f: &dyn Fn(&mut Setup)| {
        let mut m = *setup;
        f(&mut m);
        Cmd::Setup(m)
    };
    let bad = vec![
        c(&|m| m.gamma = 1.0),
        c(&|m| m.phi_rad = f32::NAN),
        c(&|m| m.height_m = -1.0),
        c(&|m| m.max_range_m = f32::INFINITY),
        c(&|m| m.height_m = 1.2e-38),
        c(&|m| m.base_m = 1e-4),
        c(&|m| m.cells_per_side = 32),
        c(&|m| m.cells_per_side = 63),
        c(&|m| m.p_obstacle = 0.5),
        c(&|m| m.p_free = 1.5),
        c(&|m| {
            m.clamp = ClampRequest::Bounds {
                min: 1.0,
                max: -1.0,
            }
        }),
        c(&|m| m.fused_margin = -1.0),
        c(&|m| m.max_range_m = 200.0),
        s(&|m| m.measuring_mode = 7),
        s(&|m| m.mount = 3),
        s(&|m| {
            m.mount = 2;
            m.mount_block.axis = 7;
        }),
        s(&|m| m.filter.sector_count = 9),
        s(&|m| m.resolution_cdeg = 30),
        s(&|m| m.sensor_m[0] = f32::NAN),
        s(&|m| m.robot_height_m = -1.0),
        s(&|m| m.step_threshold_m = 5000.0),
        s(&|m| m.ceiling_m = f32::INFINITY),
    ];
    let n = steps.len();
    let mut i = 4;
    for cmd in bad {
        if i + 3 >= n {
            i = 4 + i % 3;
        }
        steps[i].cmds.insert(0, cmd);
        i += 4;
    }
}
