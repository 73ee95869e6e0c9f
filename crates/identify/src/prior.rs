//! Gaussian priors on the parameters: maximum a posteriori identification (`docs/model.md`
//! §7).
//!
//! A prior `x_k ~ N(x0_k, σ0_k²)` on parameter k is one more row of the least squares,
//! `(x_k − x0_k)/σ0_k`, beside the data's rows `e/σ_e` (σ_e the noise of one residual row:
//! mm per axis unweighted, 1 when the rows are weighted by 1/σ). Multiplied through by σ_e²
//! to keep the data's cost in its units, the cost is
//!
//! `F(x) = Σ_j ‖e_j‖² + Σ_k λ_k (x_k − x0_k)²`, `λ_k = σ_e² / σ0_k²`,
//!
//! so the solver adds `λ_k` to the diagonal of the normal matrix, `λ_k (x0_k − x_k)` to the
//! gradient and the sum to the cost ([`PriorTerm`], carried by the [`crate::Problem`]), and
//! nothing else changes. At the solution the covariance of the solved parameters is the
//! posterior `σ_e² (JᵀJ + Λ)⁻¹` ([`Posterior`]). A parameter whose posterior standard
//! deviation exceeds half its prior's is held by the prior rather than determined by the data
//! ([`HELD_BY_PRIOR`]); `1 − var_post/var_prior` is the share of the prior's uncertainty the
//! data removed (the information they gave it).

use kinematics::{Robot, Unit};
use nalgebra::{DMatrix, DVector};
use serde::{Deserialize, Serialize};

use crate::error::IdentifyError;

/// A parameter is said to be held by the prior when its posterior standard deviation exceeds
/// this fraction of the prior's [0.5: the data then removed less than three quarters of the
/// prior variance; the value comes more from the robot file than from the measurements].
pub const HELD_BY_PRIOR: f64 = 0.5;

/// A Gaussian prior: mean and standard deviation per parameter (layout order, internal units:
/// rad, mm; `None`: no prior on that parameter).
#[derive(Clone, Debug, PartialEq)]
pub struct Prior {
    /// Means, one per parameter of the layout.
    pub mean: Vec<f64>,
    /// Standard deviations, one per parameter (`None`: no prior).
    pub sd: Vec<Option<f64>>,
}

impl Prior {
    /// A prior centred on `robot`'s parameters with the standard deviations `sd` (internal
    /// units, one per parameter).
    ///
    /// # Errors
    /// [`IdentifyError::InvalidOption`] for a length other than the layout's or a standard
    /// deviation that is not finite and positive.
    pub fn centred_on(robot: &Robot, sd: Vec<Option<f64>>) -> Result<Prior, IdentifyError> {
        let layout = robot.layout();
        if sd.len() != robot.n_params() {
            return Err(IdentifyError::InvalidOption {
                name: "prior",
                value: format!("{} standard deviations", sd.len()),
                reason: "one per parameter of the robot is needed",
            });
        }
        if let Some(k) = sd
            .iter()
            .position(|s| s.is_some_and(|s| !(s.is_finite() && s > 0.0)))
        {
            return Err(IdentifyError::InvalidOption {
                name: "prior",
                value: format!("{} sd = {:?}", layout.get(k).name, sd[k]),
                reason: "a prior's standard deviation must be finite and positive",
            });
        }
        Ok(Prior {
            mean: robot.params(),
            sd,
        })
    }

    /// The term the solver adds for residual rows of noise `sigma_e` (mm per axis
    /// unweighted, 1 weighted by 1/σ).
    pub fn term(&self, sigma_e: f64) -> PriorTerm {
        PriorTerm {
            mean: self.mean.clone(),
            weight: self
                .sd
                .iter()
                .map(|s| s.map_or(0.0, |s| (sigma_e / s).powi(2)))
                .collect(),
            sigma_e,
        }
    }
}

/// The prior's rows as the solver sees them: `λ_k (x_k − x0_k)²` (module docs).
#[derive(Clone, Debug, PartialEq)]
pub struct PriorTerm {
    /// x0 per parameter (layout order, internal units).
    pub mean: Vec<f64>,
    /// λ_k = σ_e²/σ0_k² per parameter (0: no prior).
    pub weight: Vec<f64>,
    /// The residual rows' noise σ_e the weights were formed with.
    pub sigma_e: f64,
}

impl PriorTerm {
    /// `Σ_{k ∈ free} λ_k (x_k − x0_k)²` (free in order).
    pub fn cost(&self, x: &[f64], free: &[usize]) -> f64 {
        free.iter()
            .map(|&k| {
                let d = x[k] - self.mean[k];
                self.weight[k] * d * d
            })
            .sum()
    }

    /// Adds the prior to the column-scaled normal equations `a`, `g` (columns `free`, scale
    /// `s`): `a_cc += s_c² λ_k`, `g_c += s_c λ_k (x0_k − x_k)`.
    pub(crate) fn add_scaled(
        &self,
        x: &[f64],
        free: &[usize],
        s: &[f64],
        a: &mut DMatrix<f64>,
        g: &mut DVector<f64>,
    ) {
        for (c, &k) in free.iter().enumerate() {
            let w = self.weight[k];
            if w > 0.0 {
                a[(c, c)] += s[c] * s[c] * w;
                g[c] += s[c] * w * (self.mean[k] - x[k]);
            }
        }
    }
}

/// The posterior `σ_e² (A + Λ)⁻¹` from the data's normal matrix `a` (`JᵀJ`, unscaled) at
/// `solution`, whose first `free.len()` columns are the robot parameters `free` (layout
/// indices; further columns, such as a tool frame's, have no prior and are not reported).
/// `None` when `A + Λ` is not positive definite (a parameter that neither the data nor the
/// prior determine). The one computation of [`crate::posterior`] (points) and of the 6-DoF
/// fit with a prior ([`crate::frames::fit_frames_with_prior`]).
pub(crate) fn posterior_from(
    mut a: DMatrix<f64>,
    term: &PriorTerm,
    solution: &Robot,
    free: &[usize],
) -> Option<Posterior> {
    let pf = a.nrows();
    for (c, &k) in free.iter().enumerate() {
        let w = term.weight[k];
        if w > 0.0 {
            a[(c, c)] += w;
        }
    }
    // Scaled to unit diagonal for the factorisation (angles against lengths).
    let s: Vec<f64> = (0..pf)
        .map(|c| {
            let d = a[(c, c)];
            if d > 0.0 { 1.0 / d.sqrt() } else { 1.0 }
        })
        .collect();
    let scaled = DMatrix::from_fn(pf, pf, |i, j| s[i] * a[(i, j)] * s[j]);
    let inv = scaled.cholesky()?.inverse();
    let layout = solution.layout();
    let s2 = term.sigma_e * term.sigma_e;
    let params = free
        .iter()
        .enumerate()
        .map(|(c, &k)| {
            let info = layout.get(k);
            let to = info.to_display(1.0).abs();
            let var = s2 * s[c] * s[c] * inv[(c, c)];
            let posterior_sd = var.max(0.0).sqrt() * to;
            let prior_sd =
                (term.weight[k] > 0.0).then(|| term.sigma_e / term.weight[k].sqrt() * to);
            PosteriorParam {
                name: info.name.to_string(),
                unit: info.unit,
                prior_sd,
                posterior_sd,
                information: prior_sd.map(|p| 1.0 - (posterior_sd / p).powi(2)),
                held_by_prior: prior_sd.is_some_and(|p| posterior_sd > HELD_BY_PRIOR * p),
            }
        })
        .collect();
    Some(Posterior {
        sigma_e: term.sigma_e,
        params,
    })
}

/// One parameter's prior, posterior and the information the data gave it (display units).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PosteriorParam {
    /// Parameter name.
    pub name: String,
    /// Display unit.
    pub unit: Unit,
    /// Prior standard deviation (`None`: no prior on it).
    pub prior_sd: Option<f64>,
    /// Posterior standard deviation.
    pub posterior_sd: f64,
    /// `1 − var_post/var_prior` (`None` without a prior): the share of the prior's
    /// uncertainty the data removed.
    pub information: Option<f64>,
    /// Posterior sd above [`HELD_BY_PRIOR`] × prior sd.
    pub held_by_prior: bool,
}

/// The posterior of the solved parameters at a MAP solution.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Posterior {
    /// σ_e the prior was weighed with.
    pub sigma_e: f64,
    /// One entry per solved free parameter, layout order.
    pub params: Vec<PosteriorParam>,
}

impl Posterior {
    /// The parameters held by the prior, by name.
    pub fn held_by_prior(&self) -> Vec<&str> {
        self.params
            .iter()
            .filter(|p| p.held_by_prior)
            .map(|p| p.name.as_str())
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{IdentifyOptions, ParamSet, identify};
    use kinematics::{PoseSampler, RobotSpec};
    use rand::{SeedableRng, rngs::ChaCha8Rng};

    /// A KR1000 with a2 0.3 mm longer, measured noise-free at 40 poses. A prior of 0.01 mm on
    /// a2 (σ_e = 0.05 mm) pulls it most of the way back: the MAP solution is where the data's
    /// gradient balances the prior's, `Jᵀe = λ (x − x0)` on every solved parameter; the
    /// posterior marks a2 as the prior's. A prior of 20 mm leaves the fit where the data put
    /// it (0.3 mm to 1e-6).
    #[test]
    fn the_map_solution_balances_the_data_and_the_prior() {
        let text = std::fs::read_to_string(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../scenarios/robots/kr1000-titan.json"
        ))
        .unwrap();
        let nominal =
            Robot::from_spec(&RobotSpec::from_json_str(&text, "kr1000").unwrap()).unwrap();
        let k = nominal.layout().index_of("a2").unwrap();
        let mut x = nominal.params();
        x[k] += 0.3;
        let truth = nominal.with_params(&x).unwrap();
        let poses = PoseSampler::default()
            .sample(&nominal, 40, &mut ChaCha8Rng::seed_from_u64(7))
            .unwrap()
            .rad;
        let points = truth.points(&poses);
        let free = ParamSet::Minimal
            .resolve(&nominal, &poses, None, &Default::default())
            .unwrap();
        let problem = crate::Problem::new(&nominal, &poses, &points, free).unwrap();
        let mut sd = vec![None; nominal.n_params()];
        sd[k] = Some(0.01);
        let prior = Prior::centred_on(&nominal, sd).unwrap();
        let term = prior.term(0.05);
        let map = problem.clone().with_prior(&term).unwrap();
        let fit = identify(&map, &IdentifyOptions::default()).unwrap();
        let a2 = fit.estimate("a2").unwrap().change;
        assert!(a2 > 0.0 && a2 < 0.3, "{a2}");
        // Stationarity: the data's gradient Jᵀe equals λ (x − x0) at the solution.
        let at = problem.with_robot(&fit.robot);
        let pf = at.free().len();
        let (mut a, mut g) = (DMatrix::zeros(pf, pf), DVector::zeros(pf));
        at.normal_equations(&mut a, &mut g);
        for (c, &j) in at.free().iter().enumerate() {
            let want = term.weight[j] * (fit.params[j] - term.mean[j]);
            assert!(
                (g[c] - want).abs() < 1e-6 * (1.0 + want.abs()),
                "{}: {} vs {want}",
                nominal.layout().get(j).name,
                g[c]
            );
        }
        let post = fit.posterior.as_ref().unwrap();
        let p = post.params.iter().find(|p| p.name == "a2").unwrap();
        assert_eq!(p.prior_sd, Some(0.01));
        assert!(p.held_by_prior && p.posterior_sd < 0.01, "{p:?}");
        assert!(post.params.iter().filter(|p| p.held_by_prior).count() == 1);
        // A wide prior: the data's answer.
        let mut sd = vec![None; nominal.n_params()];
        sd[k] = Some(20.0);
        let term = Prior::centred_on(&nominal, sd).unwrap().term(0.05);
        let fit = identify(
            &problem.clone().with_prior(&term).unwrap(),
            &Default::default(),
        )
        .unwrap();
        assert!((fit.estimate("a2").unwrap().change - 0.3).abs() < 1e-6);
        assert!(fit.posterior.unwrap().held_by_prior().is_empty());
        // Bad standard deviations are refused.
        let mut sd = vec![None; nominal.n_params()];
        sd[k] = Some(0.0);
        assert!(Prior::centred_on(&nominal, sd).is_err());
    }
}
