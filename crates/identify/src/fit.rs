//! The whole identification: optional base registration, damped least squares, covariance.

use kinematics::{ParamName, Robot, Unit};
use nalgebra::{DMatrix, DVector};
use serde::{Deserialize, Serialize, Serializer};

use crate::covariance::{Covariance, covariance_at_solution};
use crate::error::IdentifyError;
use crate::identifiability::IdentifiabilityOptions;
use crate::lm::{Damping, LmOptions, LmSolution, StopReason, TraceEntry, solve_with};
use crate::problem::{Problem, weighted_rss};
use crate::registration::{
    RegistrationPolicy, RegistrationReport, mean_point_error, not_applied, register_base,
};
use crate::scratch;

/// Options of [`identify`]. Defaults in brackets.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct IdentifyOptions {
    /// The damped least-squares solver [`LmOptions::default`].
    pub lm: LmOptions,
    /// Base registration before solving [`RegistrationPolicy::Auto`] at 10 mm.
    pub registration: RegistrationPolicy,
    /// Rank decisions for the covariance's identifiable subset
    /// [`IdentifiabilityOptions::default`].
    pub identifiability: IdentifiabilityOptions,
    /// Correlations with |ρ| above this are flagged [0.9, the customary threshold].
    pub correlation_flag: f64,
}

impl Default for IdentifyOptions {
    fn default() -> Self {
        IdentifyOptions {
            lm: LmOptions::default(),
            registration: RegistrationPolicy::default(),
            identifiability: IdentifiabilityOptions::default(),
            correlation_flag: 0.9,
        }
    }
}

/// One free parameter's estimate, display units (deg, mm).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ParamEstimate {
    /// Name.
    pub name: ParamName,
    /// Unit of `start`, `value`, `change`, `std_error`.
    pub unit: Unit,
    /// Value in the start model (after registration).
    pub start: f64,
    /// Identified value.
    pub value: f64,
    /// value − start.
    pub change: f64,
    /// Standard error, for identifiable parameters (`None` for redundant ones, whose value is
    /// arbitrary along their null-space direction).
    pub std_error: Option<f64>,
}

fn serialize_robot<S: Serializer>(robot: &Robot, s: S) -> Result<S::Ok, S::Error> {
    robot.to_spec().serialize(s)
}

/// The result of [`identify`].
#[derive(Clone, Debug, Serialize)]
pub struct Fit {
    /// The identified robot (serialised as its model file).
    #[serde(serialize_with = "serialize_robot")]
    pub robot: Robot,
    /// Its full parameter vector, internal units (rad, mm), layout order.
    pub params: Vec<f64>,
    /// Free parameters, layout order.
    pub free: Vec<ParamName>,
    /// Free parameters held at their start values because they were exactly redundant there
    /// ([`crate::lm::Redundant::Hold`]), layout order; their `change` is 0 and they have no
    /// standard error.
    pub held: Vec<ParamName>,
    /// Per free parameter: start, value, change, standard error (display units).
    pub estimates: Vec<ParamEstimate>,
    /// The schedule used.
    pub damping: Damping,
    /// Whether columns were scaled.
    pub column_scaling: bool,
    /// Iterations (accepted + rejected).
    pub iterations: usize,
    /// Accepted steps.
    pub accepted_steps: usize,
    /// Why the solver stopped.
    pub stop: StopReason,
    /// max_k |J_kᵀe| / (‖J_k‖‖e‖) at the solution: ≈ 0 at a true minimum; a stop on a
    /// small step or cost change with a large value here means the damping stalled the
    /// solver short of the minimum.
    pub gradient_cosine: f64,
    /// Per-iteration trace.
    pub trace: Vec<TraceEntry>,
    /// Number of poses m.
    pub n_poses: usize,
    /// Equations 3m.
    pub n_equations: usize,
    /// RMS 3-D point error √(Σ‖e_j‖²/m) at the LM start (after registration), mm.
    pub initial_rms_mm: f64,
    /// Unweighted residual sum of squares Σ‖e_j‖² at the solution, mm².
    pub rss_mm2: f64,
    /// RMS 3-D point error √(rss/m) at the solution, mm.
    pub rms_mm: f64,
    /// The cost minimised (weighted RSS; equals `rss_mm2` when unweighted).
    pub weighted_rss: f64,
    /// σ̂ = √(weighted_rss / dof) (mm per axis unweighted); `None` when dof = 0.
    pub sigma_hat: Option<f64>,
    /// Degrees of freedom 3m − r, r the number of identifiable free parameters (0 when the
    /// covariance could not be formed).
    pub dof: usize,
    /// Covariance of the identifiable free parameters.
    pub covariance: Option<Covariance>,
    /// What registration did (`None` under [`RegistrationPolicy::Never`]).
    pub registration: Option<RegistrationReport>,
    /// With a prior ([`Problem::with_prior`]): the posterior of the solved parameters, which
    /// of them the prior rather than the data determine, and the information the data gave
    /// each (`crate::prior`). `covariance` stays the data's alone.
    pub posterior: Option<crate::prior::Posterior>,
}

impl Fit {
    /// Gives the fit's buffers (robot, parameters, names, estimates, trace, covariance) back
    /// to the thread for its next solves (see [`crate::LmSolution::recycle`]).
    pub fn recycle(self) {
        let Fit {
            robot,
            params,
            free,
            held,
            estimates,
            trace,
            covariance,
            ..
        } = self;
        scratch::give_back_robot(robot);
        scratch::give_back(params);
        scratch::give_back_names(free);
        scratch::give_back_names(held);
        scratch::give_back_estimates(estimates);
        scratch::give_back_trace(trace);
        if let Some(c) = covariance {
            c.recycle();
        }
    }

    /// The estimate of the named free parameter.
    pub fn estimate(&self, name: &str) -> Option<&ParamEstimate> {
        self.estimates.iter().find(|e| e.name == name)
    }
}

/// Identifies the free parameters of `problem`: registers the base if the policy says so,
/// runs [`solve`](crate::solve), and forms the covariance of the identifiable free parameters.
///
/// Registration only re-expresses the base parameters of the start model (whether or not
/// they are free); the free set is kept as given. A `minimal` set resolved on the
/// unregistered model (it keeps `base_rx, base_ry, theta1` of the base-rotation group) stays
/// minimal unless the registered base has rx near ±90° (θ1's axis then lies in the plane of
/// the base_rx and base_ry axes) or ry near ±90° (the Euler singularity); when in doubt,
/// call [`register_base`] first and resolve the set on the registered model. The covariance
/// picks its identifiable subset afresh at the solution.
pub fn identify(problem: &Problem, options: &IdentifyOptions) -> Result<Fit, IdentifyError> {
    options.lm.validate()?;
    if !(options.correlation_flag.is_finite()
        && options.correlation_flag > 0.0
        && options.correlation_flag <= 1.0)
    {
        return Err(IdentifyError::InvalidOption {
            name: "correlation_flag",
            value: format!("{:?}", options.correlation_flag),
            reason: "must lie in (0, 1]",
        });
    }
    let (poses, points) = (problem.poses_rad(), problem.points_mm());
    let start = problem.robot();
    let (registered, registration) = match options.registration {
        RegistrationPolicy::Never => (None, None),
        RegistrationPolicy::Always => {
            let (r, rep) = register_base(start, poses, points)?;
            (Some(r), Some(rep))
        }
        RegistrationPolicy::Auto { threshold_mm } => {
            let before = mean_point_error(start, poses, points);
            if before > threshold_mm {
                let (r, rep) = register_base(start, poses, points)?;
                (Some(r), Some(rep))
            } else {
                (None, Some(not_applied(start, before)))
            }
        }
    };
    let start = registered.as_ref().unwrap_or(start);
    let problem = problem.with_robot(start);
    let sol = solve_with(&problem, &options.lm, &options.identifiability)?;

    let m = problem.n_poses();
    let free = problem.free();
    let cov = covariance_at_solution(
        &problem,
        &sol,
        points,
        &options.identifiability,
        options.correlation_flag,
    )?;
    // Unweighted, the solver's costs are these sums already (the same points, in the same
    // order: bit for bit).
    let (rss_mm2, initial_rss) = if problem.weights().is_none() && problem.prior().is_none() {
        (sol.cost, sol.initial_cost)
    } else {
        (
            weighted_rss(&sol.robot, poses, points, None),
            weighted_rss(start, poses, points, None),
        )
    };
    let layout = start.layout();
    let mut estimates = scratch::estimates();
    estimates.extend(free.iter().map(|&k| {
        let info = layout.get(k);
        let (s, v) = (
            info.to_display(start.param(k)),
            info.to_display(sol.params[k]),
        );
        ParamEstimate {
            name: info.name,
            unit: info.unit,
            start: s,
            value: v,
            change: v - s,
            std_error: cov.as_ref().and_then(|c| c.std_error(&info.name)),
        }
    }));
    // (Without a prior there is none: the solved set is not built.)
    let posterior = problem
        .prior()
        .and_then(|_| posterior(&problem, &sol.robot, &sol.solved(&problem)));
    let weighted_rss = match problem.prior() {
        Some(_) => weighted_rss(&sol.robot, poses, points, problem.weights()),
        None => sol.cost,
    };
    let mut free_names = scratch::names();
    free_names.extend(free.iter().map(|&k| layout.get(k).name));
    let mut held = scratch::names();
    held.extend(sol.held.iter().map(|&k| layout.get(k).name));
    let LmSolution {
        robot,
        params,
        trace,
        column_scale,
        held: held_indices,
        system,
        ..
    } = sol;
    // (What the fit does not hand on, back to the thread's buffers.)
    scratch::give_back(column_scale);
    scratch::give_back_indices(held_indices);
    crate::lm::give_back_system(system);
    Ok(Fit {
        params,
        free: free_names,
        held,
        estimates,
        damping: options.lm.damping,
        column_scaling: options.lm.column_scaling,
        iterations: sol.iterations,
        accepted_steps: sol.accepted_steps,
        stop: sol.stop,
        gradient_cosine: sol.gradient_cosine,
        trace,
        n_poses: m,
        n_equations: 3 * m,
        initial_rms_mm: (initial_rss / m as f64).sqrt(),
        rss_mm2,
        rms_mm: (rss_mm2 / m as f64).sqrt(),
        weighted_rss,
        posterior,
        sigma_hat: cov.as_ref().map(|c| c.sigma_hat),
        dof: cov.as_ref().map_or(0, |c| c.dof),
        covariance: cov,
        registration,
        robot,
    })
}

/// The posterior `σ_e² (JᵀJ + Λ)⁻¹` at `solution` of `problem` on the free parameters
/// `solved` (those the solver moved: a subset of the problem's; `problem` carries the prior
/// term). `None` when the problem has no prior or the matrix is not positive definite (a
/// parameter that neither the data nor the prior determine).
pub fn posterior(
    problem: &Problem,
    solution: &Robot,
    solved: &[usize],
) -> Option<crate::prior::Posterior> {
    let term = problem.prior()?;
    if !solved.iter().all(|k| problem.free().contains(k)) {
        return None;
    }
    let at = problem.with_robot(solution).with_free(solved.to_vec());
    let free = at.free().to_vec();
    let pf = free.len();
    let mut a = DMatrix::zeros(pf, pf);
    let mut g = DVector::zeros(pf);
    at.normal_equations(&mut a, &mut g);
    crate::prior::posterior_from(a, term, solution, &free)
}
