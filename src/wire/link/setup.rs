//! The host's Setup and SetRule bodies (`docs/protocol.md`, "0x87 Setup", "0x8B SetRule"):
//! the laser's mounting and grouping, the classifier's thresholds, the navigability rule block
//! and the laser block, unvalidated.

/// Bytes of a Setup body before its laser block: the mount, the SICK fields, the sensor's
/// position, the grouping and the classifier's thresholds.
pub(crate) const SETUP_BASE_LEN: usize = 38;
/// Bytes of Setup's navigability rule block ([`RuleSetup`]), between the base part and the
/// laser block.
pub const SETUP_RULE_LEN: usize = 22;
/// Bytes of Setup's laser block ([`LaserSetup`]).
pub const SETUP_LASER_LEN: usize = 22;
/// Bytes of Setup's mount block ([`MountSetup`], version 5).
pub const SETUP_MOUNT_LEN: usize = 20;
/// Bytes of Setup's filter block ([`FilterSetup`], version 5).
pub const SETUP_FILTER_LEN: usize = 6 + 4 * SETUP_SECTORS;
/// The masked sectors a Setup's filter block holds room for.
pub const SETUP_SECTORS: usize = 8;
/// Bytes of a Setup body.
pub(crate) const SETUP_LEN: usize =
    SETUP_BASE_LEN + SETUP_RULE_LEN + SETUP_LASER_LEN + SETUP_MOUNT_LEN + SETUP_FILTER_LEN;
/// Bytes of a SetRule body: the step threshold and a rule block.
pub(crate) const SET_RULE_LEN: usize = 4 + SETUP_RULE_LEN;

/// Setup's navigability rule block (protocol version 3, offset 38; its pair depth from version
/// 6): which rule judges a cell's points and the plane rule's parameters. Unvalidated ([`crate::link::convert::frontend_config`]
/// checks it; the plane parameters only under the plane rule).
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct RuleSetup {
    /// 0 the paper's spread rule, 1 the plane rule.
    pub rule: u8,
    /// The largest traversable slope as a grade (rise per run, tan of its angle).
    pub max_grade: f32,
    /// The RMS by which a navigable cell's points may stray from their plane beyond the
    /// noise, metres.
    pub residual_m: f32,
    /// The sensor's range noise σ, metres.
    pub range_sigma_m: f32,
    /// The sensor's elevation error σ_a, radians.
    pub angle_sigma_rad: f32,
    /// How many σ of height noise the allowances hold.
    pub noise_factor: f32,
    /// How many of a cell's previous returns the pair test pairs each return with
    /// (1 ..= [`MAX_PAIR_DEPTH`](crate::classify::MAX_PAIR_DEPTH); version 6).
    pub pair_depth: u8,
}

impl RuleSetup {
    /// The paper's spread rule (the plane parameters zero: ignored).
    pub const SPREAD: Self = Self {
        rule: 0,
        max_grade: 0.0,
        residual_m: 0.0,
        range_sigma_m: 0.0,
        angle_sigma_rad: 0.0,
        noise_factor: 0.0,
        pair_depth: 0,
    };
}

/// A SetRule command (0x8B): the classifier's step threshold and navigability rule, for a
/// device already set up (the rest of its setup stays). Unvalidated
/// ([`crate::link::convert::set_rule_of`] checks it).
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct SetRule {
    /// The step threshold, metres (as Setup's `step_threshold`).
    pub step_threshold_m: f32,
    /// The rule block (as Setup's).
    pub rule: RuleSetup,
}

/// Setup's laser block (protocol version 3): which laser, at which baud rate, and what moves
/// its scan plane. Unvalidated ([`crate::link::convert::frontend_config`] checks it).
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct LaserSetup {
    /// The sensor: 0 SICK LMS2xx, 1 LDROBOT LD06/LD19/STL-19P, 2 Slamtec RPLIDAR, 3 YDLIDAR.
    pub sensor: u8,
    /// What moves the scan plane: 0 an external actuator (the board's encoder, else the
    /// host's PanAngle), 1 a nodding servo the device commands (the servo fields).
    pub actuator: u8,
    /// The laser UART's baud rate; 0 = the sensor's default (SICK 500 000, LD06 230 400,
    /// RPLIDAR 115 200, YDLIDAR 128 000).
    pub baud: u32,
    /// The servo's sweep, lower end, degrees (signed; the actuator angle of the mount).
    pub servo_min_deg: f32,
    /// The servo's sweep, upper end, degrees.
    pub servo_max_deg: f32,
    /// The servo's sweep rate, degrees per second.
    pub servo_rate_deg_s: f32,
    /// The servo's delay behind its command, milliseconds.
    pub servo_latency_ms: f32,
}

impl LaserSetup {
    /// A SICK at its default baud rate on an external actuator (what a version-2 Setup
    /// meant).
    pub const SICK: Self = Self {
        sensor: 0,
        actuator: 0,
        baud: 0,
        servo_min_deg: 0.0,
        servo_max_deg: 0.0,
        servo_rate_deg_s: 0.0,
        servo_latency_ms: 0.0,
    };
}

impl Default for LaserSetup {
    fn default() -> Self {
        Self::SICK
    }
}

/// Setup's mount block (protocol version 5, offset 81): the actuator's zero and sense, and,
/// for the general mount (Setup's `mount` 2), the actuator's axis and the sensor frame's
/// roll, pitch and yaw (`docs/protocol.md`, "0x87 Setup"). Unvalidated.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct MountSetup {
    /// The actuator's axis (general mount only): 0 pan, 1 tilt, 2 none.
    pub axis: u8,
    /// The actuator's sense: +1 as the axis's positive sense, −1 reversed.
    pub sense: i8,
    /// The reported actuator angle that is the geometry's 0, degrees.
    pub zero_deg: f32,
    /// The sensor frame's roll, pitch, yaw relative to the actuator's frame at zero, degrees
    /// (general mount only; REP-103, `R_z(yaw)·R_y(pitch)·R_x(roll)`).
    pub rpy_deg: [f32; 3],
}

impl MountSetup {
    /// Zero 0, sense +1, the rest zero: what a preset mount of version 4 meant.
    pub const PRESET: Self = Self {
        axis: 0,
        sense: 1,
        zero_deg: 0.0,
        rpy_deg: [0.0; 3],
    };
}

/// Setup's filter block (protocol version 5, offset 101): the masks and filters each return
/// passes before geometry. Unvalidated.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct FilterSetup {
    /// The smallest range kept, centimetres; 0 = off.
    pub min_range_cm: u16,
    /// The largest range kept, centimetres; 0 = off.
    pub max_range_cm: u16,
    /// The smallest quality kept (the sensor's byte); 0 = off.
    pub min_quality: u8,
    /// How many of `sectors` are masked, 0 ..= [`SETUP_SECTORS`].
    pub sector_count: u8,
    /// Masked sectors of the sensor's own angle, centidegrees 0 ..= 35 999: (start, end) in
    /// the angle's growing sense, `[start, end)`, wrapping past 0 when end < start.
    pub sectors: [(u16, u16); SETUP_SECTORS],
}

impl FilterSetup {
    /// No mask, no filter.
    pub const NONE: Self = Self {
        min_range_cm: 0,
        max_range_cm: 0,
        min_quality: 0,
        sector_count: 0,
        sectors: [(0, 0); SETUP_SECTORS],
    };
}

/// Host to device: how the laser is mounted and how its lines make observations, the
/// classifier's thresholds, and (version 3) which laser it is and what moves it. The fields
/// of a recording's setup event (`docs/recording.md`) plus the thresholds and the laser
/// block; unvalidated (the device checks it with
/// [`crate::link::convert::frontend_config`]).
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Setup {
    /// 0 the panned-vertical preset, 1 the tilted-horizontal preset, 2 the general mount of
    /// the mount block (version 5).
    pub mount: u8,
    /// The sensor's mode: for a SICK its measuring mode (the 0x77 mode number); RPLIDAR 0
    /// standard scan, 1 express scan; YDLIDAR 0 with the X4/X2 angle correction, 1 without;
    /// LD06 0.
    pub measuring_mode: u8,
    /// Field of view, degrees: 100 or 180.
    pub field_deg: u16,
    /// Angular resolution, centidegrees: 25, 50 or 100.
    pub resolution_cdeg: u16,
    /// The sensor's position in the robot frame, metres: x, y, z.
    pub sensor_m: [f32; 3],
    /// Lines per observation; 0 = one observation per sweep.
    pub lines_per_observation: u32,
    /// Points higher than the cell's ground plus this are overhang, metres; > 0.
    pub robot_height_m: f32,
    /// A spread above this makes a cell not navigable, metres; ≥ 0.
    pub step_threshold_m: f32,
    /// A return this far below the robot's ground marks a drop-off, metres; 0 = off.
    pub drop_threshold_m: f32,
    /// Returns higher than this above the robot's ground are overhang, metres; 0 = off.
    pub ceiling_m: f32,
    /// The navigability rule block (version 3).
    pub rule: RuleSetup,
    /// The laser block (version 3).
    pub laser: LaserSetup,
    /// The mount block (version 5).
    pub mount_block: MountSetup,
    /// The filter block (version 5).
    pub filter: FilterSetup,
}
