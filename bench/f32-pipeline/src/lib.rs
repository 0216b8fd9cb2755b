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
//!   z-interval fold (robot height) and step rule, heights and distances in `f32` metres;
//!   cells by `floor(x · 1/r)`.
//! - Gate: per layer a 512-bin `f32` table (the library's table widened; a weight whose
//!   gated increments would both round to zero in Q8.8 is 0 here too, so the same layers are
//!   fed), binned as the library bins.
//! - Pyramid: per layer a W × W circular window of `f32` log-odds (NaN = unknown), the same
//!   recentring and row/column resets, clamping to OctoMap's −2 ..= 3.5, dirty tiles.
//!
//! It is not bit-identical to the fixed pipeline (nor meant to be); it does the same work.
#![no_std]
#![deny(missing_docs)]

use micromath::F32Ext;
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

/// One layer: a circular window of f32 log-odds, NaN = unknown.
pub struct Layer<const W: usize> {
    cells: [[f32; W]; W],
    origin_x: i32,
    origin_y: i32,
    start_x: usize,
    start_y: usize,
    inv_res: f32,
    dirty: u64,
}

impl<const W: usize> Layer<W> {
    const fn new() -> Self {
        Self {
            cells: [[f32::NAN; W]; W],
            origin_x: 0,
            origin_y: 0,
            start_x: 0,
            start_y: 0,
            inv_res: 1.0,
            dirty: 0,
        }
    }

    #[inline]
    fn slot(start: usize, offset: usize) -> usize {
        let s = start + offset;
        if s >= W {
            s - W
        } else {
            s
        }
    }

    #[inline]
    fn update(&mut self, i: i32, j: i32, g: f32, initial: f32, min: f32, max: f32) {
        #[allow(clippy::cast_sign_loss)]
        let (ox, oy) = (
            i.wrapping_sub(self.origin_x) as u32 as usize,
            j.wrapping_sub(self.origin_y) as u32 as usize,
        );
        if ox >= W || oy >= W {
            return;
        }
        let (col, row) = (Self::slot(self.start_x, ox), Self::slot(self.start_y, oy));
        if let Some(cell) = self.cells.get_mut(row).and_then(|r| r.get_mut(col)) {
            let start = if cell.is_nan() { initial } else { *cell };
            // Comparisons, not `f32::clamp`/`min`/`max`: those are `fminf`/`fmaxf` calls on an
            // FPv4 (NaN rules), and no value here is NaN.
            let sum = start + g;
            let new = if sum < min {
                min
            } else if sum > max {
                max
            } else {
                sum
            };
            if new != *cell {
                *cell = new;
                let tile = (row * TILES_PER_SIDE / W) * TILES_PER_SIDE + col * TILES_PER_SIDE / W;
                self.dirty |= 1 << (tile & 63);
            }
        }
    }

    /// Moves the origin to world cell (nx, ny), resetting what enters; returns cells reset.
    fn move_origin(&mut self, nx: i32, ny: i32) -> usize {
        let w = W as i64;
        let (dx, dy) = (
            i64::from(nx) - i64::from(self.origin_x),
            i64::from(ny) - i64::from(self.origin_y),
        );
        let reset = if dx.abs() >= w || dy.abs() >= w {
            for row in &mut self.cells {
                row.fill(f32::NAN);
            }
            W * W
        } else {
            let mut n = 0;
            #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
            if dy != 0 {
                let count = dy.unsigned_abs() as usize;
                let first = if dy > 0 {
                    self.start_y
                } else {
                    Self::slot(self.start_y, W - count)
                };
                for t in 0..count {
                    if let Some(row) = self.cells.get_mut(Self::slot(first, t)) {
                        row.fill(f32::NAN);
                    }
                }
                n += count * W;
            }
            #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
            if dx != 0 {
                let count = dx.unsigned_abs() as usize;
                let first = if dx > 0 {
                    self.start_x
                } else {
                    Self::slot(self.start_x, W - count)
                };
                for row in &mut self.cells {
                    for t in 0..count {
                        if let Some(c) = row.get_mut(Self::slot(first, t)) {
                            *c = f32::NAN;
                        }
                    }
                }
                n += count * (W - dy.unsigned_abs() as usize);
            }
            n
        };
        self.origin_x = nx;
        self.origin_y = ny;
        #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
        {
            self.start_x = i64::from(nx).rem_euclid(w) as usize;
            self.start_y = i64::from(ny).rem_euclid(w) as usize;
        }
        reset
    }
}

/// The f32 pyramid: L layers of W × W cells and their gate tables.
pub struct Pyramid<const W: usize, const L: usize> {
    layers: [Layer<W>; L],
    gates: [[f32; GATE_BINS]; L],
    count: usize,
    bins_per_m: f32,
    obstacle: f32,
    free: f32,
    initial: f32,
    min: f32,
    max: f32,
    /// Cells reset by window moves.
    pub cells_reset: u32,
}

impl<const W: usize, const L: usize> Pyramid<W, L> {
    /// An unconfigured pyramid (no layers). `const`, for a `static`.
    #[must_use]
    pub const fn new() -> Self {
        Self {
            layers: [const { Layer::new() }; L],
            gates: [[0.0; GATE_BINS]; L],
            count: 0,
            bins_per_m: 1.0,
            obstacle: 0.0,
            free: 0.0,
            initial: 0.0,
            min: -2.0,
            max: 3.5,
            cells_reset: 0,
        }
    }

    /// Configures the layers and gates from the library's design (configuration time).
    ///
    /// # Errors
    /// The design or configuration the library refuses.
    pub fn configure(&mut self, design: &Design<L>, config: &Config) -> Result<(), DesignError> {
        let increments = config.model.increments()?;
        let bins = DistanceBins::for_range(design.sensor().max_range_m);
        self.bins_per_m = 1.0 / bins.width_m();
        self.obstacle = increments.obstacle.to_num();
        self.free = increments.free.to_num();
        self.initial = increments.initial.to_num();
        if let terrain_pyramid::Clamp::Bounds { min, max } = config.clamp {
            self.min = min.to_num();
            self.max = max.to_num();
        } else {
            self.min = -128.0;
            self.max = 128.0;
        }
        self.count = design.layers().len();
        for (k, ((layer, gate), d)) in self
            .layers
            .iter_mut()
            .zip(self.gates.iter_mut())
            .zip(design.layers())
            .enumerate()
        {
            *layer = Layer::new();
            layer.inv_res = 1.0 / d.resolution_m;
            let table = GateTable::build(design, k, bins);
            for (w, q) in gate.iter_mut().zip(table.weights()) {
                let skip = gated(increments.obstacle, *q) == 0 && gated(increments.free, *q) == 0;
                *w = if skip { 0.0 } else { q.to_num() };
            }
            let _ = layer.move_origin(-(W as i32) / 2, -(W as i32) / 2);
        }
        Ok(())
    }

    #[inline]
    #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
    fn bin(&self, distance: f32) -> usize {
        let d = if distance > 0.0 { distance } else { 0.0 };
        let b = (d * self.bins_per_m) as usize;
        b.min(GATE_BINS - 1)
    }

    /// Recentres every layer on the robot at (x, y); returns cells reset.
    pub fn recentre(&mut self, x: f32, y: f32) -> usize {
        let mut reset = 0;
        for layer in self.layers.iter_mut().take(self.count) {
            let half = (W / 2) as i32;
            let nx = floor_i32(x * layer.inv_res) - half;
            let ny = floor_i32(y * layer.inv_res) - half;
            reset += layer.move_origin(nx, ny);
        }
        self.cells_reset = self
            .cells_reset
            .saturating_add(u32::try_from(reset).unwrap_or(u32::MAX));
        reset
    }

    /// The log-odds of world cell (i, j) of layer k; `None` when unknown or outside.
    #[must_use]
    pub fn get(&self, k: usize, i: i32, j: i32) -> Option<f32> {
        let layer = self.layers.get(k)?;
        let ox = usize::try_from(i.checked_sub(layer.origin_x)?)
            .ok()
            .filter(|&o| o < W)?;
        let oy = usize::try_from(j.checked_sub(layer.origin_y)?)
            .ok()
            .filter(|&o| o < W)?;
        let v = *layer
            .cells
            .get(Layer::<W>::slot(layer.start_y, oy))?
            .get(Layer::<W>::slot(layer.start_x, ox))?;
        (!v.is_nan()).then_some(v)
    }
}

impl<const W: usize, const L: usize> Default for Pyramid<W, L> {
    fn default() -> Self {
        Self::new()
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
    order: [u16; C],
    used: usize,
    reference_z: f32,
    robot_height: f32,
    step: f32,
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
            order: [0; C],
            used: 0,
            reference_z: 0.0,
            robot_height: config.classifier.robot_height.to_num(),
            step: config.classifier.step_threshold.to_num(),
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
        let (col_c, aux, sign) = match self.config.mount.plane {
            ScanPlane::PannedVertical => (r2, r1, 1.0),
            ScanPlane::TiltedHorizontal => (r1, r2, -1.0),
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
            self.add_point(pyramid, x, y, z, distance);
        }
        self.lines_in_observation += 1;
        let per = self.config.lines_per_observation;
        if per != 0 && self.lines_in_observation >= per {
            self.end_observation(pyramid);
        }
    }

    #[inline]
    fn add_point<const W: usize, const L: usize>(
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
            let (cx, cy) = (floor_i32(x * layer.inv_res), floor_i32(y * layer.inv_res));
            #[allow(clippy::cast_possible_truncation)]
            self.accumulate(k as u8, cx, cy, distance, z);
        }
    }

    #[inline]
    fn accumulate(&mut self, layer: u8, cx: i32, cy: i32, distance: f32, z: f32) {
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
                return;
            }
            if slot.layer == layer && slot.cell_x == cx && slot.cell_y == cy {
                if distance < slot.distance {
                    slot.distance = distance;
                }
                let h = self.robot_height;
                if z < slot.z_low {
                    let cut = z + h;
                    if slot.z_high > cut {
                        slot.z_high = if slot.z_low <= cut { slot.z_low } else { z };
                    }
                    slot.z_low = z;
                } else if z <= slot.z_low + h && z > slot.z_high {
                    slot.z_high = z;
                }
                return;
            }
            index = (index + 1) & mask;
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
            let l = if slot.z_high - slot.z_low > self.step {
                obstacle
            } else {
                free
            };
            let bin = pyramid.bin(slot.distance);
            let w = pyramid
                .gates
                .get(k)
                .and_then(|g| g.get(bin))
                .copied()
                .unwrap_or(0.0);
            let g = l * w;
            if g != 0.0 {
                if let Some(layer) = pyramid.layers.get_mut(k) {
                    layer.update(slot.cell_x, slot.cell_y, g, initial, min, max);
                }
            }
            *slot = Slot::VACANT;
        }
        self.used = 0;
        self.lines_in_observation = 0;
    }
}
