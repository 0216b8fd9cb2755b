//! An `f32` counterpart of `terrain-pyramid`'s per-line pipeline, for the benchmark only
//! (`cargo xtask bench`): the same stages and the same rules, in `f32` instead of fixed point.
//!
//! - Telegrams: the library's own parser ([`MeasuredValues`]), as the fixed pipeline uses.
//! - Geometry: per line, the actuator's and the pose's sines and cosines with micromath
//!   (one `sin`/`cos` pair each), the world images of the beam's cos/sin directions (six
//!   `f32`) and the scanner's origin; per return, eight multiplies, the horizontal distance
//!   with a square root (`vsqrt.f32` on an FPU, two Newton steps on micromath's estimate
//!   without one). The beam table holds the library's own Q1.15 cos/sin, widened to `f32`.
//! - Classifier: the same open-addressing table keyed by (layer, cell x, cell y), the same
//!   z-interval fold (robot height) and rule, heights and distances in `f32` metres; cells by
//!   `floor(x · 1/r)`. The rule is the configuration's: the paper's spread against the step
//!   threshold, or the plane rule (`docs/core.md`): per cell the running sums of the points'
//!   position in the cell and height below the overhang cut, and at the observation's end the
//!   same ridge least-squares plane, residual, gradient and rise tests as the library's, its
//!   extremes test (the lowest and highest points' positions kept as they change) and its pair
//!   test (the last point below the cut and the largest step a pair of consecutive points
//!   shows, `min(rise, rise − slope·run + step)`), with the step between neighbouring cells'
//!   lowest points at the observation's end, in `f32` (no decimation: `f32` sums need no
//!   width bound). The pair across a cell's edge (two consecutive points in neighbouring
//!   cells) it does not have.
//! - Gate: per layer a 512-bin `f32` table (the library's table widened; a weight whose
//!   gated increments would both round to zero in Q8.8 is 0 here too, so the same layers are
//!   fed), binned as the library bins.
//! - Pyramid: per layer a W × W circular window of `f32` log-odds (NaN = unknown), the same
//!   recentring and row/column resets, clamping to OctoMap's −2 ..= 3.5 (each record reaching
//!   no further than its weight's share of the bound), dirty tiles.
//!
//! It is not bit-identical to the fixed pipeline (nor meant to be); it does the same work.
#![no_std]
#![deny(missing_docs)]

use micromath::F32Ext;
use terrain_pyramid::classify::{NavigabilityRule, PlaneRule};
use terrain_pyramid::design::Design;
use terrain_pyramid::gate::{DistanceBins, GateTable, GATE_BINS};
use terrain_pyramid::geometry::ScanPlane;
use terrain_pyramid::geometry::{BeamDir, MAX_RANGE_MM};
use terrain_pyramid::logodds::gated;
use terrain_pyramid::pipeline::FrontendConfig;
use terrain_pyramid::wire::sick::MeasuredValues;
use terrain_pyramid::wire::sick::Variant;
use terrain_pyramid::wire::sick::MAX_BEAMS;
use terrain_pyramid::{Config, DesignError};

mod pyramid;

pub use pyramid::{Layer, Pyramid};

/// Tiles per side of a layer's dirty map (as the library's).
const TILES_PER_SIDE: usize = 8;

/// `√x` for x ≥ 0.
#[inline(always)]
#[allow(unsafe_code)]
fn sqrt(x: f32) -> f32 {
    #[cfg(all(target_arch = "arm", target_feature = "vfp2"))]
    {
        let y: f32;
        // SAFETY: a register-only FPU instruction.
        unsafe {
            core::arch::asm!("vsqrt.f32 {0}, {1}", out(sreg) y, in(sreg) x, options(pure, nomem, nostack));
        }
        y
    }
    #[cfg(not(all(target_arch = "arm", target_feature = "vfp2")))]
    {
        if x <= 0.0 {
            return 0.0;
        }
        let mut y = F32Ext::sqrt(x);
        y = 0.5 * (y + x / y);
        0.5 * (y + x / y)
    }
}

/// `floor(v)` as an `i32` (saturating as `as` does).
#[inline(always)]
#[allow(clippy::cast_possible_truncation, clippy::cast_precision_loss)]
fn floor_i32(v: f32) -> i32 {
    let t = v as i32;
    if (t as f32) > v {
        t - 1
    } else {
        t
    }
}

const EMPTY: u8 = u8::MAX;

#[derive(Clone, Copy)]
struct Slot {
    cell_x: i32,
    cell_y: i32,
    distance: f32,
    z_low: f32,
    z_high: f32,
    layer: u8,
}

impl Slot {
    const VACANT: Self = Self {
        cell_x: 0,
        cell_y: 0,
        distance: 0.0,
        z_low: 0.0,
        z_high: 0.0,
        layer: EMPTY,
    };
}

/// The plane rule's running sums of one cell: u, v the point's position in its cell in
/// units of 1/64 cell from the centre (as the library's), dz its height in mm above the
/// cell's first summed point.
#[derive(Clone, Copy)]
struct Sums {
    n: f32,
    z0: f32,
    su: f32,
    sv: f32,
    sz: f32,
    suu: f32,
    svv: f32,
    suv: f32,
    suz: f32,
    svz: f32,
    szz: f32,
    /// Where the lowest and the highest point lie (u, v).
    low_at: (f32, f32),
    high_at: (f32, f32),
    /// The last point below the cut (u, v, z m) and the largest step a pair of points has
    /// shown (mm, [`shown`]).
    last: (f32, f32, f32),
    pair_rise: f32,
}

impl Sums {
    const ZERO: Self = Self {
        n: 0.0,
        z0: 0.0,
        su: 0.0,
        sv: 0.0,
        sz: 0.0,
        suu: 0.0,
        svv: 0.0,
        suv: 0.0,
        suz: 0.0,
        svz: 0.0,
        szz: 0.0,
        low_at: (0.0, 0.0),
        high_at: (0.0, 0.0),
        last: (0.0, 0.0, 0.0),
        pair_rise: 0.0,
    };

    /// The sums of the one point (u, v, z m).
    fn first(u: f32, v: f32, z: f32) -> Self {
        let mut s = Self::ZERO;
        s.z0 = z;
        s.low_at = (u, v);
        s.high_at = (u, v);
        s.last = (u, v, z);
        s.add(u, v, z);
        s
    }

    /// The pair test's step from the last point to (u, v, z m), `slope` the largest slope's
    /// rise per unit of position and `step` the step allowance (mm).
    #[inline]
    fn step(&mut self, u: f32, v: f32, z: f32, slope: f32, step: f32) {
        let rise = (z - self.last.2).abs() * 1000.0;
        // A rise within the step shows none beyond it (as the library's, not computed).
        if rise > step {
            let run = (u - self.last.0).abs() + (v - self.last.1).abs();
            self.keep(shown(rise, run, slope, step));
        }
        self.last = (u, v, z);
    }

    /// Keeps `shown` (mm) when it is the largest step a pair has shown.
    #[inline]
    fn keep(&mut self, shown: f32) {
        if shown > self.pair_rise {
            self.pair_rise = shown;
        }
    }

    #[inline]
    fn add(&mut self, u: f32, v: f32, z: f32) {
        let dz = (z - self.z0) * 1000.0;
        self.n += 1.0;
        self.su += u;
        self.sv += v;
        self.sz += dz;
        self.suu += u * u;
        self.svv += v * v;
        self.suv += u * v;
        self.suz += u * dz;
        self.svz += v * dz;
        self.szz += dz * dz;
    }
}

/// The step a pair of points shows (mm): its rise beyond the largest slope over its run
/// (`slope` mm a unit, at least 0) plus the step allowance, at most the rise, so that it
/// exceeds `step + noise` exactly when the surface between them is steeper than the largest
/// slope beyond the noise and rises more than a step beyond it (`docs/core.md`).
///
/// Comparisons, not `f32::max`/`min`: those call `fmaxf`/`fminf` on the Cortex-M4F.
#[inline]
fn shown(rise: f32, run: f32, slope: f32, step: f32) -> f32 {
    let beyond = rise - slope * run;
    let shown = if beyond > 0.0 { beyond + step } else { step };
    if shown < rise {
        shown
    } else {
        rise
    }
}

/// The plane rule's parameters in `f32`: tan of the largest slope, the residual allowance,
/// the range noise and the elevation noise (mm, mm, rad), the noise factor, the step (mm),
/// and the spread below which a cell is navigable without its plane (mm).
#[derive(Clone, Copy)]
struct PlaneF32 {
    grade: f32,
    residual_mm: f32,
    sigma_mm: f32,
    angle: f32,
    factor: f32,
    step_mm: f32,
    quick_mm: f32,
}

impl PlaneF32 {
    fn new(rule: &PlaneRule, step: f32) -> Self {
        let residual_mm = rule.residual.to_num::<f32>().max(0.0) * 1000.0;
        let step_mm = step.max(0.0) * 1000.0;
        Self {
            grade: rule.max_grade.to_num::<f32>().max(0.0),
            residual_mm,
            sigma_mm: rule.range_sigma.to_num::<f32>().max(0.0) * 1000.0,
            angle: rule.angle_sigma.to_num::<f32>().max(0.0),
            factor: rule.noise_factor.to_num::<f32>().max(0.0),
            step_mm,
            // As the library's: the residual's RMS is at most half the spread, the rise at
            // most √3 times it.
            quick_mm: (2.0 * residual_mm).min(step_mm / 1.732) - 1.0,
        }
    }

    /// Whether the cell of `s` is not navigable: `h` the sensor's height above the ground,
    /// `d` the cell's closest look, `cell` its side, `spread_mm` its highest less its lowest
    /// point, all in mm.
    fn obstacle(&self, s: &Sums, h: f32, d: f32, cell: f32, spread_mm: f32) -> bool {
        let n = s.n;
        let r = sqrt(h * h + d * d);
        let range = if r > 0.0 {
            self.sigma_mm * h / r
        } else {
            self.sigma_mm
        };
        if n < 2.0 {
            // One point fits no plane; a pair with a point beside it may still show a step.
            return s.pair_rise > self.step_mm + 2.0 * self.factor * range;
        }
        // Centred moments times n²; the ridge of 1 unit² times n².
        let cuu = n * s.suu - s.su * s.su;
        let cvv = n * s.svv - s.sv * s.sv;
        let cuv = n * s.suv - s.su * s.sv;
        let cuz = n * s.suz - s.su * s.sz;
        let cvz = n * s.svz - s.sv * s.sz;
        let czz = n * s.szz - s.sz * s.sz;
        let n2 = n * n;
        let (a, b) = (cuu + n2, cvv + n2);
        let det = a * b - cuv * cuv;
        if det <= 0.0 {
            return false;
        }
        let wa = (b * cuz - cuv * cvz) / det;
        let wb = (a * cvz - cuv * cuz) / det;
        // The extremes and the pair tests against step + 2·k·σ·h/r.
        let unexplained = if spread_mm > self.step_mm {
            let du = s.high_at.0 - s.low_at.0;
            let dv = s.high_at.1 - s.low_at.1;
            spread_mm - (wa * du + wb * dv).max(0.0)
        } else {
            0.0
        };
        let excess = unexplained.max(s.pair_rise);
        if excess > self.step_mm && excess > self.step_mm + 2.0 * self.factor * range {
            return true;
        }
        let explained = wa * wa * cuu + 2.0 * wa * wb * cuv + wb * wb * cvv;
        let residual = czz - 2.0 * (wa * cuz + wb * cvz) + explained;
        let angle = self.angle * r;
        let noise = self.factor * sqrt(range * range + angle * angle);
        let allowed = self.residual_mm * self.residual_mm + noise * noise;
        if residual > allowed * n2 {
            return true;
        }
        let slope = sqrt(wa * wa + wb * wb);
        let steep = 64.0 * slope - self.grade * cell;
        if steep <= 0.0 {
            return false;
        }
        let rise_n = sqrt(12.0 * explained.max(0.0));
        let rise_noise = noise * sqrt(12.0 / n);
        rise_n > n * (self.step_mm + rise_noise)
            && rise_n * steep > 64.0 * slope * n * 1.5 * rise_noise
    }
}

#[inline]
#[allow(clippy::cast_sign_loss)]
fn hash(layer: u8, x: i32, y: i32) -> u32 {
    let h = (x as u32).wrapping_mul(0x9E37_79B1)
        ^ (y as u32).wrapping_mul(0x85EB_CA77).rotate_left(13)
        ^ u32::from(layer).wrapping_mul(0xC2B2_AE3D);
    h ^ (h >> 15)
}

/// The f32 per-line pipeline with `C` classifier slots (a power of two).
pub struct Frontend<const C: usize> {
    beams: [(f32, f32); MAX_BEAMS],
    variant: Variant,
    config: FrontendConfig,
    sensor: [f32; 3],
    slots: [Slot; C],
    /// The plane rule's sums of each slot (untouched under the spread rule).
    sums: [Sums; C],
    order: [u16; C],
    used: usize,
    reference_z: f32,
    robot_height: f32,
    step: f32,
    /// The plane rule's parameters when it is the configuration's rule.
    plane: Option<PlaneF32>,
    pose: [f32; 6],
    rot: [[f32; 3]; 3],
    actuator: u16,
    last_actuator: Option<u16>,
    direction: i8,
    lines_in_observation: u32,
    returns: u32,
    /// Lines taken.
    lines: u32,
}

impl<const C: usize> Frontend<C> {
    /// A pipeline for `config` (the library's), at the world origin with the actuator at 0.
    #[must_use]
    pub fn new(config: FrontendConfig) -> Self {
        let mut beams = [(0.0, 0.0); MAX_BEAMS];
        for (i, b) in beams
            .iter_mut()
            .enumerate()
            .take(config.variant.beam_count())
        {
            if let Some(theta) = config.variant.beam_angle(i) {
                let d = BeamDir::new(theta);
                *b = (d.cos().to_num(), d.sin().to_num());
            }
        }
        let p = config.mount.position;
        let mut f = Self {
            beams,
            variant: config.variant,
            config,
            sensor: [p.x.to_num(), p.y.to_num(), p.z.to_num()],
            slots: [Slot::VACANT; C],
            sums: [Sums::ZERO; C],
            order: [0; C],
            used: 0,
            reference_z: 0.0,
            robot_height: config.classifier.robot_height.to_num(),
            step: config.classifier.step_threshold.to_num(),
            plane: match &config.classifier.rule {
                NavigabilityRule::Plane(rule) => Some(PlaneF32::new(
                    rule,
                    config.classifier.step_threshold.to_num(),
                )),
                NavigabilityRule::Spread => None,
            },
            pose: [0.0; 6],
            rot: [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
            actuator: 0,
            last_actuator: None,
            direction: 0,
            lines_in_observation: 0,
            returns: 0,
            lines: 0,
        };
        f.set_pose([0.0; 6]);
        f
    }

    /// Returns seen so far.
    #[must_use]
    pub const fn returns(&self) -> u32 {
        self.returns
    }

    /// Lines taken so far.
    #[must_use]
    pub const fn lines(&self) -> u32 {
        self.lines
    }

    /// The actuator angle, a fraction of a turn.
    pub fn set_actuator(&mut self, turns: u16) {
        self.actuator = turns;
    }

    /// The robot's pose: x, y, z (m), roll, pitch, yaw (rad): R = Rz(yaw)·Ry(pitch)·Rx(roll).
    pub fn set_pose(&mut self, pose: [f32; 6]) {
        let [_, _, _, roll, pitch, yaw] = pose;
        let (sr, cr) = (roll.sin(), roll.cos());
        let (sp, cp) = (pitch.sin(), pitch.cos());
        let (sy, cy) = (yaw.sin(), yaw.cos());
        self.rot = [
            [cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
            [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
            [-sp, cp * sr, cp * cr],
        ];
        self.pose = pose;
    }

    fn sweep_turned(&mut self) -> bool {
        let now = self.actuator;
        let Some(last) = self.last_actuator.replace(now) else {
            return false;
        };
        #[allow(clippy::cast_possible_wrap)]
        let direction = (now.wrapping_sub(last) as i16).signum() as i8;
        if direction == 0 {
            return false;
        }
        let turned = self.direction != 0 && direction != self.direction;
        self.direction = direction;
        turned
    }

    /// Feeds one line (a full scan or an interlaced partial scan of the variant).
    pub fn line<const W: usize, const L: usize>(
        &mut self,
        pyramid: &mut Pyramid<W, L>,
        values: &MeasuredValues<'_>,
    ) {
        let count = usize::from(values.count());
        let partial = if count == self.variant.beam_count() && values.partial_index() == 0 {
            None
        } else if count == self.variant.sweep_count() {
            Some(values.partial_index())
        } else {
            return;
        };
        self.lines = self.lines.saturating_add(1);
        if self.config.lines_per_observation == 0 && self.sweep_turned() {
            self.end_observation(pyramid);
        }
        // The line's transform: world = T + R·(p + r·(s·a + c·b)).
        let angle = f32::from(self.actuator) * (core::f32::consts::TAU / 65536.0);
        let (sa, ca) = (angle.sin(), angle.cos());
        let r = &self.rot;
        let col = |j: usize| [r[0][j], r[1][j], r[2][j]];
        let (r0, r1, r2) = (col(0), col(1), col(2));
        // This comparison pipeline models the two preset mounts (what the benchmarks run).
        let (col_c, aux, sign) = match self.config.mount.preset() {
            Some(ScanPlane::PannedVertical) => (r2, r1, 1.0),
            _ => (r1, r2, -1.0),
        };
        let mm = 0.001_f32;
        let kc = [-col_c[0] * mm, -col_c[1] * mm, -col_c[2] * mm];
        let ks = [
            (ca * r0[0] + sign * sa * aux[0]) * mm,
            (ca * r0[1] + sign * sa * aux[1]) * mm,
            (ca * r0[2] + sign * sa * aux[2]) * mm,
        ];
        let [px, py, pz] = self.sensor;
        let o = [
            self.pose[0] + r0[0] * px + r1[0] * py + r2[0] * pz,
            self.pose[1] + r0[1] * px + r1[1] * py + r2[1] * pz,
            self.pose[2] + r0[2] * px + r1[2] * py + r2[2] * pz,
        ];
        if self.lines_in_observation == 0 {
            self.discard();
            self.reference_z = o[2];
        }
        for (j, range) in values.ranges_mm(self.config.measuring_mode).enumerate() {
            let Some(range) = range else {
                continue;
            };
            self.returns = self.returns.wrapping_add(1);
            let beam = match partial {
                None => Some(j),
                Some(p) => self.variant.partial_scan_beam(p, j),
            };
            let Some(&(c, s)) = beam.and_then(|b| self.beams.get(b)) else {
                continue;
            };
            if range > MAX_RANGE_MM {
                continue;
            }
            #[allow(clippy::cast_precision_loss)]
            let r = range as f32;
            let (rc, rs) = (r * c, r * s);
            let dx = kc[0] * rc + ks[0] * rs;
            let dy = kc[1] * rc + ks[1] * rs;
            let dz = kc[2] * rc + ks[2] * rs;
            let distance = sqrt(dx * dx + dy * dy);
            let (x, y, z) = (o[0] + dx, o[1] + dy, o[2] + dz - self.reference_z);
            // The rule chosen once per point, so that the spread rule's code has no plane in it.
            if self.plane.is_some() {
                self.add_point::<true, W, L>(pyramid, x, y, z, distance);
            } else {
                self.add_point::<false, W, L>(pyramid, x, y, z, distance);
            }
        }
        self.lines_in_observation += 1;
        let per = self.config.lines_per_observation;
        if per != 0 && self.lines_in_observation >= per {
            self.end_observation(pyramid);
        }
    }

    #[inline]
    fn add_point<const PLANE: bool, const W: usize, const L: usize>(
        &mut self,
        pyramid: &Pyramid<W, L>,
        x: f32,
        y: f32,
        z: f32,
        distance: f32,
    ) {
        let bin = pyramid.bin(distance);
        for k in 0..pyramid.count.min(L) {
            let (Some(gate), Some(layer)) = (pyramid.gates.get(k), pyramid.layers.get(k)) else {
                break;
            };
            if gate.get(bin).copied().unwrap_or(0.0) == 0.0 {
                continue;
            }
            let (fx, fy) = (x * layer.inv_res, y * layer.inv_res);
            let (cx, cy) = (floor_i32(fx), floor_i32(fy));
            // The position in the cell, 1/64 cell from its centre (the plane rule's only).
            #[allow(clippy::cast_precision_loss)]
            let (u, v) = if PLANE {
                (
                    (fx - cx as f32) * 64.0 - 32.0,
                    (fy - cy as f32) * 64.0 - 32.0,
                )
            } else {
                (0.0, 0.0)
            };
            // The pair test's slope: the largest slope's rise per unit of position, mm.
            let slope = self.plane.as_ref().map_or(0.0, |p| p.grade * layer.unit_mm);
            #[allow(clippy::cast_possible_truncation)]
            self.accumulate::<PLANE>(k as u8, cx, cy, distance, z, (u, v), slope);
        }
    }

    #[inline]
    #[allow(clippy::too_many_arguments)]
    fn accumulate<const PLANE: bool>(
        &mut self,
        layer: u8,
        cx: i32,
        cy: i32,
        distance: f32,
        z: f32,
        uv: (f32, f32),
        slope: f32,
    ) {
        let plane = PLANE;
        let mask = C - 1;
        let mut index = hash(layer, cx, cy) as usize & mask;
        for _ in 0..C {
            let Some(slot) = self.slots.get_mut(index) else {
                return;
            };
            if slot.layer == EMPTY {
                let Some(o) = self.order.get_mut(self.used) else {
                    return;
                };
                #[allow(clippy::cast_possible_truncation)]
                {
                    *o = index as u16;
                }
                self.used += 1;
                *slot = Slot {
                    cell_x: cx,
                    cell_y: cy,
                    distance,
                    z_low: z,
                    z_high: z,
                    layer,
                };
                if plane {
                    if let Some(sums) = self.sums.get_mut(index) {
                        *sums = Sums::first(uv.0, uv.1, z);
                    }
                }
                return;
            }
            if slot.layer == layer && slot.cell_x == cx && slot.cell_y == cy {
                if distance < slot.distance {
                    slot.distance = distance;
                }
                let h = self.robot_height;
                let step_mm = self.step * 1000.0;
                let sums = if plane {
                    self.sums.get_mut(index)
                } else {
                    None
                };
                if z < slot.z_low {
                    let cut = z + h;
                    if slot.z_high > cut {
                        let low_stays = slot.z_low <= cut;
                        slot.z_high = if low_stays { slot.z_low } else { z };
                        if let Some(sums) = sums {
                            // The summed points lie above the cut now: restart from this
                            // point and, when still below it, the previous lowest.
                            let previous_low_at = sums.low_at;
                            *sums = Sums::first(uv.0, uv.1, z);
                            if low_stays {
                                sums.add(previous_low_at.0, previous_low_at.1, slot.z_low);
                                sums.high_at = previous_low_at;
                            }
                        }
                    } else if let Some(sums) = sums {
                        sums.step(uv.0, uv.1, z, slope, step_mm);
                        sums.add(uv.0, uv.1, z);
                        sums.low_at = uv;
                    }
                    slot.z_low = z;
                } else if z <= slot.z_low + h {
                    let higher = z > slot.z_high;
                    if higher {
                        slot.z_high = z;
                    }
                    if let Some(sums) = sums {
                        sums.step(uv.0, uv.1, z, slope, step_mm);
                        sums.add(uv.0, uv.1, z);
                        if higher {
                            sums.high_at = uv;
                        }
                    }
                }
                return;
            }
            index = (index + 1) & mask;
        }
    }

    /// The slot of `(layer, cx, cy)` if the observation touched that cell.
    fn find(&self, layer: u8, cx: i32, cy: i32) -> Option<usize> {
        let mask = C - 1;
        let mut index = hash(layer, cx, cy) as usize & mask;
        for _ in 0..C {
            let slot = self.slots.get(index)?;
            if slot.layer == EMPTY {
                return None;
            }
            if slot.layer == layer && slot.cell_x == cx && slot.cell_y == cy {
                return Some(index);
            }
            index = (index + 1) & mask;
        }
        None
    }

    /// The step between neighbouring cells' lowest points (`docs/core.md`): each cell's
    /// lowest point paired with those of its east and north neighbours in the same layer;
    /// a rise beyond the step and at most the robot's height gives the upper cell the step
    /// the pair shows over its run. Plane rule only (nothing to do under the spread rule).
    fn steps_between_cells<const W: usize, const L: usize>(&mut self, pyramid: &Pyramid<W, L>) {
        let Some(plane) = self.plane else {
            return;
        };
        let step_mm = self.step * 1000.0;
        for n in 0..self.used {
            let Some(&a) = self.order.get(n) else {
                break;
            };
            let a = usize::from(a);
            let Some(&cell) = self.slots.get(a) else {
                continue;
            };
            let unit_mm = pyramid
                .layers
                .get(usize::from(cell.layer))
                .map_or(0.0, |l| l.unit_mm);
            for (dx, dy) in [(1, 0), (0, 1)] {
                let Some(b) = self.find(cell.layer, cell.cell_x + dx, cell.cell_y + dy) else {
                    continue;
                };
                let Some(&beside) = self.slots.get(b) else {
                    continue;
                };
                let rise_m = beside.z_low - cell.z_low;
                let rise = rise_m.abs() * 1000.0;
                if rise <= step_mm || rise_m.abs() > self.robot_height {
                    continue;
                }
                let (Some(from), Some(to)) = (self.sums.get(a), self.sums.get(b)) else {
                    continue;
                };
                #[allow(clippy::cast_precision_loss)]
                let run = (to.low_at.0 + 64.0 * dx as f32 - from.low_at.0).abs()
                    + (to.low_at.1 + 64.0 * dy as f32 - from.low_at.1).abs();
                let shown = shown(rise, run, plane.grade * unit_mm, step_mm);
                let upper = if rise_m > 0.0 { b } else { a };
                if let Some(sums) = self.sums.get_mut(upper) {
                    sums.keep(shown);
                }
            }
        }
    }

    fn discard(&mut self) {
        for &i in self.order.iter().take(self.used) {
            if let Some(s) = self.slots.get_mut(usize::from(i)) {
                *s = Slot::VACANT;
            }
        }
        self.used = 0;
    }

    /// Ends the observation: recentres on the robot and applies the evidence.
    pub fn end_observation<const W: usize, const L: usize>(&mut self, pyramid: &mut Pyramid<W, L>) {
        if self.lines_in_observation == 0 {
            return;
        }
        pyramid.recentre(self.pose[0], self.pose[1]);
        self.steps_between_cells(pyramid);
        let (obstacle, free, initial, min, max) = (
            pyramid.obstacle,
            pyramid.free,
            pyramid.initial,
            pyramid.min,
            pyramid.max,
        );
        for &i in self.order.iter().take(self.used) {
            let Some(slot) = self.slots.get_mut(usize::from(i)) else {
                continue;
            };
            let k = usize::from(slot.layer);
            let spread = slot.z_high - slot.z_low;
            let is_obstacle = match &self.plane {
                // A pair beside the cell may mark a cell whose own points lie flat: its step
                // is read before the quick answer.
                Some(p)
                    if spread * 1000.0 <= p.quick_mm
                        && self.sums.get(usize::from(i)).map_or(0.0, |s| s.pair_rise)
                            <= p.step_mm =>
                {
                    false
                }
                Some(p) => {
                    let cell = pyramid.layers.get(k).map_or(1.0, |l| 1000.0 / l.inv_res);
                    p.obstacle(
                        self.sums.get(usize::from(i)).unwrap_or(&Sums::ZERO),
                        (self.reference_z - self.pose[2]) * 1000.0,
                        slot.distance * 1000.0,
                        cell,
                        spread * 1000.0,
                    )
                }
                None => spread > self.step,
            };
            let l = if is_obstacle { obstacle } else { free };
            let bin = pyramid.bin(slot.distance);
            let w = pyramid
                .gates
                .get(k)
                .and_then(|g| g.get(bin))
                .copied()
                .unwrap_or(0.0);
            let g = l * w;
            if g != 0.0 {
                let reach = if g < 0.0 { min * w } else { max * w };
                if let Some(layer) = pyramid.layers.get_mut(k) {
                    layer.update(slot.cell_x, slot.cell_y, g, reach, initial, min, max);
                }
            }
            *slot = Slot::VACANT;
        }
        self.used = 0;
        self.lines_in_observation = 0;
    }
}
