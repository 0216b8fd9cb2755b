//! The scenarios' layouts ([`Scenario`], the module documentation of [`super`]): flat
//! ground, stairs, a curb, a gate, a room, a ditch, a branch and a slope, each as a
//! [`Scene`].
use super::{Feature, FeatureKind, Footprint, GroundTerm, Scene, Solid, StairsSpec};

/// The scenarios, each with a default layout (see the module documentation).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Scenario {
    /// Flat ground.
    Flat,
    /// Stairs rising away from the robot (the paper's Figs 5-7).
    Stairs,
    /// A 10 cm curb.
    Curb,
    /// A gate: two posts and a bar overhead (the paper's Figs 8-9).
    Gate,
    /// A ditch: a negative obstacle.
    Ditch,
    /// An overhanging branch.
    Branch,
    /// Ground rising at 10°.
    Slope,
}

impl Scenario {
    /// Every scenario.
    pub const ALL: [Self; 7] = [
        Self::Flat,
        Self::Stairs,
        Self::Curb,
        Self::Gate,
        Self::Ditch,
        Self::Branch,
        Self::Slope,
    ];
}

const ALL_Y: (f64, f64) = (f64::NEG_INFINITY, f64::INFINITY);

impl Scene {
    /// Flat ground at z = 0, nothing else.
    #[must_use]
    pub fn flat() -> Self {
        Self {
            name: "flat",
            ground: Vec::new(),
            solids: Vec::new(),
            features: Vec::new(),
            target_x: None,
        }
    }

    /// The default scene of a scenario (layouts in the module documentation).
    #[must_use]
    pub fn scenario(scenario: Scenario) -> Self {
        match scenario {
            Scenario::Flat => Self::flat(),
            Scenario::Stairs => Self::stairs(StairsSpec::default()),
            Scenario::Curb => Self::curb(4.05, 0.10),
            Scenario::Gate => Self::gate(5.05, 1.5, 2.0),
            Scenario::Ditch => Self::ditch(4.05, 0.6, 0.5),
            Scenario::Branch => Self::branch(4.05, 1.0, 2.0, 1.6, 1.8),
            Scenario::Slope => Self::slope(3.05, 10.0),
        }
    }

    /// Stairs rising away from the robot; features: every riser across the flight's width and
    /// both sides of the flight (from the first riser on), as [`FeatureKind::StepEdge`] lines.
    #[must_use]
    pub fn stairs(spec: StairsSpec) -> Self {
        let half = 0.5 * spec.width_m;
        let mut features: Vec<Feature> = (0..spec.steps)
            .map(|i| Feature {
                kind: FeatureKind::StepEdge,
                footprint: Footprint::Rect {
                    x_min: spec.riser_x(i),
                    x_max: spec.riser_x(i),
                    y_min: -half,
                    y_max: half,
                },
                bottom_m: 0.0,
                height_m: spec.rise_m,
            })
            .collect();
        for y in [-half, half] {
            features.push(Feature {
                kind: FeatureKind::StepEdge,
                footprint: Footprint::Rect {
                    x_min: spec.first_riser_x,
                    x_max: f64::INFINITY,
                    y_min: y,
                    y_max: y,
                },
                bottom_m: 0.0,
                height_m: spec.rise_m,
            });
        }
        Self {
            name: "stairs",
            ground: vec![GroundTerm::Stairs(spec)],
            solids: Vec::new(),
            features,
            target_x: Some(spec.first_riser_x),
        }
    }

    /// A curb: the ground steps up by `height_m` at `x0`, across all y.
    #[must_use]
    pub fn curb(x0: f64, height_m: f64) -> Self {
        Self {
            name: "curb",
            ground: vec![GroundTerm::Step {
                x0,
                height_m,
                y_min: ALL_Y.0,
                y_max: ALL_Y.1,
            }],
            solids: Vec::new(),
            features: vec![Feature {
                kind: FeatureKind::Curb,
                footprint: Footprint::Rect {
                    x_min: x0,
                    x_max: x0,
                    y_min: ALL_Y.0,
                    y_max: ALL_Y.1,
                },
                bottom_m: 0.0,
                height_m: height_m.abs(),
            }],
            target_x: Some(x0),
        }
    }

    /// A gate at `x`: two posts (radius 0.06 m, from the ground up to the bar's top)
    /// `spacing_m` apart, centred on y = 0, and a 0.1 m × 0.1 m bar across them (to the posts'
    /// outer sides) whose underside is at `bar_m`. Features: the posts, and the bar (overhead:
    /// an obstacle only for a robot taller than `bar_m`).
    #[must_use]
    pub fn gate(x: f64, spacing_m: f64, bar_m: f64) -> Self {
        const RADIUS: f64 = 0.06;
        const BAR: f64 = 0.1;
        let half = 0.5 * spacing_m;
        let top = bar_m + BAR;
        let mut solids = Vec::new();
        let mut features = Vec::new();
        for y in [-half, half] {
            solids.push(Solid::Cylinder {
                centre: [x, y],
                radius_m: RADIUS,
                z_min: 0.0,
                z_max: top,
            });
            features.push(Feature {
                kind: FeatureKind::Post,
                footprint: Footprint::Disc {
                    centre: [x, y],
                    radius_m: RADIUS,
                },
                bottom_m: 0.0,
                height_m: top,
            });
        }
        let bar = (
            [x - 0.5 * BAR, -half - RADIUS, bar_m],
            [x + 0.5 * BAR, half + RADIUS, top],
        );
        solids.push(Solid::Box {
            min: bar.0,
            max: bar.1,
        });
        features.push(Feature {
            kind: FeatureKind::Bar,
            footprint: Footprint::Rect {
                x_min: bar.0[0],
                x_max: bar.1[0],
                y_min: bar.0[1],
                y_max: bar.1[1],
            },
            bottom_m: bar_m,
            height_m: BAR,
        });
        Self {
            name: "gate",
            ground: Vec::new(),
            solids,
            features,
            target_x: Some(x),
        }
    }

    /// A room to turn in: four walls 2 m high and 0.2 m thick, their inner faces
    /// `half_x_m` and `half_y_m` from the origin, and two pillars (0.6 m boxes, 1.5 m high) at
    /// (0.5 · `half_x_m`, 0.4 · `half_y_m`) and (−0.4 · `half_x_m`, −0.5 · `half_y_m`), so that
    /// no two headings see the same thing. Features: every solid, as [`FeatureKind::Block`].
    #[must_use]
    pub fn room(half_x_m: f64, half_y_m: f64) -> Self {
        const THICK: f64 = 0.2;
        const WALL: f64 = 2.0;
        const PILLAR: f64 = 0.6;
        const PILLAR_H: f64 = 1.5;
        let (ox, oy) = (half_x_m + THICK, half_y_m + THICK);
        let mut boxes = vec![
            ([half_x_m, -oy, 0.0], [ox, oy, WALL]),
            ([-ox, -oy, 0.0], [-half_x_m, oy, WALL]),
            ([-half_x_m, half_y_m, 0.0], [half_x_m, oy, WALL]),
            ([-half_x_m, -oy, 0.0], [half_x_m, -half_y_m, WALL]),
        ];
        for (cx, cy) in [
            (0.5 * half_x_m, 0.4 * half_y_m),
            (-0.4 * half_x_m, -0.5 * half_y_m),
        ] {
            let h = 0.5 * PILLAR;
            boxes.push(([cx - h, cy - h, 0.0], [cx + h, cy + h, PILLAR_H]));
        }
        let solids = boxes
            .iter()
            .map(|&(min, max)| Solid::Box { min, max })
            .collect();
        let features = boxes
            .iter()
            .map(|&(min, max)| Feature::block(min, max))
            .collect();
        Self {
            name: "room",
            ground: Vec::new(),
            solids,
            features,
            target_x: None,
        }
    }

    /// A ditch: a trench `depth_m` deep from `x0` to `x0 + width_m`, across all y.
    #[must_use]
    pub fn ditch(x0: f64, width_m: f64, depth_m: f64) -> Self {
        Self {
            name: "ditch",
            ground: vec![GroundTerm::Trench {
                x0,
                width_m,
                depth_m,
                y_min: ALL_Y.0,
                y_max: ALL_Y.1,
            }],
            solids: Vec::new(),
            features: vec![Feature {
                kind: FeatureKind::Ditch,
                footprint: Footprint::Rect {
                    x_min: x0,
                    x_max: x0 + width_m,
                    y_min: ALL_Y.0,
                    y_max: ALL_Y.1,
                },
                bottom_m: -depth_m,
                height_m: depth_m,
            }],
            target_x: Some(x0),
        }
    }

    /// An overhanging branch: a box from `x0` to `x0 + length_m`, `width_m` wide centred on
    /// y = 0, between heights `z_min` and `z_max` (no trunk).
    #[must_use]
    pub fn branch(x0: f64, length_m: f64, width_m: f64, z_min: f64, z_max: f64) -> Self {
        let (min, max) = (
            [x0, -0.5 * width_m, z_min],
            [x0 + length_m, 0.5 * width_m, z_max],
        );
        Self {
            name: "branch",
            ground: Vec::new(),
            solids: vec![Solid::Box { min, max }],
            features: vec![Feature {
                kind: FeatureKind::Branch,
                footprint: Footprint::Rect {
                    x_min: min[0],
                    x_max: max[0],
                    y_min: min[1],
                    y_max: max[1],
                },
                bottom_m: z_min,
                height_m: z_max - z_min,
            }],
            target_x: Some(x0),
        }
    }

    /// Ground rising at `angle_deg` from `x0` on (no obstacle features: a 10° slope is
    /// navigable).
    #[must_use]
    pub fn slope(x0: f64, angle_deg: f64) -> Self {
        Self {
            name: "slope",
            ground: vec![GroundTerm::Slope {
                x0,
                angle_rad: angle_deg.to_radians(),
            }],
            solids: Vec::new(),
            features: Vec::new(),
            target_x: Some(x0),
        }
    }
}
