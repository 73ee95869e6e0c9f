//! Damped least squares (Levenberg–Marquardt) on the free parameters, instrumented.
//!
//! # The iteration
//!
//! With the weighted Jacobian `J = diag(w)·∂p/∂x_free` (3m × P), the residual `e` and the cost
//! `F = ‖e‖²` (see [`Problem`]), each iteration solves the damped normal equations in the
//! *solver variables* `x̃ = S⁻¹ x` (S = diag(s_k), the column scaling, see
//! [`LmOptions::column_scaling`]):
//!
//! `(Ã + μ·D) δ̃ = g̃`, with `Ã = S JᵀJ S`, `g̃ = S Jᵀe`, and `δ = S δ̃`,
//!
//! where `D = I` (Levenberg, Nielsen) or `D = diag(Ã)` (Marquardt). The system is formed by
//! accumulating the 3 × P block of every pose (no stacked Jacobian is stored) and solved by
//! Cholesky. A trial point `x + δ` is accepted when the cost decreases; the gain ratio
//! `ρ = (F(x) − F(x + δ)) / (F(x) − ‖e − Jδ‖²)` (actual over predicted decrease, where the
//! predicted decrease is `2δ̃ᵀg̃ − δ̃ᵀÃδ̃`) drives Nielsen's schedule and is traced for all.
//!
//! # Redundant parameters
//!
//! By default ([`Redundant::Hold`]) the free parameters that are exactly redundant at the
//! start model are held there and the iteration below runs on the others (the minimal set's
//! choice, decided from the start system; see [`Redundant`] for why). Under
//! [`Redundant::Damp`], the paper's method, they stay in the system:
//! with the paper's 34 parameters `Ã` is singular (7 exact redundancies for the KR1000). The
//! damping keeps the system positive definite and, because `g̃` lies in the row space of J,
//! steps carry no null-space component: predictions converge, the redundant parameters stay
//! where they started up to second-order drift. To keep this true after many successful
//! iterations, μ never drops below a floor ([`LmOptions::mu_min_rel`]).
//!
//! # Failures
//!
//! A damped matrix that is not positive definite, or a non-finite step or cost, is an error
//! ([`IdentifyError::Singular`], [`IdentifyError::NonFiniteStep`]); no NaN is ever returned.

use std::sync::Arc;

use nalgebra::{DMatrix, DVector, Vector3, linalg::Cholesky};
use serde::{Deserialize, Serialize};

use kinematics::{PoseTrig, Robot};

use crate::error::IdentifyError;
use crate::identifiability::{IdentifiabilityOptions, ZERO_COLUMN_RTOL_SQ, redundant_positions};
use crate::linalg;
use crate::problem::{NormalWork, Problem, assemble_normal, weighted_rss, weighted_rss_trig};
use crate::scratch;

/// When the damped matrix fails to factorise, μ is raised to at least this fraction of
/// max diag(Ã) (and by ×10 each further failure) [1e-12: a thousand times the rounding level
/// of an exactly singular Ã].
const RESCUE_MU_REL: f64 = 1e-12;

/// Largest diagonal scaling D_kk of the damping term.
fn max_dk(damping: Damping, sys: &Scaled) -> f64 {
    match damping {
        Damping::Marquardt { .. } => sys.max_diag(),
        _ => 1.0,
    }
}

fn default_mu0() -> f64 {
    1e-3
}
fn default_factor() -> f64 {
    10.0
}
fn default_tau() -> f64 {
    1e-3
}
fn default_nu0() -> f64 {
    2.0
}

/// How the damping μ starts and adapts (`docs/model.md` §7). Serialised with a `kind` tag, e.g.
/// `{"kind": "levenberg", "mu0": 0.001}`; omitted fields take the defaults below.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "lowercase", deny_unknown_fields)]
pub enum Damping {
    /// The paper's schedule: `(JᵀJ + μI) δ = Jᵀe`, μ ÷ `decrease` after a successful step,
    /// μ × `increase` after a failed one.
    Levenberg {
        /// Initial damping μ0 [1e-3, the paper's value]. In the solver variables: with column
        /// scaling on, diag(Ã) = 1, so μ0 is relative to the curvature of every parameter.
        #[serde(default = "default_mu0")]
        mu0: f64,
        /// Divisor after a successful step [10, the paper].
        #[serde(default = "default_factor")]
        decrease: f64,
        /// Multiplier after a failed step [10, the paper].
        #[serde(default = "default_factor")]
        increase: f64,
    },
    /// Marquardt's scale-invariant form `(JᵀJ + μ·diag(JᵀJ)) δ = Jᵀe`, same updates.
    Marquardt {
        /// Initial damping μ0, relative to each diagonal entry [1e-3].
        #[serde(default = "default_mu0")]
        mu0: f64,
        /// Divisor after a successful step [10, as in Levenberg's].
        #[serde(default = "default_factor")]
        decrease: f64,
        /// Multiplier after a failed step [10, as in Levenberg's].
        #[serde(default = "default_factor")]
        increase: f64,
    },
    /// Nielsen's gain-ratio schedule on `(JᵀJ + μI)`: μ0 = τ·max diag(JᵀJ); after a
    /// successful step μ ← μ·max(1/3, 1 − (2ρ − 1)³) and ν ← ν0; after a failed one
    /// μ ← μ·ν, ν ← 2ν.
    Nielsen {
        /// τ [1e-3, Madsen–Nielsen–Tingleff's recommendation for a start near the solution].
        #[serde(default = "default_tau")]
        tau: f64,
        /// ν0, the first growth factor after a failure and its reset value [2, Nielsen's].
        #[serde(default = "default_nu0")]
        nu0: f64,
    },
}

impl Default for Damping {
    /// The paper's: Levenberg, μ0 = 1e-3, ÷10 / ×10.
    fn default() -> Self {
        Damping::levenberg()
    }
}

impl Damping {
    /// Levenberg with the paper's constants.
    pub fn levenberg() -> Self {
        Damping::Levenberg {
            mu0: default_mu0(),
            decrease: default_factor(),
            increase: default_factor(),
        }
    }

    /// Marquardt with μ0 = 1e-3, ÷10 / ×10.
    pub fn marquardt() -> Self {
        Damping::Marquardt {
            mu0: default_mu0(),
            decrease: default_factor(),
            increase: default_factor(),
        }
    }

    /// Nielsen with τ = 1e-3, ν0 = 2.
    pub fn nielsen() -> Self {
        Damping::Nielsen {
            tau: default_tau(),
            nu0: default_nu0(),
        }
    }

    /// `"levenberg"`, `"marquardt"` or `"nielsen"`.
    pub fn name(&self) -> &'static str {
        match self {
            Damping::Levenberg { .. } => "levenberg",
            Damping::Marquardt { .. } => "marquardt",
            Damping::Nielsen { .. } => "nielsen",
        }
    }

    fn validate(&self) -> Result<(), IdentifyError> {
        let pos = |name: &'static str, v: f64| {
            if v.is_finite() && v > 0.0 {
                Ok(())
            } else {
                Err(IdentifyError::InvalidOption {
                    name,
                    value: format!("{v:?}"),
                    reason: "must be finite and > 0",
                })
            }
        };
        let above_one = |name: &'static str, v: f64| {
            if v.is_finite() && v > 1.0 {
                Ok(())
            } else {
                Err(IdentifyError::InvalidOption {
                    name,
                    value: format!("{v:?}"),
                    reason: "must be finite and > 1",
                })
            }
        };
        match *self {
            Damping::Levenberg {
                mu0,
                decrease,
                increase,
            }
            | Damping::Marquardt {
                mu0,
                decrease,
                increase,
            } => {
                pos("damping.mu0", mu0)?;
                above_one("damping.decrease", decrease)?;
                above_one("damping.increase", increase)
            }
            Damping::Nielsen { tau, nu0 } => {
                pos("damping.tau", tau)?;
                above_one("damping.nu0", nu0)
            }
        }
    }
}

/// What [`solve`] does with free parameters that are exactly redundant at the start model
/// (`docs/model.md` §6: with the paper's 34 parameters, 7 on the KR1000 and 10 on the UR10).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Redundant {
    /// Hold them at their start values and solve on the identifiable rest \[default\]. Which
    /// ones are held follows the minimal set's priority ([`crate::identifiability`]): a
    /// greedy Cholesky of the column-scaled start system drops, from the lowest priority up,
    /// columns within rounding of the span of those kept, and the SVD decides when a column
    /// is not clearly in or out. With the clear gap of exact redundancies (the usual case)
    /// the solved parameters are what [`crate::ParamSet::Minimal`] keeps there. For
    /// redundancies that hold at every parameter value (d1 ↔ base_dz, θ6/d6/a6/α6
    /// ↔ the ball offset, …) the fit is the same as [`Redundant::Damp`]'s: the held columns
    /// stay combinations of the solved ones. For redundancies that hold only at the nominal
    /// geometry (the UR10's parallel axes), damping lets the solver creep along a valley that
    /// second-order effects tilt by a few parts per million of the cost, 100+ iterations for
    /// nothing a tracker can resolve; holding them converges in a few.
    #[default]
    Hold,
    /// Keep every free column in the damped system, as the paper does: the damping alone
    /// keeps `Ã + μD` positive definite (see the module docs).
    Damp,
}

/// Options of [`solve`]. Defaults in brackets, with the reason.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct LmOptions {
    /// The damping schedule [[`Damping::levenberg`], the paper's].
    pub damping: Damping,
    /// Scale every Jacobian column to unit norm (computed once, at the start point) before
    /// damping [true]. Without it μI adds the same number to the curvature of an angle
    /// (‖∂p/∂θ‖² ~ 10⁸ mm²/rad² over 50 poses) and of a length (~10² for the same poses), so
    /// one μ over-damps lengths while leaving angles undamped. Scaled, μ is relative for every
    /// parameter, stopping tests become unit-free, and the solver variable x̃_k = x_k·‖J_k‖ is
    /// "mm of point motion". Set false to reproduce the paper's verbatim `JᵀJ + μI`.
    pub column_scaling: bool,
    /// Iteration cap, counting accepted and rejected steps [100: converging runs take < 20;
    /// the paper iterates "a finite number of times"].
    pub max_iterations: usize,
    /// Small-step test after an accepted step: stop when ‖δ̃‖ ≤ step_tol·(‖x̃‖ + step_tol)
    /// [1e-10: with scaling ‖x̃‖ ≈ 10⁴ mm for the KR1000, i.e. a step moving the points by
    /// ≈ 1e-6 mm].
    pub step_tol: f64,
    /// Small-cost-change test after an accepted step: stop when
    /// F_old − F_new ≤ cost_rel_tol·F_old [1e-10: just above rounding of F at the noise floor
    /// (≈ 1e-11 relative for coordinates of 10³ mm and residuals of 10⁻² mm)]. Also applied to
    /// a rejected step, |F_trial − F| ≤ cost_rel_tol·F: the cost can no longer be told apart,
    /// and further damping only repeats the rejection.
    pub cost_rel_tol: f64,
    /// Small-gradient test: stop when every free column is nearly orthogonal to the residual,
    /// max_k |J_kᵀe| / (‖J_k‖‖e‖) ≤ gradient_tol (scale-invariant; also checked at the start)
    /// [1e-10]. A zero residual passes.
    pub gradient_tol: f64,
    /// Stop after this many consecutive rejected steps [10: μ has then grown by 10¹⁰ under
    /// Levenberg/Marquardt, 2⁵⁵ under Nielsen; the step is negligible].
    pub max_rejections: usize,
    /// Damping floor relative to max diag(Ã) [1e-15]. Every diagonal entry receives at least
    /// mu_min_rel·max diag(Ã), and μ never falls below that (Levenberg, Nielsen) or below
    /// mu_min_rel (Marquardt). With exactly redundant parameters (the paper's set) Ã has
    /// eigenvalues at rounding level (≈ 1e-16·max diag·P); the floor bounds the null-space
    /// part of the step (rounding in g̃ divided by μ) and does not move the fixed point, which
    /// depends only on the gradient. It is low enough that the paper's unscaled schedule
    /// (μ0 = 1e-3 on max diag(JᵀJ) ≈ 4e8 for the KR1000) follows ÷10 for six iterations. If
    /// rounding still makes the damped matrix indefinite, μ is raised (at least to 1e-12·max
    /// diag, ×10 per retry) and the system refactorised; failing even at μ ≥ max diag is
    /// [`IdentifyError::Singular`].
    pub mu_min_rel: f64,
    /// Free parameters exactly redundant at the start [[`Redundant::Hold`]: they are held at
    /// their start values and the rest is solved; `"damp"` keeps them in the damped system,
    /// the paper's verbatim method]. The rank decision uses
    /// [`IdentifiabilityOptions::default`] under [`solve`], the caller's under
    /// [`crate::identify`].
    pub redundant: Redundant,
}

impl Default for LmOptions {
    fn default() -> Self {
        LmOptions {
            damping: Damping::default(),
            column_scaling: true,
            max_iterations: 100,
            step_tol: 1e-10,
            cost_rel_tol: 1e-10,
            gradient_tol: 1e-10,
            max_rejections: 10,
            mu_min_rel: 1e-15,
            redundant: Redundant::Hold,
        }
    }
}

impl LmOptions {
    /// Default options with the given schedule.
    pub fn with_damping(damping: Damping) -> Self {
        LmOptions {
            damping,
            ..LmOptions::default()
        }
    }

    /// Checks every option's range.
    pub fn validate(&self) -> Result<(), IdentifyError> {
        self.damping.validate()?;
        for (name, v) in [
            ("step_tol", self.step_tol),
            ("cost_rel_tol", self.cost_rel_tol),
            ("gradient_tol", self.gradient_tol),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                return Err(IdentifyError::InvalidOption {
                    name,
                    value: format!("{v:?}"),
                    reason: "must be finite and ≥ 0",
                });
            }
        }
        if !(self.mu_min_rel.is_finite() && self.mu_min_rel > 0.0 && self.mu_min_rel < 1.0) {
            return Err(IdentifyError::InvalidOption {
                name: "mu_min_rel",
                value: format!("{:?}", self.mu_min_rel),
                reason: "must lie in (0, 1)",
            });
        }
        if self.max_rejections == 0 {
            return Err(IdentifyError::InvalidOption {
                name: "max_rejections",
                value: "0".into(),
                reason: "must be ≥ 1",
            });
        }
        Ok(())
    }
}

/// Why the iteration stopped.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum StopReason {
    /// The residual is orthogonal to every free column ([`LmOptions::gradient_tol`]).
    SmallGradient,
    /// The last step changed the cost by less than [`LmOptions::cost_rel_tol`] (relative).
    SmallCostChange,
    /// The last accepted step was below [`LmOptions::step_tol`].
    SmallStep,
    /// [`LmOptions::max_iterations`] reached.
    MaxIterations,
    /// [`LmOptions::max_rejections`] consecutive steps failed to lower the cost.
    TooManyRejections,
}

impl StopReason {
    /// True for the three convergence tests.
    pub fn converged(self) -> bool {
        matches!(
            self,
            StopReason::SmallGradient | StopReason::SmallCostChange | StopReason::SmallStep
        )
    }

    /// Snake-case name, as serialised.
    pub fn as_str(self) -> &'static str {
        match self {
            StopReason::SmallGradient => "small_gradient",
            StopReason::SmallCostChange => "small_cost_change",
            StopReason::SmallStep => "small_step",
            StopReason::MaxIterations => "max_iterations",
            StopReason::TooManyRejections => "too_many_rejections",
        }
    }
}

impl std::fmt::Display for StopReason {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.as_str())
    }
}

/// One iteration of the trace.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct TraceEntry {
    /// 1-based iteration (accepted and rejected steps both count).
    pub iteration: usize,
    /// Damping μ used to compute this step.
    pub mu: f64,
    /// ‖δ̃‖, the step in solver variables (mm of point motion with column scaling).
    pub step_norm: f64,
    /// Cost (weighted RSS) before the step.
    pub cost_before: f64,
    /// Cost at the trial point.
    pub cost_trial: f64,
    /// Gain ratio ρ = actual / predicted decrease (0 when the model predicts none).
    pub gain_ratio: f64,
    /// Whether the step was taken.
    pub accepted: bool,
}

/// What [`solve`] returns.
#[derive(Clone, Debug)]
pub struct LmSolution {
    /// The start robot with the identified parameters.
    pub robot: Robot,
    /// Its full parameter vector, internal units (rad, mm).
    pub params: Vec<f64>,
    /// Iterations made (accepted + rejected).
    pub iterations: usize,
    /// Accepted steps.
    pub accepted_steps: usize,
    /// Why it stopped.
    pub stop: StopReason,
    /// One entry per iteration.
    pub trace: Vec<TraceEntry>,
    /// Cost (weighted RSS) at the start.
    pub initial_cost: f64,
    /// Cost at the solution.
    pub cost: f64,
    /// Column scale s_k of each free parameter (1 when scaling is off or the column is zero).
    pub column_scale: Vec<f64>,
    /// max_k |J_kᵀe| / (‖J_k‖‖e‖) at the solution (0 for a zero residual).
    pub gradient_cosine: f64,
    /// Free parameters held at their start values because they were exactly redundant there
    /// ([`Redundant::Hold`]), parameter indices ascending; empty when none was or under
    /// [`Redundant::Damp`]. The trace, `column_scale` and `gradient_cosine` are those of the
    /// other, solved, free parameters.
    pub held: Vec<usize>,
    /// The normal matrix at the solution, for [`crate::covariance_at_solution`].
    pub(crate) system: Option<Arc<FinalSystem>>,
}

impl LmSolution {
    /// Gives the solution's buffers (robot, parameters, trace, column scale, held set) back
    /// to the thread for its next solves (`crate::scratch`): what a caller that runs many
    /// solves does with one it is done with, instead of dropping it (which is always
    /// correct too).
    pub fn recycle(self) {
        let LmSolution {
            robot,
            params,
            trace,
            column_scale,
            held,
            system,
            ..
        } = self;
        scratch::give_back_robot(robot);
        scratch::give_back(params);
        scratch::give_back_trace(trace);
        scratch::give_back(column_scale);
        scratch::give_back_indices(held);
        give_back_system(system);
    }

    /// The free parameters of `problem` that were solved (all but [`LmSolution::held`]),
    /// parameter indices ascending.
    pub fn solved(&self, problem: &Problem) -> Vec<usize> {
        let mut out = Vec::with_capacity(problem.free().len());
        self.solved_into(problem, &mut out);
        out
    }

    /// [`LmSolution::solved`] appended to `out`.
    pub(crate) fn solved_into(&self, problem: &Problem, out: &mut Vec<usize>) {
        out.extend(
            problem
                .free()
                .iter()
                .copied()
                .filter(|k| !self.held.contains(k)),
        );
    }
}

/// What the fast path leaves behind at the solution: the poses' sines and cosines and the
/// unscaled `JᵀJ` (weighted, free parameters), with what they were computed for.
#[derive(Clone, Debug)]
pub(crate) struct FinalSystem {
    pub trig: PoseTrig,
    pub a: DMatrix<f64>,
    pub free: Vec<usize>,
    pub weights: Option<Vec<f64>>,
    pub poses: Vec<f64>,
}

thread_local! {
    /// Emptied final systems' shared boxes, refilled by the thread's next solves (issue 43).
    static SYSTEMS: kinematics::kept::Pool<Arc<FinalSystem>> =
        const { kinematics::kept::Pool::new() };
}

impl FinalSystem {
    /// A system without buffers (nothing allocated).
    fn empty() -> Self {
        FinalSystem {
            trig: PoseTrig::default(),
            a: DMatrix::zeros(0, 0),
            free: Vec::new(),
            weights: None,
            poses: Vec::new(),
        }
    }

    /// `self` in a shared box, one the thread kept if it has one ([`give_back_system`]).
    fn shared(self) -> Arc<FinalSystem> {
        match kinematics::kept::take_pooled(&SYSTEMS) {
            Some(mut arc) => match Arc::get_mut(&mut arc) {
                Some(slot) => {
                    *slot = self;
                    arc
                }
                None => Arc::new(self),
            },
            None => Arc::new(self),
        }
    }
}

/// Gives a solution's final system back: its buffers to the thread's pools and, when no one
/// else holds it, its shared box for the next solve's ([`FinalSystem::shared`]).
pub(crate) fn give_back_system(system: Option<Arc<FinalSystem>>) {
    if let Some(mut arc) = system
        && let Some(fs) = Arc::get_mut(&mut arc)
    {
        // (The old contents drop here: their buffers go back to the pools.)
        *fs = FinalSystem::empty();
        kinematics::kept::give_pooled(&SYSTEMS, 4, || arc);
    }
}

impl Drop for FinalSystem {
    /// Its buffers back to the thread's pools (the sines and cosines to [`PoseTrig`]'s).
    fn drop(&mut self) {
        scratch::give_back_matrix(std::mem::replace(&mut self.a, DMatrix::zeros(0, 0)));
        scratch::give_back_indices(std::mem::take(&mut self.free));
        scratch::give_back(std::mem::take(&mut self.poses));
        if let Some(w) = self.weights.take() {
            scratch::give_back(w);
        }
    }
}

/// The column-scaled system `S a S`, `S g` (S = diag(s)) into `sa`, `sg`.
pub(crate) fn scale_system(
    a: &DMatrix<f64>,
    g: &DVector<f64>,
    s: &[f64],
    sa: &mut DMatrix<f64>,
    sg: &mut DVector<f64>,
) {
    let p = s.len();
    let (src, dst) = (a.as_slice(), sa.as_mut_slice());
    for l in 0..p {
        let sl = s[l];
        let (src, dst) = (&src[l * p..(l + 1) * p], &mut dst[l * p..(l + 1) * p]);
        for ((d, v), sk) in dst.iter_mut().zip(src).zip(s) {
            *d = sk * v * sl;
        }
        sg[l] = sl * g[l];
    }
}

/// Reusable buffers of the scaled system.
struct Scaled {
    a: DMatrix<f64>,
    g: DVector<f64>,
}

impl Scaled {
    fn set(&mut self, a: &DMatrix<f64>, g: &DVector<f64>, s: &[f64]) {
        scale_system(a, g, s, &mut self.a, &mut self.g);
    }

    fn max_diag(&self) -> f64 {
        (0..self.g.len()).fold(0.0, |m: f64, k| m.max(self.a[(k, k)]))
    }

    /// max_k |g̃_k| / (√Ã_kk · √F) (scale-invariant).
    fn gradient_cosine(&self, cost: f64) -> f64 {
        if cost <= 0.0 {
            return 0.0;
        }
        let e_norm = cost.sqrt();
        let mut worst: f64 = 0.0;
        for k in 0..self.g.len() {
            let d = self.a[(k, k)];
            if d > 0.0 {
                worst = worst.max(self.g[k].abs() / (d.sqrt() * e_norm));
            }
        }
        worst
    }

    fn finite(&self) -> bool {
        let all = |v: &[f64]| v.iter().fold(true, |ok, x| ok & x.is_finite());
        all(self.a.as_slice()) && all(self.g.as_slice())
    }
}

/// Which linear algebra [`solve`] runs on; the control flow (damping, acceptance, stopping)
/// is shared.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Path {
    /// The straightforward one: [`assemble_normal`] from [`Robot::point_jacobian_into`] and
    /// nalgebra's Cholesky. What the fast path is tested against.
    Reference,
    /// Sin/cos once per pose, the vectorised assembly ([`NormalWork`]) and the in-place
    /// Cholesky of [`crate::linalg`].
    Fast,
}

/// Writes the damped matrix `Ã + diag(max(μ·D_kk, floor))` into `work`.
fn damped(sys: &Scaled, damping: Damping, mu: f64, floor: f64, work: &mut DMatrix<f64>) {
    let pf = sys.g.len();
    if work.shape() != (pf, pf) {
        *work = DMatrix::zeros(pf, pf);
    }
    work.copy_from(&sys.a);
    for k in 0..pf {
        let dk = match damping {
            Damping::Marquardt { .. } => sys.a[(k, k)],
            _ => 1.0,
        };
        work[(k, k)] += (mu * dk).max(floor);
    }
}

/// Solves the damped system into `step`: the Cholesky factor of the damped matrix
/// `Ã + diag(max(μ·D_kk, floor))` is built in `work`. If rounding makes the matrix
/// indefinite (exactly redundant parameters at a tiny μ), μ is raised and the matrix
/// refactorised; once μ·max D exceeds max diag(Ã) only a non-SPD Ã can fail, which is
/// [`IdentifyError::Singular`].
#[allow(clippy::too_many_arguments)]
fn damped_step(
    path: Path,
    sys: &Scaled,
    damping: Damping,
    mu: &mut f64,
    floor: f64,
    work: &mut DMatrix<f64>,
    pad: &mut Vec<f64>,
    step: &mut DVector<f64>,
    iteration: usize,
) -> Result<(), IdentifyError> {
    let pf = sys.g.len();
    loop {
        step.copy_from(&sys.g);
        match path {
            Path::Reference => {
                damped(sys, damping, *mu, floor, work);
                if let Some(c) = Cholesky::new(std::mem::replace(work, DMatrix::zeros(0, 0))) {
                    c.solve_mut(step);
                    *work = c.unpack();
                    return Ok(());
                }
            }
            Path::Fast => {
                // The damped matrix straight into a buffer padded to whole vector blocks
                // (same factor bits, vectorised). The padding rows stay zero through the
                // factorisation, so they are zeroed only when the buffer is made.
                let ld = linalg::padded_ld(pf);
                if pad.len() != ld * pf {
                    pad.clear();
                    pad.resize(ld * pf, 0.0);
                }
                for (k, (dst, src)) in pad
                    .chunks_exact_mut(ld)
                    .zip(sys.a.as_slice().chunks_exact(pf))
                    .enumerate()
                {
                    dst[..pf].copy_from_slice(src);
                    let dk = match damping {
                        Damping::Marquardt { .. } => src[k],
                        _ => 1.0,
                    };
                    dst[k] += (*mu * dk).max(floor);
                }
                if linalg::cholesky_padded(pad, pf, ld) {
                    linalg::cholesky_solve_padded(pad, pf, ld, step.as_mut_slice());
                    return Ok(());
                }
            }
        }
        if *mu * max_dk(damping, sys) >= sys.max_diag().max(f64::MIN_POSITIVE) {
            return Err(IdentifyError::Singular { iteration, mu: *mu });
        }
        *mu = (*mu * 10.0).max(RESCUE_MU_REL * sys.max_diag());
    }
}

/// The normal equations at a model, by either path.
struct Assembler<'p> {
    path: Path,
    poses: &'p [f64],
    points: &'p [Vector3<f64>],
    weights: Option<&'p [f64]>,
    free: &'p [usize],
    trig: PoseTrig,
    normal: Option<NormalWork>,
    /// The system at the last trial point, assembled with its cost
    /// ([`Assembler::trial_cost`]) and taken over if the step is accepted
    /// ([`Assembler::accept_scaled`]).
    spare: Option<NormalWork>,
    /// Whether `spare` holds the system at the last trial point.
    spare_valid: bool,
}

impl<'p> Assembler<'p> {
    fn new(path: Path, problem: &Problem<'p>, free: &'p [usize]) -> Self {
        let poses = problem.poses_rad();
        let fast = path == Path::Fast;
        Assembler {
            path,
            poses,
            points: problem.points_mm(),
            weights: problem.weights(),
            free,
            trig: if fast {
                PoseTrig::for_robot(problem.robot(), poses)
            } else {
                PoseTrig::default()
            },
            normal: fast.then(|| NormalWork::new(free.len())),
            spare: fast.then(|| NormalWork::new(free.len())),
            spare_valid: false,
        }
    }

    /// An assembler of the same data on the subset `free` of the free parameters, taking
    /// over this one's sines and cosines.
    fn on_subset<'q>(&mut self, free: &'q [usize]) -> Assembler<'q>
    where
        'p: 'q,
    {
        Assembler {
            path: self.path,
            poses: self.poses,
            points: self.points,
            weights: self.weights,
            free,
            trig: std::mem::take(&mut self.trig),
            normal: self.normal.is_some().then(|| NormalWork::new(free.len())),
            spare: self.spare.is_some().then(|| NormalWork::new(free.len())),
            spare_valid: false,
        }
    }

    /// `a`, `g` at `robot`; returns the cost.
    fn assemble(&mut self, robot: &Robot, a: &mut DMatrix<f64>, g: &mut DVector<f64>) -> f64 {
        match &mut self.normal {
            Some(normal) => {
                let cost = normal.assemble(robot, &self.trig, self.points, self.weights, self.free);
                normal.copy_to(a, g);
                cost
            }
            None => assemble_normal(
                robot,
                self.poses,
                self.points,
                self.weights,
                self.free,
                a,
                g,
            ),
        }
    }

    /// Brings `a`, `g` up to date with the last assembly.
    fn unscaled(&self, a: &mut DMatrix<f64>, g: &mut DVector<f64>) {
        if let Some(normal) = &self.normal {
            normal.copy_to(a, g);
        }
    }

    /// The cost at the trial point `robot` (bit for bit the cost [`Assembler::assemble`]
    /// returns). With `speculate` (fast path), the whole system there is assembled on the
    /// way, so that an accepted step needs no second pass over the poses
    /// ([`Assembler::accept_scaled`]); a rejected one then wasted an assembly, so the caller
    /// speculates only after an accepted step, and not on a step predicted to change the cost
    /// by no more than `cost_rel_tol` (rounding level: rejected about as often as accepted).
    fn trial_cost(&mut self, robot: &Robot, speculate: bool) -> f64 {
        self.spare_valid = false;
        match (&mut self.spare, speculate) {
            (Some(spare), true) => {
                self.spare_valid = true;
                spare.assemble(robot, &self.trig, self.points, self.weights, self.free)
            }
            _ => match self.path {
                Path::Fast => weighted_rss_trig(robot, &self.trig, self.points, self.weights),
                Path::Reference => weighted_rss(robot, self.poses, self.points, self.weights),
            },
        }
    }

    /// The system at `robot`, the new point of an accepted step, straight into the
    /// column-scaled `sys`; returns the cost (`cost_trial`, computed there by
    /// [`Assembler::trial_cost`]). The fast path takes over the system `trial_cost` assembled
    /// there if it did (the same bits), and skips the full unscaled matrix (the same bits as
    /// assembling into `a`, `g` and scaling): `a`, `g` are then stale until
    /// [`Assembler::unscaled`].
    #[allow(clippy::too_many_arguments)]
    fn accept_scaled(
        &mut self,
        robot: &Robot,
        a: &mut DMatrix<f64>,
        g: &mut DVector<f64>,
        scale: &[f64],
        sa: &mut DMatrix<f64>,
        sg: &mut DVector<f64>,
        cost_trial: f64,
    ) -> f64 {
        let speculated = std::mem::take(&mut self.spare_valid);
        match self.normal.as_mut() {
            Some(normal) => {
                let cost = match self.spare.as_mut() {
                    Some(spare) if speculated => {
                        std::mem::swap(normal, spare);
                        cost_trial
                    }
                    _ => normal.assemble(robot, &self.trig, self.points, self.weights, self.free),
                };
                normal.scaled_to(scale, sa.as_mut_slice(), sg.as_mut_slice());
                cost
            }
            None => {
                let cost = self.assemble(robot, a, g);
                scale_system(a, g, scale, sa, sg);
                cost
            }
        }
    }
}

/// Solves the problem by damped least squares from the start model. See the module docs for
/// the iteration and [`LmOptions`] for every option.
pub fn solve(problem: &Problem, options: &LmOptions) -> Result<LmSolution, IdentifyError> {
    solve_on(
        Path::Fast,
        problem,
        options,
        &IdentifiabilityOptions::default(),
    )
}

/// [`solve`] with the rank decision of [`Redundant::Hold`] taken under `ident`.
pub(crate) fn solve_with(
    problem: &Problem,
    options: &LmOptions,
    ident: &IdentifiabilityOptions,
) -> Result<LmSolution, IdentifyError> {
    solve_on(Path::Fast, problem, options, ident)
}

/// [`solve`] on the straightforward linear algebra (reference Jacobian, unvectorised
/// assembly, nalgebra's Cholesky): the reference the fast path is tested against. Same
/// iteration, same results up to rounding.
#[doc(hidden)]
pub fn solve_reference(
    problem: &Problem,
    options: &LmOptions,
) -> Result<LmSolution, IdentifyError> {
    solve_on(
        Path::Reference,
        problem,
        options,
        &IdentifiabilityOptions::default(),
    )
}

/// Holds the exactly redundant free parameters (under [`Redundant::Hold`]) and solves the
/// rest.
fn solve_on(
    path: Path,
    problem: &Problem,
    options: &LmOptions,
    ident: &IdentifiabilityOptions,
) -> Result<LmSolution, IdentifyError> {
    solve_speculating(path, problem, options, ident, true)
}

/// [`solve_on`], with or without the trial-point assembly of [`Assembler::trial_cost`]
/// (which changes no bit of the result; the tests compare both).
fn solve_speculating(
    path: Path,
    problem: &Problem,
    options: &LmOptions,
    ident: &IdentifiabilityOptions,
    speculate: bool,
) -> Result<LmSolution, IdentifyError> {
    options.validate()?;
    let free = problem.free();
    let pf = free.len();
    let mut asm = Assembler::new(path, problem, free);
    if !speculate {
        asm.spare = None;
    }
    let mut a = scratch::zero_matrix(pf, pf);
    let mut g = scratch::zero_vector(pf);
    let cost = asm.assemble(problem.robot(), &mut a, &mut g);
    if options.redundant == Redundant::Hold {
        let dropped = redundant_positions(
            problem.robot(),
            problem.poses_rad(),
            problem.weights(),
            free,
            &a,
            ident,
        )?;
        // Every column zero (nothing moves the points) is left to the damped solve, which
        // stops on its gradient test at once.
        if !dropped.is_empty() && dropped.len() < pf {
            let mut held = scratch::indices(dropped.len());
            held.extend(dropped.iter().map(|&d| free[d]));
            let mut kept = scratch::indices(pf);
            kept.extend((0..pf).filter(|c| !dropped.contains(c)));
            scratch::give_back_indices(dropped);
            let mut solved = scratch::indices(kept.len());
            solved.extend(kept.iter().map(|&c| free[c]));
            let reduced = problem.with_free(solved);
            // The start system of the solved columns is a block of the one just assembled.
            let pk = kept.len();
            let (mut a_k, mut g_k) = (scratch::zero_matrix(pk, pk), scratch::zero_vector(pk));
            for (j, &cj) in kept.iter().enumerate() {
                g_k[j] = g[cj];
                for (i, &ci) in kept.iter().enumerate() {
                    a_k[(i, j)] = a[(ci, cj)];
                }
            }
            scratch::give_back_indices(kept);
            scratch::give_back_matrix(a);
            scratch::give_back_vector(g);
            let start = (a_k, g_k, cost);
            let mut asm = asm.on_subset(reduced.free());
            let mut sol = solve_free(path, &reduced, options, &mut asm, start)?;
            sol.held = held;
            return Ok(sol);
        }
        scratch::give_back_indices(dropped);
    }
    solve_free(path, problem, options, &mut asm, (a, g, cost))
}

/// A damped least-squares problem, as the one solver ([`least_squares`]) sees it: the
/// problem gives the weighted normal equations, the cost and the step on its unknowns; the
/// solver owns the damping ([`Damping`]), the column scaling, the stopping tests
/// ([`StopReason`]), the trace and the covariance ([`LsSolution::covariance`]). Points
/// ([`solve`], on [`Problem`]) and frames or several targets ([`crate::frames::fit_frames`])
/// both implement it; which unknowns are free (the restriction to a free set) is part of the
/// problem's value.
///
/// Every quantity is in the problem's internal units; `dx` of [`LeastSquares::step`] and the
/// columns of `JᵀJ` are ordered as the unknowns.
pub trait LeastSquares {
    /// What the unknowns move (the robot; the robot with its tool frame and targets).
    type Model: Clone;

    /// The number of unknowns P.
    fn n_unknowns(&self) -> usize;

    /// The weighted normal equations at `m`, `a = JᵀJ` (P × P) and `g = Jᵀe` (P), with `e`
    /// = measured − model and `J` = ∂model/∂x (= −∂e/∂x), so that the Gauss–Newton step
    /// `a⁻¹g` is added to the unknowns; returns the cost `‖e‖²`. `a` and `g` may come in with
    /// any shape.
    fn normal_equations(
        &mut self,
        m: &Self::Model,
        a: &mut DMatrix<f64>,
        g: &mut DVector<f64>,
    ) -> f64;

    /// The cost `‖e‖²` at the trial point `m`, bit for bit what
    /// [`LeastSquares::normal_equations`] returns there. `likely_accepted`: the solver expects
    /// the step to be accepted, so a problem may assemble the system at `m` on the way for
    /// [`LeastSquares::accept`] to take over.
    fn cost(&mut self, m: &Self::Model, likely_accepted: bool) -> f64;

    /// `m` moved by `dx` (one entry per unknown), written into `out`.
    fn step(&self, m: &Self::Model, dx: &[f64], out: &mut Self::Model)
    -> Result<(), IdentifyError>;

    /// `√Σ_c (x_c / s_c)²`, the norm of the unknowns' values at `m` in solver variables
    /// (column scale `s`), for the small-step test.
    fn scaled_norm(&self, m: &Self::Model, s: &[f64]) -> f64;

    /// A copy of `m` for the solver's trial point (the default clones it; a problem may take
    /// it from buffers it keeps, and take it back in [`LeastSquares::retire_model`]).
    fn copy_model(&self, m: &Self::Model) -> Self::Model {
        m.clone()
    }

    /// The solver is done with the trial-point model `m` (the default drops it).
    fn retire_model(&self, m: Self::Model) {
        drop(m);
    }

    /// The system at `m`, the point of an accepted step whose cost [`LeastSquares::cost`]
    /// returned as `cost_trial`, column-scaled (`S a S`, `S g`) into `sa`, `sg`; returns the
    /// cost. The default assembles it into `a`, `g` and scales it; a problem that writes
    /// only `sa`, `sg` brings `a`, `g` up to date in [`LeastSquares::unscaled`].
    #[allow(clippy::too_many_arguments)]
    fn accept(
        &mut self,
        m: &Self::Model,
        a: &mut DMatrix<f64>,
        g: &mut DVector<f64>,
        s: &[f64],
        sa: &mut DMatrix<f64>,
        sg: &mut DVector<f64>,
        cost_trial: f64,
    ) -> f64 {
        let _ = cost_trial;
        let cost = self.normal_equations(m, a, g);
        scale_system(a, g, s, sa, sg);
        cost
    }

    /// Brings `a`, `g` up to date with the last [`LeastSquares::accept`] (nothing to do for
    /// the default).
    fn unscaled(&self, a: &mut DMatrix<f64>, g: &mut DVector<f64>) {
        let _ = (a, g);
    }

    /// The cost at `m` of a Gaussian prior on the unknowns (one more block of rows,
    /// `√λ_k (x_k − x0_k)`, `crate::prior`), which [`LeastSquares::cost`] and
    /// [`LeastSquares::accept`] include; `None` (the default) without a prior. The solver
    /// adds it to the start cost.
    fn prior_cost(&self, m: &Self::Model) -> Option<f64> {
        let _ = m;
        None
    }

    /// Adds the prior's diagonal and gradient at `m` to the column-scaled system `sa`, `sg`
    /// (nothing without a prior, the default); the solver calls it on the start system.
    fn add_prior_scaled(
        &self,
        m: &Self::Model,
        s: &[f64],
        sa: &mut DMatrix<f64>,
        sg: &mut DVector<f64>,
    ) {
        let _ = (m, s, sa, sg);
    }
}

/// What [`least_squares`] returns: the solution, why the iteration stopped, its trace, and
/// the normal matrix there.
#[derive(Clone, Debug)]
pub struct LsSolution<M> {
    /// The model at the solution.
    pub model: M,
    /// The schedule used.
    pub damping: Damping,
    /// Iterations made (accepted + rejected).
    pub iterations: usize,
    /// Accepted steps.
    pub accepted_steps: usize,
    /// Why it stopped (a damping blow-up is [`StopReason::TooManyRejections`], not
    /// converged).
    pub stop: StopReason,
    /// One entry per iteration.
    pub trace: Vec<TraceEntry>,
    /// Cost (weighted RSS) at the start.
    pub initial_cost: f64,
    /// Cost at the solution.
    pub cost: f64,
    /// Column scale s_k of each unknown (1 when scaling is off or the column is zero).
    pub column_scale: Vec<f64>,
    /// max_k |J_kᵀe| / (‖J_k‖‖e‖) at the solution (0 for a zero residual).
    pub gradient_cosine: f64,
    /// The weighted `JᵀJ` at the solution (unscaled).
    pub normal_matrix: DMatrix<f64>,
}

/// The one damped least-squares solver: Levenberg–Marquardt on `problem` from `start`, with
/// the damping, scaling and stopping tests of `options` (the module docs; every unknown of
/// `problem` is solved: [`LmOptions::redundant`] is the caller's to apply, as [`solve`] does
/// for points).
///
/// # Errors
/// An option out of range, a non-positive-definite damped system
/// ([`IdentifyError::Singular`]) or a non-finite step or cost
/// ([`IdentifyError::NonFiniteStep`]).
pub fn least_squares<P: LeastSquares>(
    problem: &mut P,
    start: &P::Model,
    options: &LmOptions,
) -> Result<LsSolution<P::Model>, IdentifyError> {
    options.validate()?;
    let pf = problem.n_unknowns();
    let mut a = DMatrix::zeros(pf, pf);
    let mut g = DVector::zeros(pf);
    let cost = problem.normal_equations(start, &mut a, &mut g);
    iterate(Path::Fast, problem, start.clone(), options, (a, g, cost))
}

/// The point problem as the solver sees it: the assembler of the normal equations on the
/// free parameters (either path) and their indices.
struct PointLs<'a, 'p, 'f> {
    asm: &'a mut Assembler<'p>,
    free: &'f [usize],
    /// The problem's prior, if any (`crate::prior`).
    prior: Option<&'f crate::prior::PriorTerm>,
    /// The data's part of the last trial cost (without the prior), for `accept`.
    trial_data: f64,
    /// A parameter vector reused by every step (no allocation per iteration).
    x: std::cell::RefCell<Vec<f64>>,
}

impl LeastSquares for PointLs<'_, '_, '_> {
    type Model = Robot;

    fn copy_model(&self, m: &Robot) -> Robot {
        scratch::robot_like(m)
    }

    fn retire_model(&self, m: Robot) {
        scratch::give_back_robot(m);
    }

    fn n_unknowns(&self) -> usize {
        self.free.len()
    }

    fn normal_equations(&mut self, m: &Robot, a: &mut DMatrix<f64>, g: &mut DVector<f64>) -> f64 {
        let pf = self.free.len();
        if a.shape() != (pf, pf) {
            *a = DMatrix::zeros(pf, pf);
        }
        if g.len() != pf {
            *g = DVector::zeros(pf);
        }
        self.asm.assemble(m, a, g)
    }

    fn cost(&mut self, m: &Robot, likely_accepted: bool) -> f64 {
        self.trial_data = self.asm.trial_cost(m, likely_accepted);
        match self.prior {
            Some(p) => self.trial_data + p.cost(&m.params(), self.free),
            None => self.trial_data,
        }
    }

    fn step(&self, m: &Robot, dx: &[f64], out: &mut Robot) -> Result<(), IdentifyError> {
        let mut x = self.x.borrow_mut();
        m.params_into(&mut x);
        for (c, &k) in self.free.iter().enumerate() {
            x[k] += dx[c];
        }
        out.set_params(&x)?;
        Ok(())
    }

    fn scaled_norm(&self, m: &Robot, s: &[f64]) -> f64 {
        let mut x = self.x.borrow_mut();
        m.params_into(&mut x);
        self.free
            .iter()
            .zip(s)
            .map(|(&k, s)| (x[k] / s).powi(2))
            .sum::<f64>()
            .sqrt()
    }

    fn accept(
        &mut self,
        m: &Robot,
        a: &mut DMatrix<f64>,
        g: &mut DVector<f64>,
        s: &[f64],
        sa: &mut DMatrix<f64>,
        sg: &mut DVector<f64>,
        cost_trial: f64,
    ) -> f64 {
        let Some(p) = self.prior else {
            return self.asm.accept_scaled(m, a, g, s, sa, sg, cost_trial);
        };
        let x = m.params();
        let cost = self.asm.accept_scaled(m, a, g, s, sa, sg, self.trial_data);
        p.add_scaled(&x, self.free, s, sa, sg);
        cost + p.cost(&x, self.free)
    }

    fn unscaled(&self, a: &mut DMatrix<f64>, g: &mut DVector<f64>) {
        self.asm.unscaled(a, g);
    }

    fn prior_cost(&self, m: &Robot) -> Option<f64> {
        self.prior.map(|p| p.cost(&m.params(), self.free))
    }

    fn add_prior_scaled(&self, m: &Robot, s: &[f64], sa: &mut DMatrix<f64>, sg: &mut DVector<f64>) {
        if let Some(p) = self.prior {
            p.add_scaled(&m.params(), self.free, s, sa, sg);
        }
    }
}

/// The damped iteration on every free parameter of `problem`, from the system `start`
/// (`JᵀJ`, `Jᵀe`, cost) that `asm` assembled at the start model.
fn solve_free(
    path: Path,
    problem: &Problem,
    options: &LmOptions,
    asm: &mut Assembler,
    start: (DMatrix<f64>, DVector<f64>, f64),
) -> Result<LmSolution, IdentifyError> {
    let free = problem.free();
    let mut ls = PointLs {
        asm,
        free,
        prior: problem.prior(),
        trial_data: 0.0,
        x: std::cell::RefCell::new(scratch::with_capacity(problem.robot().n_params())),
    };
    let sol = iterate(
        path,
        &mut ls,
        scratch::robot_like(problem.robot()),
        options,
        start,
    );
    scratch::give_back(ls.x.into_inner());
    let sol = sol?;
    let system = (path == Path::Fast).then(|| {
        // Without an accepted step the normal matrix is still the start system (on a subset
        // of the free parameters, a block of the one assembled on all of them: the same
        // bits, each entry being its own sum).
        FinalSystem {
            trig: std::mem::take(&mut asm.trig),
            a: sol.normal_matrix,
            free: scratch::copy_indices(free),
            weights: problem.weights().map(scratch::copy),
            poses: scratch::copy(problem.poses_rad()),
        }
        .shared()
    });
    let mut params = scratch::with_capacity(sol.model.n_params());
    sol.model.params_into(&mut params);
    Ok(LmSolution {
        system,
        params,
        robot: sol.model,
        iterations: sol.iterations,
        accepted_steps: sol.accepted_steps,
        stop: sol.stop,
        trace: sol.trace,
        initial_cost: sol.initial_cost,
        cost: sol.cost,
        column_scale: sol.column_scale,
        gradient_cosine: sol.gradient_cosine,
        held: Vec::new(),
    })
}

/// Trace entries reserved up front (a solve of the default options stops well before).
const TRACE_RESERVE: usize = 64;

/// The damped iteration of the module docs on every unknown of `problem`, from `model` and
/// the system `start` (`JᵀJ`, `Jᵀe`, cost) there.
fn iterate<P: LeastSquares>(
    path: Path,
    problem: &mut P,
    model: P::Model,
    options: &LmOptions,
    start: (DMatrix<f64>, DVector<f64>, f64),
) -> Result<LsSolution<P::Model>, IdentifyError> {
    let pf = problem.n_unknowns();

    let mut model = model;
    let mut trial = problem.copy_model(&model);

    let (mut a, mut g, mut cost) = start;
    // A Gaussian prior (`crate::prior`): its cost joins the data's, its diagonal and gradient
    // the column-scaled system; `a`, `g` stay the data's (the final system is `JᵀJ`).
    if let Some(prior_cost) = problem.prior_cost(&model) {
        cost += prior_cost;
    }
    let initial_cost = cost;

    let max_col_sq = (0..pf).fold(0.0, |m: f64, k| m.max(a[(k, k)]));
    let mut scale = scratch::with_capacity(pf);
    scale.extend((0..pf).map(|k| {
        let d = a[(k, k)];
        if options.column_scaling && d > ZERO_COLUMN_RTOL_SQ * max_col_sq {
            1.0 / d.sqrt()
        } else {
            1.0
        }
    }));
    // Scratch from the thread's pools (no allocation per solve, issue 43), zeroed as new.
    let mut sys = Scaled {
        a: scratch::zero_matrix(pf, pf),
        g: scratch::zero_vector(pf),
    };
    sys.set(&a, &g, &scale);
    problem.add_prior_scaled(&model, &scale, &mut sys.a, &mut sys.g);
    if !cost.is_finite() || !sys.finite() {
        return Err(IdentifyError::NonFiniteStep {
            iteration: 0,
            what: "residual or Jacobian at the start point",
        });
    }

    let mut mu = match options.damping {
        Damping::Levenberg { mu0, .. } | Damping::Marquardt { mu0, .. } => mu0,
        Damping::Nielsen { tau, .. } => tau * sys.max_diag(),
    };
    let mut nu = match options.damping {
        Damping::Nielsen { nu0, .. } => nu0,
        _ => 0.0,
    };

    // (`work`: the reference path's damped matrix, sized on first use; `pad`: the fast
    // path's, zeroed when its size changes, see `damped_step`.)
    let mut work = DMatrix::zeros(0, 0);
    let mut pad = scratch::with_capacity(0);
    let mut step = scratch::zero_vector(pf);
    let mut dx = scratch::zeros(pf);
    let mut a_step = scratch::zero_vector(pf);
    let mut trace = scratch::trace();
    trace.reserve(options.max_iterations.min(TRACE_RESERVE));
    let mut iterations = 0;
    let mut accepted_steps = 0;
    let mut rejections = 0;

    let stop = if sys.gradient_cosine(cost) <= options.gradient_tol {
        StopReason::SmallGradient
    } else {
        loop {
            if iterations >= options.max_iterations {
                break StopReason::MaxIterations;
            }
            iterations += 1;

            let floor = options.mu_min_rel * sys.max_diag();
            mu = mu.max(match options.damping {
                Damping::Marquardt { .. } => options.mu_min_rel,
                _ => floor,
            });
            damped_step(
                path,
                &sys,
                options.damping,
                &mut mu,
                floor,
                &mut work,
                &mut pad,
                &mut step,
                iterations,
            )?;
            if !step.iter().all(|v| v.is_finite()) {
                return Err(IdentifyError::NonFiniteStep {
                    iteration: iterations,
                    what: "step",
                });
            }

            for (d, (s, v)) in dx.iter_mut().zip(scale.iter().zip(step.iter())) {
                *d = s * v;
            }
            problem.step(&model, &dx, &mut trial)?;
            match path {
                Path::Fast => {
                    linalg::mat_vec(sys.a.as_slice(), pf, step.as_slice(), a_step.as_mut_slice())
                }
                Path::Reference => sys.a.mul_to(&step, &mut a_step),
            }
            let predicted = 2.0 * step.dot(&sys.g) - step.dot(&a_step);
            // The system at the trial point is assembled on the way (speculatively) after an
            // accepted step, unless the step is predicted to change the cost by no more than
            // the cost-change tolerance: such a step is at rounding level, is about as likely
            // rejected as accepted, and usually ends the solve. (Either choice gives the
            // same bits; this one spares the assembly a rejected last step would waste.)
            let speculate = rejections == 0 && predicted > options.cost_rel_tol * cost;
            let cost_trial = problem.cost(&trial, speculate);
            if !cost_trial.is_finite() {
                return Err(IdentifyError::NonFiniteStep {
                    iteration: iterations,
                    what: "cost at the trial point",
                });
            }
            let actual = cost - cost_trial;
            let accepted = actual > 0.0 && predicted > 0.0;
            let gain_ratio = if predicted > 0.0 {
                actual / predicted
            } else {
                0.0
            };
            let step_norm = step.norm();
            trace.push(TraceEntry {
                iteration: iterations,
                mu,
                step_norm,
                cost_before: cost,
                cost_trial,
                gain_ratio,
                accepted,
            });

            if accepted {
                accepted_steps += 1;
                rejections = 0;
                std::mem::swap(&mut model, &mut trial);
                let cost_old = cost;
                cost = problem.accept(
                    &model, &mut a, &mut g, &scale, &mut sys.a, &mut sys.g, cost_trial,
                );
                if !cost.is_finite() || !sys.finite() {
                    return Err(IdentifyError::NonFiniteStep {
                        iteration: iterations,
                        what: "residual or Jacobian",
                    });
                }
                match options.damping {
                    Damping::Levenberg { decrease, .. } | Damping::Marquardt { decrease, .. } => {
                        mu /= decrease
                    }
                    Damping::Nielsen { nu0, .. } => {
                        mu *= (1.0 / 3.0_f64).max(1.0 - (2.0 * gain_ratio - 1.0).powi(3));
                        nu = nu0;
                    }
                }
                let x_norm = problem.scaled_norm(&model, &scale);
                if sys.gradient_cosine(cost) <= options.gradient_tol {
                    break StopReason::SmallGradient;
                }
                if cost_old - cost_trial <= options.cost_rel_tol * cost_old {
                    break StopReason::SmallCostChange;
                }
                if step_norm <= options.step_tol * (x_norm + options.step_tol) {
                    break StopReason::SmallStep;
                }
            } else {
                if actual.abs() <= options.cost_rel_tol * cost {
                    // The trial cost cannot be told from the current one: rounding level.
                    break StopReason::SmallCostChange;
                }
                rejections += 1;
                match options.damping {
                    Damping::Levenberg { increase, .. } | Damping::Marquardt { increase, .. } => {
                        mu *= increase
                    }
                    Damping::Nielsen { .. } => {
                        mu *= nu;
                        nu *= 2.0;
                    }
                }
                if rejections >= options.max_rejections {
                    break StopReason::TooManyRejections;
                }
            }
        }
    };

    let gradient_cosine = sys.gradient_cosine(cost);
    // `a` is the system at the solution: assembled there by the last accepted step, or,
    // without one, the start system.
    if accepted_steps > 0 {
        problem.unscaled(&mut a, &mut g);
    }
    // The scratch back to the thread's pools for its next solve (`g` was the caller's).
    scratch::give_back_matrix(sys.a);
    scratch::give_back_vector(sys.g);
    scratch::give_back_vector(step);
    scratch::give_back_vector(a_step);
    scratch::give_back_vector(g);
    scratch::give_back(dx);
    scratch::give_back(pad);
    problem.retire_model(trial);
    Ok(LsSolution {
        model,
        damping: options.damping,
        iterations,
        accepted_steps,
        stop,
        trace,
        initial_cost,
        cost,
        column_scale: scale,
        gradient_cosine,
        normal_matrix: a,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use kinematics::{PoseSampler, RobotSpec, Unit};
    use nalgebra::Vector3;
    use rand::SeedableRng;
    use rand::rngs::ChaCha8Rng;

    /// The trial-point assembly changes no bit of the iteration or of the final system, on
    /// runs where steps are rejected in mid-run (the next accepted step must not take over
    /// the system of a rejected trial point) and at the end; and the final system is the
    /// one assembled afresh at the solution.
    #[test]
    fn speculative_assembly_changes_no_bit() {
        let text = include_str!("../../../scenarios/robots/kr1000-titan.json");
        let nominal = Robot::from_spec(&RobotSpec::from_json_str(text, "kr1000").unwrap()).unwrap();
        // Far from the truth (45° on every angle, 300 mm on every length): the undamped
        // steps overshoot and are rejected again and again.
        let mut x = nominal.params();
        for (k, v) in x.iter_mut().enumerate() {
            let sign = if k % 2 == 0 { 1.0 } else { -1.0 };
            *v += sign
                * match nominal.layout().get(k).unit {
                    Unit::Deg => 45f64.to_radians(),
                    _ => 300.0,
                };
        }
        let truth = nominal.with_params(&x).unwrap();
        let poses = PoseSampler::default()
            .sample(&nominal, 50, &mut ChaCha8Rng::seed_from_u64(501))
            .unwrap()
            .rad;
        let points: Vec<Vector3<f64>> = truth
            .points(&poses)
            .iter()
            .enumerate()
            .map(|(j, p)| p + Vector3::new(0.01, -0.02, 0.015) * ((j as f64) * 0.7).sin())
            .collect();
        let all: Vec<usize> = (0..nominal.n_params()).collect();
        let problem = Problem::new(&nominal, &poses, &points, all).unwrap();
        let ident = IdentifiabilityOptions::default();
        let mut mid_run = 0;
        for damping in [
            Damping::levenberg(),
            Damping::nielsen(),
            Damping::marquardt(),
        ] {
            let opts = LmOptions::with_damping(damping);
            let with = solve_speculating(Path::Fast, &problem, &opts, &ident, true).unwrap();
            let without = solve_speculating(Path::Fast, &problem, &opts, &ident, false).unwrap();
            let marks: String = with
                .trace
                .iter()
                .map(|t| if t.accepted { 'A' } else { 'r' })
                .collect();
            mid_run += usize::from(marks.contains("rA"));
            assert_eq!(with.trace, without.trace, "{damping:?}: {marks}");
            assert_eq!(with.params, without.params, "{damping:?}");
            assert_eq!(with.cost.to_bits(), without.cost.to_bits(), "{damping:?}");
            let (sw, so) = (with.system.unwrap(), without.system.unwrap());
            assert_eq!(sw.a, so.a, "{damping:?}: final system");
            // ... which is the system at the solution.
            let solved = Problem::new(&with.robot, &poses, &points, sw.free.clone()).unwrap();
            let (mut a, mut g) = (DMatrix::zeros(0, 0), DVector::zeros(0));
            solved.normal_equations(&mut a, &mut g);
            assert_eq!(sw.a, a, "{damping:?}: system at the solution");
        }
        assert!(mid_run >= 2, "{mid_run} runs with a rejection in mid-run");

        // No step at all (the start is the solution; 7 parameters held): the final system
        // is still the one at the solution.
        let exact = nominal.points(&poses);
        let all: Vec<usize> = (0..nominal.n_params()).collect();
        let problem = Problem::new(&nominal, &poses, &exact, all).unwrap();
        let sol = solve(&problem, &LmOptions::default()).unwrap();
        assert_eq!((sol.iterations, sol.held.len()), (0, 7));
        let sys = sol.system.unwrap();
        let solved = Problem::new(&nominal, &poses, &exact, sys.free.clone()).unwrap();
        let (mut a, mut g) = (DMatrix::zeros(0, 0), DVector::zeros(0));
        solved.normal_equations(&mut a, &mut g);
        assert_eq!(sys.a, a, "system without a step");
    }
}
