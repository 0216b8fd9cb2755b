//! A swept-laser ray-casting simulator that writes recordings with real SICK telegrams
//! (`f64`, `std`, deterministic: every random draw comes from a seeded generator).
//!
//! - [`scene`]: the world — a ground height field plus boxes and posts, the scenarios
//!   (flat, stairs, curb, gate, ditch, branch, slope), the exact ray cast, the ground truth.
//! - [`lidar`]: an LD06/LD19, RPLIDAR or YDLIDAR on a nodding servo or the panned mount:
//!   their packets as the sensors send them, a recording of version 2 with its sensor event.
//! - [`laser`]: a SICK LMS2xx on a pan or tilt actuator: beams, sweep, noise, encoding,
//!   measured-values telegrams.
//! - [`trajectory`]: the robot standing, then driving along +x to a stop.
//! - [`record`]: a whole run as a recording (`docs/recording.md`) with markers, and its
//!   ground truth.
//! - [`changing`]: scenes that change — a pedestrian, a door, a car leaving — and their
//!   truth over time.
//! - [`terrain`]: slopes, camber, roughness, gravel, curbs with kerb cuts, ramps, and the
//!   ground truth of every cell of any grid, for the navigability rules.
//! - [`cloud`]: point clouds straight from the ray cast (a car's ring laser, the paper's
//!   panned plane), the observations the navigability rules are measured on.
//! - [`rng`]: the seeded generator.
//!
//! ```
//! use terrain_pyramid_host_tests::sim::record::{simulate, SimConfig};
//! // The paper's stairs: stand 1 s, drive at 1 m/s to 1.0 m from the first riser.
//! let sim = simulate(&SimConfig::paper_stairs(1.0, 1.0, 1.0)).unwrap();
//! assert_eq!(sim.lines, 191); // ⌈5.05 s · 37.5 lines/s⌉ + the line at t = 0
//! assert!(!sim.ground_truth.is_empty());
//! ```

pub mod changing;
pub mod cloud;
pub mod drive;
pub mod laser;
pub mod lidar;
pub mod record;
pub mod rng;
pub mod scene;
pub mod terrain;
pub mod trajectory;
