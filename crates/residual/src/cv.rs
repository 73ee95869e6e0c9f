//! k-fold cross-validation of the hybrid (geometry + residual model) against the geometry
//! alone, the gate that decides whether the hybrid is used, and the coverage of its
//! standard deviation on held-out poses.
//!
//! **Folds.** Fold `f` (1-based) holds out the rows `i` with `i mod k = f − 1`: interleaved,
//! so that every fold spans the whole recording (its time, its temperature, its regions of
//! the workspace), and deterministic (no shuffle, no seed).
//!
//! **One fold.** The caller's geometric fit runs on the other `k − 1` folds and returns the
//! residuals `e_i = p_i − p_geometry(q_i)` of every row; the residual model
//! ([`ResidualModel::fit`]) is fitted on the training rows' residuals and predicts the
//! held-out rows. The geometry's held-out error is `‖e_i‖`, the hybrid's `‖e_i − r̂(q_i)‖`.
//! Nothing of the held-out fold is used to fit or to choose anything.
//!
//! **The gate** ([`CrossValidation::helps`]). With `Δ_f` the improvement of a statistic in
//! fold `f` (geometry − hybrid, mm), `Δ̄` its mean over the folds and `s_Δ` its sample
//! standard deviation (`1/(k−1)`): the hybrid is used iff
//!
//! ```text
//! Δ̄_mean > s_Δ,mean   and   Δ̄_p95 > s_Δ,p95
//! ```
//!
//! — both the mean and the 95th percentile of the held-out 3-D error improve by more than
//! their fold-to-fold scatter. For one statistic this is a paired t statistic
//! `Δ̄ / (s_Δ/√k)` above `√k` (2.24 at `k = 5`: one-sided p ≈ 0.04 with 4 degrees of
//! freedom); asking it of the p95 too refuses a model that helps on average while it makes
//! the worse poses worse.
//!
//! **Coverage.** Over every held-out row and axis, the fraction of hybrid errors within
//! one and two predicted standard deviations (`|e_c − r̂_c| ≤ z·sd_c`); a calibrated Gaussian
//! gives 68.3 % and 95.4 %.

use evaluate::AxisStats;

use crate::error::{ResidualError, Result};
use crate::gp::{GpOptions, ResidualModel};

/// Folds of the cross-validation by default \[5: each fold trains on 80 % of the poses, so
/// the gate judges a model trained on nearly as many poses as the one written; the
/// scikit-learn example uses 5 too\].
pub const DEFAULT_FOLDS: usize = 5;

/// Options of [`cross_validate`].
#[derive(Clone, Debug, PartialEq)]
pub struct CvOptions {
    /// Folds `k` \[[`DEFAULT_FOLDS`]\]; at least 3 (the fold-to-fold scatter needs 2
    /// degrees of freedom).
    pub folds: usize,
    /// The residual model's options.
    pub gp: GpOptions,
}

impl Default for CvOptions {
    fn default() -> Self {
        Self {
            folds: DEFAULT_FOLDS,
            gp: GpOptions::default(),
        }
    }
}

/// One fold's held-out errors.
#[derive(Clone, Debug, PartialEq)]
pub struct FoldResult {
    /// The fold, 1-based.
    pub fold: usize,
    /// Training poses (the other folds).
    pub train_poses: usize,
    /// Held-out poses.
    pub held_out_poses: usize,
    /// The geometry's held-out 3-D errors, mm.
    pub geometry: AxisStats,
    /// The hybrid's held-out 3-D errors, mm.
    pub hybrid: AxisStats,
}

/// The improvement of a statistic over the folds.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Gain {
    /// `Δ̄`: the mean over the folds of geometry − hybrid, mm (positive: the hybrid is
    /// better).
    pub mean_mm: f64,
    /// `s_Δ`: the sample standard deviation of the per-fold improvements, mm.
    pub scatter_mm: f64,
}

impl Gain {
    fn of(d: &[f64]) -> Self {
        let k = d.len() as f64;
        let mean = d.iter().sum::<f64>() / k;
        let var = d.iter().map(|v| (v - mean) * (v - mean)).sum::<f64>() / (k - 1.0);
        Self {
            mean_mm: mean,
            scatter_mm: var.sqrt(),
        }
    }

    /// Whether the gain exceeds its fold-to-fold scatter.
    pub fn significant(&self) -> bool {
        self.mean_mm > self.scatter_mm
    }
}

/// Coverage of the predicted standard deviation on held-out rows.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Coverage {
    /// Axis values counted (3 a held-out row).
    pub values: usize,
    /// Fraction within one standard deviation (a calibrated Gaussian: 0.683).
    pub within_1sd: f64,
    /// Fraction within two standard deviations (a calibrated Gaussian: 0.954).
    pub within_2sd: f64,
}

/// The cross-validation of the hybrid against the geometry alone.
#[derive(Clone, Debug, PartialEq)]
pub struct CrossValidation {
    /// Each fold.
    pub folds: Vec<FoldResult>,
    /// The geometry's held-out errors, every fold pooled.
    pub geometry: AxisStats,
    /// The hybrid's held-out errors, every fold pooled.
    pub hybrid: AxisStats,
    /// The improvement of the mean 3-D error.
    pub mean_gain: Gain,
    /// The improvement of the 95th percentile.
    pub p95_gain: Gain,
    /// The coverage of the hybrid's standard deviation.
    pub coverage: Coverage,
}

impl CrossValidation {
    /// The gate (module doc): both gains exceed their fold-to-fold scatter.
    pub fn helps(&self) -> bool {
        self.mean_gain.significant() && self.p95_gain.significant()
    }
}

/// The held-out rows of each of `k` interleaved folds of `n` rows: fold `f` (0-based here)
/// holds the rows `i ≡ f (mod k)`.
pub fn folds(n: usize, k: usize) -> Vec<Vec<usize>> {
    (0..k).map(|f| (f..n).step_by(k).collect()).collect()
}

/// What the geometric fit of a fold returns: the residuals (measured − geometry, mm) of
/// every row, the geometry fitted on the training rows it was given.
pub type GeometryResult =
    std::result::Result<Vec<[f64; 3]>, Box<dyn std::error::Error + Send + Sync>>;

/// What the geometric fit of a fold returns for 6-DoF data: the position residuals (mm) and
/// the orientation residuals (rotation vectors of `R_measured · R_geometryᵀ`, degrees) of
/// every row, the geometry fitted on the training rows it was given.
pub type PoseGeometryResult =
    std::result::Result<(Vec<[f64; 3]>, Vec<[f64; 3]>), Box<dyn std::error::Error + Send + Sync>>;

/// The cross-validation of 6-DoF data ([`cross_validate_pose`]): one per part, the same
/// folds and the same geometric fit of each fold.
#[derive(Clone, Debug, PartialEq)]
pub struct PoseCrossValidation {
    /// The position part, mm.
    pub position_mm: CrossValidation,
    /// The orientation part: the held-out angle errors (the norms of the rotation vectors)
    /// and their gains, **degrees** (its `_mm`-named fields hold degrees here).
    pub orientation_deg: CrossValidation,
}

/// Cross-validates the hybrid on the rows `joints_deg` (module doc): `geometry(train)`
/// fits the geometric model on the rows `train` (indices, ascending) and returns the
/// residuals of all rows.
///
/// # Errors
/// [`ResidualError::CrossValidation`] for fewer than 3 folds or a fold with fewer training
/// poses than [`crate::MIN_TRAIN_POSES`]; [`ResidualError::Geometry`] when a fold's
/// geometric fit fails or returns another number of residuals; the residual model's errors.
pub fn cross_validate(
    joints_deg: &[Vec<f64>],
    opts: &CvOptions,
    mut geometry: impl FnMut(&[usize]) -> GeometryResult,
) -> Result<CrossValidation> {
    let mut parts = cross_validate_parts(joints_deg, opts, 1, |train| {
        geometry(train).map(|r| vec![r])
    })?;
    Ok(parts.remove(0))
}

/// [`cross_validate`] of 6-DoF data: each fold's one geometric fit (`geometry(train)`)
/// returns the position and the orientation residuals of every row; a GP is fitted to each
/// part on the training rows, and each part is judged by the same rule
/// ([`CrossValidation::helps`]).
///
/// # Errors
/// As [`cross_validate`].
pub fn cross_validate_pose(
    joints_deg: &[Vec<f64>],
    opts: &CvOptions,
    mut geometry: impl FnMut(&[usize]) -> PoseGeometryResult,
) -> Result<PoseCrossValidation> {
    let mut parts = cross_validate_parts(joints_deg, opts, 2, |train| {
        geometry(train).map(|(p, o)| vec![p, o])
    })?;
    let orientation_deg = parts.pop().expect("two parts");
    let position_mm = parts.pop().expect("two parts");
    Ok(PoseCrossValidation {
        position_mm,
        orientation_deg,
    })
}

/// One part's held-out errors, accumulated over the folds.
#[derive(Default)]
struct Part {
    results: Vec<FoldResult>,
    geometry: Vec<f64>,
    hybrid: Vec<f64>,
    in1: usize,
    in2: usize,
    values: usize,
}

/// The folds of [`cross_validate`] and [`cross_validate_pose`]: `geometry(train)` returns
/// `parts` residual sets of every row, each judged on its own.
fn cross_validate_parts(
    joints_deg: &[Vec<f64>],
    opts: &CvOptions,
    parts: usize,
    mut geometry: impl FnMut(
        &[usize],
    ) -> std::result::Result<
        Vec<Vec<[f64; 3]>>,
        Box<dyn std::error::Error + Send + Sync>,
    >,
) -> Result<Vec<CrossValidation>> {
    let (n, k) = (joints_deg.len(), opts.folds);
    if k < 3 {
        return Err(ResidualError::CrossValidation(format!(
            "{k} folds: at least 3 are needed (the fold-to-fold scatter of the gate)"
        )));
    }
    if n < k || n - n.div_ceil(k) < crate::MIN_TRAIN_POSES {
        return Err(ResidualError::CrossValidation(format!(
            "{n} poses in {k} folds: each fold must train on at least {} poses",
            crate::MIN_TRAIN_POSES
        )));
    }
    let mut acc: Vec<Part> = (0..parts).map(|_| Part::default()).collect();
    for (f, test) in folds(n, k).into_iter().enumerate() {
        let train: Vec<usize> = (0..n).filter(|i| i % k != f).collect();
        let all = geometry(&train).map_err(|source| ResidualError::Geometry {
            fold: f + 1,
            source,
        })?;
        if all.len() != parts {
            return Err(ResidualError::Geometry {
                fold: f + 1,
                source: format!("{} residual sets returned, {parts} expected", all.len()).into(),
            });
        }
        let q_train: Vec<Vec<f64>> = train.iter().map(|&i| joints_deg[i].clone()).collect();
        let q_test: Vec<Vec<f64>> = test.iter().map(|&i| joints_deg[i].clone()).collect();
        for (res, part) in all.iter().zip(acc.iter_mut()) {
            if res.len() != n {
                return Err(ResidualError::Geometry {
                    fold: f + 1,
                    source: format!("{} residuals returned for {n} rows", res.len()).into(),
                });
            }
            let r_train: Vec<[f64; 3]> = train.iter().map(|&i| res[i]).collect();
            let model = ResidualModel::fit(&q_train, &r_train, &opts.gp)?;
            let r_test: Vec<[f64; 3]> = test.iter().map(|&i| res[i]).collect();
            let HeldOut {
                geometry_mm: geo,
                hybrid_mm: hyb,
                coverage: c,
            } = held_out(&model, &q_test, &r_test)?;
            part.in1 += c.0;
            part.in2 += c.1;
            part.values += c.2;
            let stats = |v: &[f64]| {
                AxisStats::from_values(v).map_err(|e| ResidualError::Geometry {
                    fold: f + 1,
                    source: Box::new(e),
                })
            };
            part.results.push(FoldResult {
                fold: f + 1,
                train_poses: train.len(),
                held_out_poses: test.len(),
                geometry: stats(&geo)?,
                hybrid: stats(&hyb)?,
            });
            part.geometry.extend(geo);
            part.hybrid.extend(hyb);
        }
    }
    acc.into_iter().map(finish).collect()
}

/// The cross-validation of one part from its folds.
fn finish(part: Part) -> Result<CrossValidation> {
    let gain = |g: fn(&AxisStats) -> f64| {
        let d: Vec<f64> = part
            .results
            .iter()
            .map(|r| g(&r.geometry) - g(&r.hybrid))
            .collect();
        Gain::of(&d)
    };
    let pooled = |v: &[f64]| {
        AxisStats::from_values(v).map_err(|e| ResidualError::CrossValidation(e.to_string()))
    };
    Ok(CrossValidation {
        geometry: pooled(&part.geometry)?,
        hybrid: pooled(&part.hybrid)?,
        mean_gain: gain(|s| s.mean_mm),
        p95_gain: gain(|s| s.p95_mm),
        coverage: Coverage {
            values: part.values,
            within_1sd: part.in1 as f64 / part.values as f64,
            within_2sd: part.in2 as f64 / part.values as f64,
        },
        folds: part.results,
    })
}

/// The errors of held-out rows: the geometry's and the hybrid's 3-D norms, and the
/// coverage counts of the model's sd.
#[derive(Clone, Debug, PartialEq)]
pub struct HeldOut {
    /// `‖e_i‖`, the geometry's error, mm, one a row.
    pub geometry_mm: Vec<f64>,
    /// `‖e_i − r̂(q_i)‖`, the hybrid's error, mm, one a row.
    pub hybrid_mm: Vec<f64>,
    /// Axis values within 1 sd, within 2 sd, and counted (3 a row).
    pub coverage: (usize, usize, usize),
}

impl HeldOut {
    /// The coverage as fractions.
    pub fn coverage(&self) -> Coverage {
        let (in1, in2, values) = self.coverage;
        Coverage {
            values,
            within_1sd: in1 as f64 / values as f64,
            within_2sd: in2 as f64 / values as f64,
        }
    }
}

/// The geometry's and the hybrid's errors at the rows `joints_deg` whose geometric
/// residuals (measured − geometry, mm) are `residuals_mm`, with the coverage of `model`'s
/// sd: `|e_c − r̂_c| ≤ z·sd_c` for z = 1, 2.
///
/// # Errors
/// The model's prediction errors (a row's joint count, a value not finite).
pub fn held_out(
    model: &ResidualModel,
    joints_deg: &[Vec<f64>],
    residuals_mm: &[[f64; 3]],
) -> Result<HeldOut> {
    let pred = model.predict(joints_deg)?;
    Ok(held_out_predicted(
        pred.iter().map(|p| (p.mean_mm, p.sd_mm)),
        residuals_mm,
    ))
}

/// [`held_out`] from predictions already made: `(mean, sd)` per row, in the residuals'
/// unit (millimetres, or degrees for the orientation part of 6-DoF data), one a residual.
pub fn held_out_predicted(
    predictions: impl ExactSizeIterator<Item = ([f64; 3], [f64; 3])>,
    residuals: &[[f64; 3]],
) -> HeldOut {
    let mut out = HeldOut {
        geometry_mm: Vec::with_capacity(predictions.len()),
        hybrid_mm: Vec::with_capacity(predictions.len()),
        coverage: (0, 0, 0),
    };
    for (e, (mean, sd)) in residuals.iter().zip(predictions) {
        let h = [0, 1, 2].map(|c| e[c] - mean[c]);
        out.geometry_mm.push(norm(*e));
        out.hybrid_mm.push(norm(h));
        for (hc, sd) in h.iter().zip(sd) {
            out.coverage.0 += usize::from(hc.abs() <= sd);
            out.coverage.1 += usize::from(hc.abs() <= 2.0 * sd);
            out.coverage.2 += 1;
        }
    }
    out
}

fn norm(e: [f64; 3]) -> f64 {
    (e[0] * e[0] + e[1] * e[1] + e[2] * e[2]).sqrt()
}
