//! The host tests of the library against the f64 reference, the simulator and hostile
//! input: one test binary (one link, each generic instantiated once), a module per file.
//! `cargo test -p terrain-pyramid-host-tests --test suite rigs::` runs one file's tests.

mod common;

mod classify;
mod decay;
mod design;
mod fading;
mod gate;
mod geometry;
mod hostile;
mod hostile_lidars;
mod lidar_wire;
mod logodds;
mod placement;
mod pyramid;
mod rigs;
mod sim;
