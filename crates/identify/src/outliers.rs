//! Outlier screening after a fit: measured points whose 3-D residual is large compared with
//! the noise level the fit itself estimates.
//!
//! With the unweighted per-axis noise estimate σ̂ = √(F / (3m − r)) of the fit
//! ([`crate::Fit::sigma_hat`], F the residual sum of squares, r the identifiable parameters),
//! the 3-D residual scale is
//!
//! `σ̂₃ = √3 · σ̂ = √(Σ_j ‖e_j‖² / (m − r/3))`,
//!
//! the degrees-of-freedom-corrected RMS of the 3-D residuals `e_j = p_j^meas − p(q_j)`.
//! A point is an outlier when `‖e_j‖ > max(k · σ̂₃, 1 nm)` (k = 3 by default). For Gaussian residuals
//! with σ per axis, ‖e‖/σ follows a χ distribution with 3 degrees of freedom, so
//! `P(‖e‖ > 3·√3·σ) = P(χ²₃ > 27) ≈ 6·10⁻⁶`: at k = 3 a clean data set of a few thousand
//! points flags nothing, and a flagged point is a gross error (wrong target, beam break,
//! mistyped row), not noise.
//!
//! Screening is one pass on the fit as given; whether flagged points are dropped and the
//! problem refitted is the caller's decision.
//!
//! # Blocks: one rule for every measurement type
//!
//! A pose of a 6-DoF or multi-target measurement gives a block of d rows (3 for a point, 6
//! for a point and an orientation, 3k for k targets, 3k + 3 for both), kept or dropped
//! together. With the fit's per-row noise estimate σ̂ = √(F / (n − r)) (F the weighted
//! residual sum of squares, n the rows, r the unknowns), the block's scale is `√d · σ̂` and a
//! block is an outlier when `‖e_b‖ > max(k · √d · σ̂, 1 nm)` ([`screen_blocks`]): the rule
//! above, which is its d = 3 case to the bit ([`block_threshold`] is the one formula of both).
//! For Gaussian residuals ‖e_b‖²/σ² is χ² with d degrees of freedom, so the false-alarm rate
//! falls with d (`P(χ²₆ > 54) ≈ 7·10⁻¹⁰`): a flagged block is a gross error, as for points.
//!
//! # Robust scale and gross errors
//!
//! σ̂ above is estimated from the residuals it screens, so many gross errors inflate it and hide
//! themselves (15 of 100 rows 10 mm off give σ̂₃ ≈ 11 mm: nothing is flagged). The robust scale
//! of a set of blocks is the median of their norms, each divided by the median of the χ
//! distribution of its rows ([`robust_sigma_row`]):
//!
//! `σ̃ = med_b(‖e_b‖ / m_{d_b})`,  `m_d = √(median of χ²_d)` ([`chi_median`]; m₃ = 1.5382),
//!
//! consistent for σ (for Gaussian residuals `‖e_b‖/σ` is χ with `d_b` degrees of freedom, whose
//! median is `m_{d_b}`). For points (d = 3) it is the median of the 3-D residual norms over
//! 1.5382 — the MAD's counterpart for norms, which are ≥ 0 and centred on no location, so
//! their median, not their deviation from it, carries the scale. Its breakdown point is 50 %:
//! up to half the blocks may be arbitrarily wrong before σ̃ can be made arbitrarily large. Its
//! asymptotic efficiency against the RMS on Gaussian data is
//! `(1/6) / (1/(4·m₃²·f₃(m₃)²)) = 53 %` for points (f₃ the χ₃ density); it only sets the first
//! cut — the final screen uses the classical σ̂ of the fit on the rows kept, so on clean data
//! the result is the least-squares fit itself. It was chosen over Qn (breakdown 50 %,
//! efficiency 82 %) because the norms of a fit's residuals have a known distribution, so one
//! order statistic is consistent without pairwise differences (O(m log m), no tuning constant
//! but `m_d`). The callers (the calibration pipeline) start it from a least-trimmed-squares
//! fit on the best half of the blocks ([`smallest`], [`trimmed_cost`]).

use kinematics::Robot;
use nalgebra::Vector3;
use serde::{Deserialize, Serialize};

use crate::error::IdentifyError;
use crate::problem::check_poses_and_points;

/// Smallest threshold, mm [1e-6: a nanometre, far below any measurement's resolution; an
/// exact fit (σ̂ = 0, e.g. synthetic data) leaves rounding-level residuals, which are never
/// outliers].
pub const MIN_THRESHOLD_MM: f64 = 1e-6;

/// One flagged point.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Outlier {
    /// 0-based index of the point in the data given to [`screen`].
    pub index: usize,
    /// Residual `p^meas − p(q)`, mm.
    pub residual_mm: [f64; 3],
    /// Its norm, mm.
    pub norm_mm: f64,
    /// `norm_mm / σ̂₃`.
    pub ratio: f64,
}

/// The outcome of [`screen`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct OutlierScreen {
    /// The factor k.
    pub k: f64,
    /// The 3-D residual scale σ̂₃ = √3·σ̂, mm.
    pub sigma_3d_mm: f64,
    /// The threshold max(k·σ̂₃, [`MIN_THRESHOLD_MM`]), mm.
    pub threshold_mm: f64,
    /// Flagged points, largest residual first.
    pub outliers: Vec<Outlier>,
}

impl OutlierScreen {
    /// Indices of the flagged points, ascending.
    pub fn indices(&self) -> Vec<usize> {
        let mut idx: Vec<usize> = self.outliers.iter().map(|o| o.index).collect();
        idx.sort_unstable();
        idx
    }
}

/// The scale `√rows · sigma_row` of a block of `rows` residual rows and its outlier threshold
/// `max(k · scale, MIN_THRESHOLD_MM)` (module docs): the one formula of [`screen`] (rows = 3)
/// and [`screen_blocks`].
pub fn block_threshold(k: f64, sigma_row: f64, rows: usize) -> (f64, f64) {
    let scale = (rows as f64).sqrt() * sigma_row;
    (scale, (k * scale).max(MIN_THRESHOLD_MM))
}

fn check_k_sigma(k: f64, sigma: f64, sigma_name: &'static str) -> Result<(), IdentifyError> {
    if !(k.is_finite() && k > 0.0) {
        return Err(IdentifyError::InvalidOption {
            name: "outlier k",
            value: format!("{k:?}"),
            reason: "must be finite and > 0",
        });
    }
    if !(sigma.is_finite() && sigma >= 0.0) {
        return Err(IdentifyError::InvalidOption {
            name: sigma_name,
            value: format!("{sigma:?}"),
            reason: "must be finite and ≥ 0",
        });
    }
    Ok(())
}

/// One flagged block of [`screen_blocks`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct BlockOutlier {
    /// 0-based index of the block (the pose) in the data given to [`screen_blocks`].
    pub index: usize,
    /// Its number of residual rows d.
    pub rows: usize,
    /// The norm of its (weighted) residual rows.
    pub norm: f64,
    /// Its threshold `max(k·√d·σ̂, 1e-6)`.
    pub threshold: f64,
    /// `norm / (√d·σ̂)`.
    pub ratio: f64,
}

/// The outcome of [`screen_blocks`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct BlockScreen {
    /// The factor k.
    pub k: f64,
    /// The per-row noise estimate σ̂ of the fit (weighted units).
    pub sigma_row: f64,
    /// Flagged blocks, largest ratio first (ties: lower index first).
    pub outliers: Vec<BlockOutlier>,
}

impl BlockScreen {
    /// Indices of the flagged blocks, ascending.
    pub fn indices(&self) -> Vec<usize> {
        let mut idx: Vec<usize> = self.outliers.iter().map(|o| o.index).collect();
        idx.sort_unstable();
        idx
    }
}

/// Flags the blocks `(norm of its residual rows, number of rows)` whose norm exceeds
/// `max(k·√d·sigma_row, 1e-6)` (module docs), `sigma_row` the fit's per-row noise estimate.
pub fn screen_blocks(
    blocks: &[(f64, usize)],
    sigma_row: f64,
    k: f64,
) -> Result<BlockScreen, IdentifyError> {
    check_k_sigma(k, sigma_row, "sigma_row")?;
    let mut outliers: Vec<BlockOutlier> = blocks
        .iter()
        .enumerate()
        .filter_map(|(index, &(norm, rows))| {
            let (scale, threshold) = block_threshold(k, sigma_row, rows);
            (norm > threshold).then(|| BlockOutlier {
                index,
                rows,
                norm,
                threshold,
                ratio: if scale > 0.0 {
                    norm / scale
                } else {
                    f64::INFINITY
                },
            })
        })
        .collect();
    outliers.sort_by(|a, b| b.ratio.total_cmp(&a.ratio).then(a.index.cmp(&b.index)));
    Ok(BlockScreen {
        k,
        sigma_row,
        outliers,
    })
}

/// Flags the points of `robot` (usually the identified one) on `poses_rad` (flat, radians)
/// whose 3-D residual against `points_mm` exceeds `k · √3 · sigma_axis_mm`, with
/// `sigma_axis_mm` the fit's per-axis noise estimate σ̂ (unweighted, mm). See the module
/// docs.
pub fn screen(
    robot: &Robot,
    poses_rad: &[f64],
    points_mm: &[Vector3<f64>],
    sigma_axis_mm: f64,
    k: f64,
) -> Result<OutlierScreen, IdentifyError> {
    check_k_sigma(k, sigma_axis_mm, "sigma_axis_mm")?;
    check_poses_and_points(robot, poses_rad, points_mm)?;
    let (sigma_3d_mm, threshold_mm) = block_threshold(k, sigma_axis_mm, 3);
    let n = robot.n_joints();
    let mut outliers: Vec<Outlier> = poses_rad
        .chunks_exact(n)
        .zip(points_mm)
        .enumerate()
        .filter_map(|(index, (q, p))| {
            let e = p - robot.point(q);
            let norm_mm = e.norm();
            (norm_mm > threshold_mm).then(|| Outlier {
                index,
                residual_mm: [e.x, e.y, e.z],
                norm_mm,
                ratio: if sigma_3d_mm > 0.0 {
                    norm_mm / sigma_3d_mm
                } else {
                    f64::INFINITY
                },
            })
        })
        .collect();
    outliers.sort_by(|a, b| b.norm_mm.total_cmp(&a.norm_mm).then(a.index.cmp(&b.index)));
    Ok(OutlierScreen {
        k,
        sigma_3d_mm,
        threshold_mm,
        outliers,
    })
}

/// Factor G of the gross-error cut `‖e_b‖ > G·√d·σ` \[5: for Gaussian residuals
/// `P(χ²₃ > 75) ≈ 4·10⁻¹⁶` — never a clean reading — while a laser-tracker reading 2 mm off on
/// a 0.45 mm fit (the UR10 example) is beyond it; readings between k = 3 and G (heavy tails of
/// real data, such as the UR10 example's line 857 at 3.9 σ̂₃) are flagged and kept\].
pub const GROSS_K: f64 = 5.0;

/// Regularised lower incomplete gamma function `P(a, x) = γ(a, x)/Γ(a)` for `a = two_a/2`,
/// by its power series `P(a, x) = x^a e^{−x} / Γ(a+1) · Σ_n x^n / ((a+1)…(a+n))` (terms
/// summed in order until below 10⁻¹⁷ of the sum; x ≤ a few hundred here).
fn gamma_p_half(two_a: usize, x: f64) -> f64 {
    if x <= 0.0 {
        return 0.0;
    }
    let a = two_a as f64 / 2.0;
    // ln Γ(a + 1) for a half-integer a, by Γ(z + 1) = z Γ(z) from Γ(1) = 1 or Γ(1/2) = √π.
    let mut ln_gamma = if two_a.is_multiple_of(2) {
        0.0
    } else {
        std::f64::consts::PI.sqrt().ln()
    };
    let mut z = if two_a.is_multiple_of(2) { 1.0 } else { 0.5 };
    while z < a + 1.0 - 0.25 {
        ln_gamma += z.ln();
        z += 1.0;
    }
    let (mut term, mut sum) = (1.0_f64, 1.0_f64);
    for n in 1..10_000 {
        term *= x / (a + n as f64);
        sum += term;
        if term < 1e-17 * sum {
            break;
        }
    }
    (a * x.ln() - x - ln_gamma).exp() * sum
}

/// The median `m_d` of the χ distribution with `d ≥ 1` degrees of freedom: `√x` with
/// `P(d/2, x/2) = 1/2`, by 200 bisections on `[0, d + 10√d + 10]` (deterministic;
/// m₁ = 0.6745, m₃ = 1.5382, m₆ = 2.3660).
pub fn chi_median(d: usize) -> f64 {
    let d = d.max(1);
    let (mut lo, mut hi) = (0.0_f64, d as f64 + 10.0 * (d as f64).sqrt() + 10.0);
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if gamma_p_half(d, 0.5 * mid) < 0.5 {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    (0.5 * (lo + hi)).sqrt()
}

/// The blocks' norms scaled to one row, `‖e_b‖ / m_{d_b}` (module docs), in block order.
fn scaled(blocks: &[(f64, usize)]) -> Vec<f64> {
    let mut medians: Vec<(usize, f64)> = Vec::new();
    blocks
        .iter()
        .map(|&(norm, rows)| {
            let m = match medians.iter().find(|(d, _)| *d == rows) {
                Some(&(_, m)) => m,
                None => {
                    let m = chi_median(rows);
                    medians.push((rows, m));
                    m
                }
            };
            norm / m
        })
        .collect()
}

/// The robust per-row scale `σ̃ = med_b(‖e_b‖ / m_{d_b})` of blocks `(norm, rows)` (module
/// docs; the median of an even count is the mean of the two middle values; 0 for none).
pub fn robust_sigma_row(blocks: &[(f64, usize)]) -> f64 {
    let mut v = scaled(blocks);
    if v.is_empty() {
        return 0.0;
    }
    v.sort_by(f64::total_cmp);
    let m = v.len();
    if m % 2 == 1 {
        v[m / 2]
    } else {
        0.5 * (v[m / 2 - 1] + v[m / 2])
    }
}

/// The `h` blocks with the smallest scaled norm `‖e_b‖ / m_{d_b}` (ties: the lower index),
/// as indices, ascending: the subset of a concentration step of least trimmed squares.
pub fn smallest(blocks: &[(f64, usize)], h: usize) -> Vec<usize> {
    let v = scaled(blocks);
    let mut idx: Vec<usize> = (0..v.len()).collect();
    idx.sort_by(|&a, &b| v[a].total_cmp(&v[b]).then(a.cmp(&b)));
    idx.truncate(h);
    idx.sort_unstable();
    idx
}

/// The least-trimmed-squares objective `Σ_{b ∈ sel} (‖e_b‖ / m_{d_b})²` of the blocks `sel`
/// (summed in the order of `sel`).
pub fn trimmed_cost(blocks: &[(f64, usize)], sel: &[usize]) -> f64 {
    let v = scaled(blocks);
    sel.iter().map(|&i| v[i] * v[i]).sum()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{IdentifyOptions, ParamSet, Problem, identify};
    use kinematics::{PoseSampler, RobotSpec};
    use rand::SeedableRng;
    use rand::rngs::ChaCha8Rng;

    #[test]
    fn a_gross_error_is_flagged_and_nothing_else() {
        let text = include_str!("../../../scenarios/robots/kr1000-titan.json");
        let nominal = Robot::from_spec(&RobotSpec::from_json_str(text, "kr1000").unwrap()).unwrap();
        let mut x = nominal.params();
        x[nominal.layout().index_of("a2").unwrap()] += 0.4;
        let truth = nominal.with_params(&x).unwrap();
        let poses = PoseSampler::default()
            .sample(&nominal, 60, &mut ChaCha8Rng::seed_from_u64(3))
            .unwrap()
            .rad;
        let mut points = truth.points(&poses);
        // Deterministic "noise" of ±0.02 mm per axis, and one point off by 2 mm.
        for (j, p) in points.iter_mut().enumerate() {
            let s = |c: usize| 0.02 * (((7 * j + 3 * c) % 5) as f64 - 2.0) / 2.0;
            *p += Vector3::new(s(0), s(1), s(2));
        }
        points[17] += Vector3::new(1.2, -1.0, 1.2);
        let free = ParamSet::Minimal
            .resolve(&nominal, &poses, None, &Default::default())
            .unwrap();
        let problem = Problem::new(&nominal, &poses, &points, free).unwrap();
        let fit = identify(&problem, &IdentifyOptions::default()).unwrap();
        let s = screen(&fit.robot, &poses, &points, fit.sigma_hat.unwrap(), 3.0).unwrap();
        assert_eq!(s.indices(), vec![17], "{s:?}");
        assert!(s.outliers[0].ratio > 3.0);
        assert!((s.threshold_mm - 3.0 * 3f64.sqrt() * fit.sigma_hat.unwrap()).abs() < 1e-15);
        // The block rule at d = 3 is this rule to the bit.
        let blocks: Vec<(f64, usize)> = poses
            .chunks_exact(nominal.n_joints())
            .zip(&points)
            .map(|(q, p)| ((p - fit.robot.point(q)).norm(), 3))
            .collect();
        let b = screen_blocks(&blocks, fit.sigma_hat.unwrap(), 3.0).unwrap();
        assert_eq!(b.indices(), s.indices());
        assert_eq!(b.outliers[0].threshold.to_bits(), s.threshold_mm.to_bits());
        assert_eq!(b.outliers[0].ratio.to_bits(), s.outliers[0].ratio.to_bits());
        assert!(screen_blocks(&blocks, f64::NAN, 3.0).is_err());
        assert!(screen(&fit.robot, &poses, &points, 0.1, 0.0).is_err());
        assert!(screen(&fit.robot, &poses, &points[1..], 0.1, 3.0).is_err());
    }

    #[test]
    fn chi_medians_and_the_robust_scale() {
        // Medians of χ²_d (tables): 0.454937, 2.365974, 5.348121.
        for (d, m2) in [(1, 0.454_936_4), (3, 2.365_973_9), (6, 5.348_120_6)] {
            let m = chi_median(d);
            assert!((m * m - m2).abs() < 1e-6, "d = {d}: {}", m * m);
        }
        // σ̃ is the median of the scaled norms (the 4th of 7): 4 clean blocks, 3 arbitrarily bad.
        let m3 = chi_median(3);
        let blocks = [
            (1.0 * m3, 3),
            (1e9, 3),
            (0.9 * m3, 3),
            (1.1 * m3, 3),
            (1e12, 3),
            (1.05 * m3, 3),
            (f64::MAX, 3),
        ];
        assert!((robust_sigma_row(&blocks) - 1.1).abs() < 1e-12);
        assert_eq!(smallest(&blocks, 4), vec![0, 2, 3, 5]);
        let cost = trimmed_cost(&blocks, &[0, 2]);
        assert!((cost - (1.0 + 0.81)).abs() < 1e-12);
        assert_eq!(robust_sigma_row(&[]), 0.0);
    }
}
