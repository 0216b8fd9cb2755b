//! The rig's design on the device (`[design]`, `docs/rig.md`): whether the pyramid a Hello
//! describes is the rig's, and the Configure that makes it so.
//!
//! A Configure clears the device's maps, so it is sent only when the device runs another
//! pyramid: a device that booted (its boot design; also one whose boot Hello was lost, found
//! on another pyramid after it ran the rig's), or one another host configured. A device
//! found running the rig's design keeps its maps, whichever session or reconnection finds it.
//! The Hello describes the layers (W, each layer's cell and band), not the gate or the sensor
//! model's probabilities; those are the library's defaults in every Configure sent here.
use crate::rigfile::DesignSpec;
use terrain_pyramid::grid::Resolution;
use terrain_pyramid::link::convert::configure_of_design;
use terrain_pyramid::wire::link::{Configure, Hello};
use terrain_pyramid::{Config, Design};

/// How far a band edge the device reports may lie from the host's, metres: both derive it by
/// the same `f32` arithmetic, so this only absorbs a compiler's different rounding.
pub const BAND_TOLERANCE_M: f32 = 1e-3;

/// The rig's design and what this connection has made of it.
#[derive(Debug, Clone, Copy)]
pub struct WantedDesign {
    /// The rig's `[design]`.
    pub spec: DesignSpec,
    /// Whether a Configure is out (answered or not) since the last connection or boot:
    /// at most one per connection or boot, so that a device that settles on other layers
    /// than the host computed is told once, not in a loop.
    pub configure_sent: bool,
    /// Whether the device was found running the rig's design since the last connection or
    /// boot (said once).
    pub confirmed: bool,
}

/// What a Hello asks of the host.
#[derive(Debug, Clone, PartialEq)]
pub enum Verdict {
    /// The device runs the rig's design; `String` describes it.
    Runs(String),
    /// The device runs another pyramid: send this Configure. The first `String` describes
    /// the device's pyramid, the second the rig's; the `bool` says the device ran the rig's
    /// design before (its boot Hello lost, most likely: its Setup and rule are the boot ones
    /// too).
    Configure(Box<Configure>, String, String, bool),
    /// A Configure was sent already and the device still runs another pyramid (described).
    StillOther(String, String),
    /// Nothing to say (already confirmed, or a Configure is out and the device's Hello has
    /// not answered it yet).
    Quiet,
    /// The rig's design cannot be built for the device's window: the library's refusal.
    Unbuildable(String),
}

impl WantedDesign {
    /// The rig's design, not yet looked at.
    #[must_use]
    pub const fn new(spec: DesignSpec) -> Self {
        Self {
            spec,
            configure_sent: false,
            confirmed: false,
        }
    }

    /// A new connection or a device's boot: the device's pyramid is to be looked at again.
    pub fn restart(&mut self) {
        self.configure_sent = false;
        self.confirmed = false;
    }

    /// What `hello` asks of the host; records a Configure as sent when it asks for one.
    pub fn on_hello(&mut self, hello: &Hello) -> Verdict {
        let (gamma, design) = match self.spec.design(usize::from(hello.cells_per_side)) {
            Ok(d) => d,
            Err(e) => {
                if self.configure_sent {
                    return Verdict::Quiet;
                }
                // Said once per connection or boot.
                self.configure_sent = true;
                return Verdict::Unbuildable(e);
            }
        };
        let wanted = describe(&design, Some(gamma));
        if runs(hello, &design) {
            if self.confirmed {
                return Verdict::Quiet;
            }
            self.confirmed = true;
            return Verdict::Runs(wanted);
        }
        let theirs = describe_hello(hello);
        let again = self.confirmed;
        if again {
            // It ran the rig's design and runs another now: a boot whose Hello was lost, or
            // another host's Configure. Looked at afresh.
            self.restart();
        }
        if self.configure_sent {
            // The Hello of a snapshot already queued when the Configure went out says the old
            // pyramid; only the Configure's own Hello (reason configured) is its answer.
            return if hello.reason == terrain_pyramid::wire::link::HelloReason::Configured {
                Verdict::StillOther(theirs, wanted)
            } else {
                Verdict::Quiet
            };
        }
        self.configure_sent = true;
        self.confirmed = false;
        Verdict::Configure(
            Box::new(configure_of_design(&design, &Config::default())),
            theirs,
            wanted,
            again,
        )
    }
}

/// Whether `hello` describes `design`'s pyramid: the same window and layers, each layer's
/// cell (Q16.16, as the device rounds it) equal and its band within [`BAND_TOLERANCE_M`].
#[must_use]
pub fn runs<const L: usize>(hello: &Hello, design: &Design<L>) -> bool {
    usize::from(hello.cells_per_side) == design.cells_per_side()
        && hello.layers.len() == design.layers().len()
        && hello.layers.iter().zip(design.layers()).all(|(h, d)| {
            Resolution::from_m(d.resolution_m).map(Resolution::to_bits) == Some(h.resolution_q16)
                && (h.band_inner_m - d.band_inner_m).abs() <= BAND_TOLERANCE_M
                && (h.band_outer_m - d.band_outer_m).abs() <= BAND_TOLERANCE_M
        })
}

/// A design in a few words: its layers, γ, the finest and coarsest cells and the range.
#[must_use]
pub fn describe<const L: usize>(design: &Design<L>, gamma: Option<f64>) -> String {
    let layers = design.layers();
    let gamma = gamma.map_or_else(String::new, |g| format!(", γ {g}"));
    match (layers.first(), layers.last()) {
        (Some(first), Some(last)) => format!(
            "{} layers of {} cells{gamma}, cells {:.2}–{:.2} m, to {:.1} m",
            layers.len(),
            design.cells_per_side(),
            first.resolution_m,
            last.resolution_m,
            last.band_outer_m
        ),
        _ => "no layers".to_string(),
    }
}

/// The pyramid a Hello describes, in the words of [`describe`].
#[must_use]
pub fn describe_hello(hello: &Hello) -> String {
    let cell = |bits: i32| f64::from(bits) / 65_536.0;
    match (hello.layers.first(), hello.layers.last()) {
        (Some(first), Some(last)) => format!(
            "{} layers of {} cells, cells {:.2}–{:.2} m, to {:.1} m",
            hello.layers.len(),
            hello.cells_per_side,
            cell(first.resolution_q16),
            cell(last.resolution_q16),
            last.band_outer_m
        ),
        _ => format!("no layers ({} cells)", hello.cells_per_side),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use terrain_pyramid::wire::link::{ClockSource, FirmwareVersion, HelloReason, LayerInfo};

    /// The Hello a device running `design` sends, built from the layers' own numbers (as
    /// the device's link does), not from [`runs`].
    fn hello_of<const L: usize>(design: &Design<L>, reason: HelloReason) -> Hello {
        let mut hello = Hello {
            protocol: terrain_pyramid::wire::link::VERSION,
            firmware: FirmwareVersion {
                major: 0,
                minor: 1,
                patch: 0,
            },
            reason,
            cells_per_side: u16::try_from(design.cells_per_side()).unwrap(),
            resend: 0,
            clock: ClockSource::NotReported,
            layers: Default::default(),
        };
        for l in design.layers() {
            let bits = (l.resolution_m * 65_536.0 + 0.5).floor();
            #[allow(clippy::cast_possible_truncation)]
            let info = LayerInfo {
                resolution_q16: bits as i32,
                band_inner_m: l.band_inner_m,
                band_outer_m: l.band_outer_m,
                origin_x: -32,
                origin_y: -32,
            };
            hello.layers.push(info).unwrap();
        }
        hello
    }

    fn ld19() -> DesignSpec {
        DesignSpec {
            phi_deg: Some(2.0),
            psi_deg: Some(0.8),
            sigma_m: Some(0.045),
            height_m: Some(1.0),
            max_range_m: Some(10.0),
            fit_layers: Some(8),
            ..DesignSpec::default()
        }
    }

    #[test]
    fn a_device_on_its_boot_design_is_configured_once_and_then_confirmed() {
        let boot = crate::design::firmware_design().unwrap();
        let mut wanted = WantedDesign::new(ld19());
        let Verdict::Configure(configure, theirs, ours, false) =
            wanted.on_hello(&hello_of(&boot, HelloReason::Boot))
        else {
            panic!("a boot design is not the LD19's");
        };
        assert!(theirs.starts_with("8 layers of 64 cells"), "{theirs}");
        assert!(ours.contains("γ"), "{ours}");
        // The Configure carries the LD19's sensor and the fitted γ, the library's defaults
        // otherwise; the device's own conversion takes it.
        assert!((configure.phi_rad - 2.0_f32.to_radians()).abs() < 1e-7);
        assert!(configure.gamma > 2.0);
        let design: Design<8> =
            terrain_pyramid::link::convert::design_of(&configure).expect("the device takes it");
        // The snapshot's Hello queued before the Configure: nothing more is sent.
        assert_eq!(
            wanted.on_hello(&hello_of(&boot, HelloReason::Snapshot)),
            Verdict::Quiet
        );
        // The Configure's Hello: the rig's design, said once.
        let configured = hello_of(&design, HelloReason::Configured);
        assert!(matches!(wanted.on_hello(&configured), Verdict::Runs(_)));
        assert_eq!(wanted.on_hello(&configured), Verdict::Quiet);
        // A reconnection to the same device: nothing to send, its maps are kept.
        wanted.restart();
        assert!(matches!(
            wanted.on_hello(&hello_of(&design, HelloReason::Snapshot)),
            Verdict::Runs(_)
        ));
        // A boot: the boot design again, so a Configure again.
        wanted.restart();
        assert!(matches!(
            wanted.on_hello(&hello_of(&boot, HelloReason::Boot)),
            Verdict::Configure(..)
        ));
    }

    #[test]
    fn a_device_found_on_another_pyramid_after_running_the_rig_s_is_configured_again() {
        // A reboot whose Hello was lost: the next snapshot's Hello shows the boot design.
        let boot = crate::design::firmware_design().unwrap();
        let mut wanted = WantedDesign::new(ld19());
        let Verdict::Configure(configure, ..) =
            wanted.on_hello(&hello_of(&boot, HelloReason::Snapshot))
        else {
            panic!("a boot design is not the LD19's");
        };
        let design: Design<8> = terrain_pyramid::link::convert::design_of(&configure).unwrap();
        assert!(matches!(
            wanted.on_hello(&hello_of(&design, HelloReason::Configured)),
            Verdict::Runs(_)
        ));
        assert!(matches!(
            wanted.on_hello(&hello_of(&boot, HelloReason::Snapshot)),
            Verdict::Configure(_, _, _, true)
        ));
        // Once: the snapshot Hellos queued behind it say nothing more.
        assert_eq!(
            wanted.on_hello(&hello_of(&boot, HelloReason::Snapshot)),
            Verdict::Quiet
        );
    }

    #[test]
    fn a_device_that_settles_elsewhere_is_told_once_not_in_a_loop() {
        let boot = crate::design::firmware_design().unwrap();
        let mut wanted = WantedDesign::new(ld19());
        assert!(matches!(
            wanted.on_hello(&hello_of(&boot, HelloReason::Snapshot)),
            Verdict::Configure(..)
        ));
        assert!(matches!(
            wanted.on_hello(&hello_of(&boot, HelloReason::Configured)),
            Verdict::StillOther(..)
        ));
    }

    #[test]
    fn layers_that_differ_in_a_cell_or_a_band_are_another_pyramid() {
        let boot = crate::design::firmware_design().unwrap();
        let hello = hello_of(&boot, HelloReason::Snapshot);
        assert!(runs(&hello, &boot));
        let mut other = hello.clone();
        other.layers[3].resolution_q16 += 1;
        assert!(!runs(&other, &boot));
        let mut other = hello.clone();
        other.layers[2].band_outer_m += 0.01;
        assert!(!runs(&other, &boot));
        let mut other = hello.clone();
        other.layers.pop();
        assert!(!runs(&other, &boot));
        let mut other = hello;
        other.cells_per_side = 32;
        assert!(!runs(&other, &boot));
    }

    #[test]
    fn a_design_the_window_cannot_hold_is_said_once() {
        // 16 cells a side (the micro:bit's) cannot hold the LD19's bands at 8 layers.
        let boot = crate::design::firmware_design().unwrap();
        let mut hello = hello_of(&boot, HelloReason::Boot);
        hello.cells_per_side = 4;
        let mut wanted = WantedDesign::new(ld19());
        assert!(matches!(wanted.on_hello(&hello), Verdict::Unbuildable(_)));
        assert_eq!(wanted.on_hello(&hello), Verdict::Quiet);
    }
}
