//! Configure ⇄ the core's design, configuration and decay: the Configure a host sends for a
//! design ([`configure_message`], [`configure_of_design`]), and the [`Design`], [`Config`] and
//! [`Decay`] a Configure asks for, by their own rules ([`design_of`], [`config_of`], [`decay_of`]).

use crate::decay::{Decay, DecayMode, TimeConstant, DECAY_LAYERS};
use crate::design::{Design, DesignError, GateShape, Param, Schedule, SensorModel};
use crate::logodds::{Clamp, InverseSensorModel};
use crate::pyramid::Config;
use crate::wire::link::{ClampRequest, Configure, GateRequest};

/// The Configure that asks for `sensor`, `schedule`, a window of `cells_per_side` and
/// `config` (clamping bounds as nats, exactly: Q8.8 values are exact in `f32`).
#[must_use]
pub fn configure_message(
    sensor: &SensorModel,
    schedule: &Schedule,
    cells_per_side: u16,
    config: &Config,
) -> Configure {
    Configure {
        phi_rad: sensor.phi_rad,
        psi_rad: sensor.psi_rad,
        sigma_m: sensor.sigma_m,
        height_m: sensor.height_m,
        max_range_m: sensor.max_range_m,
        base_m: schedule.base_m,
        gamma: schedule.gamma,
        gate: match schedule.gate {
            GateShape::Hard => GateRequest::Hard,
            GateShape::Soft { width_factor } => GateRequest::Soft { width_factor },
        },
        cells_per_side,
        p_obstacle: config.model.p_obstacle,
        p_free: config.model.p_free,
        prior: config.model.prior,
        clamp: match config.clamp {
            Clamp::Off => ClampRequest::Off,
            Clamp::Bounds { min, max } => ClampRequest::Bounds {
                min: min.to_num(),
                max: max.to_num(),
            },
        },
        fused_margin: config.fused_margin,
        uniform_resolution: schedule.uniform_resolution,
        decay_mode: config.decay.mode.to_u8(),
        decay_tau: config.decay.tau.map(TimeConstant::code),
    }
}

/// The Configure of a design and a configuration ([`configure_message`]).
#[must_use]
pub fn configure_of_design<const L: usize>(design: &Design<L>, config: &Config) -> Configure {
    configure_message(
        design.sensor(),
        design.schedule(),
        u16::try_from(design.cells_per_side()).unwrap_or(u16::MAX),
        config,
    )
}

/// The design a Configure asks for, by [`Design::new`]'s rules.
///
/// # Errors
/// The first rule broken.
pub fn design_of<const L: usize>(c: &Configure) -> Result<Design<L>, DesignError> {
    let sensor = SensorModel {
        phi_rad: c.phi_rad,
        psi_rad: c.psi_rad,
        sigma_m: c.sigma_m,
        height_m: c.height_m,
        max_range_m: c.max_range_m,
    };
    let schedule = Schedule {
        base_m: c.base_m,
        gamma: c.gamma,
        gate: match c.gate {
            GateRequest::Hard => GateShape::Hard,
            GateRequest::Soft { width_factor } => GateShape::Soft { width_factor },
        },
        uniform_resolution: c.uniform_resolution,
    };
    Design::new(sensor, schedule, usize::from(c.cells_per_side))
}

/// The configuration a Configure asks for, by [`InverseSensorModel::increments`]' and
/// [`Clamp::bounds`]' rules (the fused margin is checked by [`crate::Pyramid::configure`]).
///
/// # Errors
/// The first rule broken.
pub fn config_of(c: &Configure) -> Result<Config, DesignError> {
    let model = InverseSensorModel {
        p_obstacle: c.p_obstacle,
        p_free: c.p_free,
        prior: c.prior,
    };
    model.increments()?;
    let clamp = match c.clamp {
        ClampRequest::Off => Clamp::Off,
        ClampRequest::Bounds { min, max } => Clamp::bounds(min, max)?,
    };
    Ok(Config {
        model,
        clamp,
        fused_margin: c.fused_margin,
        decay: decay_of(c)?,
    })
}

/// The decay a Configure asks for: its mode and time constants (checked against the design
/// and the window by [`Decay::validate`], when the pyramid adopts it).
///
/// # Errors
/// A mode byte above 3 ([`Param::DecayMode`]; the wire's parser already refuses it).
pub fn decay_of(c: &Configure) -> Result<Decay, DesignError> {
    let mode = DecayMode::from_u8(c.decay_mode).ok_or(DesignError::OutOfRange {
        param: Param::DecayMode,
        value: f32::from(c.decay_mode),
        min: 0.0,
        max: 3.0,
    })?;
    let mut tau = [TimeConstant::NONE; DECAY_LAYERS];
    for (t, &code) in tau.iter_mut().zip(&c.decay_tau) {
        *t = TimeConstant::from_code(code);
    }
    Ok(Decay { mode, tau })
}
