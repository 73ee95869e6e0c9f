//! The calibration of a measurement file (`docs/model.md` §5), whatever its kind:
//! [`run`] reads it ([`Inputs::load`]), [`calibrate`] chooses the kind of measurement from
//! the data ([`MeasurementKind::of`]) and runs the one pipeline (`crate::pipeline`) →
//! a [`Calibration`], the values every output is rendered from (by the `report` crate's
//! `report::calibration`; the front ends write the files).
//!
//! This module also holds the point kind's stages: register the base if the data are in
//! another frame, resolve the free set, identify, screen outlier rows, analyse
//! identifiability at the solution, validate ([`PointCalibration`]).

use std::cell::Cell;
use std::path::Path;
use std::time::Instant;

use evaluate::Table4;
use identify::{
    Fit, IdentifiabilityOptions, IdentifiabilityReport, IdentifyError, IdentifyOptions,
    OutlierScreen, ParamSpec, Problem, RegistrationPolicy, RegistrationReport, analyze,
    generic_poses, identify, outliers, register_base,
};
use kinematics::Robot;
use measurements::{Measurement, MeasurementError, MeasurementSet};
use nalgebra::Vector3;

use crate::checks;
use crate::error::{CalibrateError, Refusal, Result, id_err};
use crate::files::{LoadedRobot, file_name, points_mm, poses_rad};
pub use crate::pipeline::mean_max;
use crate::pipeline::{self, Common, Held, Kind, MeasurementKind, RobustScreen, register};
use crate::request::{Check, IdentifyRequest, Split};
use crate::tool_frame::ToolFrameCalibration;

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

/// A finished calibration of any kind of measurement: everything the outputs are rendered
/// from (`report::calibration::render` writes the same set of files for every kind).
#[derive(Clone, Debug)]
pub enum Calibration {
    /// From points ([`MeasurementKind::Points`]).
    Points(Box<PointCalibration>),
    /// From 6-DoF or multi-target data ([`MeasurementKind::SixDof`],
    /// [`MeasurementKind::Targets`]): the tool frame and the targets are unknowns.
    ToolFrame(Box<ToolFrameCalibration>),
}

/// A finished calibration from points: everything the outputs are rendered from.
#[derive(Clone, Debug)]
pub struct PointCalibration {
    /// What was asked. Its paths are those of the files read by [`run`]; a calibration of
    /// [`Inputs`] built in memory ([`calibrate`]) names its sources by
    /// [`PointCalibration::data_source`] and the nominal's [`LoadedRobot::path`].
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
    /// The outlier screen (at k) of every identification row against the final fit.
    pub screen: Option<OutlierScreen>,
    /// Rows screened (the rows of the first fit), for labels.
    pub screened_rows: Vec<Measurement>,
    /// Whether outliers were excluded and the model refitted.
    pub rejected: bool,
    /// The robust screen: its scale and the rows excluded (indices into
    /// [`PointCalibration::screened_rows`]); `None` with `keep_outliers` or without degrees of
    /// freedom.
    pub robust: Option<RobustScreen>,
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
    /// The measurements' scale factor identified with `--fit-scale` (`crate::scale`): the
    /// points were divided by it before this calibration; `None` without `--fit-scale` or
    /// when the factor was not significant (the points were left as measured).
    pub measurement_scale: Option<crate::scale::ScaleEvidence>,
    /// The learned residual model's cross-validation and, when it helps, the model
    /// ([`crate::residual`]); `None` unless asked for
    /// ([`Calibration::fit_residual_model`]).
    pub residual: Option<crate::residual::ResidualOutcome>,
}

/// Joint range of motion below which a joint is said not to move, degrees [1: a joint that
/// moves less than a degree leaves its axis's parameters unseen].
pub const STILL_JOINT_DEG: f64 = 1.0;

/// One registration and fit.
#[derive(Clone)]
struct Pass {
    start: Robot,
    registration: Option<RegistrationReport>,
    decision: String,
    free: Vec<usize>,
    fit: Fit,
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

/// The 3-D norms of error vectors (one implementation: `evaluate::norms`).
pub use evaluate::norms;

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

/// Each row's block `(‖p^meas − p(q)‖, 3)` against `robot`, mm (the units of the robust
/// outlier screen).
fn point_blocks(robot: &Robot, rows: &[Measurement]) -> Vec<(f64, usize)> {
    residuals(robot, rows)
        .iter()
        .map(|e| (Vector3::from(*e).norm(), 3))
        .collect()
}

/// Refuses a request that cannot run, before anything is read.
pub(crate) fn check(request: &IdentifyRequest) -> Result<()> {
    let k = request.outlier_k;
    if !(k.is_finite() && k > 0.0) {
        return Err(Refusal::OutlierK(k).into());
    }
    checks::outlier_k(request)?;
    if request.keep_outliers && request.reject_outliers {
        return Err(Refusal::KeepAndRejectOutliers.into());
    }
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
        // Each file is read once, whole, and parsed from memory: a pipe (`--data <(…)`)
        // cannot be read a second time.
        let data_text = nominal.read_text(&request.data, "identification data")?;
        // Points need a row per three free parameters, checked on reading; 6-DoF and
        // multi-target data one row (the fit says when their equations are too few).
        let points = request.euler.is_none() && !header_names_poses(&data_text);
        let min_rows = if points { min_rows } else { 1 };
        let read = |text: &str, path: &Path, min: usize, what: &str, units: (f64, f64)| {
            let source = path.display().to_string();
            nominal.read_text_with(text, &source, true, (min, None), what, units, request.euler)
        };
        let as_degrees = |text: &str, path: &Path| read(text, path, 0, "data", (1.0, units.1)).ok();
        let data = read(
            &data_text,
            &request.data,
            min_rows,
            "identification data",
            units,
        )
        .map_err(|e| {
            declared_radians(request, &nominal, e, || {
                as_degrees(&data_text, &request.data)
            })
        })
        .map_err(|e| {
            if points {
                too_few_rows(request, n_free, min_rows, e)
            } else {
                e
            }
        })?;
        let validate = match (&request.validate, &request.split) {
            (Some(path), Split::All) => {
                let val_text = nominal.read_text(path, "validation data")?;
                let set = read(&val_text, path, 0, "validation data", units).map_err(|e| {
                    declared_radians(request, &nominal, e, || as_degrees(&val_text, path))
                })?;
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

/// Whether the measurement file's header names orientation or target columns (`qw`, `rx`,
/// `target`): the first line of `text` that is neither blank nor a `#` comment.
pub(crate) fn header_names_poses(text: &str) -> bool {
    text.lines()
        .map(str::trim)
        .find(|l| !l.is_empty() && !l.starts_with('#'))
        .is_some_and(|h| {
            h.split(',')
                .map(|c| c.trim().to_ascii_lowercase())
                .any(|c| c == "qw" || c == "rx" || c == "target")
        })
}

/// A read in declared radians that failed (`err`): when the rows read cleanly as degrees
/// (`as_degrees`: the rows read again in degrees, `None` if they do not pass) and
/// [`checks::declared_radians`] sees degrees, that refusal (with its evidence) instead of
/// `err` (typically the first joint beyond a limit in radians). Not when the request allows
/// the `joint-units` check or declares degrees (`as_degrees` is then not called).
pub(crate) fn declared_radians(
    request: &IdentifyRequest,
    nominal: &LoadedRobot,
    err: CalibrateError,
    as_degrees: impl FnOnce() -> Option<MeasurementSet>,
) -> CalibrateError {
    if request.joint_units != crate::JointUnits::Rad || request.allows(Check::JointUnits) {
        return err;
    }
    match as_degrees() {
        Some(set) => {
            match checks::declared_radians(&set.source, &set.rows, &nominal.revolute_limits_deg()) {
                Err(refusal) => refusal.into(),
                Ok(()) => err,
            }
        }
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
/// sources are named by the inputs): the kind of measurement is the data's
/// ([`MeasurementKind::of`]), and every kind goes through the same stages and checks.
///
/// # Errors
/// As [`run`], without the reading errors; too few identification rows is
/// [`CalibrateError::TooFewRows`] as when reading.
pub fn calibrate(request: &IdentifyRequest, inputs: Inputs) -> Result<Calibration> {
    check(request)?;
    if !request.fit_scale {
        return calibrate_as_measured(request, inputs);
    }
    // `--fit-scale`: a first fit with the checks that a scale trips off, its common scale,
    // and, when significant, the fit of the points divided by it (`crate::scale`).
    let probe = IdentifyRequest {
        fit_scale: false,
        allow: [
            request.allow.clone(),
            vec![Check::Scale, Check::Parameters, Check::Validation],
        ]
        .concat(),
        ..request.clone()
    };
    let first = calibrate_as_measured(&probe, inputs.clone())?;
    let Some(e) = first.scale_evidence().filter(|e| e.significant()) else {
        return calibrate_as_measured(request, inputs);
    };
    let divide = |set: &mut MeasurementSet| {
        for r in &mut set.rows {
            if let Some(p) = &mut r.point_mm {
                p.iter_mut().for_each(|v| *v /= e.factor);
            }
        }
    };
    let mut scaled = inputs;
    divide(&mut scaled.data);
    if let Some(v) = &mut scaled.validate {
        divide(v);
    }
    let mut c = calibrate_as_measured(request, scaled)?;
    c.set_measurement_scale(e);
    Ok(c)
}

/// [`calibrate`] of the points as measured (no `--fit-scale`).
fn calibrate_as_measured(request: &IdentifyRequest, inputs: Inputs) -> Result<Calibration> {
    let kind = MeasurementKind::of(&inputs.data, request.points_only);
    let Inputs {
        mut nominal,
        data,
        validate: validation_set,
    } = inputs;
    let (robot, n_free, min_rows) = extended(request, &nominal)?;
    // The extended parameters after `+` join the geometric ones.
    nominal.robot = robot;
    let nom = &nominal.robot;
    // Each row gives at least three equations: point data need free / 3 rows (the other
    // kinds' fit says when its equations are too few).
    if kind.is_points() && data.rows.len() < min_rows {
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
    // The units the split and the screen take or drop whole: rows, or poses.
    let units: Vec<Vec<usize>> = if kind.is_points() {
        (0..data.rows.len()).map(|i| vec![i]).collect()
    } else {
        data.poses()
    };
    let split = pipeline::split(
        request,
        nom,
        &data,
        validation_set,
        (kind, &units),
        (n_free, min_rows),
    )?;
    let id_rows = pipeline::rows_of(&data, &units, &split.id);
    // Plausibility of the data, before any fit: units and handedness; of a validation file
    // as of the identification data (a validation file in metres or radians would show a
    // Table 4 of metres).
    let limits = nominal.revolute_limits_deg();
    pipeline::check_data(request, &data.source, nom, &limits, &id_rows)?;
    if let Some((_, Held::File(set))) = &split.val {
        pipeline::check_data(request, &set.source, nom, &limits, &set.rows)?;
    }
    let overlap = split.val.as_ref().map_or(0, |(_, held)| match held {
        Held::Rest(rest) => {
            pipeline::overlapping(&id_rows, &pipeline::rows_of(&data, &units, rest))
        }
        Held::File(set) => pipeline::overlapping(&id_rows, &set.rows),
    });
    let overlap_warning = (overlap > 0).then(|| {
        format!(
            "{overlap} validation rows are also identification rows (same joints and point): \
             validation on them is not independent"
        )
    });
    let common = Common {
        request,
        nominal,
        data,
        units,
        split,
        kind,
        notices,
        overlap_warning,
    };
    if kind.is_points() {
        calibrate_points(common, id_rows).map(|c| Calibration::Points(Box::new(c)))
    } else {
        crate::tool_frame::calibrate(common).map(|c| Calibration::ToolFrame(Box::new(c)))
    }
}

/// The point kind's stages (`crate::pipeline::Kind`).
struct PointKind<'a> {
    request: &'a IdentifyRequest,
    nominal: &'a LoadedRobot,
    source: &'a str,
    id_opts: IdentifiabilityOptions,
    options: IdentifyOptions,
    /// The time of the passes alone (registration, free set, fit; summed over the rejection
    /// passes): the checks, the analyses and validation after them are not the fit's time.
    fit_ms: Cell<f64>,
}

impl Kind for PointKind<'_> {
    const UNIT: &'static str = "row";
    type Data = Vec<Measurement>;
    type Pass = Pass;
    type Screen = OutlierScreen;
    /// Identifiability at the solution, and the weak-data warnings.
    type Analysis = (
        IdentifiabilityReport,
        Vec<String>,
        crate::excitation::Excitation,
    );
    type Held = Vec<Measurement>;
    type Validation = Validation;

    fn subset(&self, data: &Vec<Measurement>, keep: &[usize]) -> Vec<Measurement> {
        keep.iter().map(|&i| data[i].clone()).collect()
    }

    fn units(&self, data: &Vec<Measurement>) -> usize {
        data.len()
    }

    /// One pass: register on `rows`, resolve the free set at the registered start (the base
    /// free where registered), fit.
    fn pass(&self, rows: &Vec<Measurement>) -> Result<Pass> {
        let (args, nom) = (self.request, &self.nominal.robot);
        let spec_err = |source| CalibrateError::Params {
            spec: args.params.to_string(),
            source,
        };
        let started = Instant::now();
        let (p, x) = (poses_rad(rows), points_mm(rows));
        let (start, registration, decision) = register(nom, &p, &x, args.registration)
            .map_err(|e| e.context(format!("identification data {}", self.source)))?;
        let mut free = args
            .params
            .resolve(&start, &p, None, &self.id_opts)
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
        let mut fit = fit_points(
            &start,
            (&p, &x),
            free.clone(),
            &self.options,
            (&self.request.prior, &self.nominal.prior_sd()),
            (nom.name(), self.source),
        )?;
        fit.robot = as_written(fit.robot, self.nominal)?;
        self.fit_ms
            .set(self.fit_ms.get() + started.elapsed().as_secs_f64() * 1e3);
        Ok(Pass {
            start,
            registration,
            decision,
            free,
            fit,
        })
    }

    fn screen(
        &self,
        pass: &Pass,
        rows: &Vec<Measurement>,
        k: f64,
    ) -> Result<Option<OutlierScreen>> {
        let fit = &pass.fit;
        fit.sigma_hat
            .map(|s| {
                outliers::screen(&fit.robot, &poses_rad(rows), &points_mm(rows), s, k)
                    .map_err(id_err("screening outliers"))
            })
            .transpose()
    }

    fn norms(&self, pass: &Pass, rows: &Vec<Measurement>) -> Vec<(f64, usize)> {
        point_blocks(&pass.fit.robot, rows)
    }

    fn start_norms(&self, pass: &Pass, rows: &Vec<Measurement>) -> Vec<(f64, usize)> {
        point_blocks(&pass.start, rows)
    }

    fn sigma_row(pass: &Pass) -> Option<f64> {
        pass.fit.sigma_hat
    }

    fn flagged(screen: &OutlierScreen) -> Vec<usize> {
        screen.indices()
    }

    fn n_free(pass: &Pass) -> usize {
        pass.free.len()
    }

    fn determines(&self, rows: &Vec<Measurement>, n_free: usize) -> bool {
        3 * rows.len() >= n_free
    }

    fn decision(pass: &mut Pass) -> &mut String {
        &mut pass.decision
    }

    fn analyse(&self, pass: &Pass, used: &Vec<Measurement>) -> Result<Self::Analysis> {
        let analysis = analyze(
            &pass.fit.robot,
            &poses_rad(used),
            None,
            &pass.free,
            &self.id_opts,
        )
        .map_err(id_err("identifiability at the solution"))?;
        let mut weak = weak_data(&pass.start, used, &pass.free, &analysis, &self.id_opts);
        let excitation = crate::excitation::diagnose(&pass.start, used, &pass.fit);
        weak.extend(excitation.warning(&self.request.prior));
        Ok((analysis, weak, excitation))
    }

    /// The parameters check with the evidence of what the poses determine
    /// ([`crate::excitation::parameters`]): weak excitation is named as such, not as units.
    fn check_parameters(&self, pass: &Pass, analysis: &Self::Analysis) -> Result<()> {
        crate::excitation::parameters(
            &pass.start,
            &pass.fit.robot,
            &analysis.0.identifiable_indices,
            &analysis.2,
        )?;
        Ok(())
    }

    fn moved<'a>(
        pass: &'a Pass,
        analysis: &'a Self::Analysis,
    ) -> (&'a Robot, &'a Robot, &'a [usize]) {
        (
            &pass.start,
            &pass.fit.robot,
            &analysis.0.identifiable_indices,
        )
    }

    fn validate(&self, pass: &Pass, source: String, rows: Vec<Measurement>) -> Result<Validation> {
        validate(
            &self.nominal.robot,
            &pass.start,
            &pass.fit.robot,
            source,
            rows,
        )
    }

    fn validated(v: &Validation) -> (&str, f64, f64) {
        (
            &v.source,
            v.table.before.norm.mean_mm,
            v.table.after.norm.mean_mm,
        )
    }
}

/// The identified robot as `identified.json` reads back. An extended model evaluates its
/// gravity torques on the geometry it was extended from (the nominal, during the fit).
/// `identified.json` re-extends its own geometry when it is read, so the model validated and
/// reported is that one: what every command loading the file will compute.
pub(crate) fn as_written(robot: Robot, nominal: &LoadedRobot) -> Result<Robot> {
    if !robot.is_extended() {
        return Ok(robot);
    }
    Robot::from_spec(&robot.to_spec()).map_err(|source| CalibrateError::Robot {
        what: "identified robot",
        path: nominal.path.clone(),
        source,
    })
}

/// The point fit: identification of `free` on `poses` and `points` from `start` (errors
/// naming the robot and the data's source). The one place the point kind calls the solver.
pub(crate) fn fit_points(
    start: &Robot,
    (poses, points): (&[f64], &[Vector3<f64>]),
    free: Vec<usize>,
    options: &IdentifyOptions,
    (prior, prior_file): (&crate::PriorSpec, &[(String, f64)]),
    (robot, source): (&str, &str),
) -> Result<Fit> {
    let problem = Problem::new(start, poses, points, free)
        .map_err(id_err(format!("setting up the identification on {source}")))?;
    let fit =
        identify(&problem, options).map_err(id_err(format!("identifying {robot} on {source}")))?;
    crate::prior::refit(prior, prior_file, &problem, options, fit)
}

/// The point kind after the split: the pipeline's stages, then the result.
fn calibrate_points(common: Common<'_>, id_rows: Vec<Measurement>) -> Result<PointCalibration> {
    let Common {
        request,
        nominal,
        data,
        units,
        split,
        kind: _,
        notices,
        overlap_warning,
    } = common;
    let kind = PointKind {
        request,
        nominal: &nominal,
        source: &data.source,
        id_opts: IdentifiabilityOptions::default(),
        options: IdentifyOptions {
            lm: request.lm_options(),
            registration: RegistrationPolicy::Never,
            ..IdentifyOptions::default()
        },
        fit_ms: Cell::new(0.0),
    };
    let val = split.val.map(|(source, held)| {
        let rows = match held {
            Held::Rest(rest) => pipeline::rows_of(&data, &units, &rest),
            Held::File(set) => set.rows,
        };
        (source, rows)
    });
    let out = pipeline::fit_and_check(&kind, request, &data.source, &id_rows, val)?;
    let pipeline::Outcome {
        first,
        last,
        screen,
        used,
        rejected,
        robust,
        analysis: (analysis, mut warnings, _),
        validation,
    } = out;
    let Pass {
        start,
        registration,
        decision,
        free,
        fit,
    } = last;
    warnings.extend(overlap_warning);
    let elapsed_ms = kind.fit_ms.get();
    Ok(PointCalibration {
        request: request.clone(),
        data_source: data.source.clone(),
        nominal: nominal.clone(),
        start,
        registration,
        selection: split.text,
        used,
        free,
        first: first.fit,
        screen,
        screened_rows: id_rows,
        rejected,
        robust,
        fit,
        analysis,
        validation,
        notices,
        elapsed_ms,
        registration_decision: decision,
        warnings,
        measurement_scale: None,
        residual: None,
    })
}

impl Calibration {
    /// The common scale of the identified lengths ([`crate::scale::common_scale`] of the start
    /// model, the identified one and the identifiable parameters).
    pub fn scale_evidence(&self) -> Option<crate::scale::ScaleEvidence> {
        match self {
            Calibration::Points(c) => {
                crate::scale::common_scale(&c.start, &c.fit.robot, &c.analysis.identifiable_indices)
            }
            Calibration::ToolFrame(c) => {
                crate::scale::common_scale(&c.start.robot, &c.fit.model.robot, &c.fit.free.robot)
            }
        }
    }

    /// The measurements' scale factor identified with `--fit-scale`, if any.
    pub fn measurement_scale(&self) -> Option<&crate::scale::ScaleEvidence> {
        match self {
            Calibration::Points(c) => c.measurement_scale.as_ref(),
            Calibration::ToolFrame(c) => c.measurement_scale.as_ref(),
        }
    }

    fn set_measurement_scale(&mut self, e: crate::scale::ScaleEvidence) {
        let line = format!("measurement scale: {}", e.describe());
        let (notices, scale) = match self {
            Calibration::Points(c) => (&mut c.notices, &mut c.measurement_scale),
            Calibration::ToolFrame(c) => (&mut c.notices, &mut c.measurement_scale),
        };
        notices.push(line);
        *scale = Some(e);
    }

    /// The kind of measurement calibrated from.
    pub fn kind(&self) -> MeasurementKind {
        match self {
            Calibration::Points(_) => MeasurementKind::Points,
            Calibration::ToolFrame(c) => c.kind,
        }
    }

    /// The calibration from points, if it is one.
    pub fn points(&self) -> Option<&PointCalibration> {
        match self {
            Calibration::Points(c) => Some(c),
            Calibration::ToolFrame(_) => None,
        }
    }

    /// The calibration from points, taken out, if it is one.
    pub fn into_points(self) -> Option<PointCalibration> {
        match self {
            Calibration::Points(c) => Some(*c),
            Calibration::ToolFrame(_) => None,
        }
    }

    /// The calibration from 6-DoF or multi-target data, if it is one.
    pub fn tool_frame(&self) -> Option<&ToolFrameCalibration> {
        match self {
            Calibration::Points(_) => None,
            Calibration::ToolFrame(c) => Some(c),
        }
    }

    /// What was asked.
    pub fn request(&self) -> &IdentifyRequest {
        match self {
            Calibration::Points(c) => &c.request,
            Calibration::ToolFrame(c) => &c.request,
        }
    }

    /// The nominal robot file (extended by the request's parameters).
    pub fn nominal(&self) -> &LoadedRobot {
        match self {
            Calibration::Points(c) => &c.nominal,
            Calibration::ToolFrame(c) => &c.nominal,
        }
    }

    /// Where the identification data come from.
    pub fn data_source(&self) -> &str {
        match self {
            Calibration::Points(c) => &c.data_source,
            Calibration::ToolFrame(c) => &c.data_source,
        }
    }

    /// Reader notices (ignored columns), in reading order.
    pub fn notices(&self) -> &[String] {
        match self {
            Calibration::Points(c) => &c.notices,
            Calibration::ToolFrame(c) => &c.notices,
        }
    }

    /// Warnings about the data, to show prominently.
    pub fn warnings(&self) -> &[String] {
        match self {
            Calibration::Points(c) => &c.warnings,
            Calibration::ToolFrame(c) => &c.warnings,
        }
    }

    /// Wall-clock time of the fit alone (ms), summed over the outlier-rejection passes.
    pub fn elapsed_ms(&self) -> f64 {
        match self {
            Calibration::Points(c) => c.elapsed_ms,
            Calibration::ToolFrame(c) => c.elapsed_ms,
        }
    }

    /// The calibrated robot as it is written (`identified.json`).
    pub fn identified_robot(&self) -> Robot {
        match self {
            Calibration::Points(c) => c.identified_robot(),
            Calibration::ToolFrame(c) => c.identified_robot(),
        }
    }

    /// The nominal robot in the data's measurement frame (`registered-nominal.json`, the
    /// targets of compensation).
    pub fn registered_robot(&self) -> Robot {
        match self {
            Calibration::Points(c) => c.registered_robot(),
            Calibration::ToolFrame(c) => c.registered_robot(),
        }
    }
}

impl PointCalibration {
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
