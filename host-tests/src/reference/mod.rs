//! The `f64` reference of the pyramid's core, written from the paper and `docs/core.md`.
//!
//! | module | what |
//! | --- | --- |
//! | [`bound`] | δ(d), eq. 17 |
//! | [`bands`] | the schedule, the bands of eq. 20, gate centres and widths, the refusal rules |
//! | [`gate`] | hard and soft gates, continuous and binned, Q1.15 rounding, binning error |
//! | [`logodds`] | eq. 6 with gating, clamping, the observed rule; ideal and quantised arithmetic |
//! | [`decay`] | decay toward unknown: the step in both arithmetics, the time constants, the sweep |
//! | [`window`] | the robot-centric windows as hash maps of world cells; evidence; counts |
//! | [`fused`] | the fused query and the region export |
//! | [`placement`] | the pose of each return's moment: the stamped poses, interpolation, extrapolation, the quantum |

pub mod bands;
pub mod bound;
pub mod decay;
pub mod fused;
pub mod gate;
pub mod logodds;
pub mod placement;
pub mod window;
