//! Covariance of the identified parameters.
//!
//! At the solution, with J the weighted Jacobian restricted to the identifiable subset K of the
//! free parameters (the minimal set of [`crate::identifiability`], r = |K| columns):
//!
//! `Cov(x_K) = σ̂² (JᵀJ)⁻¹`, `σ̂² = F / (3m − r)`,
//!
//! F the (weighted) residual sum of squares. Unweighted, σ̂ estimates the per-axis point noise
//! (mm); weighted by 1/σ, σ̂ ≈ 1 when the σ are right. `(JᵀJ)⁻¹` is computed through the SVD of
//! the column-scaled Jacobian, `(JᵀJ)⁻¹ = S V Σ⁻² Vᵀ S`, which is accurate even when JᵀJ
//! spans ten orders of magnitude (angles vs lengths).
//!
//! Redundant free parameters (e.g. the paper's 34) have no finite variance: they are listed in
//! [`Covariance::omitted`], and the covariance describes the minimal re-parametrisation with
//! the omitted ones held at their values.

use kinematics::{Robot, Unit};
use nalgebra::{DMatrix, Vector3, linalg::SVD};
use serde::{Deserialize, Serialize};

use crate::error::IdentifyError;
use crate::identifiability::{IdentifiabilityOptions, analyze_matrix, keep_priority};
use crate::problem::{weighted_jacobian, weighted_rss};

/// A pair of parameters with a large correlation.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CorrelatedPair {
    /// First parameter.
    pub a: String,
    /// Second parameter.
    pub b: String,
    /// Correlation coefficient ρ_ab.
    pub rho: f64,
}

/// Covariance, standard errors and correlations of the identifiable free parameters, in
/// display units (deg, mm).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Covariance {
    /// Parameters covered (the identifiable subset of the free ones), layout order.
    pub parameters: Vec<String>,
    /// Their indices in the robot's parameter vector.
    pub indices: Vec<usize>,
    /// Their display units.
    pub units: Vec<Unit>,
    /// Free parameters left out because they are redundant.
    pub omitted: Vec<String>,
    /// σ̂ = √(F / dof): mm per axis unweighted, dimensionless weighted.
    pub sigma_hat: f64,
    /// Degrees of freedom 3m − r.
    pub dof: usize,
    /// Whether the residuals were weighted.
    pub weighted: bool,
    /// Covariance matrix, display units (deg², deg·mm, mm²), row-major.
    pub covariance: Vec<Vec<f64>>,
    /// Standard errors √Cov_kk, display units.
    pub std_errors: Vec<f64>,
    /// Correlation matrix ρ_kl = Cov_kl / (σ_k σ_l), row-major.
    pub correlation: Vec<Vec<f64>>,
    /// Pairs with |ρ| above the flag threshold.
    pub high_correlations: Vec<CorrelatedPair>,
    /// The flag threshold used.
    pub correlation_flag: f64,
}

impl Covariance {
    /// Standard error of the named parameter (display units), if covered.
    pub fn std_error(&self, name: &str) -> Option<f64> {
        self.parameters
            .iter()
            .position(|n| n == name)
            .map(|i| self.std_errors[i])
    }
}

/// Computes the covariance at `robot` (the solution) for the free parameters. Returns
/// `Ok(None)` when there are no degrees of freedom left (3m = r) or nothing is identifiable.
#[allow(clippy::too_many_arguments)]
pub fn covariance(
    robot: &Robot,
    poses_rad: &[f64],
    points_mm: &[Vector3<f64>],
    weights: Option<&[f64]>,
    free: &[usize],
    opts: &IdentifiabilityOptions,
    correlation_flag: f64,
) -> Result<Option<Covariance>, IdentifyError> {
    let layout = robot.layout();
    let jac = weighted_jacobian(robot, poses_rad, weights, free);
    let priority: Vec<usize> = keep_priority(layout)
        .into_iter()
        .filter_map(|k| free.iter().position(|&f| f == k))
        .collect();
    let an = analyze_matrix(jac.clone(), &priority, opts)?;
    let r = an.kept.len();
    let m = poses_rad.len() / robot.n_joints();
    if r == 0 || 3 * m <= r {
        return Ok(None);
    }
    let dof = 3 * m - r;
    let rss = weighted_rss(robot, poses_rad, points_mm, weights);
    let sigma2 = rss / dof as f64;

    // Scaled Jacobian of the kept columns and its SVD.
    let mut jk = jac.select_columns(an.kept.iter());
    for (c, &k) in an.kept.iter().enumerate() {
        jk.column_mut(c).scale_mut(an.scale[k]);
    }
    let svd = SVD::try_new(jk, false, true, f64::EPSILON, 10_000).ok_or(IdentifyError::Svd {
        what: "scaled Jacobian of the identifiable parameters",
    })?;
    let v_t = svd.v_t.as_ref().ok_or(IdentifyError::Svd {
        what: "scaled Jacobian of the identifiable parameters",
    })?;
    if svd.singular_values.iter().any(|&s| s.is_nan() || s <= 0.0) {
        return Err(IdentifyError::Svd {
            what: "scaled Jacobian of the identifiable parameters (zero singular value)",
        });
    }
    let inv_s2 = svd.singular_values.map(|s| 1.0 / (s * s));
    // (J̃ᵀJ̃)⁻¹ = V Σ⁻² Vᵀ
    let v = v_t.transpose();
    let cs = &v * DMatrix::from_diagonal(&inv_s2) * v_t;

    let indices: Vec<usize> = an.kept.iter().map(|&k| free[k]).collect();
    let infos: Vec<_> = indices.iter().map(|&k| layout.get(k)).collect();
    let factor: Vec<f64> = infos
        .iter()
        .zip(&an.kept)
        .map(|(info, &k)| info.to_display(1.0) * an.scale[k])
        .collect();
    let cov: Vec<Vec<f64>> = (0..r)
        .map(|i| {
            (0..r)
                .map(|j| sigma2 * factor[i] * cs[(i, j)] * factor[j])
                .collect()
        })
        .collect();
    let std_errors: Vec<f64> = (0..r).map(|i| cov[i][i].sqrt()).collect();
    let correlation: Vec<Vec<f64>> = (0..r)
        .map(|i| {
            (0..r)
                .map(|j| {
                    let d = std_errors[i] * std_errors[j];
                    if i == j {
                        1.0
                    } else if d > 0.0 {
                        cov[i][j] / d
                    } else {
                        0.0
                    }
                })
                .collect()
        })
        .collect();
    let names: Vec<String> = infos.iter().map(|i| i.name.clone()).collect();
    let mut high = Vec::new();
    for i in 0..r {
        for j in i + 1..r {
            if correlation[i][j].abs() > correlation_flag {
                high.push(CorrelatedPair {
                    a: names[i].clone(),
                    b: names[j].clone(),
                    rho: correlation[i][j],
                });
            }
        }
    }
    if !cov.iter().flatten().all(|v| v.is_finite()) {
        return Err(IdentifyError::NonFiniteStep {
            iteration: 0,
            what: "covariance",
        });
    }
    Ok(Some(Covariance {
        units: infos.iter().map(|i| i.unit).collect(),
        omitted: an
            .dropped
            .iter()
            .map(|&k| layout.get(free[k]).name.clone())
            .collect(),
        parameters: names,
        indices,
        sigma_hat: sigma2.sqrt(),
        dof,
        weighted: weights.is_some(),
        covariance: cov,
        std_errors,
        correlation,
        high_correlations: high,
        correlation_flag,
    }))
}
