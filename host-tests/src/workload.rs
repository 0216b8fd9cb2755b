//! Workloads that drive a library pyramid and reference pyramids in lock step: evidence
//! records and recentres, and a small deterministic random generator for the `agreement`
//! example (the property tests draw their workloads from proptest strategies instead).

use terrain_pyramid as tp;
use tp::units::Meters;

use crate::harness;
use crate::reference::window::Pyramid;

/// One step of a workload.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Step {
    /// Apply one observation (the library weighs it with its gating).
    Update(harness::Observation),
    /// Recentre on the robot at raw Q16.16 (x, y).
    Recentre(i32, i32),
    /// Accrue and pay the decay owed at this clock, ms (the library's `Pyramid::decay`).
    Decay(u32),
}

/// Runs `steps` on the library pyramid and on every reference pyramid.
///
/// Returns the number of steps whose per-record outcome (updated / gated out / outside the
/// window / bad layer) differed between the library and the *first* reference, which should
/// follow the quantised arithmetic for this count to be meaningful.
pub fn run<const W: usize, const L: usize>(
    steps: &[Step],
    lib: &mut tp::Pyramid<W, L>,
    gates: &tp::gate::Gates<L>,
    references: &mut [&mut Pyramid],
) -> Vec<(usize, String)> {
    use crate::reference::window::Applied as R;
    let mut outcome_mismatches = Vec::new();
    for (n, step) in steps.iter().enumerate() {
        match *step {
            Step::Update(e) => {
                let got = lib.apply(&e.evidence(gates));
                let re = harness::evidence(&e);
                for (r, reference) in references.iter_mut().enumerate() {
                    let want = reference.apply(&re);
                    if r == 0 {
                        let same = matches!(
                            (got, want),
                            (tp::Applied::Updated, R::Updated)
                                | (tp::Applied::GatedOut, R::NoEffect)
                                | (tp::Applied::OutsideWindow, R::OutsideWindow)
                                | (tp::Applied::BadLayer, R::NoSuchLayer)
                        );
                        let applies = if re.layer < reference.layers.len() {
                            reference_would_update(reference, &re)
                        } else {
                            Some(false)
                        };
                        // Outside the window, the spec's step 3 (g = 0: nothing happens) may
                        // come before or after the window check: accept either report.
                        let gated_outside = got == tp::Applied::GatedOut
                            && want == R::OutsideWindow
                            && applies != Some(true);
                        // A table entry that may legitimately differ decides whether g = 0.
                        let undecidable = applies.is_none()
                            && matches!(
                                (got, want),
                                (
                                    tp::Applied::Updated | tp::Applied::GatedOut,
                                    R::Updated | R::NoEffect
                                )
                            );
                        if !same && !gated_outside && !undecidable {
                            outcome_mismatches
                                .push((n, format!("{e:?}: library {got:?}, reference {want:?}")));
                        }
                    }
                }
            }
            Step::Recentre(x, y) => {
                lib.recentre(Meters::from_bits(x), Meters::from_bits(y));
                for reference in references.iter_mut() {
                    reference.recentre(x, y);
                }
            }
            Step::Decay(now_ms) => {
                lib.decay(now_ms);
                for reference in references.iter_mut() {
                    reference.decay(now_ms);
                }
            }
        }
    }
    outcome_mismatches
}

/// Would this record change a cell, were its cell inside the window? `None` when it depends
/// on table entries that may legitimately differ.
fn reference_would_update(
    reference: &Pyramid,
    e: &crate::reference::window::Evidence,
) -> Option<bool> {
    let w = reference.tables.weight(e.layer, e.distance_raw);
    reference.model.applies(e.obstacle, w)
}

/// SplitMix64: a small, seedable generator for reproducible workloads.
#[derive(Debug, Clone)]
pub struct Rng(u64);

impl Rng {
    /// A generator from a seed.
    #[must_use]
    pub fn new(seed: u64) -> Self {
        Self(seed)
    }

    /// The next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in `[0, 1)`.
    pub fn unit(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }

    /// Uniform in `[lo, hi)`.
    pub fn range(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.unit()
    }

    /// Uniform in `0 ..= n − 1` (`n` > 0).
    pub fn below(&mut self, n: u64) -> u64 {
        self.next_u64() % n
    }

    /// Uniform in `lo ..= hi`.
    pub fn range_i64(&mut self, lo: i64, hi: i64) -> i64 {
        let span = (hi - lo + 1) as u64;
        lo + (self.next_u64() % span) as i64
    }
}

/// How a random workload spreads its evidence.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Shape {
    /// Cells are drawn within this many cells of the robot's cell in each axis (W/2 plus a few
    /// covers the window and a margin outside it).
    pub spread: i64,
    /// A recentre follows an update with this probability.
    pub recentre_probability: f64,
    /// A recentre is a far jump (many windows away) with this probability.
    pub jump_probability: f64,
    /// A small move is at most this far in each axis, metres.
    pub step_m: f64,
}

/// `n` random updates (random layer, cell, class and distance in `0 ..= max range`),
/// interleaved with random recentres, for a pyramid of `layers` layers with cell sizes
/// `resolutions_raw` (raw Q16.16).
#[must_use]
pub fn random(
    rng: &mut Rng,
    n: usize,
    resolutions_raw: &[i64],
    max_range_m: f64,
    shape: Shape,
) -> Vec<Step> {
    let mut steps = Vec::with_capacity(n + n / 8);
    let (mut x, mut y) = (0_i64, 0_i64);
    let max_d = (max_range_m * 65_536.0) as i64;
    for _ in 0..n {
        let k = rng.range_i64(0, resolutions_raw.len() as i64 - 1) as usize;
        let rq = resolutions_raw[k];
        let (cx, cy) = (x.div_euclid(rq), y.div_euclid(rq));
        let e = harness::Observation {
            layer: k as u8,
            cell_x: (cx + rng.range_i64(-shape.spread, shape.spread)) as i32,
            cell_y: (cy + rng.range_i64(-shape.spread, shape.spread)) as i32,
            class: if rng.next_u64() & 1 == 0 {
                tp::EvidenceClass::Obstacle
            } else {
                tp::EvidenceClass::Navigable
            },
            distance: Meters::from_bits(rng.range_i64(0, max_d) as i32),
        };
        steps.push(Step::Update(e));
        if rng.unit() < shape.recentre_probability {
            if rng.unit() < shape.jump_probability {
                x += rng.range_i64(-2_000, 2_000) * 65_536;
                y += rng.range_i64(-2_000, 2_000) * 65_536;
            } else {
                let s = (shape.step_m * 65_536.0) as i64;
                x += rng.range_i64(-s, s);
                y += rng.range_i64(-s, s);
            }
            x = x.clamp(-30_000 * 65_536, 30_000 * 65_536);
            y = y.clamp(-30_000 * 65_536, 30_000 * 65_536);
            steps.push(Step::Recentre(x as i32, y as i32));
        }
    }
    steps
}
