//! The error type of this crate.

use std::path::PathBuf;

use identify::IdentifyError;
use kinematics::ModelError;
use measurements::MeasurementError;

/// Everything that stops a calibration, prediction or compensation.
///
/// Leaves name the file, line, column or request field at fault (never a command-line flag:
/// front ends add their own); [`CalibrateError::Context`] adds
/// what was being done, outermost first, as a front end prints the chain (`{:#}` of an
/// `anyhow::Error`, or the [`std::error::Error::source`] chain).
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum CalibrateError {
    /// A robot model file could not be loaded.
    #[error("loading the {what} {}", path.display())]
    Robot {
        /// Which robot (`"robot"`, `"calibrated robot"`, …).
        what: &'static str,
        /// The file.
        path: PathBuf,
        /// Why.
        #[source]
        source: ModelError,
    },
    /// A measurement or joint file could not be read (its error names file, line, column).
    #[error("{context}")]
    Read {
        /// What was read, for which robot.
        context: String,
        /// Why.
        #[source]
        source: MeasurementError,
    },
    /// The identification library refused.
    #[error("{context}")]
    Identify {
        /// What was being done.
        context: String,
        /// Why.
        #[source]
        source: IdentifyError,
    },
    /// Statistics could not be computed (no finite errors).
    #[error("{context}")]
    Evaluate {
        /// What was being computed.
        context: String,
        /// Why.
        #[source]
        source: evaluate::EvalError,
    },
    /// The design of a [`crate::Split::Select`] failed (too few rows, a rank-deficient pool,
    /// bad joints).
    #[error("{context}")]
    Design {
        /// What was being chosen.
        context: String,
        /// Why (boxed: a design error carries a whole measurement error, and this variant would
        /// otherwise set the size of every `Result` of this crate).
        #[source]
        source: Box<design::DesignError>,
    },
    /// The parameter spec of the request does not fit the robot (an unknown name, a family
    /// member of a joint the robot does not have, compliance without a mass model).
    #[error("parameter spec `{spec}`")]
    Params {
        /// The spec, as written.
        spec: String,
        /// Why.
        #[source]
        source: IdentifyError,
    },
    /// The identification data hold fewer rows than the free parameters need; `source` is the
    /// reader's or the split's refusal, naming the file.
    #[error(
        "{free} free parameters (parameter spec `{spec}`) need at least {needed} rows: 3 \
         equations per row, at least as many equations as free parameters"
    )]
    TooFewRows {
        /// Free parameters.
        free: usize,
        /// The spec they come from, as written.
        spec: String,
        /// Rows needed, ⌈free / 3⌉.
        needed: usize,
        /// What found too few.
        #[source]
        source: Box<CalibrateError>,
    },
    /// The learned residual model (`crate::residual`) could not be fitted, read or checked.
    #[error("{context}")]
    Residual {
        /// What was being done, naming the file where one was read.
        context: String,
        /// Why.
        #[source]
        source: residual::ResidualError,
    },
    /// A residual model file does not go with the robot file that names it (another digest,
    /// another calibration run), or a residual model was asked of data it does not model.
    #[error("{0}")]
    ResidualMismatch(String),
    /// A request or its inputs cannot be used; the refusal names the request field or the file.
    #[error(transparent)]
    Refused(#[from] Refusal),
    /// `source` happened while doing `context`.
    #[error("{context}")]
    Context {
        /// What was being done.
        context: String,
        /// What went wrong.
        #[source]
        source: Box<CalibrateError>,
    },
}

impl CalibrateError {
    /// Wraps `self` with what was being done.
    pub fn context(self, context: impl Into<String>) -> Self {
        CalibrateError::Context {
            context: context.into(),
            source: Box::new(self),
        }
    }

    /// The plausibility check that refused ([`Refusal::Implausible`]), under any context:
    /// the check whose name, given to [`crate::IdentifyRequest::allow`] (`--allow`,
    /// Python's `allow=`), overrides the refusal. `None` for every other error.
    pub fn refused_check(&self) -> Option<crate::Check> {
        match self {
            CalibrateError::Refused(Refusal::Implausible { check, .. }) => Some(*check),
            CalibrateError::Context { source, .. } | CalibrateError::TooFewRows { source, .. } => {
                source.refused_check()
            }
            _ => None,
        }
    }
}

/// Why a request or its inputs cannot be used. Each variant names the request field or the
/// file at fault, with the value.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Refusal {
    /// [`crate::IdentifyRequest::outlier_k`] is not a finite number > 0.
    #[error("outlier_k = {0}: must be a finite number > 0")]
    OutlierK(f64),
    /// Both [`crate::IdentifyRequest::keep_outliers`] and
    /// [`crate::IdentifyRequest::reject_outliers`].
    #[error(
        "keep_outliers and reject_outliers: give one (keep every row, or drop every flagged \
         one; without either the gross errors are dropped)"
    )]
    KeepAndRejectOutliers,
    /// The threshold of an automatic registration is not a finite number ≥ 0.
    #[error("registration threshold_mm = {0}: must be a finite number ≥ 0")]
    RegistrationThreshold(f64),
    /// A [`crate::Split::Every`] with `every` = 0.
    #[error("split every = 0: must be at least 1")]
    EveryZero,
    /// A [`crate::Split::Every`] whose `offset` is not below `every`.
    #[error("split offset = {offset} must be below every = {every}")]
    OffsetNotBelowEvery {
        /// K.
        every: usize,
        /// The first identification row.
        offset: usize,
    },
    /// A [`crate::Split::Every`] that selects fewer rows than the free parameters need
    /// (within [`CalibrateError::TooFewRows`]).
    #[error(
        "the split every = {every}, offset = {offset} selects {selected} of the {rows} data rows"
    )]
    EveryTooFew {
        /// K.
        every: usize,
        /// The first identification row.
        offset: usize,
        /// Rows selected.
        selected: usize,
        /// Rows of the file.
        rows: usize,
        /// The file, with the rows found and needed (boxed: it would set the size of every
        /// `Result` of this crate).
        #[source]
        source: Box<MeasurementError>,
    },
    /// A validation file beside a split that validates on the rows it does not identify on.
    #[error(
        "a validation file and the `{split}` split exclude each other: the split validates on \
         the rows it does not identify on"
    )]
    ValidateWithSplit {
        /// `every` or `select`.
        split: &'static str,
    },
    /// A [`crate::Split::Select`] of fewer rows than the free parameters need.
    #[error(
        "select {poses} rows: {free} free parameters (parameter spec `{spec}`) need at least \
         {needed} rows: 3 equations per row, at least as many equations as free parameters"
    )]
    SelectTooFew {
        /// Rows asked for.
        poses: usize,
        /// Free parameters.
        free: usize,
        /// The spec they come from, as written.
        spec: String,
        /// Rows needed.
        needed: usize,
    },
    /// A [`crate::Split::Select`] that would leave no row to validate on.
    #[error(
        "select {poses} rows: {file} has {rows} rows; choose fewer so that the others validate"
    )]
    SelectTooMany {
        /// Rows asked for.
        poses: usize,
        /// The data file.
        file: String,
        /// Its rows.
        rows: usize,
    },
    /// Rejecting the outliers ([`crate::IdentifyRequest::reject_outliers`]) leaves too few
    /// rows for the free parameters.
    #[error(
        "{file}: {outliers} of {rows} rows are outliers; the {kept} left are too few for \
         {free} free parameters (3 equations per row) — keep the outliers (keep_outliers = \
         true)"
    )]
    TooManyOutliers {
        /// The data file.
        file: String,
        /// Rows flagged.
        outliers: usize,
        /// Rows screened.
        rows: usize,
        /// Rows left.
        kept: usize,
        /// Free parameters.
        free: usize,
    },
    /// A plausibility check failed (`crate::checks`): the data or the result look wrong.
    /// Its text names settings as the request's fields, Python's keywords
    /// (`length_units="cm"`, `allow="length-units"`); [`Refusal::in_words`] with
    /// [`crate::Front::Flags`] names the command line's options instead.
    #[error("{}", implausible(*.check, .evidence, .remedy, *.setting, crate::Front::Keywords))]
    Implausible {
        /// The check, which a request may override ([`crate::IdentifyRequest::allow`]).
        check: crate::Check,
        /// What it saw, with the figures (naming no setting).
        evidence: String,
        /// What to do (naming no setting: that is `setting`).
        remedy: String,
        /// The setting the remedy suggests, if any, shown after it.
        setting: Option<crate::Setting>,
    },
    /// A data file with a header and no data rows.
    #[error("{file}: the {what} file has no data rows")]
    NoDataRows {
        /// Which file (`validation`, `identification data`).
        what: &'static str,
        /// The file.
        file: String,
    },
    /// A validation file naming a target the identification data do not measure (its point
    /// is not identified).
    #[error(
        "{file}: target `{target}` is not among the identification data's targets ({known}): \
         its point is not identified"
    )]
    ValidationTarget {
        /// The validation file.
        file: String,
        /// The target it names.
        target: String,
        /// The identification data's targets, comma-separated.
        known: String,
    },
    /// Compensation between two robots of different kinds (joints, parameters).
    #[error(
        "{} ({calibrated_joints} joints, {calibrated_params} parameters) and {} \
         ({nominal_joints} joints, {nominal_params} parameters) are not the same kind of robot",
        calibrated.display(),
        nominal.display()
    )]
    DifferentRobots {
        /// The calibrated robot's file.
        calibrated: PathBuf,
        /// Its joints.
        calibrated_joints: usize,
        /// Its parameters.
        calibrated_params: usize,
        /// The nominal robot's file.
        nominal: PathBuf,
        /// Its joints.
        nominal_joints: usize,
        /// Its parameters.
        nominal_params: usize,
    },
    /// Compensation with a nominal model outside the calibrated robot's measurement frame
    /// (rotation above [`crate::SAME_FRAME_DEG`] or mean shift above `bound_mm`).
    #[error(
        "{} and {} are not in the same measurement frame: at the target poses a rigid \
         transform of {angle_deg:.3}° and {translation_mm:.1} mm separates their points (mean \
         shift {shift_mm:.1} mm; a calibration moves them by at most {bound_mm:.0} mm and {}°), \
         so the nominal targets would be meaningless for the calibrated robot; pass the \
         nominal model registered in its frame (`registered-nominal.json`, written by \
         `identify` next to `identified.json`{})",
        calibrated.display(),
        nominal.display(),
        crate::SAME_FRAME_DEG,
        if nominal.file_name().is_some_and(|f| f == "registered-nominal.json") {
            "; this one is, so the calibration moved the base that far from the registration \
             it started from: check identify's registration and fit before compensating"
        } else {
            ""
        }
    )]
    DifferentFrames {
        /// The calibrated robot's file.
        calibrated: PathBuf,
        /// The nominal robot's file.
        nominal: PathBuf,
        /// Rotation of the separating transform, degrees.
        angle_deg: f64,
        /// Its translation, mm.
        translation_mm: f64,
        /// Mean shift of the points, mm.
        shift_mm: f64,
        /// The largest mean shift accepted for this robot, mm.
        bound_mm: f64,
    },
    /// Targets the calibrated robot cannot reach, when they are not allowed.
    #[error(
        "{}\n{} of {targets} targets in {file} are unreachable for {robot} (listed above); \
         nothing written (allow_unreachable writes the others)",
        unreachable.join("\n"),
        unreachable.len()
    )]
    Unreachable {
        /// `file:line: id: unreachable: why`, one per target.
        unreachable: Vec<String>,
        /// Targets read.
        targets: usize,
        /// The targets file.
        file: String,
        /// The calibrated robot's name.
        robot: String,
    },
    /// The calibrated and nominal robots given to compensation do not belong together
    /// ([`crate::provenance::check_pair`]).
    #[error(
        "{robot} and {nominal}: {reason}; nothing written — give the identified.json and the \
         registered-nominal.json of one identify run, or override the check (allow provenance)"
    )]
    MismatchedPair {
        /// The calibrated robot's file.
        robot: String,
        /// The nominal robot's file.
        nominal: String,
        /// What does not match.
        reason: String,
    },
    /// The start joints of the nominal IK of Cartesian targets
    /// ([`crate::CartesianOptions::start_deg`]) do not fit the robot.
    #[error("start joints for {}: {reason}; nothing written", robot.display())]
    StartJoints {
        /// The nominal robot file.
        robot: PathBuf,
        /// What does not fit.
        reason: String,
    },
    /// The targets file has no rows: nothing to compensate.
    #[error("{file}: the targets file has no rows (no target to compensate); nothing written")]
    NoTargets {
        /// The targets file.
        file: String,
    },
    /// No target is reachable.
    #[error("{}\nno target in {file} is reachable; nothing written", unreachable.join("\n"))]
    NoneReachable {
        /// `file:line: id: unreachable: why`, one per target.
        unreachable: Vec<String>,
        /// The targets file.
        file: String,
    },
}

impl Refusal {
    /// The refusal's text with the settings it names spelled by `front`
    /// ([`crate::Setting::spelled`]): `--length-units cm` and `--allow length-units` on the
    /// command line, `length_units="cm"` and `allow="length-units"` in Python (the
    /// `Display`). Only [`Refusal::Implausible`] names settings that way; the others are
    /// their `Display`.
    pub fn in_words(&self, front: crate::Front) -> String {
        match self {
            Refusal::Implausible {
                check,
                evidence,
                remedy,
                setting,
            } => implausible(*check, evidence, remedy, *setting, front),
            other => other.to_string(),
        }
    }
}

/// The text of [`Refusal::Implausible`] in `front`'s words.
fn implausible(
    check: crate::Check,
    evidence: &str,
    remedy: &str,
    setting: Option<crate::Setting>,
    front: crate::Front,
) -> String {
    let setting = setting.map_or(String::new(), |s| format!(" ({})", s.spelled(front)));
    let allow = crate::Setting::Allow(check).spelled(front);
    format!("{evidence}; nothing written — {remedy}{setting}, or override the check ({allow})")
}

/// `Result` with [`CalibrateError`].
pub type Result<T, E = CalibrateError> = std::result::Result<T, E>;

/// Turns an identification error into a [`CalibrateError`] with context.
pub(crate) fn id_err(context: impl Into<String>) -> impl FnOnce(IdentifyError) -> CalibrateError {
    let context = context.into();
    move |source| CalibrateError::Identify { context, source }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Check;

    #[test]
    fn a_refusal_names_its_check_under_any_context() {
        let refusal = || {
            CalibrateError::from(Refusal::Implausible {
                check: Check::Mirror,
                evidence: "a reflection fits".to_string(),
                remedy: "check the frame".to_string(),
                setting: None,
            })
        };
        assert_eq!(refusal().refused_check(), Some(Check::Mirror));
        let wrapped = refusal().context("identifying").context("calibrating");
        assert_eq!(wrapped.refused_check(), Some(Check::Mirror));
        assert!(wrapped.to_string().contains("calibrating"));
        assert_eq!(
            CalibrateError::from(Refusal::EveryZero).refused_check(),
            None
        );
        assert_eq!(
            CalibrateError::from(Refusal::EveryZero)
                .context("splitting")
                .refused_check(),
            None
        );
    }
}
