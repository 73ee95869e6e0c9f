//! What one trial produces ([`TrialResult`]) and the identification's figures in brief
//! ([`FitSummary`]), whichever measurement identified it.

use evaluate::{AxisStats, IsoReport, ParameterRecovery, Table4};
use identify::{Observability, StopReason};
use kinematics::kept::{Pool, give_vec, take_vec};
use serde::{Deserialize, Serialize};

/// A stop on a small step or a small cost change with the gradient cosine at the solution
/// above this is counted as *stalled*, not converged: at a true minimum the residual is
/// orthogonal to every column (cosines of 10⁻⁹–10⁻⁶ on the shipped scenarios), while an
/// over-damped solver (e.g. Nielsen with τ = 1000 on an unscaled Jacobian) stops on tiny steps
/// with cosines of 10⁻³–1.
pub const STALL_GRADIENT_COSINE: f64 = 1e-4;

/// The identification outcome of one trial, in brief.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FitSummary {
    /// LM iterations (accepted and rejected).
    pub iterations: usize,
    /// Why LM stopped.
    pub stop: StopReason,
    /// Converged (a stop reason other than the caps).
    pub converged: bool,
    /// RMS of the 3-D residuals at the solution, mm.
    pub rms_mm: f64,
    /// Free parameters.
    pub free: usize,
    /// Numerical rank of the free parameters at the solution (size of the identifiable set).
    pub rank: Option<usize>,
    /// max_k |J_kᵀe| / (‖J_k‖‖e‖) at the solution (see [`identify::Fit::gradient_cosine`]).
    pub gradient_cosine: f64,
}

impl FitSummary {
    /// `converged`, `stalled` (a converged stop reason but a gradient cosine above
    /// [`STALL_GRADIENT_COSINE`]) or `cap` (iteration or rejection cap).
    pub fn convergence(&self) -> &'static str {
        if !self.converged {
            "cap"
        } else if self.gradient_cosine > STALL_GRADIENT_COSINE {
            "stalled"
        } else {
            "converged"
        }
    }
}

/// Everything one trial produces.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TrialResult {
    /// Trial index.
    pub trial: u64,
    /// Per validation pose: measured − nominal target before compensation, mm.
    pub before_mm: Vec<[f64; 3]>,
    /// Per validation pose: measured − nominal target after compensation, mm (poses whose
    /// compensation failed are left out and counted).
    pub after_mm: Vec<[f64; 3]>,
    /// Table 4 statistics.
    pub table4: Table4,
    /// Poses the tracker could not measure (skipped).
    pub unmeasurable: usize,
    /// Validation targets the identified model could not reach within limits.
    pub compensation_failures: usize,
    /// ISO 9283 targets (P1–P5) the identified model could not reach within limits: those
    /// points are commanded uncompensated in the "after" cycles, and counted here.
    pub iso_compensation_failures: usize,
    /// Share of candidate poses the sampler rejected (identification and validation sets):
    /// wrist, floor, tracker window, range or condition constraints.
    pub pose_rejection_rate: f64,
    /// Identification summary.
    pub fit: FitSummary,
    /// Mean distance between the identified model's and the true geometry's points on the
    /// validation poses, mm (how well the geometry itself was recovered).
    pub predicted_error_mm: f64,
    /// Recovery per minimal-set parameter (when enabled and computable).
    pub recovery: Vec<ParameterRecovery>,
    /// Observability indices O1–O5 of the identification poses (`docs/model.md` §6; see
    /// [`Observability`]).
    pub observability: Option<Observability>,
    /// ISO 9283 results (when enabled).
    pub iso: Option<IsoReport>,
    /// The learned residual model's outcome (scenario `residual_model`; absent without it).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub residual: Option<ResidualTrial>,
}

thread_local! {
    /// Error series of recycled trial results ([`TrialResult::recycle`]).
    static ERRORS: Pool<Vec<[f64; 3]>> = const { Pool::new() };
    /// Recovery rows of recycled trial results.
    static RECOVERY: Pool<Vec<ParameterRecovery>> = const { Pool::new() };
}

/// Error series and recovery row lists a thread keeps (a trial's result holds three).
const RESULT_POOL_SIZE: usize = 4;

/// An empty error series with room for `len` (one a recycled result gave back, if the thread
/// has one).
pub(super) fn error_series(len: usize) -> Vec<[f64; 3]> {
    let mut v = take_vec(&ERRORS);
    v.reserve(len);
    v
}

/// An empty list of recovery rows (as [`error_series`]).
pub(super) fn recovery_rows(len: usize) -> Vec<ParameterRecovery> {
    let mut v = take_vec(&RECOVERY);
    v.reserve(len);
    v
}

impl TrialResult {
    /// Gives the result's series (errors before and after, recovery rows) back to the thread
    /// for its next trial, once the caller has taken what it needs (a campaign's aggregate
    /// does); dropping the result instead stays correct.
    pub fn recycle(self) {
        give_vec(&ERRORS, RESULT_POOL_SIZE, self.before_mm);
        give_vec(&ERRORS, RESULT_POOL_SIZE, self.after_mm);
        give_vec(&RECOVERY, RESULT_POOL_SIZE, self.recovery);
    }
}

/// What the learned residual model did in one trial (scenario `residual_model`,
/// `docs/residual-model.md`, "In campaigns"). The trial's `after_mm` and Table 4 are the
/// compensation the gate chose: the hybrid's when [`ResidualTrial::used`], the geometry's
/// otherwise; both are here.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ResidualTrial {
    /// The gate kept the model: the cross-validation's mean and p95 gains both exceed their
    /// fold-to-fold scatter.
    pub used: bool,
    /// The cross-validation's gain of the mean held-out error (geometry − hybrid), mm.
    pub cv_mean_gain: Gain,
    /// The cross-validation's gain of the held-out 95th percentile, mm.
    pub cv_p95_gain: Gain,
    /// The validation poses compensated by the geometry alone: 3-D errors, mm.
    pub geometry_after: AxisStats,
    /// The same poses compensated by the hybrid of the model fitted on every
    /// identification pose (whether the gate kept it or not): 3-D errors, mm; `None` when
    /// no pose could be compensated.
    pub hybrid_after: Option<AxisStats>,
    /// Validation targets the hybrid could not reach (its fixed point failed).
    pub hybrid_compensation_failures: usize,
    /// The coverage of the model's predictive sd on the validation poses (predicted −
    /// measured, before compensation): fractions within 1 and 2 sd over every axis value.
    pub coverage_1sd: f64,
    /// See [`ResidualTrial::coverage_1sd`].
    pub coverage_2sd: f64,
}

/// An improvement over the folds of a cross-validation (`calibrate::residual::Gain`), mm.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Gain {
    /// Mean over the folds of geometry − hybrid, mm.
    pub mean_mm: f64,
    /// Its fold-to-fold sample standard deviation, mm.
    pub scatter_mm: f64,
}

impl From<calibrate::residual::Gain> for Gain {
    fn from(g: calibrate::residual::Gain) -> Self {
        Gain {
            mean_mm: g.mean_mm,
            scatter_mm: g.scatter_mm,
        }
    }
}
