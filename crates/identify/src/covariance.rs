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
//! spans ten orders of magnitude (angles vs lengths) — or, when the identifiable subset can
//! be certified without the SVD (the usual case: exact redundancies at rounding level and a
//! well-conditioned rest, see `kept_by_cholesky` in [`crate::identifiability`]), through the
//! Cholesky factor of the scaled `J̃_KᵀJ̃_K`, `(JᵀJ)⁻¹ = S L⁻ᵀL⁻¹ S`, a hundred times
//! cheaper. The two agree to ~1e-9 relative; [`covariance_reference`] always takes the SVD.
//!
//! Redundant free parameters (e.g. the paper's 34) have no finite variance: they are listed in
//! [`Covariance::omitted`], and the covariance describes the minimal re-parametrisation with
//! the omitted ones held at their values.

use kinematics::{ParamName, PoseTrig, Robot, Unit};
use nalgebra::{DMatrix, DVector, Vector3, linalg::SVD};
use serde::{Deserialize, Serialize};

use crate::error::IdentifyError;
use crate::identifiability::{
    IdentifiabilityOptions, analyze_matrix, free_priority, kept_by_cholesky,
};
use crate::lm::{FinalSystem, LmSolution, LsSolution};
use crate::problem::{
    NormalWork, Problem, check_free, check_poses_and_points, check_weights, weighted_jacobian,
    weighted_rss, weighted_rss_trig,
};

/// A pair of parameters with a large correlation.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CorrelatedPair {
    /// First parameter.
    pub a: ParamName,
    /// Second parameter.
    pub b: ParamName,
    /// Correlation coefficient ρ_ab.
    pub rho: f64,
}

/// Covariance, standard errors and correlations of the identifiable free parameters, in
/// display units (deg, mm).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Covariance {
    /// Parameters covered (the identifiable subset of the free ones), layout order.
    pub parameters: Vec<ParamName>,
    /// Their indices in the robot's parameter vector.
    pub indices: Vec<usize>,
    /// Their display units.
    pub units: Vec<Unit>,
    /// Free parameters left out because they are redundant.
    pub omitted: Vec<ParamName>,
    /// σ̂ = √(F / dof): mm per axis unweighted, dimensionless weighted.
    pub sigma_hat: f64,
    /// Degrees of freedom 3m − r.
    pub dof: usize,
    /// Whether the residuals were weighted.
    pub weighted: bool,
    /// Covariance matrix, display units (deg², deg·mm, mm²); written as rows.
    #[serde(with = "rows")]
    pub covariance: DMatrix<f64>,
    /// Standard errors √Cov_kk, display units.
    pub std_errors: Vec<f64>,
    /// Correlation matrix ρ_kl = Cov_kl / (σ_k σ_l); written as rows.
    #[serde(with = "rows")]
    pub correlation: DMatrix<f64>,
    /// Pairs with |ρ| above the flag threshold.
    pub high_correlations: Vec<CorrelatedPair>,
    /// The flag threshold used.
    pub correlation_flag: f64,
}

impl Covariance {
    /// Gives the covariance's buffers back to the thread for its next solves (see
    /// [`crate::LmSolution::recycle`]).
    pub fn recycle(self) {
        let Covariance {
            parameters,
            indices,
            units,
            omitted,
            covariance,
            std_errors,
            correlation,
            high_correlations,
            ..
        } = self;
        crate::scratch::give_back_names(parameters);
        crate::scratch::give_back_indices(indices);
        crate::scratch::give_back_units(units);
        crate::scratch::give_back_names(omitted);
        crate::scratch::give_back_matrix(covariance);
        crate::scratch::give_back(std_errors);
        crate::scratch::give_back_matrix(correlation);
        crate::scratch::give_back_correlations(high_correlations);
    }

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
///
/// The identifiable subset and `(J̃_KᵀJ̃_K)⁻¹` come from a Cholesky factorisation of the
/// scaled normal matrix when that choice can be certified to be the SVD's (a clear gap
/// between exact redundancies and the identifiable directions, the usual case; see
/// [`crate::identifiability`]); otherwise from the SVD as described above. The two agree to
/// ~1e-9 relative.
///
/// Errors on inputs that do not fit: poses not a whole number of joint vectors or not
/// finite, a point count other than the pose count, weights other than 3 per pose, free
/// indices out of range or repeated.
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
    let m = check_poses_and_points(robot, poses_rad, points_mm)?;
    if let Some(w) = weights {
        check_weights(w, 3 * m)?;
    }
    // (Checked on a copy: the caller's order is the order of the result.)
    check_free(robot, free.to_vec())?;
    covariance_on(
        Source::Fast,
        robot,
        poses_rad,
        points_mm,
        weights,
        free,
        opts,
        correlation_flag,
    )
}

/// [`covariance`] at the solution of [`crate::solve`], reusing the normal matrix the solver
/// assembled there instead of assembling it again: the same result, bit for bit, as
/// `covariance(&solution.robot, …)` with the problem's poses, weights and free parameters.
/// `points_mm` (one per pose) give the residual sum of squares; they may differ from the
/// problem's, e.g. the measurements when the solve fitted a model's points. When the
/// solution does not match the problem (other poses, weights or free set) or comes from the
/// reference path, the matrix is assembled afresh. Free parameters the solver held
/// ([`LmSolution::held`]) are left out: the covariance is that of the solved ones.
pub fn covariance_at_solution(
    problem: &Problem,
    solution: &LmSolution,
    points_mm: &[Vector3<f64>],
    opts: &IdentifiabilityOptions,
    correlation_flag: f64,
) -> Result<Option<Covariance>, IdentifyError> {
    let (poses, weights) = (problem.poses_rad(), problem.weights());
    // Parameters the solver held (exactly redundant at the start) are not estimated.
    let mut solved = crate::scratch::indices(problem.free().len());
    solution.solved_into(problem, &mut solved);
    let free = &solved[..];
    let source = match &solution.system {
        Some(sys)
            if sys.free == free
                && sys.poses == poses
                && sys.weights.as_deref() == weights
                && points_mm.len() == sys.trig.n_poses() =>
        {
            // The solver's cost is this sum, bit for bit, when the points are the problem's.
            // (With a prior the solver's cost holds the prior's too.)
            let cost = (std::ptr::eq(points_mm, problem.points_mm()) && problem.prior().is_none())
                .then_some(solution.cost);
            Source::Solved(sys, cost)
        }
        _ => Source::Fast,
    };
    let mut cov = covariance_on(
        source,
        &solution.robot,
        poses,
        points_mm,
        weights,
        free,
        opts,
        correlation_flag,
    )?;
    // The held parameters are redundant too: named among the omitted ones, layout order.
    if let Some(c) = cov.as_mut().filter(|_| !solution.held.is_empty()) {
        let layout = solution.robot.layout();
        let mut omitted = crate::scratch::copy_indices(&solution.held);
        omitted.extend(c.omitted.iter().filter_map(|n| layout.index_of(n).ok()));
        omitted.sort_unstable();
        c.omitted.clear();
        c.omitted
            .extend(omitted.iter().map(|&k| layout.get(k).name));
        crate::scratch::give_back_indices(omitted);
    }
    crate::scratch::give_back_indices(solved);
    Ok(cov)
}

/// Where [`covariance_on`] gets the Jacobian and normal matrix from.
enum Source<'s> {
    /// The reference Jacobian and the SVD, always.
    Reference,
    /// The fast assembly, then the Cholesky path when certified.
    Fast,
    /// The solver's normal matrix at the solution, then the Cholesky path when certified;
    /// with the residual sum of squares when it is already known.
    Solved(&'s FinalSystem, Option<f64>),
}

/// [`covariance`] always through the SVD, with the reference Jacobian: the straightforward
/// path the fast one is tested against.
#[doc(hidden)]
#[allow(clippy::too_many_arguments)]
pub fn covariance_reference(
    robot: &Robot,
    poses_rad: &[f64],
    points_mm: &[Vector3<f64>],
    weights: Option<&[f64]>,
    free: &[usize],
    opts: &IdentifiabilityOptions,
    correlation_flag: f64,
) -> Result<Option<Covariance>, IdentifyError> {
    covariance_on(
        Source::Reference,
        robot,
        poses_rad,
        points_mm,
        weights,
        free,
        opts,
        correlation_flag,
    )
}

/// `(J̃_KᵀJ̃_K)⁻¹` of the kept scaled columns by the SVD of J̃_K.
fn inverse_by_svd(
    jac: &DMatrix<f64>,
    kept: &[usize],
    scale: &[f64],
) -> Result<DMatrix<f64>, IdentifyError> {
    let mut jk = jac.select_columns(kept.iter());
    for (c, &k) in kept.iter().enumerate() {
        jk.column_mut(c).scale_mut(scale[k]);
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
    Ok(&v * DMatrix::from_diagonal(&inv_s2) * v_t)
}

#[allow(clippy::too_many_arguments)]
fn covariance_on(
    source: Source,
    robot: &Robot,
    poses_rad: &[f64],
    points_mm: &[Vector3<f64>],
    weights: Option<&[f64]>,
    free: &[usize],
    opts: &IdentifiabilityOptions,
    correlation_flag: f64,
) -> Result<Option<Covariance>, IdentifyError> {
    let layout = robot.layout();
    let n = robot.n_joints();
    let m = poses_rad.len() / n;
    let pf = free.len();
    let priority = free_priority(layout, free);
    // The stacked Jacobian, computed at most once and only when needed.
    let mut jac: Option<DMatrix<f64>> = None;
    let (rss, certified) = match source {
        Source::Reference => {
            jac = Some(weighted_jacobian(robot, poses_rad, weights, free));
            (weighted_rss(robot, poses_rad, points_mm, weights), None)
        }
        Source::Fast => {
            let trig = PoseTrig::for_robot(robot, poses_rad);
            let mut work = NormalWork::new(pf);
            let mut j = DMatrix::zeros(3 * m, pf);
            let cost = work.assemble_stacked(robot, &trig, points_mm, weights, free, &mut j);
            let mut a = DMatrix::zeros(pf, pf);
            let mut g = DVector::zeros(pf);
            work.copy_to(&mut a, &mut g);
            let certified = kept_by_cholesky(&mut || j.clone(), &a, &priority, opts);
            jac = Some(j);
            (cost, certified)
        }
        Source::Solved(sys, cost) => {
            let rss =
                cost.unwrap_or_else(|| weighted_rss_trig(robot, &sys.trig, points_mm, weights));
            let mut make = || {
                let mut j = DMatrix::zeros(3 * m, pf);
                NormalWork::stacked_jacobian(robot, &sys.trig, weights, free, &mut j);
                j
            };
            let certified = kept_by_cholesky(&mut make, &sys.a, &priority, opts);
            if certified.is_none() {
                jac = Some(make());
            }
            (rss, certified)
        }
    };
    let (kept, dropped, scale, cs) = match certified {
        Some(k) => (k.kept, k.dropped, k.scale, Some(k.inv)),
        None => {
            let j = jac
                .as_ref()
                .expect("the Jacobian is computed when not certified");
            let an = analyze_matrix(j.clone(), &priority, opts)?;
            (an.kept, an.dropped, an.scale, None)
        }
    };
    let r = kept.len();
    if r == 0 || 3 * m <= r {
        return Ok(None);
    }
    let dof = 3 * m - r;
    let sigma2 = rss / dof as f64;
    let cs = match cs {
        Some(cs) => cs,
        None => inverse_by_svd(
            jac.as_ref()
                .expect("the Jacobian is computed when not certified"),
            &kept,
            &scale,
        )?,
    };

    // (The result's buffers from the thread's pools: `Covariance::recycle` gives them back.)
    let mut indices = crate::scratch::indices(r);
    indices.extend(kept.iter().map(|&k| free[k]));
    let mut factor = crate::scratch::with_capacity(r);
    factor.extend(
        indices
            .iter()
            .zip(&kept)
            .map(|(&p, &k)| layout.get(p).to_display(1.0) * scale[k]),
    );
    let mut cov = crate::scratch::zero_matrix(r, r);
    for j in 0..r {
        for i in 0..r {
            cov[(i, j)] = sigma2 * factor[i] * cs[(i, j)] * factor[j];
        }
    }
    let mut std_errors = crate::scratch::with_capacity(r);
    std_errors.extend((0..r).map(|i| cov[(i, i)].sqrt()));
    let mut correlation = crate::scratch::zero_matrix(r, r);
    for j in 0..r {
        for i in 0..r {
            let d = std_errors[i] * std_errors[j];
            correlation[(i, j)] = if i == j {
                1.0
            } else if d > 0.0 {
                cov[(i, j)] / d
            } else {
                0.0
            };
        }
    }
    let mut names = crate::scratch::names();
    names.extend(indices.iter().map(|&k| layout.get(k).name));
    let mut high = crate::scratch::correlations();
    for i in 0..r {
        for j in i + 1..r {
            if correlation[(i, j)].abs() > correlation_flag {
                high.push(CorrelatedPair {
                    a: names[i],
                    b: names[j],
                    rho: correlation[(i, j)],
                });
            }
        }
    }
    crate::scratch::give_back(factor);
    if !cov.iter().all(|v| v.is_finite()) {
        return Err(IdentifyError::NonFiniteStep {
            iteration: 0,
            what: "covariance",
        });
    }
    let mut units = crate::scratch::units();
    units.extend(indices.iter().map(|&k| layout.get(k).unit));
    let mut omitted = crate::scratch::names();
    omitted.extend(dropped.iter().map(|&k| layout.get(free[k]).name));
    // The scratch back to the thread's pools (a rank decided by the SVD gave owned buffers:
    // they join the pools too).
    crate::scratch::give_back_indices(kept);
    crate::scratch::give_back_indices(priority);
    crate::scratch::give_back(scale);
    crate::scratch::give_back_matrix(cs);
    Ok(Some(Covariance {
        units,
        omitted,
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

/// The covariance of every unknown of a least-squares fit from its normal matrix
/// ([`crate::lm::LsSolution::covariance`]): what the 6-DoF and multi-target fits report,
/// whose unknowns are all identifiable by construction ([`crate::frames::select_free`]).
#[derive(Clone, Debug, PartialEq)]
pub struct NormalCovariance {
    /// Degrees of freedom n − P.
    pub dof: usize,
    /// σ̂ = √(cost/dof) (1 when the weights are the true 1/σ); NaN when dof = 0.
    pub sigma_hat: f64,
    /// Condition number of the column-scaled Jacobian, √(λ_max/λ_min) of the scaled `JᵀJ`.
    pub condition_number: f64,
    /// `σ̂²(JᵀJ)⁻¹`, internal units, the unknowns' order.
    pub covariance: DMatrix<f64>,
}

/// `σ̂²(JᵀJ)⁻¹` of the weighted normal matrix `a` at a solution of cost `cost` from
/// `n_equations` residual rows, through the column-scaled matrix (`S a S`, unit diagonal:
/// better conditioned) and its Cholesky factor.
///
/// # Errors
/// [`IdentifyError::Singular`] (with `iteration`, μ = 0) when the scaled matrix is not
/// positive definite.
pub fn normal_covariance(
    a: &DMatrix<f64>,
    cost: f64,
    n_equations: usize,
    iteration: usize,
) -> Result<NormalCovariance, IdentifyError> {
    let pf = a.nrows();
    let dof = n_equations.saturating_sub(pf);
    let sigma_hat = if dof > 0 {
        (cost / dof as f64).sqrt()
    } else {
        f64::NAN
    };
    let s: Vec<f64> = (0..pf)
        .map(|k| 1.0 / a[(k, k)].sqrt().max(1e-300))
        .collect();
    let scaled = DMatrix::from_fn(pf, pf, |r, c| a[(r, c)] * s[r] * s[c]);
    let eig = scaled.clone().symmetric_eigenvalues();
    let (emax, emin) = (eig.max(), eig.min());
    let condition_number = if emin > 0.0 {
        (emax / emin).sqrt()
    } else {
        f64::INFINITY
    };
    let inv = scaled
        .cholesky()
        .ok_or(IdentifyError::Singular { iteration, mu: 0.0 })?
        .inverse();
    let covariance = DMatrix::from_fn(pf, pf, |r, c| {
        inv[(r, c)] * s[r] * s[c] * sigma_hat * sigma_hat
    });
    Ok(NormalCovariance {
        dof,
        sigma_hat,
        condition_number,
        covariance,
    })
}

// The covariance of the one solver's solution lives here, with the covariance maths (the
// solver does not depend on this module).
impl<M> LsSolution<M> {
    /// The covariance of the unknowns at the solution, `σ̂²(JᵀJ)⁻¹` with `σ̂² = cost / (n −
    /// P)`, for `n_equations` = n residual rows ([`normal_covariance`]).
    ///
    /// # Errors
    /// [`IdentifyError::Singular`] when `JᵀJ` is not positive definite.
    pub fn covariance(&self, n_equations: usize) -> Result<NormalCovariance, IdentifyError> {
        normal_covariance(&self.normal_matrix, self.cost, n_equations, self.iterations)
    }
}

/// A square matrix written and read as an array of rows (`[[..], ..]`): the covariance's
/// and correlation's form in `identified.json`.
mod rows {
    use nalgebra::DMatrix;
    use serde::de::Error as _;
    use serde::ser::SerializeSeq;
    use serde::{Deserialize, Deserializer, Serialize, Serializer};

    /// Row `.1` of matrix `.0`, as a sequence.
    struct Row<'a>(&'a DMatrix<f64>, usize);

    impl Serialize for Row<'_> {
        fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
            let mut seq = s.serialize_seq(Some(self.0.ncols()))?;
            for j in 0..self.0.ncols() {
                seq.serialize_element(&self.0[(self.1, j)])?;
            }
            seq.end()
        }
    }

    pub fn serialize<S: Serializer>(m: &DMatrix<f64>, s: S) -> Result<S::Ok, S::Error> {
        let mut seq = s.serialize_seq(Some(m.nrows()))?;
        for i in 0..m.nrows() {
            seq.serialize_element(&Row(m, i))?;
        }
        seq.end()
    }

    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<DMatrix<f64>, D::Error> {
        let rows = Vec::<Vec<f64>>::deserialize(d)?;
        let n = rows.len();
        if let Some((i, row)) = rows.iter().enumerate().find(|(_, r)| r.len() != n) {
            return Err(D::Error::custom(format!(
                "row {i} has {} entries: a square matrix of {n} rows needs {n} in each",
                row.len()
            )));
        }
        Ok(DMatrix::from_fn(n, n, |i, j| rows[i][j]))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The matrices are written as arrays of rows, the same text a `Vec<Vec<f64>>` gives
    /// (what `identified.json` held before they were matrices), and read back equal; a
    /// ragged or non-square array is refused naming the row. The matrix is not symmetric
    /// (nor is a computed covariance, to the last bit), so a transposition would show.
    #[test]
    fn matrices_are_written_and_read_as_rows() {
        let m = DMatrix::from_row_slice(2, 2, &[1.0, -0.25, -0.5, 4.5e-7]);
        let cov = Covariance {
            parameters: vec!["a_1".into(), "d_2".into()],
            indices: vec![3, 4],
            units: vec![Unit::Mm, Unit::Mm],
            omitted: vec![],
            sigma_hat: 0.01,
            dof: 10,
            weighted: false,
            covariance: m.clone(),
            std_errors: vec![1.0, 4.5e-7_f64.sqrt()],
            correlation: m.transpose(),
            high_correlations: vec![],
            correlation_flag: 0.9,
        };
        let text = serde_json::to_string_pretty(&cov).unwrap();
        let rows = serde_json::to_string_pretty(&vec![vec![1.0, -0.25], vec![-0.5, 4.5e-7]])
            .unwrap()
            .replace('\n', "\n  ");
        assert!(text.contains(&format!("\"covariance\": {rows}")), "{text}");
        let back: Covariance = serde_json::from_str(&text).unwrap();
        assert_eq!(back, cov);
        let mut v: serde_json::Value = serde_json::from_str(&text).unwrap();
        v["correlation"] = serde_json::json!([[1.0, 0.0], [0.0]]);
        let e = serde_json::from_value::<Covariance>(v)
            .unwrap_err()
            .to_string();
        assert!(e.contains("row 1 has 1 entries"), "{e}");
    }
}
