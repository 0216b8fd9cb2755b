//! The plane rule's decision for one cell, in integers: the centred moments of a slot's sums,
//! the ridge-regularised plane, its residual and slope against the allowances, and the height
//! noise `σ_z(d)` those allowances grow with (the method: [`super`]'s module documentation).

use super::{CellGeometry, PlaneParams, PlaneState, HALVE_AT};

/// `√x` through 64 bits: exact (`⌊√x⌋`) when `x` fits them, else `⌊√(x/4ˢ)⌋·2ˢ` with the
/// smallest s that makes `x/4ˢ` fit (at most 2ˢ below `⌊√x⌋`, a relative error under 2⁻³¹).
pub(super) fn isqrt(x: u128) -> u128 {
    match u64::try_from(x) {
        Ok(small) => u128::from(small.isqrt()),
        Err(_) => {
            let s = (128 - x.leading_zeros() - 63) / 2;
            let scaled = u64::try_from(x >> (2 * s)).unwrap_or(u64::MAX);
            u128::from(scaled.isqrt()) << s
        }
    }
}

/// `⌊√(12/n)·2¹⁶⌋` for n = 0 ..= [`HALVE_AT`] (0 at n = 0), computed at compile time.
pub(super) const ROOT_12_OVER_N: [u32; HALVE_AT as usize + 1] = {
    let mut table = [0_u32; HALVE_AT as usize + 1];
    let mut n = 1;
    while n <= HALVE_AT as usize {
        // ⌊√(12·2³²/n)⌋ by bisection (below 2²²).
        let x = (12_u64 << 32) / n as u64;
        let (mut lo, mut hi) = (0_u64, 1_u64 << 22);
        while hi - lo > 1 {
            let mid = (lo + hi) / 2;
            if mid * mid <= x {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        // Evaluated at compile time: an index out of range would fail the build, not panic.
        #[allow(clippy::cast_possible_truncation, clippy::indexing_slicing)]
        {
            table[n] = lo as u32;
        }
        n += 1;
    }
    table
};

/// The noise allowance `k·σ_z(d)`, mm Q16.
pub(super) fn noise_q16(params: &PlaneParams, geometry: &CellGeometry) -> i64 {
    noise_q16_narrow(params, geometry).unwrap_or_else(|| noise_q16_wide(params, geometry))
}

/// [`noise_q16`] in 64 bits, or `None` where a value would not fit them (σ·h or σ_a·r of 2⁶³
/// or more, or σ_z's terms of 2³¹ mm Q16 or more: with the default rule only beyond 24 km).
/// h < 2³¹ and d < 2²⁵ mm, so `h² + d² < 2⁶³` and `r < 2³²`; terms below 2³¹ keep their
/// squares' sum below 2⁶³. The same integers as [`noise_q16_wide`] (tested).
pub(super) fn noise_q16_narrow(params: &PlaneParams, geometry: &CellGeometry) -> Option<i64> {
    let h = i64::from(geometry.sensor_height_mm.max(0));
    let d = (i64::from(geometry.distance.to_bits()).max(0) * 1000) >> 16;
    #[allow(clippy::cast_sign_loss, clippy::cast_possible_wrap)]
    let r = ((h * h + d * d) as u64).isqrt() as i64;
    let range = if r == 0 {
        params.sigma_q16
    } else {
        params.sigma_q16.checked_mul(h)? / r
    };
    let angle = params.angle_q16.checked_mul(r)?;
    if range >= 1 << 31 || angle >= 1 << 31 {
        return None;
    }
    #[allow(clippy::cast_sign_loss, clippy::cast_possible_wrap)]
    let sigma_z = ((range * range + angle * angle) as u64).isqrt() as i64;
    sigma_z.checked_mul(params.factor_q16).map(|v| v >> 16)
}

/// [`noise_q16`] in 128 bits, saturating.
pub(super) fn noise_q16_wide(params: &PlaneParams, geometry: &CellGeometry) -> i64 {
    let h = i128::from(geometry.sensor_height_mm.max(0));
    let d = (i128::from(geometry.distance.to_bits()).max(0) * 1000) >> 16;
    // r = √(h² + d²), mm.
    #[allow(clippy::cast_sign_loss, clippy::cast_possible_wrap)]
    let r = isqrt((h * h + d * d) as u128) as i128;
    // The range noise seen in the vertical, σ·h/r (σ itself at r = 0), and the elevation
    // error's, σ_a·r; mm Q16. σ·h/r in 64 bits when σ·h fits them (any σ below 32 km).
    let range = if r == 0 {
        i128::from(params.sigma_q16)
    } else {
        let product = i128::from(params.sigma_q16) * h;
        match (i64::try_from(product), i64::try_from(r)) {
            (Ok(p), Ok(r)) => i128::from(p / r),
            _ => product / r,
        }
    };
    let angle = i128::from(params.angle_q16).saturating_mul(r);
    #[allow(clippy::cast_sign_loss, clippy::cast_possible_wrap)]
    let sigma_z = isqrt(
        range
            .saturating_mul(range)
            .saturating_add(angle.saturating_mul(angle)) as u128,
    ) as i128;
    ((sigma_z * i128::from(params.factor_q16)) >> 16)
        .clamp(0, i128::from(i64::MAX))
        .try_into()
        .unwrap_or(i64::MAX)
}

/// `⌊num·2¹⁶/den⌉` towards zero, for `den > 0`: in 64-bit divisions when `num` and `den` fit
/// 64 bits (always for the plane's sums: |num| < 2⁵⁴, den < 2⁴⁵): one division of `num·2¹⁶`
/// when |num| < 2⁴⁷ (most cells), else the integer quotient and the quotient of the remainder
/// times 2¹⁶ (< 2⁶¹); in 128 bits otherwise.
pub(super) fn q16_quotient(num: i128, den: i128) -> i128 {
    match (i64::try_from(num), i64::try_from(den)) {
        (Ok(n), Ok(d)) if d > 0 && d < (1_i64 << 46) => {
            if n.unsigned_abs() < 1 << 47 {
                // num·2¹⁶ fits 64 bits: one division, of the magnitudes ([`crate::wide::div_u64`],
                // in `udiv`s on ARMv7-M), the quotient's sign restored (towards zero, as
                // `i64` division rounds).
                #[allow(clippy::cast_sign_loss, clippy::cast_possible_wrap)]
                let q = crate::wide::div_u64(n.unsigned_abs() << 16, d as u64) as i64;
                return i128::from(if n < 0 { -q } else { q });
            }
            let (q, r) = (n / d, n % d);
            (i128::from(q) << 16) + i128::from((r << 16) / d)
        }
        _ => (num << 16) / den,
    }
}

/// The centred moments of a cell's sums times n² (u, v in units of c/64; z in mm).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) struct Moments {
    /// The summed points, 0 ..= 62.
    pub(super) n: i32,
    /// n·Σuu − (Σu)², within ±2²².
    pub(super) cuu: i32,
    /// n·Σvv − (Σv)², within ±2²².
    pub(super) cvv: i32,
    /// n·Σuv − Σu·Σv, within ±2²².
    pub(super) cuv: i32,
    /// n·Σuz − Σu·Σz, below 2³¹ in magnitude.
    pub(super) cuz: i32,
    /// n·Σvz − Σv·Σz, below 2³¹ in magnitude.
    pub(super) cvz: i32,
    /// n·Σzz − (Σz)², below 2³⁹ in magnitude.
    pub(super) czz: i64,
}

/// [`Moments`] of `state` in 32-bit words where they fit (their products `muls`, not a 64-bit
/// library call, on a Cortex-M0). With n ≤ 62 and |u|, |v| ≤ 32, |dz| ≤ 8192 per summed point
/// (a halving keeps the bounds: |Σu| ≤ 32n, Σuu ≤ 1024n, |Σuz| ≤ 32·8192·n, …; |Σuv| ≤ 2¹⁵
/// saturated): the moments of u and v lie within ±2²², |C_uz|, |C_vz| ≤ 2·62²·32·8192 < 2³¹,
/// and C_zz = n·Σzz − (Σz)² from two 64-bit products ([`crate::wide`]). Wrapping operations:
/// sums outside their bounds (never made) give wrong moments, not a panic. Tested against the
/// 128-bit moments.
pub(super) fn moments(state: &PlaneState) -> Moments {
    let n = i32::from(state.n);
    let (su, sv) = (i32::from(state.su()), i32::from(state.sv()));
    let sz = state.sz;
    let moment = |nsum: i32, a: i32, b: i32| nsum.wrapping_sub(a.wrapping_mul(b));
    #[allow(clippy::cast_possible_wrap, clippy::cast_sign_loss)]
    let czz = (crate::wide::umul(n as u32, state.szz) as i64)
        .wrapping_sub(crate::wide::square(sz) as i64);
    Moments {
        n,
        cuu: moment(n.wrapping_mul(i32::from(state.suu())), su, su),
        cvv: moment(n.wrapping_mul(i32::from(state.svv())), sv, sv),
        cuv: moment(n.wrapping_mul(i32::from(state.suv)), su, sv),
        cuz: moment(n.wrapping_mul(state.suz), su, sz),
        cvz: moment(n.wrapping_mul(state.svz), sv, sz),
        czz,
    }
}

/// wᵀCw and the residual `C_zz·2³² − 2·wᵀc·2¹⁶ + wᵀCw` (both times n², Q32 mm²) for the plane
/// `w = (wa, wb)` (mm per unit, Q16) in 64-bit words, where they surely fit them: |wa|, |wb|
/// below 2¹⁹ and |C_zz| below 2²⁹ (a plane of gradient below 8 mm per unit, z spread within
/// metres), and the partial results within the bounds below; `None` otherwise (the caller
/// computes in 128 bits). The same integers as the 128-bit computation (tested).
pub(super) fn residual_narrow(wa: i128, wb: i128, m: &Moments) -> Option<(i64, i64)> {
    const W: u32 = 1 << 19;
    let (wa, wb) = (i32::try_from(wa).ok()?, i32::try_from(wb).ok()?);
    if wa.unsigned_abs() >= W || wb.unsigned_abs() >= W || m.czz.unsigned_abs() >= 1 << 29 {
        return None;
    }
    let product = crate::wide::smul;
    // Squares and products of w below 2³⁸, the moments of u and v within ±2²²: the terms
    // below 2⁶⁰, 2⁶¹ and 2⁶⁰. |C_uz|, |C_vz| < 2³¹: wᵀc below 2⁵¹.
    let explained = product(wa, wa) * i64::from(m.cuu)
        + 2 * product(wa, wb) * i64::from(m.cuv)
        + product(wb, wb) * i64::from(m.cvv);
    let wc = product(wa, m.cuz) + product(wb, m.cvz);
    if explained.unsigned_abs() >= 1 << 61 || wc.unsigned_abs() >= 1 << 44 {
        return None;
    }
    // Three terms below 2⁶¹ each: the sum below 2⁶³.
    Some((explained, (m.czz << 32) - 2 * (wc << 16) + explained))
}

/// `x²` as `i128`, saturating: from a 32 × 32 → 64-bit square when |x| < 2³¹.
pub(super) fn square_saturating(x: i64) -> i128 {
    match i32::try_from(x) {
        Ok(x) => i128::from(crate::wide::square(x)),
        Err(_) => i128::from(x).saturating_mul(i128::from(x)),
    }
}

/// `a·n2` saturating, for `n2 = n²` with n ≤ 62: in 64 bits when `0 ≤ a < 2⁵¹` (the product
/// below 2⁶³).
pub(super) fn times_n2(a: i128, n2: i32) -> i128 {
    match i64::try_from(a) {
        Ok(a) if (0..1 << 51).contains(&a) && (0..=62 * 62).contains(&n2) => {
            i128::from(a * i64::from(n2))
        }
        _ => a.saturating_mul(i128::from(n2)),
    }
}

/// `⌊tan·c⌋` in mm Q16 for the largest slope `grade_q16` (tan, Q16, ≥ 0) and the cell side
/// `cell` (raw Q16.16 metres; taken as at least 1): `⌊grade·c·1000 / 2¹⁶⌋` exactly, in 64-bit
/// words (`grade·c` below 2⁶², split at 2¹⁶ so that the product with 1 000 fits).
pub(super) fn tan_times_cell(grade_q16: i64, cell: i32) -> i64 {
    let grade = u32::try_from(grade_q16.max(0)).unwrap_or(u32::MAX);
    let cell = cell.max(1).unsigned_abs();
    let gc = crate::wide::umul(grade, cell);
    // gc = h·2¹⁶ + l: ⌊gc·1000 / 2¹⁶⌋ = h·1000 + ⌊l·1000 / 2¹⁶⌋, h·1000 below 2⁵⁶.
    #[allow(clippy::cast_possible_wrap)]
    let t = ((gc >> 16) * 1000 + (((gc & 0xFFFF) * 1000) >> 16)) as i64;
    t
}

/// Whether the gradient `⌊√(wa² + wb²)⌋` (mm per unit, Q16) is surely not steeper than the
/// largest slope, `64·⌊√(wa² + wb²)⌋ ≤ tan_c` (mm Q16), decided without the root: exactly
/// when `wa² + wb² < (⌊tan_c / 64⌋ + 1)²`, in 64-bit words where the squares fit them (|wa|,
/// |wb| below 2³¹ and the bound below 2³²; most cells). `false` also where they do not (the
/// caller takes the root).
pub(super) fn not_steeper(wa: i128, wb: i128, tan_c: i128) -> bool {
    match (
        i32::try_from(wa),
        i32::try_from(wb),
        u32::try_from((tan_c >> 6) + 1),
    ) {
        // Squares below 2⁶² each: the sum fits a u64.
        (Ok(a), Ok(b), Ok(bound)) => {
            crate::wide::square(a) + crate::wide::square(b) < crate::wide::umul(bound, bound)
        }
        _ => false,
    }
}

/// The allowance of the extremes and the pair test, `step + 2·k·σ·h/r` (mm Q16): the step
/// plus the range noise of two returns seen in the vertical, `r = √(h² + d²)` (σ itself at
/// r = 0); saturating. The decision compares with it without computing it
/// ([`beyond_allowance`]).
#[cfg(test)]
pub(super) fn extremes_allowance_q16(params: &PlaneParams, geometry: &CellGeometry) -> i128 {
    let h = i128::from(geometry.sensor_height_mm.max(0));
    let d = (i128::from(geometry.distance.to_bits()).max(0) * 1000) >> 16;
    #[allow(clippy::cast_sign_loss, clippy::cast_possible_wrap)]
    let r = isqrt((h * h + d * d) as u128) as i128;
    let sigma = i128::from(params.sigma_q16);
    let range = if r == 0 { sigma } else { sigma * h / r };
    let noise = (range.saturating_mul(i128::from(params.factor_q16)) >> 16).saturating_mul(2);
    i128::from(params.step_q16).saturating_add(noise)
}

/// The extremes test's excess: how far the cell's lowest and highest points (spread
/// `spread_mm`, the highest at `Δ = (du, dv)` units from the lowest) stand apart beyond what
/// the plane `w = (wa, wb)` (mm per unit, Q16) explains, `spread − max(0, w·Δ)` (mm Q16; 0
/// for a spread within the step, which is never an obstacle by this test). The unexplained
/// part is at most the spread.
pub(super) fn extremes_excess_q16(
    wa: i128,
    wb: i128,
    delta: (i8, i8),
    spread_mm: i32,
    params: &PlaneParams,
) -> i128 {
    let spread = i128::from(spread_mm) << 16;
    if spread <= i128::from(params.step_q16) {
        return 0;
    }
    let explained = (wa * i128::from(delta.0) + wb * i128::from(delta.1)).max(0);
    spread - explained
}

/// Whether a rise `excess_q16` (mm Q16) between two returns, beyond what the cell's plane or
/// the largest slope explains between them, is a step: more than the allowance
/// `step + 2·k·σ·h/r` ([`extremes_allowance_q16`]), decided without its root and division:
/// with `e = excess − step > 0`, `e > 2·k·σ·h/r` exactly when `e²·r² > (2·k·σ·h)²`
/// (`r² = h² + d²`, mm²; `k·σ` in mm Q32 and the right side's root truncated to mm Q16), in
/// 64-bit words and two 64 × 64 → 128-bit products; at `r = 0`, `e > 2·k·σ`. Saturating: an
/// allowance beyond 2⁶⁴ never passes.
pub(super) fn beyond_allowance(
    excess_q16: i128,
    params: &PlaneParams,
    geometry: &CellGeometry,
) -> bool {
    let e = excess_q16 - i128::from(params.step_q16);
    if e <= 0 {
        return false;
    }
    let e = u64::try_from(e).unwrap_or(u64::MAX);
    let h = u64::from(geometry.sensor_height_mm.max(0).unsigned_abs());
    // d < 2³¹·1000 / 2¹⁶ < 2²⁵ mm and h < 2³¹: r² < 2⁶³.
    let d = (u64::from(geometry.distance.to_bits().max(0).unsigned_abs()) * 1000) >> 16;
    let r2 = h * h + d * d;
    let sigma = u64::try_from(params.sigma_q16).unwrap_or(0);
    let factor = u64::try_from(params.factor_q16).unwrap_or(0);
    // k·σ, mm Q32.
    let k_sigma = sigma.saturating_mul(factor);
    if r2 == 0 {
        return e > (k_sigma >> 16).saturating_mul(2);
    }
    // 2·k·σ·h, mm² Q16.
    let noise_h = (k_sigma >> 16).saturating_mul(2).saturating_mul(h);
    let e2 = e.saturating_mul(e);
    u128::from(e2) * u128::from(r2) > u128::from(noise_h) * u128::from(noise_h)
}

/// The pair test: whether the step a pair of consecutive returns of the cell shows exceeds the
/// allowance, `pair_rise > step + 2·k·σ·h/r` (`pair_rise` mm, [`PlaneState::keep_rise`]): the
/// two lie on a surface steeper than the largest slope beyond the noise and rise more than the
/// allowance (a kerb's face, where the returns of two beams stand on each other, or where one
/// beam crosses it). The decision takes the larger of this and the extremes test's excess
/// ([`extremes_excess_q16`]).
#[cfg(test)]
pub(super) fn pair_obstacle(pair_rise: u8, params: &PlaneParams, geometry: &CellGeometry) -> bool {
    beyond_allowance(i128::from(pair_rise) << 16, params, geometry)
}

/// Whether the plane rule calls the cell of `state` not navigable: two to four 64-bit
/// divisions (the plane), up to two integer square roots (the gradient, the rise), and the
/// noise (one division, two roots) only for a cell whose residual exceeds the allowance
/// without noise or that is steeper than the largest slope; the extremes and the pair tests
/// ([`extremes_excess_q16`], the slot's pair rise, [`beyond_allowance`]: their allowance
/// once, for the larger excess, only when it exceeds the step), the extremes for a spread
/// `spread_mm` (highest − lowest below the cut, mm) beyond the step.
pub(in crate::classify) fn plane_obstacle(
    state: &PlaneState,
    params: &PlaneParams,
    geometry: &CellGeometry,
    spread_mm: i32,
) -> bool {
    if state.n < 2 {
        // One return fits no plane; a pair across the cell's edge or between its lowest
        // return and a neighbour's is two returns, and still shows its step.
        return beyond_allowance(i128::from(state.pair_rise()) << 16, params, geometry);
    }
    let m = moments(state);
    let Moments {
        n,
        cuu,
        cvv,
        cuv,
        cuz,
        cvz,
        czz,
    } = m;
    // The ridge λ = 1 unit², times n²; the determinant and the plane's numerators from
    // 32 × 32 → 64-bit products: |det| < 2⁴⁷, the numerators < 2⁵⁵. The rest in 128 bits.
    let n2 = n * n;
    let (a, b) = (cuu + n2, cvv + n2);
    let product = crate::wide::smul;
    let det = product(a, b) - product(cuv, cuv);
    if det <= 0 {
        return false;
    }
    // w = (C + λI)⁻¹ c, mm per unit, Q16.
    let wa = q16_quotient(
        i128::from(product(b, cuz) - product(cuv, cvz)),
        i128::from(det),
    );
    let wb = q16_quotient(
        i128::from(product(a, cvz) - product(cuv, cuz)),
        i128::from(det),
    );
    let (low, high) = (state.low_at(), state.high_at());
    let delta = (high.0.wrapping_sub(low.0), high.1.wrapping_sub(low.1));
    // The extremes and the pair test share their allowance: the larger excess decides.
    let excess = extremes_excess_q16(wa, wb, delta, spread_mm, params)
        .max(i128::from(state.pair_rise()) << 16);
    if beyond_allowance(excess, params, geometry) {
        return true;
    }
    // wᵀCw and the residual, times n² (Q32 mm²).
    let (explained, residual) = match residual_narrow(wa, wb, &m) {
        Some((explained, residual)) => (i128::from(explained), i128::from(residual)),
        None => {
            let (cuu, cvv, cuv) = (i128::from(cuu), i128::from(cvv), i128::from(cuv));
            let (cuz, cvz, czz) = (i128::from(cuz), i128::from(cvz), i128::from(czz));
            let explained = wa * wa * cuu + 2 * wa * wb * cuv + wb * wb * cvv;
            // wᵀc, Q16 mm² times n².
            let wc = wa * cuz + wb * cvz;
            (explained, (czz << 32) - 2 * (wc << 16) + explained)
        }
    };
    // Saturating where extreme configurations (σ or k in the thousands) could overflow.
    let quiet = square_saturating(params.residual_q16);
    // The noise (two roots and a division) only where a decision needs it: a residual within
    // the allowance without noise is within it with noise (the saturating sums only grow).
    let mut noise = None;
    if residual > times_n2(quiet, n2) {
        let sigma = noise_q16(params, geometry);
        let allowed = quiet.saturating_add(square_saturating(sigma));
        if residual > times_n2(allowed, n2) {
            return true;
        }
        noise = Some(i128::from(sigma));
    }
    // The gradient G = |w| (mm per unit, Q16), g = 64·G/c: steeper than the largest slope
    // when 64·G > tan·c (c in mm; both sides mm, Q16), with G = ⌊√(wa² + wb²)⌋.
    let tan_c = i128::from(tan_times_cell(params.grade_q16, geometry.cell));
    if not_steeper(wa, wb, tan_c) {
        return false;
    }
    #[allow(clippy::cast_sign_loss, clippy::cast_possible_wrap)]
    let slope = isqrt((wa * wa + wb * wb) as u128) as i128;
    let steep = 64 * slope - tan_c;
    if steep <= 0 {
        return false;
    }
    let noise = noise.unwrap_or_else(|| i128::from(noise_q16(params, geometry)));
    rises_too_far(explained, slope, steep, state.n, noise, params.step_q16)
}

/// The rise test of a plane steeper than the largest slope: `explained` = wᵀCw·n² (Q32 mm²),
/// `slope` = G (mm per position unit, Q16), `steep` = 64·G − tan·c (> 0), `n` the points,
/// `noise` = a (mm, Q16), `step_q16` the step (mm, Q16). With the rise times n,
/// R·n = √(12·wᵀCw·n²), and the rise's noise N = a·√(12/n): not navigable when R > step + N
/// (more than a step in all) and R·(g − tan) > g·1.5·N (beyond the largest slope over the
/// extent D = R/g by more than the noise allows), the second times n·c/64:
/// R·n·(64·G − tan·c) > 64·G·n·1.5·N. Saturating: never panics.
pub(in crate::classify) fn rises_too_far(
    explained: i128,
    slope: i128,
    steep: i128,
    n: u8,
    noise: i128,
    step_q16: i64,
) -> bool {
    #[allow(clippy::cast_sign_loss, clippy::cast_possible_wrap)]
    let rise_n = isqrt((12 * explained.max(0)) as u128) as i128;
    let root = ROOT_12_OVER_N
        .get(usize::from(n))
        .map_or(0, |&r| i128::from(r));
    let rise_noise = noise.saturating_mul(root) >> 16;
    let above_step = i128::from(step_q16).saturating_add(rise_noise);
    let beyond_slope = rise_noise.saturating_add(rise_noise >> 1);
    let n = i128::from(n);
    rise_n > n.saturating_mul(above_step)
        && rise_n.saturating_mul(steep) > (64 * slope * n).saturating_mul(beyond_slope)
}
