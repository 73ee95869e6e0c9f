//! The calibration workflow on a measurement file (`docs/model.md` §5):
//!
//! read → (split) → register the base if the data are in another frame → identify → screen
//! outliers (refit without them on request) → analyse identifiability at the solution →
//! validate → a [`Calibration`], the values every output is rendered from (by the `report`
//! crate's `report::calibration`; the front ends write the files).

use std::path::Path;
use std::time::Instant;

use evaluate::Table4;
use identify::{
    Fit, IdentifiabilityOptions, IdentifiabilityReport, IdentifyError, IdentifyOptions,
    OutlierScreen, ParamSpec, Problem, RegistrationPolicy, RegistrationReport, analyze,
    generic_poses, identify, mean_point_error, outliers, register_base, register_base_robust,
};
use kinematics::Robot;
use measurements::{Measurement, MeasurementError, MeasurementSet};
use nalgebra::Vector3;

use crate::checks;
use crate::error::{CalibrateError, Refusal, Result, id_err};
use crate::files::{LoadedRobot, file_name, points_mm, poses_rad};
use crate::request::{Check, IdentifyRequest, Split};

/// Validation of the nominal and identified models on one measurement set.
#[derive(Clone, Debug)]
pub struct Validation {
    /// Where the rows come from.
    pub source: String,
    /// The validation rows.
    pub rows: Vec<Measurement>,
    /// measured − start model (the nominal after registration).
    pub before: Vec<[f64; 3]>,
    /// measured − identified.
    pub after: Vec<[f64; 3]>,
    /// Table 4 of before and after.
    pub table: Table4,
    /// Mean and max of the nominal model rigidly registered on these points themselves.
    pub self_registered: Option<(f64, f64)>,
}

/// A finished calibration: everything the outputs are rendered from.
#[derive(Clone, Debug)]
pub struct Calibration {
    /// What was asked. Its paths are those of the files read by [`run`]; a calibration of
    /// [`Inputs`] built in memory ([`calibrate`]) names its sources by [`Calibration::data_source`]
    /// and the nominal's [`LoadedRobot::path`].
    pub request: IdentifyRequest,
    /// The nominal robot file.
    pub nominal: LoadedRobot,
    /// Where the identification data come from ([`MeasurementSet::source`]: the file's path as
    /// given, or the name an in-memory set was given).
    pub data_source: String,
    /// The model the fit started from (the nominal after registration).
    pub start: Robot,
    /// The registration, if considered.
    pub registration: Option<RegistrationReport>,
    /// Which rows identified, in words.
    pub selection: String,
    /// The identification rows used by the final fit.
    pub used: Vec<Measurement>,
    /// Free parameter indices.
    pub free: Vec<usize>,
    /// The first fit (before outlier rejection).
    pub first: Fit,
    /// The outlier screen after the first fit.
    pub screen: Option<OutlierScreen>,
    /// Rows screened (the rows of the first fit), for labels.
    pub screened_rows: Vec<Measurement>,
    /// Whether outliers were excluded and the model refitted.
    pub rejected: bool,
    /// The final fit.
    pub fit: Fit,
    /// Identifiability at the solution.
    pub analysis: IdentifiabilityReport,
    /// Validation, if validation rows were given.
    pub validation: Option<Validation>,
    /// Reader notices (ignored columns), in reading order.
    pub notices: Vec<String>,
    /// Wall-clock time of the fit alone (ms): registration, the free set and the
    /// identification, summed over the outlier-rejection passes; not the plausibility checks,
    /// the identifiability and weak-data analyses, outlier screening or validation (which
    /// took the `fit:` line's time from 7.5 to 26–66 ms on the UR10 example when counted).
    pub elapsed_ms: f64,
    /// What was decided about registration, and the evidence.
    pub registration_decision: String,
    /// Warnings about the data (joints that do not move and the parameters that costs,
    /// validation rows that are identification rows), to show prominently.
    pub warnings: Vec<String>,
}

/// Passes of outlier rejection at most [10: each pass drops what the fit on the others
/// flags; a clean recording needs one or two].
pub const MAX_REJECTION_PASSES: usize = 10;

/// Joint range of motion below which a joint is said not to move, degrees [1: a joint that
/// moves less than a degree leaves its axis's parameters unseen].
pub const STILL_JOINT_DEG: f64 = 1.0;

/// One registration and fit.
struct Pass {
    start: Robot,
    registration: Option<RegistrationReport>,
    decision: String,
    free: Vec<usize>,
    fit: Fit,
}

/// Rows of `val` equal to a row of `id` (joints and point bit for bit).
fn overlapping(id: &[Measurement], val: &[Measurement]) -> usize {
    let key = |r: &Measurement| {
        let mut k: Vec<u64> = r.q_deg.iter().map(|v| v.to_bits()).collect();
        if let Some(p) = r.point_mm {
            k.extend(p.iter().map(|v| v.to_bits()));
        }
        k
    };
    let ids: std::collections::BTreeSet<Vec<u64>> = id.iter().map(key).collect();
    val.iter().filter(|r| ids.contains(&key(r))).count()
}

/// Weak data: joints whose range of motion in `rows` is below [`STILL_JOINT_DEG`], and the
/// free parameters the data leave unidentifiable that generic poses identify.
fn weak_data(
    start: &Robot,
    rows: &[Measurement],
    free: &[usize],
    analysis: &IdentifiabilityReport,
    opts: &IdentifiabilityOptions,
) -> Vec<String> {
    let n = start.n_joints();
    let still: Vec<String> = (0..n)
        .filter(|&j| {
            let (lo, hi) = rows
                .iter()
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), r| {
                    (lo.min(r.q_deg[j]), hi.max(r.q_deg[j]))
                });
            hi - lo < STILL_JOINT_DEG
        })
        .map(|j| format!("q{}", j + 1))
        .collect();
    let generic = generic_poses(start)
        .ok()
        .and_then(|p| analyze(start, &p, None, free, opts).ok());
    let lost: Vec<String> = generic.map_or_else(Vec::new, |g| {
        g.identifiable
            .iter()
            .filter(|p| !analysis.identifiable.contains(p))
            .cloned()
            .collect()
    });
    if still.is_empty() && lost.is_empty() {
        return Vec::new();
    }
    let mut w = String::from("weak data: ");
    if !still.is_empty() {
        w.push_str(&format!(
            "joint{} {} never move{} (range < {STILL_JOINT_DEG}°); ",
            if still.len() > 1 { "s" } else { "" },
            still.join(", "),
            if still.len() > 1 { "" } else { "s" },
        ));
    }
    if lost.is_empty() {
        w.push_str("every parameter that generic poses identify is identified");
    } else {
        w.push_str(&format!(
            "{} parameters that generic poses identify are not identifiable from these data \
             (rank {} where generic poses give {}): {}",
            lost.len(),
            analysis.rank,
            analysis.rank + lost.len(),
            lost.join(", ")
        ));
    }
    vec![w]
}

/// The number of free parameters of `spec` on `robot` (extended by it), for the rows it needs
/// (3·rows ≥ free). For `minimal` it is the structural rank of the robot (on generic random
/// poses).
fn free_count(
    robot: &Robot,
    spec: &ParamSpec,
    opts: &IdentifiabilityOptions,
) -> Result<usize, IdentifyError> {
    Ok(match spec.listed(robot)? {
        Some(names) => names.len(),
        None => {
            let all: Vec<usize> = (0..robot.n_params()).collect();
            generic_poses(robot)
                .ok()
                .and_then(|poses| analyze(robot, &poses, None, &all, opts).ok())
                .map_or(robot.n_params(), |a| a.identifiable.len())
        }
    })
}

fn to_arr(v: Vector3<f64>) -> [f64; 3] {
    [v.x, v.y, v.z]
}

/// The 3-D norms of error vectors.
pub fn norms(errors: &[[f64; 3]]) -> Vec<f64> {
    errors.iter().map(|e| Vector3::from(*e).norm()).collect()
}

/// The mean and the largest of `v` (0 and 0 for an empty slice).
pub fn mean_max(v: &[f64]) -> (f64, f64) {
    let mean = v.iter().sum::<f64>() / v.len().max(1) as f64;
    (mean, v.iter().copied().fold(0.0, f64::max))
}

/// Residuals `measured − robot` of `rows` (which have points), mm.
pub fn residuals(robot: &Robot, rows: &[Measurement]) -> Vec<[f64; 3]> {
    let n = robot.n_joints();
    let poses = poses_rad(rows);
    poses
        .chunks_exact(n)
        .zip(points_mm(rows))
        .map(|(q, p)| to_arr(p - robot.point(q)))
        .collect()
}

/// The registration decision with its evidence: the start model, the report (`None` when
/// never considered) and a sentence saying what was decided and why.
fn register(
    nominal: &Robot,
    poses: &[f64],
    points: &[Vector3<f64>],
    policy: RegistrationPolicy,
) -> Result<(Robot, Option<RegistrationReport>, String)> {
    let before = mean_point_error(nominal, poses, points);
    let threshold = match policy {
        RegistrationPolicy::Never => {
            return Ok((
                nominal.clone(),
                None,
                format!(
                    "not registered (registration never): nominal mean error {before:.3} mm \
                     in the robot's base frame"
                ),
            ));
        }
        RegistrationPolicy::Always => None,
        RegistrationPolicy::Auto { threshold_mm } => Some(threshold_mm),
    };
    if let Some(t) = threshold
        && before.partial_cmp(&t) != Some(std::cmp::Ordering::Greater)
    {
        return Ok((
            nominal.clone(),
            Some(not_registered(nominal, before)),
            format!(
                "not registered: nominal mean error {before:.3} mm ≤ {t} mm, the data are taken \
                 to be in the robot's base frame (the fit refines the base)"
            ),
        ));
    }
    let robust =
        register_base_robust(nominal, poses, points).map_err(id_err("registering the base"))?;
    let (robust, tool_note) = crate::tool_offset::prefer(nominal, poses, points, robust);
    let n = points.len();
    let mut evidence = format!(
        "rigid fit on {} of {n} points (the others beyond {} × the median residual), median \
         error {:.3} mm → {:.3} mm, mean {before:.3} mm → {:.3} mm",
        robust.inliers.len(),
        identify::ROBUST_INLIER_FACTOR,
        robust.median_before_mm,
        robust.median_after_mm,
        robust.report.mean_error_after_mm
    );
    if let Some(note) = tool_note {
        evidence = format!("{evidence}; {note}");
    }
    let better = robust.median_after_mm < robust.median_before_mm;
    match threshold {
        Some(t) if !better => Ok((
            nominal.clone(),
            Some(not_registered(nominal, before)),
            format!(
                "not registered: nominal mean error {before:.3} mm > {t} mm, but the \
                 registration would make it worse ({evidence})"
            ),
        )),
        Some(t) => Ok((
            robust.robot,
            Some(robust.report),
            format!(
                "registered (nominal mean error {before:.3} mm > {t} mm: the data are in \
                 another frame): {evidence}; the base is refitted with the other parameters"
            ),
        )),
        None => Ok((
            robust.robot,
            Some(robust.report),
            format!("registered (registration always): {evidence}"),
        )),
    }
}

/// A report for "not registered" at a start error of `before` mm.
fn not_registered(nominal: &Robot, before: f64) -> RegistrationReport {
    let layout = nominal.layout();
    let x = nominal.params();
    let b = identify::base_parameter_indices(nominal).map(|k| layout.get(k).to_display(x[k]));
    RegistrationReport {
        applied: false,
        mean_error_before_mm: before,
        mean_error_after_mm: before,
        rotation_deg: 0.0,
        translation_mm: [0.0; 3],
        base_before: b,
        base_after: b,
    }
}

/// Refuses a request that cannot run, before anything is read.
pub(crate) fn check(request: &IdentifyRequest) -> Result<()> {
    let k = request.outlier_k;
    if !(k.is_finite() && k > 0.0) {
        return Err(Refusal::OutlierK(k).into());
    }
    checks::outlier_k(request)?;
    if let RegistrationPolicy::Auto { threshold_mm } = request.registration
        && !(threshold_mm.is_finite() && threshold_mm >= 0.0)
    {
        return Err(Refusal::RegistrationThreshold(threshold_mm).into());
    }
    if let Split::Every { every, offset } = request.split {
        if every == 0 {
            return Err(Refusal::EveryZero.into());
        }
        if offset >= every {
            return Err(Refusal::OffsetNotBelowEvery { every, offset }.into());
        }
    }
    if let (Some(split), Some(_)) = (request.split.name(), &request.validate) {
        return Err(Refusal::ValidateWithSplit { split }.into());
    }
    request
        .lm_options()
        .validate()
        .map_err(id_err("the solver options"))
}

/// The identification rows, the validation rows (with where they come from) and which rows
/// identify, in words.
type SplitRows = (Vec<Measurement>, Option<(String, Vec<Measurement>)>, String);

/// Splits the rows of `data` as `request.split` says; `free` and `min_rows` for the refusals.
fn split_rows(
    request: &IdentifyRequest,
    nominal: &LoadedRobot,
    data: &MeasurementSet,
    validate: Option<MeasurementSet>,
    (free, min_rows): (usize, usize),
) -> Result<SplitRows> {
    let n_file_rows = data.rows.len();
    let too_few = |source: CalibrateError| CalibrateError::TooFewRows {
        free,
        spec: request.params.to_string(),
        needed: min_rows,
        source: Box::new(source),
    };
    Ok(match request.split {
        Split::Every { every: k, offset } => {
            let (mut sel, mut rest) = (Vec::new(), Vec::new());
            for (i, r) in data.rows.iter().enumerate() {
                if i % k == offset {
                    sel.push(r.clone());
                } else {
                    rest.push(r.clone());
                }
            }
            if sel.len() < min_rows {
                return Err(too_few(
                    Refusal::EveryTooFew {
                        every: k,
                        offset,
                        selected: sel.len(),
                        rows: n_file_rows,
                        source: Box::new(MeasurementError::TooFewRows {
                            file: data.source.clone(),
                            found: sel.len(),
                            needed: min_rows,
                        }),
                    }
                    .into(),
                ));
            }
            let text = format!(
                "{} of {n_file_rows} rows (data rows {offset}, {}, {}, … — every {k}th from \
                 {offset})",
                sel.len(),
                offset + k,
                offset + 2 * k,
            );
            let val = (!rest.is_empty()).then(|| {
                (
                    format!("{} (the {} other rows)", data.source, rest.len()),
                    rest,
                )
            });
            (sel, val, text)
        }
        Split::Select { poses, criterion } => {
            if poses < min_rows {
                return Err(Refusal::SelectTooFew {
                    poses,
                    free,
                    spec: request.params.to_string(),
                    needed: min_rows,
                }
                .into());
            }
            if poses >= n_file_rows {
                return Err(Refusal::SelectTooMany {
                    poses,
                    file: data.source.clone(),
                    rows: n_file_rows,
                }
                .into());
            }
            let q_deg: Vec<f64> = data.rows.iter().flat_map(|r| r.q_deg.clone()).collect();
            let chosen = design::select_rows(&nominal.robot, &q_deg, poses, criterion, None)
                .map_err(|source| CalibrateError::Design {
                    context: format!(
                        "choosing {poses} rows of {} by the {} criterion",
                        data.source,
                        criterion.as_str()
                    ),
                    source: Box::new(source),
                })?;
            let (mut sel, mut rest) = (Vec::new(), Vec::new());
            for (i, r) in data.rows.iter().enumerate() {
                if chosen.binary_search(&i).is_ok() {
                    sel.push(r.clone());
                } else {
                    rest.push(r.clone());
                }
            }
            let lines: Vec<String> = sel.iter().take(3).map(|r| r.line.to_string()).collect();
            let text = format!(
                "{} of {n_file_rows} rows chosen by the {} criterion on their joints (lines {}, …)",
                sel.len(),
                criterion.as_str().to_uppercase(),
                lines.join(", "),
            );
            let val = Some((
                format!("{} (the {} other rows)", data.source, rest.len()),
                rest,
            ));
            (sel, val, text)
        }
        Split::All => {
            let val = validate.map(|v| (v.source, v.rows));
            (data.rows.clone(), val, format!("all {n_file_rows} rows"))
        }
    })
}

/// Validation of the start model and the identified one on `rows`.
fn validate(
    nominal: &Robot,
    start: &Robot,
    fit: &Robot,
    source: String,
    rows: Vec<Measurement>,
) -> Result<Validation> {
    let before = residuals(start, &rows);
    let after = residuals(fit, &rows);
    let table =
        Table4::from_errors(&before, &after).map_err(|source| CalibrateError::Evaluate {
            context: "validation statistics".into(),
            source,
        })?;
    let (vp, vx) = (poses_rad(&rows), points_mm(&rows));
    let self_registered = register_base(nominal, &vp, &vx)
        .ok()
        .map(|(r, _)| mean_max(&norms(&residuals(&r, &rows))));
    Ok(Validation {
        source,
        rows,
        before,
        after,
        table,
        self_registered,
    })
}

/// What a calibration reads, loaded: the nominal robot, the identification data and the
/// validation data (with [`Split::All`] only). [`Inputs::load`] reads the request's files; a
/// binding builds them in memory and calls [`calibrate`].
#[derive(Clone, Debug)]
pub struct Inputs {
    /// The nominal robot (geometric: the request's extended parameters are applied by the
    /// calibration).
    pub nominal: LoadedRobot,
    /// The identification data (points required).
    pub data: MeasurementSet,
    /// Validation data, if any.
    pub validate: Option<MeasurementSet>,
}

impl Inputs {
    /// Reads the files of `request`: the robot, the identification data (at least the rows
    /// the request's free parameters need) and the validation file.
    ///
    /// # Errors
    /// As [`run`], for the reading part.
    pub fn load(request: &IdentifyRequest) -> Result<Self> {
        check(request)?;
        let nominal = LoadedRobot::load(&request.robot, "robot")?;
        let (_, n_free, min_rows) = extended(request, &nominal)?;
        let units = (
            request.joint_units.deg_per_unit(),
            request.length_units.mm_per_unit(),
        );
        let as_degrees = |path: &std::path::Path| {
            nominal
                .read_set_in(path, true, (0, None), "data", (1.0, units.1))
                .ok()
        };
        let data = nominal
            .read_set_in(
                &request.data,
                true,
                (min_rows, None),
                "identification data",
                units,
            )
            .map_err(|e| declared_radians(request, e, || as_degrees(&request.data)))
            .map_err(|e| too_few_rows(request, n_free, min_rows, e))?;
        let validate = match (&request.validate, &request.split) {
            (Some(path), Split::All) => {
                let set = nominal
                    .read_set_in(path, true, (0, None), "validation data", units)
                    .map_err(|e| declared_radians(request, e, || as_degrees(path)))?;
                Some(with_rows(set, "validation")?)
            }
            _ => None,
        };
        Ok(Inputs {
            nominal,
            data,
            validate,
        })
    }
}

/// A read in declared radians that failed (`err`): when the rows read cleanly as degrees
/// (`as_degrees`: the rows read again in degrees, `None` if they do not pass) and
/// [`checks::declared_radians`] sees degrees, that refusal (with its evidence) instead of
/// `err` (typically the first joint beyond a limit in radians). Not when the request allows
/// the `joint-units` check or declares degrees (`as_degrees` is then not called).
pub(crate) fn declared_radians(
    request: &IdentifyRequest,
    err: CalibrateError,
    as_degrees: impl FnOnce() -> Option<MeasurementSet>,
) -> CalibrateError {
    if request.joint_units != crate::JointUnits::Rad || request.allows(Check::JointUnits) {
        return err;
    }
    match as_degrees() {
        Some(set) => match checks::declared_radians(&set.source, &set.rows) {
            Err(refusal) => refusal.into(),
            Ok(()) => err,
        },
        None => err,
    }
}

/// `set` if it has rows, else [`Refusal::NoDataRows`] naming it as the `what` file.
pub(crate) fn with_rows(set: MeasurementSet, what: &'static str) -> Result<MeasurementSet> {
    if set.rows.is_empty() {
        return Err(Refusal::NoDataRows {
            what,
            file: set.source,
        }
        .into());
    }
    Ok(set)
}

/// The nominal of `request` extended by its `+` parameters, with the number of free
/// parameters and the identification rows they need (⌈free / 3⌉).
fn extended(request: &IdentifyRequest, nominal: &LoadedRobot) -> Result<(Robot, usize, usize)> {
    let spec_err = |source| CalibrateError::Params {
        spec: request.params.to_string(),
        source,
    };
    let robot = request
        .params
        .apply(&nominal.robot, &nominal.path.display().to_string())
        .map_err(spec_err)?;
    let n_free = free_count(&robot, &request.params, &IdentifiabilityOptions::default())
        .map_err(spec_err)?;
    Ok((robot, n_free, n_free.div_ceil(3)))
}

/// A reading error of the identification data: too few rows says why so many are needed.
fn too_few_rows(
    request: &IdentifyRequest,
    free: usize,
    needed: usize,
    e: CalibrateError,
) -> CalibrateError {
    match e {
        CalibrateError::Read {
            source: MeasurementError::TooFewRows { .. },
            ..
        } => CalibrateError::TooFewRows {
            free,
            spec: request.params.to_string(),
            needed,
            source: Box::new(e),
        },
        e => e,
    }
}

/// Runs the whole calibration of `request` and returns what the outputs are rendered from;
/// nothing is written: [`Inputs::load`] then [`calibrate`].
///
/// # Errors
/// A [`Refusal`] naming the request field before anything is read; then the files' errors
/// (file, line, column), [`CalibrateError::Params`] for a spec that does not fit the robot,
/// [`CalibrateError::TooFewRows`], and the identification's.
pub fn run(request: &IdentifyRequest) -> Result<Calibration> {
    let inputs = Inputs::load(request)?;
    calibrate(request, inputs)
}

/// Calibrates loaded `inputs` with the options of `request` (its paths are not read: the
/// sources are named by the inputs).
///
/// # Errors
/// As [`run`], without the reading errors; too few identification rows is
/// [`CalibrateError::TooFewRows`] as when reading.
pub fn calibrate(request: &IdentifyRequest, inputs: Inputs) -> Result<Calibration> {
    check(request)?;
    let args = request;
    let Inputs {
        mut nominal,
        data,
        validate: validation_set,
    } = inputs;
    let spec_err = |source| CalibrateError::Params {
        spec: args.params.to_string(),
        source,
    };
    let (robot, n_free, min_rows) = extended(request, &nominal)?;
    // The extended parameters after `+` join the geometric ones.
    nominal.robot = robot;
    let nom = &nominal.robot;
    let id_opts = IdentifiabilityOptions::default();
    if data.rows.len() < min_rows {
        let e = CalibrateError::Read {
            context: format!(
                "reading the identification data {} for {} ({} joints)",
                data.source,
                nom.name(),
                nom.n_joints()
            ),
            source: MeasurementError::TooFewRows {
                file: data.source.clone(),
                found: data.rows.len(),
                needed: min_rows,
            },
        };
        return Err(too_few_rows(request, n_free, min_rows, e));
    }
    let mut notices = data.notices.clone();
    if let Some(v) = &validation_set {
        notices.extend(v.notices.iter().cloned());
    }
    let (id_rows, val_rows, selection) =
        split_rows(args, &nominal, &data, validation_set, (n_free, min_rows))?;

    // Plausibility of the data, before any fit: units and handedness.
    let source = data.source.clone();
    if !args.allows(Check::JointUnits) {
        checks::joint_units(&source, &id_rows, &nominal.limits_deg())?;
    }
    if !args.allows(Check::LengthUnits) {
        checks::length_units(&source, nom, &id_rows)?;
    }
    if !args.allows(Check::Mirror) {
        checks::mirror(&source, nom, &id_rows)?;
    }
    let overlap = val_rows
        .as_ref()
        .map_or(0, |(_, rows)| overlapping(&id_rows, rows));

    // The time of the passes alone (registration, free set, fit; summed over the rejection
    // passes): the checks, the analyses and validation after them are not the fit's time.
    let fit_ms = std::cell::Cell::new(0.0_f64);
    let options = IdentifyOptions {
        lm: args.lm_options(),
        registration: RegistrationPolicy::Never,
        ..IdentifyOptions::default()
    };
    // One pass: register on `rows`, resolve the free set at the registered start (the base
    // free where registered), fit.
    let pass = |rows: &[Measurement]| -> Result<Pass> {
        let started = Instant::now();
        let (p, x) = (poses_rad(rows), points_mm(rows));
        let (start, registration, decision) = register(nom, &p, &x, args.registration)
            .map_err(|e| e.context(format!("identification data {}", data.source)))?;
        let mut free = args
            .params
            .resolve(&start, &p, None, &id_opts)
            .map_err(spec_err)?;
        // `minimal` already holds every base parameter identifiable at the registered start;
        // the others are redundant there (base_rz with theta1 for most arms).
        if registration.as_ref().is_some_and(|r| r.applied)
            && args.params.base != identify::ParamSet::Minimal
        {
            for k in identify::base_parameter_indices(&start) {
                if !free.contains(&k) {
                    free.push(k);
                }
            }
            free.sort_unstable();
        }
        let problem = Problem::new(&start, &p, &x, free.clone()).map_err(id_err(format!(
            "setting up the identification on {}",
            data.source
        )))?;
        let fit = identify(&problem, &options).map_err(id_err(format!(
            "identifying {} on {}",
            nom.name(),
            data.source
        )))?;
        let mut fit = crate::prior::refit(&args.prior, &problem, &options, fit)?;
        // An extended model evaluates its gravity torques on the geometry it was extended
        // from (the nominal, during the fit). `identified.json` re-extends its own geometry
        // when it is read, so the model validated and reported is that one: what every
        // command loading the file will compute.
        if fit.robot.is_extended() {
            fit.robot =
                Robot::from_spec(&fit.robot.to_spec()).map_err(|source| CalibrateError::Robot {
                    what: "identified robot",
                    path: nominal.path.clone(),
                    source,
                })?;
        }
        fit_ms.set(fit_ms.get() + started.elapsed().as_secs_f64() * 1e3);
        Ok(Pass {
            start,
            registration,
            decision,
            free,
            fit,
        })
    };
    let poses = poses_rad(&id_rows);
    let points = points_mm(&id_rows);
    let screen_of = |fit: &Fit| -> Result<Option<OutlierScreen>> {
        fit.sigma_hat
            .map(|s| {
                outliers::screen(&fit.robot, &poses, &points, s, args.outlier_k)
                    .map_err(id_err("screening outliers"))
            })
            .transpose()
    };
    let mut current = pass(&id_rows)?;
    let first = current.fit.clone();
    let first_decision = current.decision.clone();
    let mut screen = screen_of(&first)?;
    let mut kept: Vec<usize> = (0..id_rows.len()).collect();
    let mut rejected = false;
    let mut rejection_passes = 0;
    // Rejection to a fixed point: every identification row is screened against the fit on
    // the rows kept, until the kept rows are those the screen passes (so that the result
    // with a rejected row is the result without it); registration is redone each time.
    while args.reject_outliers && rejection_passes <= MAX_REJECTION_PASSES {
        let flagged = screen.as_ref().map_or_else(Vec::new, |s| s.indices());
        let next: Vec<usize> = (0..id_rows.len())
            .filter(|i| flagged.binary_search(i).is_err())
            .collect();
        if next == kept || rejection_passes == MAX_REJECTION_PASSES {
            break;
        }
        if !args.allows(Check::Outliers) {
            checks::rejected_fraction(&source, flagged.len(), id_rows.len(), args.outlier_k)?;
        }
        if 3 * next.len() < current.free.len() {
            return Err(Refusal::TooManyOutliers {
                file: data.source.clone(),
                outliers: flagged.len(),
                rows: id_rows.len(),
                kept: next.len(),
                free: current.free.len(),
            }
            .into());
        }
        kept = next;
        rejected = true;
        rejection_passes += 1;
        let rows: Vec<Measurement> = kept.iter().map(|&i| id_rows[i].clone()).collect();
        current = pass(&rows).map_err(|e| e.context("refitting without the outliers"))?;
        screen = screen_of(&current.fit)?;
    }
    let used: Vec<Measurement> = kept.iter().map(|&i| id_rows[i].clone()).collect();
    let Pass {
        start,
        registration,
        mut decision,
        free,
        fit,
    } = current;
    if rejected {
        decision = format!(
            "{decision} — decided on the {} rows kept after rejecting the outliers (on all {} \
             rows: {first_decision})",
            used.len(),
            id_rows.len()
        );
    }
    let analysis = analyze(&fit.robot, &poses_rad(&used), None, &free, &id_opts)
        .map_err(id_err("identifiability at the solution"))?;
    let mut weak = weak_data(&start, &used, &free, &analysis, &id_opts);
    let excitation = crate::excitation::diagnose(&start, &used, &fit);
    weak.extend(excitation.warning(&args.prior));
    if !args.allows(Check::Parameters) {
        crate::excitation::parameters(&start, &fit, &analysis, &excitation)?;
    }
    let validation = val_rows
        .map(|(source, rows)| validate(nom, &start, &fit.robot, source, rows))
        .transpose()?;
    if let Some(v) = &validation
        && !args.allows(Check::Validation)
    {
        checks::validation(
            &v.source,
            v.table.before.norm.mean_mm,
            v.table.after.norm.mean_mm,
        )?;
    }
    let mut warnings = weak;
    if overlap > 0 {
        warnings.push(format!(
            "{overlap} validation rows are also identification rows (same joints and point): \
             validation on them is not independent"
        ));
    }
    let elapsed_ms = fit_ms.get();
    Ok(Calibration {
        request: request.clone(),
        data_source: data.source.clone(),
        nominal: nominal.clone(),
        start,
        registration,
        selection,
        used,
        free,
        first,
        screen,
        screened_rows: id_rows,
        rejected,
        fit,
        analysis,
        validation,
        notices,
        elapsed_ms,
        registration_decision: decision,
        warnings,
    })
}

impl Calibration {
    /// Whether the measurement frame was registered onto the robot base (the start model is
    /// then the nominal one moved into the data's frame).
    pub fn registered(&self) -> bool {
        self.registration.as_ref().is_some_and(|r| r.applied)
    }

    /// The calibrated robot as it is written (`identified.json`): the final fit, named after
    /// the nominal robot and the data file.
    pub fn identified_robot(&self) -> Robot {
        let mut robot = self.fit.robot.clone();
        robot.set_name(format!(
            "{}, identified from {}",
            self.nominal.robot.name(),
            file_name(Path::new(&self.data_source))
        ));
        robot
    }

    /// The nominal robot in the data's measurement frame (`registered-nominal.json`, the
    /// targets of compensation): the start model, named after the data file when registered.
    pub fn registered_robot(&self) -> Robot {
        let mut registered = self.start.clone();
        if self.registered() {
            registered.set_name(format!(
                "{}, base registered on {}",
                self.nominal.robot.name(),
                file_name(Path::new(&self.data_source))
            ));
        }
        registered
    }

    /// Residuals (measured − model, mm) of the start model and of the identified one on the
    /// rows the final fit used.
    pub fn fit_residuals(&self) -> (Vec<[f64; 3]>, Vec<[f64; 3]>) {
        (
            residuals(&self.start, &self.used),
            residuals(&self.fit.robot, &self.used),
        )
    }

    /// Residuals (measured − model, mm) of the start model and of the identified one on the
    /// screened rows (those of the first fit, outliers included).
    pub fn screened_residuals(&self) -> (Vec<[f64; 3]>, Vec<[f64; 3]>) {
        (
            residuals(&self.start, &self.screened_rows),
            residuals(&self.fit.robot, &self.screened_rows),
        )
    }
}
