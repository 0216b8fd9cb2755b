//! The navigability rule's unit tests: the plane state's sums and halvings, the noise, and the
//! fixed-point decision against a 128-bit and an f64 reference.

use super::decision::*;
use super::*;
use crate::test_rng::XorShift;
extern crate std;

fn geometry(cell_m: f32) -> CellGeometry {
    CellGeometry {
        cell: Meters::from_num(cell_m).to_bits(),
        sensor_height_mm: 1000,
        distance: Meters::from_num(5),
    }
}

fn params(sigma: f32) -> PlaneParams {
    PlaneParams::new(
        &PlaneRule {
            range_sigma: Meters::from_num(sigma),
            angle_sigma: Ratio::ZERO,
            ..PlaneRule::DEFAULT
        },
        Meters::from_num(0.05),
    )
}

/// The sums of points on a lattice of the cell, height `f(u, v)` mm.
fn lattice(f: impl Fn(i32, i32) -> i32) -> PlaneState {
    let mut s = PlaneState::EMPTY;
    for i in 0..7 {
        for j in 0..7 {
            let (u, v) = (-30 + 10 * i, -30 + 10 * j);
            s.add(
                i8::try_from(u).unwrap(),
                i8::try_from(v).unwrap(),
                i16::try_from(f(u, v)).unwrap(),
            );
        }
    }
    s
}

#[test]
fn a_slope_below_the_limit_is_navigable_and_a_step_is_not() {
    // A 1 m cell: a unit is 1/64 m = 15.6 mm.
    let g = geometry(1.0);
    let p = params(0.0);
    // 10°: 2.76 mm per unit.
    let slope = lattice(|u, v| (f64::from(u + v) * 15.625 * 0.176).round() as i32);
    assert!(!plane_obstacle(&slope, &p, &g, 0));
    // 30°: steeper than 20°, rising 0.58 m across the cell.
    let steep = lattice(|u, _| (f64::from(u) * 15.625 * 0.577).round() as i32);
    assert!(plane_obstacle(&steep, &p, &g, 0));
    // A 10 cm step across the middle: RMS 2.4 cm about the best plane.
    let step = lattice(|u, _| if u > 0 { 100 } else { 0 });
    assert!(plane_obstacle(&step, &p, &g, 0));
    // 1 cm of texture: within the residual allowance.
    let texture = lattice(|u, v| if (u + v) % 20 == 0 { 10 } else { -10 });
    assert!(!plane_obstacle(&texture, &p, &g, 0));
}

#[test]
fn noise_widens_the_allowance() {
    let g = geometry(1.0);
    // ±25 mm of alternating "noise": RMS 25 mm, over 1.5 cm.
    let noisy = lattice(|u, v| if (u / 10 + v / 10) % 2 == 0 { 25 } else { -25 });
    assert!(plane_obstacle(&noisy, &params(0.0), &g, 0));
    // σ = 2 cm at 5 m from a sensor 1 m up: σ_z = 3.9 mm; k = 2 → √(15² + 7.8²) = 17 mm.
    assert!(plane_obstacle(&noisy, &params(0.02), &g, 0));
    // σ = 10 cm: σ_z = 19.6 mm, allowance √(15² + 39²) = 42 mm.
    assert!(!plane_obstacle(&noisy, &params(0.10), &g, 0));
}

#[test]
fn a_single_point_or_a_vertical_line_of_points() {
    let g = geometry(0.1);
    let p = params(0.0);
    assert!(!plane_obstacle(&PlaneState::first(3, 4, 100), &p, &g, 0));
    // A post: points at one (u, v), 0 … 300 mm: no slope fits, the residual is the spread.
    let mut post = PlaneState::EMPTY;
    for z in 0..30 {
        post.add(5, 5, z * 10);
    }
    assert!(plane_obstacle(&post, &p, &g, 0));
}

#[test]
fn at_the_last_level_halving_changes_nothing() {
    let mut s = PlaneState::EMPTY;
    for i in 0..HALVE_AT {
        s.add_next(i8::try_from(i % 64).unwrap() - 32, 3, 100);
    }
    // The first halving happened at 62 summed points.
    assert_eq!((s.n, s.level), (HALVE_AT / 2, 1));
    s.level = MAX_LEVEL;
    s.n = HALVE_AT;
    let before = s;
    s.halve();
    assert_eq!(s, before);
    s.level = MAX_LEVEL - 1;
    s.halve();
    assert_eq!(
        (s.n, s.level, s.su()),
        (HALVE_AT / 2, MAX_LEVEL, before.su() >> 1)
    );
}

#[test]
fn halving_keeps_the_sums_within_their_widths_and_the_decision() {
    let g = geometry(2.0);
    let p = params(0.0);
    let mut flat = PlaneState::EMPTY;
    let mut step = PlaneState::EMPTY;
    for i in 0..60_000_u32 {
        let u = i8::try_from((i * 7) % 64).unwrap() - 32;
        let v = i8::try_from((i * 13) % 64).unwrap() - 32;
        flat.add(u, v, i16::try_from((i * 31) % 9).unwrap());
        step.add(u, v, if u > 0 { 8191 } else { -8192 });
    }
    assert!(flat.count() < HALVE_AT && flat.level > 5);
    assert!(!plane_obstacle(&flat, &p, &g, 0));
    assert!(plane_obstacle(&step, &p, &g, 0));
    assert!(step.szz <= 62 * 8192 * 8192);
}

#[test]
fn the_elevation_error_widens_the_allowance_with_range() {
    let with_angle = PlaneParams::new(&PlaneRule::DEFAULT, Meters::from_num(0.05));
    let at = |d: f32| CellGeometry {
        cell: Meters::from_num(1).to_bits(),
        sensor_height_mm: 1300,
        distance: Meters::from_num(d),
    };
    // k·σ_z at 3 m: √((20·1.3/3.27)² + (1.309e-3·3270)²) = 9.0 mm, times 2; at 20 m:
    // √(1.3² + 26.2²) = 26.3 mm, times 2.
    let mm = |v: i64| v as f64 / 65_536.0;
    assert!((mm(noise_q16(&with_angle, &at(3.0))) - 18.0).abs() < 0.2);
    assert!((mm(noise_q16(&with_angle, &at(20.0))) - 52.5).abs() < 0.3);
}

#[test]
fn the_quick_bound_is_the_default_and_never_hides_an_obstacle() {
    assert_eq!(
        PlaneParams::new(&PlaneRule::DEFAULT, Meters::from_num(0.05)),
        PlaneParams::DEFAULT
    );
    // Cells whose spread is at the bound: no plane through them is an obstacle, whatever
    // their layout, with no noise allowance at all.
    let p = params(0.0);
    let g = geometry(0.1);
    let top = i16::try_from(p.quick_mm).unwrap();
    let mut state = 0x9E37_79B9_u32;
    for _ in 0..2000 {
        let mut s = PlaneState::EMPTY;
        for _ in 0..(2 + state % 40) {
            state ^= state << 13;
            state ^= state >> 17;
            state ^= state << 5;
            let u = i8::try_from(state % 64).unwrap() - 32;
            let v = i8::try_from((state >> 8) % 64).unwrap() - 32;
            let z = if (state >> 16).is_multiple_of(2) {
                0
            } else {
                top
            };
            s.add(u, v, z);
        }
        assert!(!plane_obstacle(&s, &p, &g, 0));
    }
}

/// [`plane_obstacle`] as it was, in 128 bits from the start.
fn plane_obstacle_128(state: &PlaneState, params: &PlaneParams, geometry: &CellGeometry) -> bool {
    let n = i128::from(state.n);
    if n < 2 {
        return false;
    }
    let (su, sv) = (i128::from(state.su()), i128::from(state.sv()));
    let sz = i128::from(state.sz);
    let cuu = n * i128::from(state.suu()) - su * su;
    let cvv = n * i128::from(state.svv()) - sv * sv;
    let cuv = n * i128::from(state.suv) - su * sv;
    let cuz = n * i128::from(state.suz) - su * sz;
    let cvz = n * i128::from(state.svz) - sv * sz;
    let czz = n * i128::from(state.szz) - sz * sz;
    let n2 = n * n;
    let (a, b) = (cuu + n2, cvv + n2);
    let det = a * b - cuv * cuv;
    if det <= 0 {
        return false;
    }
    let wa = q16_quotient(b * cuz - cuv * cvz, det);
    let wb = q16_quotient(a * cvz - cuv * cuz, det);
    let explained = wa * wa * cuu + 2 * wa * wb * cuv + wb * wb * cvv;
    let wc = wa * cuz + wb * cvz;
    let residual = (czz << 32) - 2 * (wc << 16) + explained;
    let noise = i128::from(noise_q16(params, geometry));
    let allowed = i128::from(params.residual_q16)
        .saturating_mul(i128::from(params.residual_q16))
        .saturating_add(noise.saturating_mul(noise));
    if residual > allowed.saturating_mul(n2) {
        return true;
    }
    let slope = isqrt((wa * wa + wb * wb) as u128) as i128;
    let cell_mm_q16 = i128::from(geometry.cell.max(1)) * 1000;
    let steep = 64 * slope - ((i128::from(params.grade_q16) * cell_mm_q16) >> 16);
    if steep <= 0 {
        return false;
    }
    rises_too_far(explained, slope, steep, state.n, noise, params.step_q16)
}

#[test]
fn the_decision_in_64_bits_first_is_the_128_bit_one() {
    let mut rng = XorShift(0xD1B5_4A32_D192_ED03_u64);
    let mut next = || rng.next();
    let mut obstacles = 0;
    let total = 20_000;
    for run in 0..total {
        // Cells of 2 to 3000 points: at the corners and extreme heights (the sums' bounds),
        // planes with noise, steps, random clouds; under rules from strict to lax.
        let mut s = PlaneState::EMPTY;
        let points = 2 + next() % if run % 10 == 0 { 3000 } else { 80 };
        let kind = next() % 4;
        let (gu, gv, off) = ((next() % 200) as i32 - 100, (next() % 200) as i32 - 100, 0);
        for _ in 0..points {
            let r = next();
            let (u, v) = ((r % 64) as i8 - 32, ((r >> 8) % 64) as i8 - 32);
            let z = match kind {
                0 => {
                    let c = [-32_i8, 31][(r >> 20) as usize % 2];
                    s.add(c, c, [i16::MIN, i16::MAX, 0][(r >> 24) as usize % 3]);
                    continue;
                }
                1 => off + gu * i32::from(u) / 10 + gv * i32::from(v) / 10 + (r >> 40) as i32 % 9,
                2 => (if u > 0 { 300 } else { 0 }) + (r >> 40) as i32 % 5,
                _ => (r >> 32) as i16 as i32 / 4,
            };
            s.add(u, v, z.clamp(-32_768, 32_767) as i16);
        }
        let params = PlaneParams::new(
            &PlaneRule {
                max_grade: Ratio::from_bits((next() % 80_000) as i32),
                residual: Meters::from_bits((next() % 3000) as i32),
                range_sigma: Meters::from_bits((next() % 3000) as i32),
                ..PlaneRule::DEFAULT
            },
            Meters::from_bits((next() % 10_000) as i32),
        );
        let geometry = CellGeometry {
            cell: Meters::from_num(0.1).to_bits() << (next() % 8),
            sensor_height_mm: (next() % 2000) as i32,
            distance: Meters::from_bits((next() % (30 << 16)) as i32),
        };
        let got = plane_obstacle(&s, &params, &geometry, 0);
        assert_eq!(got, plane_obstacle_128(&s, &params, &geometry), "run {run}");
        obstacles += usize::from(got);
    }
    // Both answers occur.
    assert!(
        obstacles > total / 20 && obstacles < total * 19 / 20,
        "{obstacles}"
    );
}

#[test]
fn the_slope_bound_in_64_bits_is_the_root_comparison() {
    // tan·c against the 128-bit product, at the extremes and at random.
    let mut rng = XorShift(0x9E37_79B9_7F4A_7C15_u64);
    let edges = [0_i64, 1, 2, 0xFFFF, 0x1_0000, 0x7FFF_FFFF];
    let cells = [
        i32::MIN,
        -1,
        0,
        1,
        655,
        6_554,
        0xFFFF,
        0x1_0000,
        1 << 29,
        i32::MAX,
    ];
    let mut pairs: std::vec::Vec<(i64, i32)> = edges
        .iter()
        .flat_map(|&g| cells.iter().map(move |&c| (g, c)))
        .collect();
    for _ in 0..100_000 {
        let g = (rng.next() >> (33 + rng.next() % 31)) as i64;
        let c = (rng.next() >> (32 + rng.next() % 32)) as u32 as i32;
        pairs.push((g, c));
    }
    for (grade, cell) in pairs {
        let expected = (i128::from(grade) * i128::from(cell.max(1)) * 1000) >> 16;
        assert_eq!(
            i128::from(tan_times_cell(grade, cell)),
            expected,
            "{grade} {cell}"
        );
    }
    // "Not steeper" exactly when 64·⌊√(wa² + wb²)⌋ ≤ tan·c, wherever it decides; next to
    // the bound (the squares of the bound ± 2) and at random.
    let root_says =
        |wa: i128, wb: i128, t: i128| 64 * isqrt((wa * wa + wb * wb) as u128) as i128 <= t;
    let mut decided = 0;
    for _ in 0..200_000 {
        let t = i128::from((rng.next() >> (24 + rng.next() % 40)) as i64);
        let m = (t >> 6) + 1;
        let (wa, wb) = if rng.next().is_multiple_of(2) {
            // wa² + wb² within a few of m² (wb small).
            let wb = (rng.next() % 8) as i128;
            let target = m * m - wb * wb + (rng.next() % 5) as i128 - 2;
            let wa = isqrt(target.max(0) as u128) as i128;
            (wa, wb)
        } else {
            let w = |r: u64| {
                (r >> (30 + r % 34)) as i64 as i128 * if r.is_multiple_of(3) { -1 } else { 1 }
            };
            (w(rng.next()), w(rng.next()))
        };
        let fast = not_steeper(wa, wb, t);
        if fast {
            decided += 1;
            assert!(root_says(wa, wb, t), "{wa} {wb} {t}");
        } else if i32::try_from(wa).is_ok() && i32::try_from(wb).is_ok() && u32::try_from(m).is_ok()
        {
            assert!(!root_says(wa, wb, t), "{wa} {wb} {t}");
        }
    }
    assert!(decided > 20_000, "{decided}");
}

#[test]
fn the_moments_in_32_bits_are_the_128_bit_moments() {
    let mut rng = XorShift(0x2545_F491_4F6C_DD1D_u64);
    let mut next = || rng.next();
    let mut widest = (0_i128, 0_i128);
    for run in 0..20_000 {
        // Up to 3000 points: the extreme corners and heights in opposite pairs (the
        // largest moments), or random ones.
        let mut s = PlaneState::EMPTY;
        let extreme = run % 2 == 0;
        for i in 0..(1 + next() % if run % 10 == 0 { 3000 } else { 70 }) {
            let r = next();
            let (u, v, z) = if extreme {
                let high = (i + r % 2) % 2 == 0;
                let (c, z) = if high { (31, 8191) } else { (-32, -8192) };
                let flip = (r >> 8) % 4 == 0;
                (c, if flip { -1 - c } else { c }, if i == 0 { 0 } else { z })
            } else {
                let (u, v) = ((r % 64) as i8 - 32, ((r >> 8) % 64) as i8 - 32);
                (u, v, (r >> 32) as i16)
            };
            s.add(u, v, z);
        }
        let m = moments(&s);
        let n = i128::from(s.n);
        let (su, sv, sz) = (i128::from(s.su()), i128::from(s.sv()), i128::from(s.sz));
        let cuz = n * i128::from(s.suz) - su * sz;
        let cvz = n * i128::from(s.svz) - sv * sz;
        assert_eq!(i128::from(m.n), n);
        assert_eq!(
            i128::from(m.cuu),
            n * i128::from(s.suu()) - su * su,
            "run {run}"
        );
        assert_eq!(
            i128::from(m.cvv),
            n * i128::from(s.svv()) - sv * sv,
            "run {run}"
        );
        assert_eq!(
            i128::from(m.cuv),
            n * i128::from(s.suv) - su * sv,
            "run {run}"
        );
        assert_eq!(i128::from(m.cuz), cuz, "run {run}");
        assert_eq!(i128::from(m.cvz), cvz, "run {run}");
        assert_eq!(
            i128::from(m.czz),
            n * i128::from(s.szz) - sz * sz,
            "run {run}"
        );
        widest = (widest.0.max(cuz.abs()), widest.1.max(i128::from(m.czz)));
    }
    // The extremes are reached: C_uz near its largest, C_zz beyond 32 bits.
    assert!(widest.0 > 1 << 29, "{widest:?}");
    assert!(widest.1 > 1 << 33, "{widest:?}");
}

#[test]
fn the_residual_in_64_bits_is_the_128_bit_residual() {
    let mut rng = XorShift(0x9E37_79B9_7F4A_7C15_u64);
    let mut next = || rng.next();
    let (mut narrow, mut wide) = (0, 0);
    for run in 0..200_000 {
        // Moments within their bounds (extremes one run in four), planes from flat to
        // beyond the narrow range.
        let extreme = run % 4 == 0;
        let mut within = |bits: u32| {
            let r = next();
            let magnitude = if extreme {
                (1_i64 << bits) - 1 - (r % 4) as i64
            } else {
                (r >> 8) as i64 % (1 << (r % u64::from(bits + 1)))
            };
            if r & 1 == 0 {
                magnitude
            } else {
                -magnitude
            }
        };
        let m = Moments {
            n: 62,
            cuu: within(22) as i32,
            cvv: within(22) as i32,
            cuv: within(22) as i32,
            cuz: within(31) as i32,
            cvz: within(31) as i32,
            czz: within(if run % 3 == 0 { 39 } else { 30 }),
        };
        let mut plane = || {
            let r = next();
            let magnitude = ((r >> 8) % (1 << (r % 24))) as i128;
            if r & 1 == 0 {
                magnitude
            } else {
                -magnitude
            }
        };
        let (wa, wb) = (plane(), plane());
        let (cuu, cvv, cuv) = (i128::from(m.cuu), i128::from(m.cvv), i128::from(m.cuv));
        let (cuz, cvz, czz) = (i128::from(m.cuz), i128::from(m.cvz), i128::from(m.czz));
        let explained = wa * wa * cuu + 2 * wa * wb * cuv + wb * wb * cvv;
        let residual = (czz << 32) - 2 * ((wa * cuz + wb * cvz) << 16) + explained;
        match residual_narrow(wa, wb, &m) {
            Some((e, r)) => {
                assert_eq!(
                    (i128::from(e), i128::from(r)),
                    (explained, residual),
                    "{run}"
                );
                narrow += 1;
            }
            None => wide += 1,
        }
    }
    // Both paths taken, each about half the time.
    assert!(narrow > 50_000 && wide > 50_000, "{narrow} {wide}");
    for x in [
        0,
        1,
        -1,
        i64::from(i32::MAX),
        i64::from(i32::MIN),
        1 << 31,
        i64::MIN,
    ] {
        let square = i128::from(x).saturating_mul(i128::from(x));
        assert_eq!(square_saturating(x), square, "{x}");
        for n in [0, 1, 2, 61, 62] {
            for a in [square, (1 << 51) - 1, 1 << 51, i128::MAX, -5] {
                assert_eq!(times_n2(a, n * n), a.saturating_mul(i128::from(n * n)));
            }
        }
    }
}

#[test]
fn the_noise_in_64_bits_is_the_128_bit_noise() {
    let mut rng = XorShift(0x6A09_E667_F3BC_C908_u64);
    let mut next = || rng.next();
    let mut narrow = 0;
    let pick = |next: &mut dyn FnMut() -> u64| -> i32 {
        // Zero, small, typical and extreme raw values.
        match next() % 4 {
            0 => [0, 1, i32::MAX, i32::MIN][(next() % 4) as usize],
            1 => (next() % 5000) as i32,
            _ => (next() as i32) >> (next() % 31),
        }
    };
    for _ in 0..200_000 {
        let rule = PlaneRule {
            range_sigma: Meters::from_bits(pick(&mut next)),
            angle_sigma: Ratio::from_bits(pick(&mut next)),
            noise_factor: Ratio::from_bits(pick(&mut next)),
            ..PlaneRule::DEFAULT
        };
        let params = PlaneParams::new(&rule, Meters::from_num(0.05));
        let geometry = CellGeometry {
            cell: Meters::from_num(0.1).to_bits(),
            sensor_height_mm: pick(&mut next),
            distance: Meters::from_bits(pick(&mut next)),
        };
        let wide = noise_q16_wide(&params, &geometry);
        if let Some(v) = noise_q16_narrow(&params, &geometry) {
            narrow += 1;
            assert_eq!(v, wide, "{rule:?} {geometry:?}");
        }
        assert_eq!(noise_q16(&params, &geometry), wide);
    }
    assert!(narrow > 50_000, "{narrow}");
    let default = PlaneParams::new(&PlaneRule::DEFAULT, Meters::from_num(0.05));
    for h in [0, 300, 1300, 32_767] {
        for d in [0.0, 0.5, 3.0, 20.0, 20_000.0] {
            let g = CellGeometry {
                cell: Meters::from_num(0.1).to_bits(),
                sensor_height_mm: h,
                distance: Meters::from_num(d),
            };
            assert!(noise_q16_narrow(&default, &g).is_some(), "{h} {d}");
        }
    }
}

#[test]
fn the_q16_quotient_is_the_128_bit_one() {
    let mut rng = XorShift(0x2545_F491_4F6C_DD1D_u64);
    let mut next = || rng.next();
    for _ in 0..100_000 {
        let num = i128::from((next() as i64) >> (next() % 60));
        let den = i128::from((next() >> (20 + next() % 40)).max(1) as i64);
        assert_eq!(q16_quotient(num, den), (num << 16) / den, "{num} / {den}");
    }
    assert_eq!(
        q16_quotient(i128::MAX >> 17, 3),
        (i128::MAX >> 17 << 16) / 3
    );
}

#[test]
fn the_root_table_is_the_square_root_of_12_over_n() {
    for (n, &root) in ROOT_12_OVER_N.iter().enumerate().skip(1) {
        let exact = (12.0 / n as f64).sqrt() * 65_536.0;
        assert!((f64::from(root) - exact).abs() <= 1.0, "{n}");
    }
    assert_eq!(isqrt(u128::from(u64::MAX) + 1), 1 << 32);
    assert_eq!(isqrt(99), 9);
    for x in [1_u128 << 70, (1 << 100) + 12_345, u128::MAX, 3 << 90] {
        let (got, exact) = (isqrt(x), x.isqrt());
        assert!(
            got <= exact && exact - got <= exact >> 31,
            "{x}: {got} {exact}"
        );
    }
}

/// [`PlaneState::add`] as it was before its sums stopped saturating (and while it counted
/// the decimation's phase before the first halving).
fn add_saturating(s: &mut PlaneState, u: i8, v: i8, z: i16) {
    let satu16 = |v: i32| u16::try_from(v.max(0)).unwrap_or(u16::MAX);
    let phase = s.offered;
    s.offered = s.offered.saturating_add(1);
    if u32::from(phase) & ((1_u32 << s.level) - 1) != 0 {
        return;
    }
    if s.n == 0 {
        s.z0 = z;
    }
    let dz = (i32::from(z) - i32::from(s.z0)).clamp(-8192, 8191);
    let (u, v) = (i32::from(u), i32::from(v));
    s.set_linear(
        crate::saturate::to_i16(i32::from(s.su()) + u),
        crate::saturate::to_i16(i32::from(s.sv()) + v),
    );
    s.set_squares(
        satu16(i32::from(s.suu()) + u * u),
        satu16(i32::from(s.svv()) + v * v),
    );
    s.suv = crate::saturate::to_i16(i32::from(s.suv) + u * v);
    s.sz = s.sz.saturating_add(dz);
    s.suz = s.suz.saturating_add(u * dz);
    s.svz = s.svz.saturating_add(v * dz);
    s.szz = s.szz.saturating_add((dz * dz) as u32);
    s.n += 1;
    // The halving itself did not change.
    if s.n >= HALVE_AT && s.level < MAX_LEVEL {
        s.halve();
    }
}

#[test]
fn the_sums_without_saturation_are_the_saturating_sums() {
    let mut rng = XorShift(0x9E37_79B9_7F4A_7C15_u64);
    let mut next = || rng.next();
    // Runs at the extremes (corners ±32/31, z at ±32 767 and far from z₀), runs with the
    // signs alternating, random runs, and runs long enough to reach the last level.
    for run in 0..400_u32 {
        let mut s = PlaneState::EMPTY;
        let mut reference = PlaneState::EMPTY;
        let length = if run % 200 == 0 {
            2_200_000
        } else {
            1 + next() % 5000
        };
        let kind = next() % 4;
        for i in 0..length {
            let r = next();
            let (u, v, z) = match kind {
                0 => {
                    let corner = [-32_i8, 31][(r & 1) as usize];
                    let z = [i16::MIN, i16::MAX, 0, -8192, 8191, -8193][(r >> 1) as usize % 6];
                    (corner, corner, z)
                }
                1 => {
                    let sign = if i % 2 == 0 { -32_i8 } else { 31 };
                    (sign, -32, if i % 3 == 0 { i16::MAX } else { i16::MIN })
                }
                2 => (-32, -32, (r >> 8) as i16),
                _ => (
                    (r % 64) as i8 - 32,
                    ((r >> 8) % 64) as i8 - 32,
                    (r >> 16) as i16,
                ),
            };
            s.add(u, v, z);
            add_saturating(&mut reference, u, v, z);
            // The reference counts the phase before the first halving too, unread there.
            let phase = if reference.level == 0 {
                0
            } else {
                reference.offered
            };
            assert_eq!(
                s,
                PlaneState {
                    offered: phase,
                    ..reference
                },
                "run {run} point {i}"
            );
        }
        if length > 2_000_000 {
            // As deep as the decimation goes: its phase saturates at 2¹⁶ − 1 offered
            // points, which at level 12 come before the 31 summed points that would halve.
            assert_eq!(s.level, 12);
        }
    }
}

/// The position as it was computed before: a 64-bit product, clamped.
fn sub_cell_64(rem: i64, reciprocal: u32) -> i8 {
    let rem = rem.clamp(0, i64::from(u32::MAX)) as u64;
    let q = (rem * u64::from(reciprocal)) >> 26;
    q.min(63) as i8 - 32
}

#[test]
fn sub_cell_in_32_bits_is_the_64_bit_product() {
    let mut rng = XorShift(0x9E37_79B9_7F4A_7C15_u64);
    let mut next = || rng.next();
    // Every cell size of the default designs' layers and their neighbours, sizes from
    // 1 raw up to 2³⁰, and random sizes; each at its edges and random remainders.
    let mut sizes = std::vec![1, 2, 3, 655, 6553, 6554, 6555, 13_107, 26_214, 52_429];
    sizes.extend([
        104_858,
        209_715,
        419_430,
        838_861,
        65_536,
        1 << 20,
        (1 << 30) - 1,
    ]);
    sizes.extend([1 << 30, i32::MAX]);
    for _ in 0..300 {
        sizes.push(1 + (next() % (1 << (1 + next() % 30))) as i32);
    }
    for c in sizes {
        let m = crate::grid::cell_reciprocal(c);
        let edges = (0..64_i64).flat_map(|j| {
            let at = j * i64::from(c) / 64;
            [at - 1, at, at + 1]
        });
        let random = (0..200).map(|_| (next() % c as u64) as i64);
        for rem in edges.chain(random).chain([i64::from(c) - 1]) {
            if !(0..i64::from(c)).contains(&rem) {
                continue;
            }
            assert_eq!(
                sub_cell(rem as u32, m),
                sub_cell_64(rem, m),
                "c {c} rem {rem}"
            );
        }
    }
}

#[test]
fn sub_cell_positions_cover_the_cell() {
    let c = Meters::from_num(0.3).to_bits();
    let m = crate::grid::cell_reciprocal(c);
    assert_eq!(sub_cell(0, m), -32);
    assert_eq!(sub_cell(c as u32 - 1, m), 31);
    assert!((-1..=0).contains(&sub_cell(c as u32 / 2, m)));
    // Every remainder lands within one unit of the exact value.
    for rem in (0..c).step_by(97) {
        let exact = (i64::from(rem) * 64 / i64::from(c)) as i8 - 32;
        let got = sub_cell(rem as u32, m);
        assert!(got == exact || got == exact - 1, "{rem}: {got} {exact}");
    }
}

/// A far cell crossed by one line of returns: `z(u)` mm at u = −30, −25, …, 30 (v = 0), the
/// lowest at `low` and the highest at `high`.
fn far_line(z: impl Fn(i32) -> i16, low: (i8, i8), high: (i8, i8)) -> (PlaneState, i32) {
    let mut s = PlaneState::EMPTY;
    let (mut lo, mut hi) = (i16::MAX, i16::MIN);
    for u in (-30..=30).step_by(5) {
        let h = z(u);
        s.add(i8::try_from(u).unwrap(), 0, h);
        lo = lo.min(h);
        hi = hi.max(h);
    }
    s.set_low_at(low);
    s.set_high_at(high);
    (s, i32::from(hi) - i32::from(lo))
}

/// The default rule (5 cm step) and a 0.6 m cell of the street design, `distance_m` away from
/// a laser 1.3 m up.
fn far_street_cell(distance_m: f64) -> (PlaneParams, CellGeometry) {
    (
        PlaneParams::new(&PlaneRule::DEFAULT, Meters::from_num(0.05)),
        CellGeometry {
            cell: Meters::from_num(0.6).to_bits(),
            sensor_height_mm: 1300,
            distance: Meters::from_num(distance_m),
        },
    )
}

#[test]
fn extremes_next_to_each_other_across_a_step_are_an_obstacle_and_on_a_slope_are_not() {
    // A 0.6 m cell 15 m away (the street design's far layers), the default rule: the residual
    // and rise tests take a 12 cm curb across the cell for a slope of 0.3.
    let (p, g) = far_street_cell(15.0);
    let curb = |u: i32| if u >= 5 { 120 } else { 0 };
    // The lowest just before the kerb's face, the highest just after it.
    let (s, spread) = far_line(curb, (0, 0), (5, 0));
    assert_eq!(spread, 120);
    assert!(!plane_obstacle(&s, &p, &g, 0), "the plane alone misses it");
    assert!(plane_obstacle(&s, &p, &g, spread), "the extremes find it");
    // The same curb with its extremes at the line's ends: the plane explains them.
    let (s, spread) = far_line(curb, (-30, 0), (30, 0));
    assert!(!plane_obstacle(&s, &p, &g, spread));
    // A slope rising 120 mm across the line (0.33 per metre, within 20°): navigable wherever
    // its extremes lie, as the plane explains the rise between them.
    let slope = |u: i32| i16::try_from(2 * (u + 30)).unwrap();
    let (s, spread) = far_line(slope, (-30, 0), (30, 0));
    assert_eq!(spread, 120);
    assert!(!plane_obstacle(&s, &p, &g, spread));
    // A spread within the step is never an obstacle by the extremes.
    let low_curb = |u: i32| if u >= 5 { 50 } else { 0 };
    let (s, spread) = far_line(low_curb, (0, 0), (5, 0));
    assert!(!plane_obstacle(&s, &p, &g, spread));
}

#[test]
fn the_extremes_allowance_is_the_step_and_twice_the_range_noise() {
    let p = PlaneParams::new(&PlaneRule::DEFAULT, Meters::from_num(0.05));
    let at = |d: i32, h: i32| {
        extremes_allowance_q16(
            &p,
            &CellGeometry {
                cell: Meters::from_num(0.1).to_bits(),
                sensor_height_mm: h,
                distance: Meters::from_num(d),
            },
        ) as f64
            / 65_536.0
    };
    // 50 mm + 2·2·20 mm·h/r: at d = 0, 130 mm; at 15 m from 1.3 m, 50 + 80·1.3/15.06 mm (the
    // parameters in Q16.16 metres: within 0.05 mm).
    assert!((at(0, 1300) - 130.0).abs() < 0.05, "{}", at(0, 1300));
    let far = 50.0 + 80.0 * 1.3 / 1.3f64.hypot(15.0);
    assert!(
        (at(15, 1300) - far).abs() < 0.05,
        "{} against {far}",
        at(15, 1300)
    );
    // No sensor height (a sensor on the ground): σ itself at r = 0 only.
    assert!((at(5, 0) - 50.0).abs() < 0.05);
}

/// The pair test's fold of `points` (u, v, z mm) in arrival order with the layer's `scale`.
fn pairs(points: &[(i8, i8, i16)], scale: PairScale) -> PlaneState {
    let (u, v, z) = points[0];
    let mut s = PlaneState::first(u, v, z);
    for &(u, v, z) in &points[1..] {
        s.step_from_last(u, v, z, scale);
        s.add_next(u, v, z);
    }
    s
}

/// A layer's pair test constants: the slope `slope_q8` (mm Q8 per unit), no step skipped.
fn slope(slope_q8: u16) -> PairScale {
    PairScale::new(0, slope_q8)
}

#[test]
fn the_pair_slope_is_the_largest_slope_per_unit_of_the_cell() {
    // tan 20°·600 mm / 64 = 3.412 mm per unit, 873.5 in Q8 (the grade and the cell in
    // Q16.16: within a unit of Q8).
    let p = PlaneParams::new(&PlaneRule::DEFAULT, Meters::from_num(0.05));
    let exact = 20f64.to_radians().tan() * 600.0 / 64.0 * 256.0;
    let scale = p.pair_scale(Meters::from_num(0.6).to_bits());
    let got = f64::from(scale.slope_q8());
    assert!((got - exact).abs() <= 1.5, "{got} against {exact}");
    // The step allowance in whole mm in the high half: 50 (0.05 m in Q16.16 is 50.003 mm).
    assert_eq!(scale.step_mm(), 50);
    // No slope allowed: 0; a negative or zero cell: 0; a huge cell saturates.
    let flat = PlaneParams::new(
        &PlaneRule {
            max_grade: Ratio::ZERO,
            ..PlaneRule::DEFAULT
        },
        Meters::from_num(0.05),
    );
    assert_eq!(
        flat.pair_scale(Meters::from_num(0.6).to_bits()).slope_q8(),
        0
    );
    assert_eq!(p.pair_scale(-5).slope_q8(), 0);
    assert_eq!(p.pair_scale(i32::MAX).slope_q8(), u32::from(u16::MAX));
}

#[test]
fn the_pair_rise_is_the_largest_step_between_consecutive_returns_beyond_the_slope() {
    // 3.41 mm per unit: 20° in a 0.6 m cell.
    let twenty = slope(874);
    // Two beams crossing a 120 mm kerb's face at one azimuth after another: their returns
    // stand on each other (a unit apart), 119 mm apart in height.
    let face = [(0, 0, 0), (1, 0, 119), (2, 1, 2), (3, 1, 120)];
    let s = pairs(&face, twenty);
    // The largest of 119 − 3.41·1, 117 − 3.41·2 and 118 − 3.41·1 mm, floored.
    assert_eq!(s.pair_rise(), 115);
    // The same heights 30 units (28 cm) apart along a line: the slope explains 102.4 mm.
    let spaced = [(-30, 0, 0), (0, 0, 119)];
    assert_eq!(pairs(&spaced, twenty).pair_rise(), 16);
    // A 20° slope sampled at any spacing: nothing beyond the slope.
    let ramp: std::vec::Vec<(i8, i8, i16)> = (-30..=30)
        .step_by(3)
        .map(|u: i32| {
            let z = (f64::from(u + 30) * 3.41).floor();
            (i8::try_from(u).unwrap(), 0, z as i16)
        })
        .collect();
    assert_eq!(pairs(&ramp, twenty).pair_rise(), 0);
    // Falling counts as rising (the beams may cross the face in either order), and the rise
    // saturates at 255 mm.
    assert_eq!(pairs(&[(0, 0, 400), (0, 0, 0)], twenty).pair_rise(), 255);
    assert_eq!(pairs(&[(0, 0, 60), (0, 0, 0)], twenty).pair_rise(), 60);
    // A rise within the scale's step is not computed: it cannot exceed the step.
    assert_eq!(
        pairs(&[(0, 0, 60), (0, 0, 0)], PairScale::new(60, 874)).pair_rise(),
        0
    );
    assert_eq!(
        pairs(&[(0, 0, 61), (0, 0, 0)], PairScale::new(60, 874)).pair_rise(),
        61
    );
    // Extreme positions and heights never panic.
    let wild = [(-32, -32, i16::MIN), (31, 31, i16::MAX), (-32, 31, 0)];
    assert_eq!(pairs(&wild, slope(0)).pair_rise(), 255);
    // 65.5 m over 126 units of 256 mm (32 m): still 255.
    assert_eq!(pairs(&wild, slope(u16::MAX)).pair_rise(), 255);
}

#[test]
fn a_pair_rise_beyond_the_step_and_the_range_noise_is_an_obstacle() {
    let (p, g) = far_street_cell(17.0);
    // The allowance at 17 m: 50 + 80·1.3/17.05 = 56.1 mm.
    assert!(!pair_obstacle(56, &p, &g));
    assert!(pair_obstacle(57, &p, &g));
    // A cell whose only sign of the kerb is a stacked pair: the plane and the extremes see a
    // gentle slope, the pair test the face.
    let face = [
        (-30, 0, 0),
        (-20, 0, 0),
        (-10, 0, 1),
        (0, 0, 0),
        (0, 1, 110),
        (10, 1, 112),
        (20, 1, 111),
        (30, 1, 110),
    ];
    let s = pairs(&face, p.pair_scale(g.cell));
    assert!(s.pair_rise() > 100);
    assert!(plane_obstacle(&s, &p, &g, 112));
    // The same returns with the stacked ones apart: 95 mm over 30 units (28 cm), which a 20°
    // slope explains (102.4 mm), shows a step only (nothing beyond the slope).
    let apart = [
        (-30, 0, 0),
        (-20, 0, 0),
        (-10, 0, 1),
        (0, 0, 0),
        (30, 0, 95),
    ];
    let s = pairs(&apart, p.pair_scale(g.cell));
    assert_eq!(s.pair_rise(), 50);
    assert!(!pair_obstacle(s.pair_rise(), &p, &g));
}

#[test]
fn a_pair_steeper_than_the_slope_beyond_the_noise_that_rises_more_than_a_step_is_an_obstacle() {
    let (p, g) = far_street_cell(17.0);
    let scale = p.pair_scale(g.cell);
    // The noise at 17 m: 80·1.3/17.05 = 6.1 mm; the allowance 56.1 mm. A beam crossing a
    // 110 mm kerb 30 units (28 cm) apart: 7 mm beyond 20° (102.4 mm, floored), more than the
    // noise, and 110 mm in all: the pair shows min(110, 7 + 50) = 57 mm, beyond the allowance.
    // (Before, only the 7 mm beyond the slope counted, against the allowance.)
    let crossing = [(0, 0, 0), (30, 0, 110)];
    let s = pairs(&crossing, scale);
    assert_eq!(s.pair_rise(), 57);
    assert!(pair_obstacle(s.pair_rise(), &p, &g));
    // 106 mm: 3 mm beyond the slope, within the noise: it shows that part and a step
    // (53 mm), within the allowance.
    let s = pairs(&[(0, 0, 0), (30, 0, 106)], scale);
    assert_eq!(s.pair_rise(), 53);
    assert!(!pair_obstacle(s.pair_rise(), &p, &g));
    // Steep beyond the noise but rising less than the allowance: 55 mm over 2 units.
    let s = pairs(&[(0, 0, 0), (2, 0, 55)], scale);
    assert_eq!(s.pair_rise(), 55);
    assert!(!pair_obstacle(s.pair_rise(), &p, &g));
}

#[test]
fn the_allowance_compared_without_its_root_is_the_allowance() {
    // Random rules, heights, distances and excesses: `beyond_allowance` decides as the
    // allowance computed with its root and division, wherever the excess is more than 1/64 mm
    // from it (the two round differently within that).
    let mut rng = XorShift(0x5EED_A110_u64);
    let mut decided = 0;
    for _ in 0..20_000 {
        let rule = PlaneRule {
            range_sigma: Meters::from_bits(i32::try_from(rng.below(13_108)).unwrap()),
            noise_factor: Ratio::from_bits(i32::try_from(rng.below(4 << 16)).unwrap()),
            ..PlaneRule::DEFAULT
        };
        let p = PlaneParams::new(&rule, Meters::from_num(0.05));
        let g = CellGeometry {
            cell: Meters::from_num(0.3).to_bits(),
            sensor_height_mm: i32::try_from(rng.below(3_000)).unwrap(),
            distance: Meters::from_bits(i32::try_from(rng.below(40 << 16)).unwrap()),
        };
        let excess = i128::from(rng.below(300 << 16));
        let allowance = extremes_allowance_q16(&p, &g);
        if (excess - allowance).abs() <= 1 << 10 {
            continue;
        }
        decided += 1;
        assert_eq!(
            beyond_allowance(excess, &p, &g),
            excess > i128::from(p.step_q16) && excess > allowance,
            "excess {excess}, allowance {allowance}, {g:?}, {p:?}"
        );
    }
    assert!(decided > 19_000, "{decided}");
    // At the sensor (r = 0): the step and 2·k·σ.
    let p = PlaneParams::new(&PlaneRule::DEFAULT, Meters::from_num(0.05));
    let at = CellGeometry {
        cell: Meters::from_num(0.1).to_bits(),
        sensor_height_mm: 0,
        distance: Meters::ZERO,
    };
    assert!(!beyond_allowance(129 << 16, &p, &at));
    assert!(beyond_allowance(131 << 16, &p, &at));
}

#[test]
fn the_pair_test_looks_as_far_back_as_the_depth() {
    // 3.41 mm per unit: 20° in a 0.6 m cell; no step skipped.
    let depth = |d: u8| slope(874).with_depth(d);
    // A kerb return (110 mm up) one unit from a road return two returns before it, with a
    // road return 59 units away between them (a 20° slope explains 201 mm over that): only a
    // pair two back sees the face, 110 − 3.41 = 106.6 mm beyond the slope.
    let two_back = [(0, 0, 0), (30, 30, 2), (1, 0, 110)];
    assert_eq!(pairs(&two_back, depth(1)).pair_rise(), 0);
    assert_eq!(pairs(&two_back, depth(2)).pair_rise(), 106);
    assert_eq!(pairs(&two_back, depth(3)).pair_rise(), 106);
    // Three back: only depth 3 sees it.
    let three_back = [(0, 0, 0), (30, 30, 2), (-30, 30, 1), (1, 0, 110)];
    assert_eq!(pairs(&three_back, depth(2)).pair_rise(), 0);
    assert_eq!(pairs(&three_back, depth(3)).pair_rise(), 106);
    // Four back is never paired.
    let four_back = [
        (0, 0, 0),
        (30, 30, 2),
        (-30, 30, 1),
        (-30, -30, 0),
        (1, 0, 110),
    ];
    assert_eq!(pairs(&four_back, depth(3)).pair_rise(), 0);
    // A slot pairs only the returns it holds: after its first return no earlier one exists
    // (an empty entry at (0, 0, 0) would show 106 mm here).
    assert_eq!(pairs(&[(30, 30, 2), (1, 0, 110)], depth(3)).pair_rise(), 0);
    // The deeper pairs keep the largest step with the last's: the last pair 200 mm over one
    // unit is the largest.
    let both = [(0, 0, 0), (30, 30, 2), (1, 0, 110), (2, 0, 310)];
    assert_eq!(pairs(&both, depth(3)).pair_rise(), 255);
    // A restart of the sums (a new lowest point that puts the summed ones above the cut)
    // starts a slot afresh ([`PlaneState::first`]): it forgets the earlier returns with the
    // rest.
    let held = pairs(&[(0, 0, 0), (30, 30, 2)], depth(3));
    assert_ne!(PlaneState::first(-30, 30, -2_000), held);
    let mut s = PlaneState::first(-30, 30, -2_000);
    s.step_from_last(1, 0, -1_890, depth(3));
    assert_eq!(s.pair_rise(), 0);
}

#[test]
fn a_pair_scale_holds_its_depth_beside_the_step_and_the_slope() {
    let scale = PairScale::new(50, 874);
    assert_eq!(
        (scale.step_mm(), scale.slope_q8(), scale.earlier()),
        (50, 874, 0)
    );
    for (depth, earlier) in [(0, 0), (1, 0), (2, 1), (3, 2), (4, 2), (255, 2)] {
        let s = scale.with_depth(depth);
        assert_eq!((s.step_mm(), s.slope_q8(), s.earlier()), (50, 874, earlier));
    }
    // The largest step and slope stay whole beside the largest depth; a larger step saturates.
    let wide = PairScale::new(u16::MAX, u16::MAX).with_depth(3);
    assert_eq!(
        (wide.step_mm(), wide.slope_q8(), wide.earlier()),
        (16_383, u32::from(u16::MAX), 2)
    );
    // The rule's depth reaches every layer's constants.
    let p = PlaneParams::new(
        &PlaneRule::DEFAULT.with_pair_depth(crate::classify::FIRING_ORDER_PAIR_DEPTH),
        Meters::from_num(0.05),
    );
    assert_eq!(p.pair_scale(Meters::from_num(0.6).to_bits()).earlier(), 2);
    assert_eq!(
        PlaneParams::DEFAULT.pair_scale(Meters::from_num(0.6).to_bits()),
        PlaneParams::new(&PlaneRule::DEFAULT, Meters::from_num(0.05))
            .pair_scale(Meters::from_num(0.6).to_bits())
    );
}
