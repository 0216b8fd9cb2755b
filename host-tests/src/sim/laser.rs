//! The sensor: a SICK LMS2xx on a pan or tilt actuator, ray-cast into a [`Scene`], its lines
//! encoded as real measured-values telegrams (reply 0xB0).
//!
//! # Geometry (the library's conventions, `terrain_pyramid::geometry`)
//! Beam k lies at `θ_k = θ_0 + k·Δθ` (0° = the scanner's right, 90° ahead, 180° its left;
//! θ_0 = 0° in the 180° field, 40° in the 100° field). Its direction in the robot frame:
//! - panned vertical plane (the paper's robot), pan p: `(sin θ cos p, sin θ sin p, −cos θ)`;
//! - tilted horizontal plane, tilt τ (positive looks down): `(sin θ cos τ, −cos θ, −sin θ sin τ)`.
//!
//! The scan centre sits at [`LaserConfig::position_m`] in the robot frame; the robot's pose
//! takes both to the world.
//!
//! # Timing
//! The LMS2xx mirror turns at 75 Hz. A 1° scan is one turn: **75 lines/s**. A 0.5° scan is two
//! interlaced 1° turns and a 0.25° scan (100° field only) four; the simulator sends each as
//! one **full-scan telegram** (361 / 201 / 401 values, partial-scan index 0) at **37.5 and
//! 18.75 lines/s**, never interlaced partial scans. The actuator angle is taken as constant
//! during a line (a documented simplification: a real pan moves ψ = 2° during the 27 ms of a
//! 0.5° scan with the default sweep), and it is the angle the recording's angle event
//! carries, quantised to 2⁻¹⁶ turn: the ray cast uses exactly what a reader will see.
//!
//! # Ranges
//! The true range (scan centre to the first surface) gets Gaussian noise of σ
//! ([`LaserConfig::sigma_m`]) and is rounded to the unit (mm or cm). A beam that meets nothing
//! within the maximum range ([`LaserConfig::max_range_m`], at most the mode's largest value:
//! 8.191 m in mm and 81.91 m in cm in the default measuring mode) and a value that rounds to
//! the mode's all-ones distance or beyond carry "no echo": the all-ones distance (0x1FFF in the
//! default mode) with no flag bit. A negative noisy range is sent as 0. In the default mode
//! (`MeasuringMode::Mm8Cm80`, mask 0x1FFF) every return has bit 13 set, as real captures do;
//! the decoder masks it off. Other modes carry no flag bits.

use super::rng::Rng;
use super::scene::{Ray, Scene};
use super::trajectory::Pose;
use std::collections::HashMap;
use terrain_pyramid::wire::recording::MountKind;
use terrain_pyramid::wire::sick::Variant;
use terrain_pyramid::wire::sick::{MeasuredValues, MeasuringMode, Unit};

/// The flag bit real captures carry on ordinary returns in the 8 m / 80 m modes.
pub const RETURN_FLAG: u16 = 1 << 13;

/// The LMS2xx mirror's rate: 1° lines per second.
pub const MIRROR_HZ: f64 = 75.0;

/// The actuator that sweeps the scan plane, and how.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Actuator {
    /// The paper's mount: a vertical scan plane panned about z, back and forth over
    /// `[−half_width, +half_width]` at a constant angular rate, starting at `−half_width`.
    Pan {
        /// Half the sweep, degrees, > 0 and < 180. Default 45°.
        half_width_deg: f64,
        /// Angular rate, degrees per second, > 0. Default 75°/s: ψ = 2° between 0.5° lines
        /// (37.5 lines/s), the paper's Figure 2.
        rate_deg_s: f64,
    },
    /// A horizontal scan plane tilted about y (positive looks down), back and forth over
    /// `[min, max]` at a constant rate, starting at `min`.
    Tilt {
        /// The lowest tilt (most upward), degrees, > −90. Default −5°.
        min_deg: f64,
        /// The highest tilt (most downward), degrees, > `min_deg` and < 90. Default 40°.
        max_deg: f64,
        /// Angular rate, degrees per second, > 0. Default 45°/s.
        rate_deg_s: f64,
    },
}

impl Actuator {
    /// The paper's pan sweep: ±45° at 75°/s.
    pub const PAPER_PAN: Self = Self::Pan {
        half_width_deg: 45.0,
        rate_deg_s: 75.0,
    };

    /// The default tilt sweep: −5° ..= 40° at 45°/s.
    pub const DEFAULT_TILT: Self = Self::Tilt {
        min_deg: -5.0,
        max_deg: 40.0,
        rate_deg_s: 45.0,
    };

    /// The mount a recording's setup names for this actuator.
    #[must_use]
    pub const fn mount_kind(&self) -> MountKind {
        match self {
            Self::Pan { .. } => MountKind::PannedVertical,
            Self::Tilt { .. } => MountKind::TiltedHorizontal,
        }
    }

    /// The sweep's range and rate: (min, max, rate), degrees and degrees per second.
    const fn sweep(&self) -> (f64, f64, f64) {
        match *self {
            Self::Pan {
                half_width_deg,
                rate_deg_s,
            } => (-half_width_deg, half_width_deg, rate_deg_s),
            Self::Tilt {
                min_deg,
                max_deg,
                rate_deg_s,
            } => (min_deg, max_deg, rate_deg_s),
        }
    }

    /// The actuator angle at `t_s` seconds, degrees: a triangle wave from the minimum up to
    /// the maximum and back, period `2·(max − min)/rate`.
    #[must_use]
    pub fn angle_deg(&self, t_s: f64) -> f64 {
        let (lo, hi, rate) = self.sweep();
        let width = hi - lo;
        let s = (rate * t_s).rem_euclid(2.0 * width);
        lo + if s <= width { s } else { 2.0 * width - s }
    }

    /// Seconds of one full sweep (from the minimum to the maximum and back).
    #[must_use]
    pub fn period_s(&self) -> f64 {
        let (lo, hi, rate) = self.sweep();
        2.0 * (hi - lo) / rate
    }
}

/// An angle in degrees as the recording's angle event carries it: a fraction of a turn in
/// 2⁻¹⁶ turns, rounded to nearest, wrapping (−45° is 57 344).
#[must_use]
pub fn angle_to_u16(deg: f64) -> u16 {
    // rem_euclid leaves 0 ..= 65 536 (the upper end by rounding), which the mask wraps.
    #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
    let v = (deg / 360.0 * 65_536.0).round().rem_euclid(65_536.0) as u32;
    #[allow(clippy::cast_possible_truncation)]
    let bits = (v & 0xFFFF) as u16;
    bits
}

/// The angle of a recording's angle event, degrees in `(−180, 180]`.
#[must_use]
pub fn u16_to_angle_deg(bits: u16) -> f64 {
    let deg = f64::from(bits) * 360.0 / 65_536.0;
    if deg > 180.0 {
        deg - 360.0
    } else {
        deg
    }
}

/// The 0x77 measuring-mode code of the setup event for a mode class (the first code of the
/// class: 0x00, 0x03, 0x05, 0x0F).
#[must_use]
pub const fn measuring_mode_code(mode: MeasuringMode) -> u8 {
    match mode {
        MeasuringMode::Mm8Cm80 => 0x00,
        MeasuringMode::Range16m => 0x03,
        MeasuringMode::Range32m => 0x05,
        MeasuringMode::Range32mNoFlags => 0x0F,
    }
}

/// The simulated laser's configuration.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LaserConfig {
    /// The actuator and its sweep (which also fixes the mount). Default: the paper's pan.
    pub actuator: Actuator,
    /// The scan centre in the robot frame, metres (x forward, y left, z up above the ground
    /// contact). Default (0, 0, 1.0): the paper's robot, h = 1.0 m.
    pub position_m: [f64; 3],
    /// The field and angular resolution. Default 180° at 0.5° (361 beams).
    pub variant: Variant,
    /// The unit of the values. Default millimetres.
    pub unit: Unit,
    /// The measuring mode (the distance mask and the flag bits). Default `Mm8Cm80`.
    pub mode: MeasuringMode,
    /// The standard deviation of the range noise, metres, ≥ 0. Default 0.01 m.
    pub sigma_m: f64,
    /// The maximum range, metres, > 0; `None` (the default) for the largest the mode and
    /// unit can carry (8.191 m in mm, 81.91 m in cm, in the default mode). A larger value is
    /// reduced to that limit.
    pub max_range_m: Option<f64>,
    /// The status byte of every telegram. Default 0.
    pub status: u8,
}

impl Default for LaserConfig {
    fn default() -> Self {
        Self::paper()
    }
}

impl LaserConfig {
    /// The paper's robot: a vertical scan plane at h = 1.0 m, panned ±45° at 75°/s, 180° at
    /// 0.5°, mm, σ = 1 cm.
    #[must_use]
    pub const fn paper() -> Self {
        Self {
            actuator: Actuator::PAPER_PAN,
            position_m: [0.0, 0.0, 1.0],
            variant: Variant::Fov180StepHalf,
            unit: Unit::Millimetre,
            mode: MeasuringMode::Mm8Cm80,
            sigma_m: 0.01,
            max_range_m: None,
            status: 0,
        }
    }

    /// A horizontal scan plane at h = 1.0 m, tilted over the default sweep, otherwise as
    /// [`paper`](Self::paper).
    #[must_use]
    pub const fn tilted() -> Self {
        Self {
            actuator: Actuator::DEFAULT_TILT,
            ..Self::paper()
        }
    }

    /// Lines per second: 75 at 1°, 37.5 at 0.5°, 18.75 at 0.25° (full scans).
    #[must_use]
    pub fn line_rate_hz(&self) -> f64 {
        MIRROR_HZ * f64::from(self.variant.step_quarter_degrees()) / 4.0
    }

    /// The largest range the mode and unit carry, metres: the all-ones distance times the
    /// unit (8.191 m for mm in the default mode).
    #[must_use]
    pub fn encodable_range_m(&self) -> f64 {
        f64::from(self.mode.distance_mask()) * f64::from(self.unit.millimetres()) / 1000.0
    }

    /// The maximum range in force, metres.
    #[must_use]
    pub fn max_range(&self) -> f64 {
        let limit = self.encodable_range_m();
        self.max_range_m.map_or(limit, |m| m.min(limit))
    }

    /// The beam angles θ_k, radians.
    #[must_use]
    pub fn beam_angles_rad(&self) -> Vec<f64> {
        (0..self.variant.beam_count())
            .filter_map(|k| self.variant.beam_quarter_degrees(k))
            .map(|q| (f64::from(q) / 4.0).to_radians())
            .collect()
    }

    /// When each beam of a full line is measured, seconds after the line's first beam, from
    /// the scanner's mirror (`docs/lidars.md`, "When a SICK beam was measured"): the mirror
    /// turns at [`MIRROR_HZ`] and sweeps the field once a turn, first beam first, so beam θ
    /// of a turn is measured `(θ − θ₀)/360°` of a turn after θ₀ passes; an interlaced line
    /// (0.5°, 0.25°) measures one 1°-spaced phase a turn, the phase offset 0 first, so a beam
    /// offset `o` (0, 0.25°, 0.5°, 0.75°) from the 1° grid is measured `o / step` turns later
    /// (besides its own angle's share of the turn). Indexed like [`Self::beam_angles_rad`].
    #[must_use]
    pub fn beam_offsets_s(&self) -> Vec<f64> {
        let turn_s = 1.0 / MIRROR_HZ;
        let step = self.variant.step_quarter_degrees();
        let first = self.variant.first_quarter_degrees();
        (0..self.variant.beam_count())
            .filter_map(|k| self.variant.beam_quarter_degrees(k))
            .map(|q| {
                let from_first = q - first;
                let phase = (from_first % 4) / step.max(1);
                turn_s * (f64::from(phase) + f64::from(from_first) / 4.0 / 360.0)
            })
            .collect()
    }

    /// Checks the fields' bounds.
    ///
    /// # Errors
    /// A message naming the first field out of bounds.
    pub fn validate(&self) -> Result<(), String> {
        let (lo, hi, rate) = self.actuator.sweep();
        let sweep_ok = match self.actuator {
            Actuator::Pan { .. } => hi > 0.0 && hi < 180.0,
            Actuator::Tilt { .. } => lo > -90.0 && hi < 90.0 && hi > lo,
        };
        if !(sweep_ok && rate > 0.0 && rate.is_finite()) {
            return Err("laser: the actuator's sweep or rate is out of bounds".into());
        }
        if !self.position_m.iter().all(|v| v.is_finite()) {
            return Err("laser: the position must be finite".into());
        }
        if !(self.sigma_m >= 0.0 && self.sigma_m.is_finite()) {
            return Err("laser: σ must be ≥ 0".into());
        }
        if self.max_range_m.is_some_and(|m| m.is_nan() || m <= 0.0) {
            return Err("laser: the maximum range must be > 0".into());
        }
        Ok(())
    }
}

/// One simulated scan line.
#[derive(Debug, Clone, PartialEq)]
pub struct ScanLine {
    /// The raw values, one per beam, flag bits included, as the telegram carries them.
    pub raw: Vec<u16>,
    /// The true (noise-free) range of each beam, metres, or `None` for no echo.
    pub true_ranges_m: Vec<Option<f64>>,
}

impl ScanLine {
    /// The values as u16 LE pairs, as on the wire.
    #[must_use]
    pub fn values_le(&self) -> Vec<u8> {
        self.raw.iter().flat_map(|v| v.to_le_bytes()).collect()
    }
}

/// The simulated laser: a configuration, its beam table, and the noise generator.
///
/// The true ranges of the lines scanned from the current pose are kept by actuator angle, so
/// a robot standing still (whose sweep repeats the same angles) pays for the ray cast once
/// per angle; the noise is drawn afresh for every line.
#[derive(Debug, Clone)]
pub struct Laser {
    config: LaserConfig,
    /// (sin θ, cos θ) per beam.
    beams: Vec<(f64, f64)>,
    rng: Rng,
    /// The pose the cache holds lines for.
    cached_pose: Option<Pose>,
    /// True ranges by actuator angle, for `cached_pose`.
    cache: HashMap<u16, Vec<Option<f64>>>,
}

impl Laser {
    /// A laser with `config`, its noise drawn from a generator seeded with `seed`.
    #[must_use]
    pub fn new(config: LaserConfig, seed: u64) -> Self {
        let beams = config
            .beam_angles_rad()
            .into_iter()
            .map(f64::sin_cos)
            .collect();
        Self {
            config,
            beams,
            rng: Rng::new(seed),
            cached_pose: None,
            cache: HashMap::new(),
        }
    }

    /// The configuration.
    #[must_use]
    pub const fn config(&self) -> &LaserConfig {
        &self.config
    }

    /// The ray of every beam for a robot at `pose` with the actuator at `angle` (the
    /// recording's 2⁻¹⁶-turn value), world frame.
    #[must_use]
    pub fn rays(&self, pose: &Pose, angle: u16) -> Vec<Ray> {
        let a = u16_to_angle_deg(angle).to_radians();
        self.beams
            .iter()
            .map(|&beam| self.ray(beam, pose, a))
            .collect()
    }

    /// The ray of the beam of (sin θ, cos θ) `beam` from a robot at `pose` with the actuator
    /// at `actuator_rad`, world frame.
    fn ray(&self, (s, c): (f64, f64), pose: &Pose, actuator_rad: f64) -> Ray {
        let (sa, ca) = actuator_rad.sin_cos();
        let r = pose.rotation();
        let origin = pose.to_world(self.config.position_m);
        let d = match self.config.actuator {
            Actuator::Pan { .. } => [s * ca, s * sa, -c],
            Actuator::Tilt { .. } => [s * ca, -c, -s * sa],
        };
        let dir = core::array::from_fn(|i| r[i][0] * d[0] + r[i][1] * d[1] + r[i][2] * d[2]);
        Ray { origin, dir }
    }

    /// The true range of every beam (scan centre to the first surface, metres; `None`
    /// beyond the maximum range or when nothing is hit) for a robot at `pose` with the
    /// actuator at `angle` (2⁻¹⁶ turn).
    #[must_use]
    pub fn true_ranges(&self, scene: &Scene, pose: &Pose, angle: u16) -> Vec<Option<f64>> {
        let max_range = self.config.max_range();
        self.rays(pose, angle)
            .iter()
            .map(|ray| scene.cast(ray, max_range).map(|h| h.t))
            .collect()
    }

    /// Forgets the cached true ranges: the scene changed (a simulator of a world that moves
    /// calls it before a line whose scene differs from the last).
    pub fn forget(&mut self) {
        self.cache.clear();
        self.cached_pose = None;
    }

    /// Scans one line of `scene` from `pose` with the actuator at `angle` (2⁻¹⁶ turn):
    /// the ray cast, the noise, the encoding. Draws one Gaussian per beam that hits, in beam
    /// order. The scene must not change between calls with the same pose (the true ranges
    /// are cached by pose and angle).
    pub fn scan(&mut self, scene: &Scene, pose: &Pose, angle: u16) -> ScanLine {
        if self.cached_pose != Some(*pose) {
            self.cache.clear();
            self.cached_pose = Some(*pose);
        }
        let true_ranges_m = match self.cache.get(&angle) {
            Some(r) => r.clone(),
            None => {
                let r = self.true_ranges(scene, pose, angle);
                self.cache.insert(angle, r.clone());
                r
            }
        };
        self.measure(true_ranges_m)
    }

    /// Scans one line of `scene` whose beam k is cast from its own moment: `at(k)` gives the
    /// robot's pose and the actuator's angle (degrees) when beam k is measured (a moving
    /// robot: [`LaserConfig::beam_offsets_s`]). The noise as [`Self::scan`]'s; nothing cached.
    pub fn scan_each(&mut self, scene: &Scene, at: &dyn Fn(usize) -> (Pose, f64)) -> ScanLine {
        let max_range = self.config.max_range();
        let true_ranges_m = self
            .beams
            .iter()
            .enumerate()
            .map(|(k, &beam)| {
                let (pose, angle_deg) = at(k);
                let ray = self.ray(beam, &pose, angle_deg.to_radians());
                scene.cast(&ray, max_range).map(|h| h.t)
            })
            .collect();
        self.measure(true_ranges_m)
    }

    /// The noise and the encoding of a line's true ranges.
    fn measure(&mut self, true_ranges_m: Vec<Option<f64>>) -> ScanLine {
        let mask = self.config.mode.distance_mask();
        let flag = if self.config.mode == MeasuringMode::Mm8Cm80 {
            RETURN_FLAG
        } else {
            0
        };
        let metres_per_unit = f64::from(self.config.unit.millimetres()) / 1000.0;
        let mut raw = Vec::with_capacity(true_ranges_m.len());
        for range in &true_ranges_m {
            let value = match *range {
                None => mask,
                Some(t) => {
                    let measured = t + self.config.sigma_m * self.rng.gaussian();
                    let units = (measured / metres_per_unit).round().max(0.0);
                    if units >= f64::from(mask) {
                        mask
                    } else {
                        // 0 ≤ units < mask ≤ 0xFFFF.
                        #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
                        let u = units as u16;
                        u | flag
                    }
                }
            };
            raw.push(value);
        }
        ScanLine { raw, true_ranges_m }
    }

    /// The measured-values telegram (0xB0, ADR 0x80, CRC) of a line: full scan, partial-scan
    /// index 0, no scan-index byte, the configured status.
    ///
    /// # Errors
    /// The library's refusal (more values than a telegram holds: never for a variant's line).
    pub fn telegram(&self, line: &ScanLine) -> Result<Vec<u8>, String> {
        let values = line.values_le();
        let reply = MeasuredValues::new(self.config.unit, 0, &values, None, self.config.status)
            .map_err(|e| e.to_string())?;
        let mut buf = vec![0_u8; reply.buffer_len()];
        let n = reply.emit(&mut buf).map_err(|e| e.to_string())?;
        buf.truncate(n);
        Ok(buf)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use terrain_pyramid::wire::sick::{range_mm, Telegram};

    #[test]
    fn angles_round_trip() {
        assert_eq!(angle_to_u16(0.0), 0);
        assert_eq!(angle_to_u16(90.0), 0x4000);
        assert_eq!(angle_to_u16(-45.0), 57_344);
        assert_eq!(angle_to_u16(359.999_999), 0);
        assert!((u16_to_angle_deg(57_344) + 45.0).abs() < 1e-12);
    }

    #[test]
    fn triangle_sweep() {
        let a = Actuator::PAPER_PAN;
        assert_eq!(a.angle_deg(0.0), -45.0);
        assert!((a.angle_deg(0.6) - 0.0).abs() < 1e-12);
        assert!((a.angle_deg(1.2) - 45.0).abs() < 1e-12);
        assert!((a.angle_deg(1.8) - 0.0).abs() < 1e-12);
        assert!((a.angle_deg(2.4) + 45.0).abs() < 1e-12);
        assert!((a.period_s() - 2.4).abs() < 1e-12);
    }

    #[test]
    fn rates() {
        let mut c = LaserConfig::paper();
        assert_eq!(c.line_rate_hz(), 37.5);
        c.variant = Variant::Fov180Step1;
        assert_eq!(c.line_rate_hz(), 75.0);
        c.variant = Variant::Fov100StepQuarter;
        assert_eq!(c.line_rate_hz(), 18.75);
        assert!((LaserConfig::paper().max_range() - 8.191).abs() < 1e-12);
        c.unit = Unit::Centimetre;
        assert!((c.max_range() - 81.91).abs() < 1e-9);
    }

    #[test]
    fn straight_down_is_h_and_up_is_no_echo() {
        let mut laser = Laser::new(
            LaserConfig {
                sigma_m: 0.0,
                ..LaserConfig::paper()
            },
            1,
        );
        let line = laser.scan(&Scene::flat(), &Pose::default(), 0);
        assert_eq!(line.raw.len(), 361);
        assert_eq!(line.raw[0], 1000 | RETURN_FLAG);
        assert_eq!(line.raw[360], 0x1FFF);
        // Beam 200 (100°) points 10° up: no echo. Beam 170 (85°): 1/sin 5° = 11.47 m: beyond.
        assert_eq!(line.raw[200], 0x1FFF);
        assert_eq!(line.raw[170], 0x1FFF);
        let mode = MeasuringMode::Mm8Cm80;
        assert_eq!(range_mm(line.raw[0], mode, Unit::Millimetre), Some(1000));
        let bytes = laser.telegram(&line).unwrap();
        assert_eq!(bytes.len(), 4 + 4 + 722 + 2);
        let t = Telegram::new_checked(&bytes[..]).unwrap();
        let mv = MeasuredValues::parse(&t).unwrap();
        assert_eq!(mv.count(), 361);
    }

    #[test]
    fn units_and_modes() {
        let scan = |unit, mode| {
            let config = LaserConfig {
                sigma_m: 0.0,
                unit,
                mode,
                variant: Variant::Fov100Step1,
                ..LaserConfig::paper()
            };
            Laser::new(config, 1)
                .scan(&Scene::flat(), &Pose::default(), 0)
                .raw
        };
        // The 100° field starts at 40°: beam 0 is 1/cos 40° = 1.3054 m away.
        let raw = scan(Unit::Centimetre, MeasuringMode::Mm8Cm80);
        assert_eq!(raw.len(), 101);
        assert_eq!(raw[0], 131 | RETURN_FLAG);
        let raw = scan(Unit::Millimetre, MeasuringMode::Range32mNoFlags);
        assert_eq!(raw[0], 1305);
        assert_eq!(raw[100], 0xFFFF);
    }
}
