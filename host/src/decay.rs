//! The `--decay` flags: decay of stale evidence toward unknown (`docs/core.md`, "Decay"), as a
//! command that configures the device (`pyramid run`) asks for it in its Configure.

use terrain_pyramid::decay::{Decay, DecayMode, TimeConstant, DECAY_LAYERS};

/// Which evidence ages, as the command line names it.
#[derive(clap::ValueEnum, Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum DecayArg {
    /// Nothing decays: the paper's behaviour.
    #[default]
    Off,
    /// Every observed cell decays toward unknown.
    All,
    /// Only obstacle evidence decays (free ground is kept).
    Obstacle,
    /// Only free evidence decays (obstacles are kept).
    Free,
}

impl DecayArg {
    /// The library's mode.
    #[must_use]
    pub const fn mode(self) -> DecayMode {
        match self {
            Self::Off => DecayMode::Off,
            Self::All => DecayMode::All,
            Self::Obstacle => DecayMode::Obstacle,
            Self::Free => DecayMode::Free,
        }
    }
}

/// The decay flags.
#[derive(clap::Args, Debug, Clone, PartialEq)]
pub struct DecayArgs {
    /// Decay of stale evidence toward unknown: `off` (the paper's behaviour), `all`,
    /// `obstacle` (only obstacle evidence ages) or `free` (only free evidence ages).
    #[arg(long, value_enum, default_value_t = DecayArg::Off)]
    pub decay: DecayArg,
    /// The decay's time constant, seconds: one value for every layer, or one per layer,
    /// finest first, comma-separated (0: the layer does not decay). 1 to 60 097 s; the
    /// device's nearest (steps of 4.4 %), and at least what its sweep's budget allows
    /// (1 s for 64 cells per side).
    #[arg(
        long = "decay-tau-s",
        value_name = "S[,S…]",
        value_delimiter = ',',
        default_value = "10"
    )]
    pub tau_s: Vec<f32>,
}

impl Default for DecayArgs {
    fn default() -> Self {
        Self {
            decay: DecayArg::Off,
            tau_s: vec![10.0],
        }
    }
}

impl DecayArgs {
    /// The library's decay for a design of `layers` layers in windows of `cells_per_side`,
    /// checked by the library's rule ([`Decay::validate`]).
    ///
    /// # Errors
    /// A time constant out of range, more values than layers, or the library's refusal (the
    /// message names the flag and the layer).
    pub fn decay(&self, layers: usize, cells_per_side: usize) -> Result<Decay, String> {
        let mode = self.decay.mode();
        if mode == DecayMode::Off {
            return Ok(Decay::OFF);
        }
        let per_layer = self.tau_s.len() > 1;
        if self.tau_s.len() > layers.min(DECAY_LAYERS) {
            return Err(format!(
                "--decay-tau-s: {} values for a design of {layers} layers",
                self.tau_s.len()
            ));
        }
        let mut decay = Decay::OFF;
        decay.mode = mode;
        let count = if per_layer {
            self.tau_s.len()
        } else {
            layers.min(DECAY_LAYERS)
        };
        for (k, slot) in decay.tau.iter_mut().enumerate().take(count) {
            let s = if per_layer {
                self.tau_s.get(k).copied().unwrap_or(0.0)
            } else {
                self.tau_s.first().copied().unwrap_or(0.0)
            };
            if per_layer && s == 0.0 {
                continue;
            }
            *slot = TimeConstant::from_seconds(s).ok_or_else(|| {
                format!(
                    "--decay-tau-s (layer {k}): {s} s is outside the time constants a device \
                     takes, 1 to 60097 s"
                )
            })?;
        }
        decay
            .validate(cells_per_side, layers)
            .map_err(|e| e.to_string())?;
        Ok(decay)
    }
}

/// What a summary says about the decay in force.
#[derive(serde::Serialize, Debug, Clone, PartialEq)]
pub struct DecaySummary {
    /// `off`, `all`, `obstacle` or `free`.
    pub mode: &'static str,
    /// Each layer's time constant, seconds (the device's value); `null` for a layer that
    /// does not decay.
    pub tau_s: Vec<Option<f32>>,
}

impl DecaySummary {
    /// The summary of `decay` for `layers` layers.
    #[must_use]
    pub fn of(decay: &Decay, layers: usize) -> Self {
        Self {
            mode: decay.mode.name(),
            tau_s: (0..layers).map(|k| decay.tau_of(k).seconds()).collect(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn args(decay: DecayArg, tau_s: &[f32]) -> DecayArgs {
        DecayArgs {
            decay,
            tau_s: tau_s.to_vec(),
        }
    }

    #[test]
    fn one_value_for_every_layer_or_one_per_layer() {
        let d = args(DecayArg::All, &[10.0]).decay(8, 64).unwrap();
        assert_eq!(d.mode, DecayMode::All);
        assert!(d.tau[..8].iter().all(|t| t.code() == 54));
        assert!(d.tau[8..].iter().all(|t| t.is_none()));
        let d = args(DecayArg::Obstacle, &[2.0, 0.0, 5.0])
            .decay(8, 64)
            .unwrap();
        assert_eq!(d.tau[0].seconds(), Some(2.0));
        assert!(d.tau[1].is_none() && !d.tau[2].is_none() && d.tau[3].is_none());
        assert_eq!(args(DecayArg::Off, &[0.1]).decay(8, 64), Ok(Decay::OFF));
    }

    #[test]
    fn refusals_name_the_flag() {
        let e = args(DecayArg::All, &[0.5]).decay(8, 64).unwrap_err();
        assert!(e.starts_with("--decay-tau-s (layer 0)"), "{e}");
        let e = args(DecayArg::All, &[1.0; 9]).decay(8, 64).unwrap_err();
        assert!(e.contains("9 values"), "{e}");
        // The sweep's budget for 128 cells per side: at least 4 s.
        let e = args(DecayArg::Free, &[2.0]).decay(8, 128).unwrap_err();
        assert!(
            e.starts_with("--decay-tau-s (layer 0): must lie within [4, "),
            "{e}"
        );
    }
}
