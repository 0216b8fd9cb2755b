//! The std side of the truth for `terrain-pyramid`: an independent `f64` reference of the
//! pyramid's core, written from the paper (Montemerlo & Thrun) and `docs/core.md` — never from
//! the library's code — and the helpers that let property tests and the `agreement` example
//! hold the fixed-point library to it.
//!
//! - [`mod@reference`]: the reference itself (no dependency on the library).
//! - [`harness`]: conversions between the library's types and the reference's, and the
//!   comparison of a library pyramid with a reference pyramid.
//! - [`workload`]: evidence/recentre sequences that drive both in lock step.
//! - [`sim`]: a swept-laser ray-casting simulator that writes recordings with real SICK
//!   telegrams, and the ground truth of its scenes.
//! - [`classify`]: the classifier's reference (every point kept, the rule applied exactly).
//! - [`fading`]: how ghosts fade — the changing scenes through the application core, with and
//!   without decay: clearing times per layer and fused, static obstacles wrongly cleared.
//! - [`navigability`]: candidate navigability rules in `f64` and the bench that measures them
//!   on simulated terrain and real scans.
//! - [`scan3dtk`]: the real 3-D scan of `../shared/data` and its hand labelling.
//! - [`png`]: a minimal PNG writer for the pictures the examples draw.

pub mod classify;
pub mod fading;
pub mod geometry;
pub mod harness;
pub mod navigability;
pub mod png;
pub mod reference;
pub mod scan3dtk;
pub mod semantic_kitti;
pub mod sim;
pub mod workload;
