//! The terrain scenes: a street (camber, curbs, kerb cuts, sidewalks, gravel, grass, stairs,
//! ramps, posts and blocks), the step gallery ([`GALLERY_STEPS_M`]), rough ground and a
//! cambered road, with the features that give their truth.
use super::{Rect, Rise, TerrainTerm};
use crate::sim::scene::{Feature, FeatureKind, Footprint, GroundTerm, Scene, Solid};

/// A feature along the segment from `(x0, y0)` to `(x1, y1)` (an axis-parallel line).
fn edge(kind: FeatureKind, x0: f64, x1: f64, y0: f64, y1: f64, height_m: f64) -> Feature {
    Feature {
        kind,
        footprint: Footprint::Rect {
            x_min: x0.min(x1),
            x_max: x0.max(x1),
            y_min: y0.min(y1),
            y_max: y0.max(y1),
        },
        bottom_m: 0.0,
        height_m,
    }
}

/// The sides of a ramp as features of 0.05 m segments along it, where the ramp has risen by
/// `t·height`: cut into a platform of `height` (a kerb cut, `into_platform`) the step beside
/// it is `height·(1 − t)`; standing on level ground (a hill) it is `height·t`. Each segment
/// carries its tallest value.
fn ramp_sides(
    rect: Rect,
    height: f64,
    rise: Rise,
    kind: FeatureKind,
    into_platform: bool,
) -> Vec<Feature> {
    let mut out = Vec::new();
    let (along, lo, hi) = match rise {
        Rise::PlusY | Rise::MinusY => (true, rect.y_min, rect.y_max),
        Rise::PlusX | Rise::MinusX => (false, rect.x_min, rect.x_max),
    };
    let n = ((hi - lo) / 0.05).ceil().max(1.0);
    #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
    let segments = n as usize;
    for s in 0..segments {
        #[allow(clippy::cast_precision_loss)]
        let (a, b) = (
            lo + (hi - lo) * s as f64 / n,
            lo + (hi - lo) * (s + 1) as f64 / n,
        );
        // The ramp's height fractions at the segment's ends.
        let (ta, tb) = match rise {
            Rise::PlusX | Rise::PlusY => ((a - lo) / (hi - lo), (b - lo) / (hi - lo)),
            Rise::MinusX | Rise::MinusY => ((hi - a) / (hi - lo), (hi - b) / (hi - lo)),
        };
        let side = if into_platform {
            height.abs() * (1.0 - ta.min(tb))
        } else {
            height.abs() * ta.max(tb)
        };
        if side <= 1e-9 {
            continue;
        }
        if along {
            out.push(edge(kind, rect.x_min, rect.x_min, a, b, side));
            out.push(edge(kind, rect.x_max, rect.x_max, a, b, side));
        } else {
            out.push(edge(kind, a, b, rect.y_min, rect.y_min, side));
            out.push(edge(kind, a, b, rect.y_max, rect.y_max, side));
        }
    }
    out
}

/// The four edges of a platform of `height` on `rect` (finite sides only).
fn platform_edges(rect: Rect, height: f64, kind: FeatureKind) -> Vec<Feature> {
    let Rect {
        x_min,
        x_max,
        y_min,
        y_max,
    } = rect;
    // Each side: where it lies, and its segment (x0, x1, y0, y1).
    [
        (x_min, [x_min, x_min, y_min, y_max]),
        (x_max, [x_max, x_max, y_min, y_max]),
        (y_min, [x_min, x_max, y_min, y_min]),
        (y_max, [x_min, x_max, y_max, y_max]),
    ]
    .into_iter()
    .filter(|(at, _)| at.is_finite())
    .map(|(_, [x0, x1, y0, y1])| edge(kind, x0, x1, y0, y1, height.abs()))
    .collect()
}

/// The curb along `y = road_m` on the left of a road (+y), `height` metres tall: the sidewalk
/// and everything beyond it raised to `height` but for a kerb cut over `x ∈ cut` (metres), a
/// 1.2 m ramp from the road up to the sidewalk; its ground terms go to `ground`, the curb's
/// edges and the cut's sides (as curbs) to `features`.
fn left_curb_with_kerb_cut(
    ground: &mut Vec<GroundTerm>,
    features: &mut Vec<Feature>,
    road_m: f64,
    cut: (f64, f64),
    height: f64,
) {
    let inf = f64::INFINITY;
    for rect in [
        Rect::new(-inf, cut.0, road_m, inf),
        Rect::new(cut.1, inf, road_m, inf),
        Rect::new(cut.0, cut.1, road_m + 1.2, inf),
    ] {
        ground.push(GroundTerm::Terrain(TerrainTerm::Platform { rect, height }));
    }
    let kerb_cut = Rect::new(cut.0, cut.1, road_m, road_m + 1.2);
    ground.push(GroundTerm::Terrain(TerrainTerm::Ramp {
        rect: kerb_cut,
        height,
        rise: Rise::PlusY,
    }));
    features.push(edge(FeatureKind::Curb, -inf, cut.0, road_m, road_m, height));
    features.push(edge(FeatureKind::Curb, cut.1, inf, road_m, road_m, height));
    features.extend(ramp_sides(
        kerb_cut,
        height,
        Rise::PlusY,
        FeatureKind::Curb,
        true,
    ));
}

/// A box standing on the ground (a wall, a parked car) as a solid and its feature.
fn block(min: [f64; 3], max: [f64; 3]) -> (Solid, Feature) {
    (Solid::Box { min, max }, Feature::block(min, max))
}

/// A pole of radius 0.05 m and 2.5 m standing at `(x, y)` on ground at `z0`.
fn pole(x: f64, y: f64, z0: f64) -> (Solid, Feature) {
    (
        Solid::Cylinder {
            centre: [x, y],
            radius_m: 0.05,
            z_min: z0 - 0.2,
            z_max: z0 + 2.5,
        },
        Feature {
            kind: FeatureKind::Post,
            footprint: Footprint::Disc {
                centre: [x, y],
                radius_m: 0.05,
            },
            bottom_m: 0.0,
            height_m: 2.5,
        },
    )
}

/// The heights of the step gallery ([`Scene::step_gallery`]), metres.
pub const GALLERY_STEPS_M: [f64; 8] = [0.03, 0.05, 0.06, 0.08, 0.10, 0.12, 0.15, 0.20];

impl Scene {
    /// A street for the car laser and the paper's robot, driven along +x at y = 0:
    /// - a road `|y| ≤ 3.5 m` crowned with a 2.5 % camber;
    /// - on the left (y > 3.5) a 15 cm curb and a sidewalk to y = 6 rising 2 % away from the
    ///   road, with a kerb cut at x ∈ [4, 5.5] (a 1.2 m ramp, 7°); beyond it gravel
    ///   (±1.2 cm, λ 0.04 m) for x < 3, stairs of four 16 cm risers every 0.3 m from y = 7
    ///   for x ∈ [6, 10], and a 15° ramp up 0.54 m from y = 6 to y = 8 for x ∈ [12, 18];
    /// - on the right (y < −3.5) a 10 cm curb and a sidewalk to y = −6, level; beyond it
    ///   grass (±2.5 cm, λ 0.12 m) for x < 5, a 10° slope away from the road (falling) for
    ///   x ∈ [5, 20], a 0.3 m deep ditch at y ∈ [−13, −12.4] for x < 5;
    /// - a parked car (a 4.5 × 1.8 × 1.4 m box) at x ∈ [8, 12.5], y ∈ [1.4, 3.2]; poles at
    ///   (2, 5.0) and (9, −5.0); a facade (a wall 3 m tall) at y ≥ 14;
    /// - everywhere, a swell of ±`swell_m` on a 3 m lattice (0 for none).
    #[must_use]
    #[allow(clippy::too_many_lines)]
    pub fn street(swell_m: f64) -> Self {
        const ROAD: f64 = 3.5;
        const LEFT_CURB: f64 = 0.15;
        const RIGHT_CURB: f64 = 0.10;
        const CAMBER: f64 = 0.025;
        let edge_z = -CAMBER * ROAD;
        let inf = f64::INFINITY;
        let cut = (4.0, 5.5);
        let mut ground = vec![GroundTerm::Terrain(TerrainTerm::Camber {
            y_centre: 0.0,
            half_width: ROAD,
            grade: CAMBER,
        })];
        if swell_m != 0.0 {
            ground.push(GroundTerm::Terrain(TerrainTerm::Swell {
                amplitude: swell_m,
                wavelength: 3.0,
                seed: 17,
            }));
        }
        let mut features = Vec::new();
        let mut solids = Vec::new();
        left_curb_with_kerb_cut(&mut ground, &mut features, ROAD, cut, LEFT_CURB);
        ground.push(GroundTerm::Terrain(TerrainTerm::SideSlope {
            y0: ROAD,
            grade: 0.02,
            dir: 1.0,
        }));
        // Gravel beyond the left sidewalk.
        ground.push(GroundTerm::Terrain(TerrainTerm::Rough {
            rect: Rect::new(-20.0, 3.0, 6.0, 13.0),
            amplitude: 0.012,
            wavelength: 0.04,
            seed: 11,
        }));
        // Stairs across y on the left.
        for i in 0..4 {
            let y = 7.0 + 0.3 * f64::from(i);
            let rect = Rect::new(6.0, 10.0, y, inf);
            ground.push(GroundTerm::Terrain(TerrainTerm::Platform {
                rect,
                height: 0.16,
            }));
            features.push(edge(FeatureKind::StepEdge, 6.0, 10.0, y, y, 0.16));
            features.push(edge(FeatureKind::StepEdge, 6.0, 6.0, y, inf, 0.16));
            features.push(edge(FeatureKind::StepEdge, 10.0, 10.0, y, inf, 0.16));
        }
        // A 15° ramp up from y = 6 to y = 8, then a plateau, for x ∈ [12, 18].
        let hill = Rect::new(12.0, 18.0, 6.0, 8.0);
        let hill_rise = 2.0 * 15f64.to_radians().tan();
        ground.push(GroundTerm::Terrain(TerrainTerm::Ramp {
            rect: hill,
            height: hill_rise,
            rise: Rise::PlusY,
        }));
        ground.push(GroundTerm::Terrain(TerrainTerm::Platform {
            rect: Rect::new(12.0, 18.0, 8.0 + 1e-9, inf),
            height: hill_rise,
        }));
        features.extend(ramp_sides(
            hill,
            hill_rise,
            Rise::PlusY,
            FeatureKind::Curb,
            false,
        ));
        features.push(edge(FeatureKind::Curb, 12.0, 12.0, 8.0, inf, hill_rise));
        features.push(edge(FeatureKind::Curb, 18.0, 18.0, 8.0, inf, hill_rise));
        // Right: a curb, a level sidewalk, then grass, a falling 10° slope and a ditch.
        ground.push(GroundTerm::Terrain(TerrainTerm::Platform {
            rect: Rect::new(-inf, inf, -inf, -ROAD),
            height: RIGHT_CURB,
        }));
        features.push(edge(FeatureKind::Curb, -inf, inf, -ROAD, -ROAD, RIGHT_CURB));
        ground.push(GroundTerm::Terrain(TerrainTerm::Rough {
            rect: Rect::new(-20.0, 5.0, -20.0, -6.0),
            amplitude: 0.025,
            wavelength: 0.12,
            seed: 7,
        }));
        ground.push(GroundTerm::Terrain(TerrainTerm::Ramp {
            rect: Rect::new(5.0, 20.0, -12.0, -6.0),
            height: -6.0 * 10f64.to_radians().tan(),
            rise: Rise::MinusY,
        }));
        ground.push(GroundTerm::Terrain(TerrainTerm::Platform {
            rect: Rect::new(5.0, 20.0, -inf, -12.0 - 1e-9),
            height: -6.0 * 10f64.to_radians().tan(),
        }));
        // The slope's sides against the level ground beside it (x = 5 and x = 20): drops.
        features.extend(ramp_sides(
            Rect::new(5.0, 20.0, -12.0, -6.0),
            6.0 * 10f64.to_radians().tan(),
            Rise::MinusY,
            FeatureKind::Curb,
            false,
        ));
        features.push(edge(
            FeatureKind::Curb,
            5.0,
            5.0,
            -inf,
            -12.0,
            6.0 * 10f64.to_radians().tan(),
        ));
        features.push(edge(
            FeatureKind::Curb,
            20.0,
            20.0,
            -inf,
            -12.0,
            6.0 * 10f64.to_radians().tan(),
        ));
        let ditch = Rect::new(-inf, 5.0, -13.0, -12.4);
        ground.push(GroundTerm::Terrain(TerrainTerm::Platform {
            rect: ditch,
            height: -0.3,
        }));
        features.push(Feature {
            kind: FeatureKind::Ditch,
            footprint: Footprint::Rect {
                x_min: ditch.x_min,
                x_max: ditch.x_max,
                y_min: ditch.y_min,
                y_max: ditch.y_max,
            },
            bottom_m: -0.3,
            height_m: 0.3,
        });
        // Objects.
        let road_edge = edge_z;
        for (s, f) in [
            block([8.0, 1.4, road_edge - 0.2], [12.5, 3.2, 1.4 + road_edge]),
            block([-20.0, 14.0, 0.0], [30.0, 14.5, 3.0]),
            pole(2.0, 5.0, LEFT_CURB),
            pole(9.0, -5.0, RIGHT_CURB + edge_z),
        ] {
            solids.push(s);
            features.push(f);
        }
        Self {
            name: "street",
            ground,
            solids,
            features,
            target_x: None,
        }
    }

    /// Flat ground with square platforms (1.5 m × 1.5 m) of each height of
    /// [`GALLERY_STEPS_M`], in rows at x = `x0`, `x0` + 4, … (one row per entry of `rows`, a
    /// row's platforms 2.5 m apart across y, centred on y = 0): the smallest step each layer
    /// still finds. Features: every platform's four edges.
    #[must_use]
    pub fn step_gallery(rows: &[f64]) -> Self {
        let mut ground = Vec::new();
        let mut features = Vec::new();
        #[allow(clippy::cast_precision_loss)]
        let n = GALLERY_STEPS_M.len() as f64;
        for &x0 in rows {
            for (i, &h) in GALLERY_STEPS_M.iter().enumerate() {
                #[allow(clippy::cast_precision_loss)]
                let y = (i as f64 - 0.5 * (n - 1.0)) * 2.5 - 0.75 + 0.013;
                let rect = Rect::new(x0 + 0.013, x0 + 1.513, y, y + 1.5);
                ground.push(GroundTerm::Terrain(TerrainTerm::Platform {
                    rect,
                    height: h,
                }));
                features.extend(platform_edges(rect, h, FeatureKind::StepEdge));
            }
        }
        Self {
            name: "step gallery",
            ground,
            solids: Vec::new(),
            features,
            target_x: rows.first().copied(),
        }
    }

    /// Flat ground for x < `x0`, then grass (±`amplitude`, λ 0.12 m) for x ∈ [x0, x0 + 8]
    /// over |y| ≤ 4 m, then gravel (±1.2 cm, λ 0.04 m) from x0 + 8 to x0 + 14. No obstacle.
    #[must_use]
    pub fn rough(x0: f64, amplitude: f64) -> Self {
        Self {
            name: "rough",
            ground: vec![
                GroundTerm::Terrain(TerrainTerm::Rough {
                    rect: Rect::new(x0, x0 + 8.0, -4.0, 4.0),
                    amplitude,
                    wavelength: 0.12,
                    seed: 3,
                }),
                GroundTerm::Terrain(TerrainTerm::Rough {
                    rect: Rect::new(x0 + 8.0, x0 + 14.0, -4.0, 4.0),
                    amplitude: 0.012,
                    wavelength: 0.04,
                    seed: 5,
                }),
            ],
            solids: Vec::new(),
            features: Vec::new(),
            target_x: Some(x0),
        }
    }

    /// A crowned road (`grade` camber over |y| ≤ 3.5 m) with curbs of `curb_m` at |y| = 3.5
    /// and a kerb cut (1.2 m ramp) in the left curb at x ∈ [`cut_x`, `cut_x` + 1.5]; the
    /// sidewalks level beyond.
    #[must_use]
    pub fn cambered_road(grade: f64, curb_m: f64, cut_x: f64) -> Self {
        const ROAD: f64 = 3.5;
        let inf = f64::INFINITY;
        let cut = (cut_x, cut_x + 1.5);
        let mut ground = vec![GroundTerm::Terrain(TerrainTerm::Camber {
            y_centre: 0.0,
            half_width: ROAD,
            grade,
        })];
        let mut features = Vec::new();
        left_curb_with_kerb_cut(&mut ground, &mut features, ROAD, cut, curb_m);
        // The right curb, unbroken.
        ground.push(GroundTerm::Terrain(TerrainTerm::Platform {
            rect: Rect::new(-inf, inf, -inf, -ROAD),
            height: curb_m,
        }));
        features.push(edge(FeatureKind::Curb, -inf, inf, -ROAD, -ROAD, curb_m));
        Self {
            name: "cambered road",
            ground,
            solids: Vec::new(),
            features,
            target_x: None,
        }
    }
}
