//! `sin` and `cos` of one argument or of a whole lane array at once, in plain IEEE
//! arithmetic: a Cody–Waite reduction by π/2 in four pieces (fdlibm's constants, the
//! roundings kept exactly by TwoSum) and fdlibm/FreeBSD's `__kernel_sin`/`__kernel_cos`
//! minimax polynomials on [−π/4, π/4] with the reduction's tail; error below one ulp.
//!
//! Why not `f64::sin_cos`: the platform's libm is a function call per value that the compiler
//! cannot vectorise, and its last bit may differ between C libraries. These functions are
//! written branch-free over lanes, so a pose's six joints (or eight poses' joint i) cost
//! about one libm call together, and they use only `+ − × /` and rounding-exact tricks
//! without FMA: the same bits on every machine and at every vector width.
//!
//! Arguments of magnitude below 2¹⁹·π/2 (≈ 8·10⁵ rad) take the fast path; larger or
//! non-finite ones fall back to `f64::sin_cos` (they do not occur in kinematics).

use crate::model::MAX_JOINTS;

/// 2/π.
const INV_PIO2: f64 = std::f64::consts::FRAC_2_PI;
/// π/2 = p1 + p2 + p3 + p3t: three pieces of 33 bits and a tail (fdlibm's `pio2_1`,
/// `pio2_2`, `pio2_3`, `pio2_3t`).
const PIO2_1: f64 = f64::from_bits(0x3ff921fb_54400000);
const PIO2_2: f64 = f64::from_bits(0x3dd0b461_1a600000);
const PIO2_3: f64 = f64::from_bits(0x3ba3198a_2e000000);
const PIO2_3T: f64 = f64::from_bits(0x397b839a_252049c1);
/// 1.5·2⁵²: adding and subtracting it rounds to the nearest integer.
const TOINT: f64 = 6_755_399_441_055_744.0;
/// Largest |x| reduced here; beyond it `f64::sin_cos`.
const LIMIT: f64 = 823_549.6;

// fdlibm's `__kernel_sin` (S1…S6) and `__kernel_cos` (C1…C6) coefficients, bit for bit.
const S1: f64 = f64::from_bits(0xbfc55555_55555549);
const S2: f64 = f64::from_bits(0x3f811111_1110f8a6);
const S3: f64 = f64::from_bits(0xbf2a01a0_19c161d5);
const S4: f64 = f64::from_bits(0x3ec71de3_57b1fe7d);
const S5: f64 = f64::from_bits(0xbe5ae5e6_8a2b9ceb);
const S6: f64 = f64::from_bits(0x3de5d93a_5acfd57c);

const C1: f64 = f64::from_bits(0x3fa55555_5555554c);
const C2: f64 = f64::from_bits(0xbf56c16c_16c15177);
const C3: f64 = f64::from_bits(0x3efa01a0_19cb1590);
const C4: f64 = f64::from_bits(0xbe927e4f_809c52ad);
const C5: f64 = f64::from_bits(0x3e21ee9e_bdb4b1c4);
const C6: f64 = f64::from_bits(0xbda8fae9_be8838d4);

/// `sin(x + y)` for |x + y| ≤ π/4, y the tail of x (fdlibm `__kernel_sin`, iy = 1).
#[inline(always)]
fn k_sin(x: f64, y: f64) -> f64 {
    let z = x * x;
    let v = z * x;
    let r = S2 + z * (S3 + z * (S4 + z * (S5 + z * S6)));
    x - ((z * (0.5 * y - v * r) - y) - v * S1)
}

/// `cos(x + y)` for |x + y| ≤ π/4 (fdlibm `__kernel_cos`).
#[inline(always)]
fn k_cos(x: f64, y: f64) -> f64 {
    let z = x * x;
    let w = z * z;
    let r = z * (C1 + z * (C2 + z * C3)) + w * w * (C4 + z * (C5 + z * C6));
    let hz = 0.5 * z;
    let w = 1.0 - hz;
    w + (((1.0 - w) - hz) + (z * r - x * y))
}

/// `a + b = s + e` exactly (Knuth's TwoSum, any magnitudes).
#[inline(always)]
fn two_sum(a: f64, b: f64) -> (f64, f64) {
    let s = a + b;
    let bb = s - a;
    (s, (a - (s - bb)) + (b - bb))
}

/// `x = n·π/2 + (y0 + y1)`, |y0 + y1| ≤ π/4 (slightly more at rounding ties), with π/2 in
/// four pieces: `x − f·p1` is exact (33-bit piece, |f| < 2²⁰), the next two pieces are
/// subtracted with their exact rounding errors (TwoSum; the products are exact), the last
/// is a correction. Good to ~150 bits before the final rounding.
#[inline(always)]
fn reduce(x: f64) -> (f64, f64, f64) {
    let f = (x * INV_PIO2 + TOINT) - TOINT;
    let r1 = x - f * PIO2_1;
    let (r2, e2) = two_sum(r1, -(f * PIO2_2));
    let (r3, e3) = two_sum(r2, -(f * PIO2_3));
    let c = (e2 + e3) - f * PIO2_3T;
    let y0 = r3 + c;
    let y1 = (r3 - y0) + c;
    (y0, y1, f)
}

/// `(sin x, cos x)` for |x| < [`LIMIT`].
#[inline(always)]
fn sin_cos_reduced(x: f64) -> (f64, f64) {
    let (y0, y1, f) = reduce(x);
    let s = k_sin(y0, y1);
    let c = k_cos(y0, y1);
    match (f as i64) & 3 {
        0 => (s, c),
        1 => (c, -s),
        2 => (-s, -c),
        _ => (-c, s),
    }
}

/// `(sin x, cos x)`, error below one ulp (see the module docs).
#[inline]
pub fn sin_cos(x: f64) -> (f64, f64) {
    if x.abs() < LIMIT {
        sin_cos_reduced(x)
    } else {
        x.sin_cos()
    }
}

/// [`sin_cos`] of every lane, branch-free on the fast path so that it vectorises; the
/// results are those of [`sin_cos`], lane by lane, at any vector width.
#[inline(always)]
pub fn sin_cos_lanes<const L: usize>(x: &[f64; L]) -> ([f64; L], [f64; L]) {
    let mut s = [0.0; L];
    let mut c = [0.0; L];
    let mut inside = true;
    for v in x {
        inside &= v.abs() < LIMIT;
    }
    if !inside {
        for t in 0..L {
            (s[t], c[t]) = sin_cos(x[t]);
        }
        return (s, c);
    }
    for t in 0..L {
        let (y0, y1, n) = reduce(x[t]);
        let ks = k_sin(y0, y1);
        let kc = k_cos(y0, y1);
        // Quadrant n mod 4 in floating point (n exact and small), then selects: n odd swaps
        // sine and cosine, n = 2, 3 negates the sine, n = 1, 2 the cosine. No integer
        // conversion, so the loop vectorises.
        let q = n * 0.25;
        let r = (q + TOINT) - TOINT;
        let fl = if r > q { r - 1.0 } else { r };
        let m = n - 4.0 * fl;
        let odd = m == 1.0 || m == 3.0;
        let (a, b) = (if odd { kc } else { ks }, if odd { ks } else { kc });
        s[t] = if m >= 2.0 { -a } else { a };
        c[t] = if m == 1.0 || m == 2.0 { -b } else { b };
    }
    (s, c)
}

/// Below this magnitude [`sin_cos_small_lanes`] takes its polynomials (2⁻⁴ rad ≈ 3.6°).
pub const SMALL_ANGLE: f64 = 0.0625;

/// `(sin x, cos x)` of every lane for the small angles of the extended model's joint offsets
/// (compliance deflections and gear errors, typically below 10⁻³ rad): for |x| <
/// [`SMALL_ANGLE`] the Taylor polynomials
/// `sin x = x + x³(−1/6 + x²(1/120 + x²(−1/5040 + x²/362880)))` and
/// `cos x = 1 + x²(−1/2 + x²(1/24 + x²(−1/720 + x²(1/40320 − x²/3628800))))`
/// (Horner, no FMA; truncation below 2·10⁻²¹ relative at the bound, so the error is the
/// evaluation's, about an ulp), [`sin_cos`] beyond, lane by lane. About ten operations per
/// lane where [`sin_cos_lanes`] needs a range reduction; each lane's value depends on that
/// lane alone, so one value through a one-lane call gives the same bits.
#[inline(always)]
pub fn sin_cos_small_lanes<const L: usize>(x: &[f64; L]) -> ([f64; L], [f64; L]) {
    const S3: f64 = -1.0 / 6.0;
    const S5: f64 = 1.0 / 120.0;
    const S7: f64 = -1.0 / 5040.0;
    const S9: f64 = 1.0 / 362_880.0;
    const C2: f64 = -0.5;
    const C4: f64 = 1.0 / 24.0;
    const C6: f64 = -1.0 / 720.0;
    const C8: f64 = 1.0 / 40_320.0;
    const C10: f64 = -1.0 / 3_628_800.0;
    let mut s = [0.0; L];
    let mut c = [0.0; L];
    // (The polynomials in a loop of their own, with no reduction, so that it vectorises.)
    for t in 0..L {
        let d = x[t];
        let d2 = d * d;
        s[t] = d + d * d2 * (S3 + d2 * (S5 + d2 * (S7 + d2 * S9)));
        c[t] = 1.0 + d2 * (C2 + d2 * (C4 + d2 * (C6 + d2 * (C8 + d2 * C10))));
    }
    for t in 0..L {
        if x[t].abs() >= SMALL_ANGLE || x[t].is_nan() {
            (s[t], c[t]) = sin_cos(x[t]);
        }
    }
    (s, c)
}

/// Lanes of [`sin_cos_slice`]'s blocks.
const BLOCK: usize = 8;

#[inline(always)]
fn slice_impl(x: &[f64], s: &mut [f64], c: &mut [f64]) {
    let n = x.len();
    let mut start = 0;
    while start < n {
        let len = BLOCK.min(n - start);
        let mut lane = [0.0; BLOCK];
        lane[..len].copy_from_slice(&x[start..start + len]);
        let (sb, cb) = sin_cos_lanes(&lane);
        s[start..start + len].copy_from_slice(&sb[..len]);
        c[start..start + len].copy_from_slice(&cb[..len]);
        start += len;
    }
}

/// `s[i], c[i] = sin_cos(x[i])` ([`sin_cos`]'s bits), eight values per block at the
/// run-time [`crate::simd::simd_level`].
///
/// Panics if `s` or `c` is shorter than `x`.
pub fn sin_cos_slice(x: &[f64], s: &mut [f64], c: &mut [f64]) {
    assert!(s.len() >= x.len() && c.len() >= x.len(), "output length");
    crate::simd::vectorised(
        #[inline(always)]
        || slice_impl(x, s, c),
    )
}

/// `[sin q_i, cos q_i]` of one joint vector ([`sin_cos`]), into
/// `out[..q_rad.len()]`; at most [`MAX_JOINTS`] values.
#[inline]
pub fn joint_sin_cos(q_rad: &[f64], out: &mut [[f64; 2]]) {
    let n = q_rad.len();
    let mut s = [0.0; MAX_JOINTS];
    let mut c = [0.0; MAX_JOINTS];
    sin_cos_slice(q_rad, &mut s[..n], &mut c[..n]);
    for (o, (s, c)) in out.iter_mut().zip(s.iter().zip(&c)).take(n) {
        *o = [*s, *c];
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ulps(a: f64, b: f64) -> f64 {
        let scale = f64::EPSILON * b.abs().max(f64::MIN_POSITIVE);
        (a - b).abs() / scale
    }

    /// The small-angle form: within 2 ulp of the platform's libm below [`SMALL_ANGLE`],
    /// [`sin_cos`] itself beyond (and for NaN), each lane its one-lane value.
    #[test]
    fn small_angles_agree_with_libm() {
        let mut state = 7_u64;
        let mut next = || {
            state = state
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            (state >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
        };
        let mut worst: f64 = 0.0;
        for k in 0..20_000 {
            // Magnitudes from 1e-12 to past the bound, both signs.
            let x = next() * 10f64.powf(-12.0 * (k % 13) as f64 / 12.0) * 0.07;
            let lanes: [f64; 8] = std::array::from_fn(|t| x * (1.0 - 0.1 * t as f64));
            let (s, c) = sin_cos_small_lanes(&lanes);
            for (t, &v) in lanes.iter().enumerate() {
                let (s1, c1) = sin_cos_small_lanes(&[v]);
                assert_eq!(
                    (s[t].to_bits(), c[t].to_bits()),
                    (s1[0].to_bits(), c1[0].to_bits())
                );
                let (ls, lc) = v.sin_cos();
                if v.abs() < SMALL_ANGLE {
                    worst = worst.max(ulps(s[t], ls)).max(ulps(c[t], lc));
                } else {
                    assert_eq!((s[t], c[t]), sin_cos(v), "{v}");
                }
            }
        }
        assert!(worst <= 2.0, "{worst} ulp");
        let (s, c) = sin_cos_small_lanes(&[f64::NAN, 0.0]);
        assert!(s[0].is_nan() && c[0].is_nan());
        assert_eq!((s[1], c[1]), (0.0, 1.0));
    }

    /// Within 1 ulp of the platform's libm (itself within 1 ulp of the truth) over the
    /// joint range, near multiples of π/2 and for tiny arguments; lanes equal scalars.
    #[test]
    fn agrees_with_libm() {
        let mut state = 0x2545_f491_4f6c_dd1d_u64;
        let mut next = || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        let mut xs: Vec<f64> = (0..200_000).map(|_| 40.0 * next() - 20.0).collect();
        for k in -40..=40 {
            let base = k as f64 * std::f64::consts::FRAC_PI_2;
            for d in [0.0, 1e-300, 1e-16, -1e-12, 3e-9, -7e-5, 0.1] {
                xs.push(base + d);
            }
        }
        xs.extend([0.0, -0.0, 1e-310, -2e-20, 1e-8, 1e3, -12345.678, 8e5]);
        let mut worst: f64 = 0.0;
        for &x in &xs {
            let (s, c) = sin_cos(x);
            let (s0, c0) = x.sin_cos();
            // Relative to max(|value|, 2⁻³⁰) so zeros of sin/cos are judged absolutely.
            for (a, b) in [(s, s0), (c, c0)] {
                let e = (a - b).abs() / (f64::EPSILON * b.abs().max(2f64.powi(-30)));
                worst = worst.max(e.min(ulps(a, b)));
            }
        }
        assert!(worst <= 1.0, "worst {worst} ulp");
        for chunk in xs.chunks_exact(8) {
            let lanes: [f64; 8] = chunk.try_into().unwrap();
            let (s, c) = sin_cos_lanes(&lanes);
            for t in 0..8 {
                assert_eq!((s[t], c[t]), sin_cos(lanes[t]), "{}", lanes[t]);
            }
        }
        let big = [1e6, -3e7, f64::NAN, 0.5, f64::INFINITY, 2.0, 3.0, 4.0];
        let (s, c) = sin_cos_lanes(&big);
        for t in 0..8 {
            let (s0, c0) = sin_cos(big[t]);
            assert!(s[t].to_bits() == s0.to_bits() || (s[t].is_nan() && s0.is_nan()));
            assert!(c[t].to_bits() == c0.to_bits() || (c[t].is_nan() && c0.is_nan()));
        }
    }
}
