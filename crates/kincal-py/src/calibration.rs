//! `kincal.identify` → `kincal.Calibration` (the point calibration of `kincal identify`), and
//! `kincal.compensate` with it.

use std::path::PathBuf;

use numpy::{IntoPyArray, PyArray1, PyArray2, PyArrayDyn, PyArrayMethods, PyUntypedArrayMethods};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::arrays::{
    ArrayArg, fk_array, joint_rows, joints_arg, matrix_array, memory_set, point_rows,
    residual_array, rows_array, vec_rows_array,
};
use crate::errors::{kincal_error, refuse, save_outputs};
use crate::options::{Shared, identify_request};
use crate::robot::PyRobot;

/// Registers `Calibration`, `identify` and `compensate`.
pub(crate) fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<PyCalibration>()?;
    m.add_function(wrap_pyfunction!(py_identify, m)?)?;
    m.add_function(wrap_pyfunction!(py_compensate, m)?)?;
    m.add_function(wrap_pyfunction!(py_compensate_cartesian, m)?)?;
    Ok(())
}

/// The result of `kincal.identify`: the calibration the CLI's `kincal identify` computes on
/// the same data, with its calibrated robot, residuals, parameter table, covariance and
/// validation; `save(dir)` writes the files of `kincal identify --out`.
#[pyclass(module = "kincal", name = "Calibration", frozen)]
pub(crate) struct PyCalibration {
    cal: calibrate::Calibration,
    /// The calibrated robot as written to (and read back from) `identified.json`.
    identified: calibrate::LoadedRobot,
    /// The nominal robot in the data's frame, as `registered-nominal.json`.
    registered: calibrate::LoadedRobot,
    /// Wall time of the library call `calibrate::calibrate`, ms.
    library_ms: f64,
}

impl PyCalibration {
    /// The calibration from points (`identify` gives points only).
    fn points(&self) -> &calibrate::PointCalibration {
        self.cal
            .points()
            .expect("identify calibrates points: its arrays have no orientations or targets")
    }

    /// The learned residual model, when one was asked for and the gate kept it.
    pub(crate) fn kept_model(&self) -> Option<&calibrate::residual::ResidualModel> {
        self.cal.residual().and_then(|o| o.model.as_ref())
    }
}

#[pymethods]
impl PyCalibration {
    /// The calibrated robot, as `identified.json` holds it (the same numbers as
    /// `kincal.Robot.load("OUT/identified.json")`).
    #[getter]
    fn robot(&self) -> PyRobot {
        PyRobot {
            loaded: self.identified.clone(),
        }
    }

    /// The nominal robot in the data's measurement frame (after registration), as
    /// `registered-nominal.json` holds it: the targets of compensation.
    #[getter]
    fn registered_nominal(&self) -> PyRobot {
        PyRobot {
            loaded: self.registered.clone(),
        }
    }

    /// Points `(n, 3)` (mm, the measurement frame) of the calibrated robot at `q_deg`
    /// (`(n, N)`, or `(N,)` → `(3,)`): `calibration.robot.fk(q_deg)`, plus the learned
    /// residual model's mean when `identify(..., residual_model="gp")` kept one, as `kincal
    /// predict` adds it; `geometry_only=True` leaves the model out.
    #[pyo3(signature = (q_deg, *, geometry_only = false))]
    fn predict<'py>(
        &self,
        py: Python<'py>,
        q_deg: ArrayArg<'py>,
        geometry_only: bool,
    ) -> PyResult<Bound<'py, PyArrayDyn<f64>>> {
        match self.kept_model().filter(|_| !geometry_only) {
            Some(model) => residual_array(py, &self.identified.robot, model, &q_deg, true),
            None => fk_array(py, &self.identified.robot, &q_deg),
        }
    }

    /// The learned residual model's predictive standard deviation `(n, 3)` (mm, per axis;
    /// `(N,)` → `(3,)`) at `q_deg`, as `kincal predict --with-sd` writes it; `None` when the
    /// calibration has no model (not asked for, or declined by the gate).
    fn predict_sd<'py>(
        &self,
        py: Python<'py>,
        q_deg: ArrayArg<'py>,
    ) -> PyResult<Option<Bound<'py, PyArrayDyn<f64>>>> {
        self.kept_model()
            .map(|model| residual_array(py, &self.identified.robot, model, &q_deg, false))
            .transpose()
    }

    /// The residual model's cross-validation and decision (`identify(...,
    /// residual_model="gp")`; `docs/residual-model.md`): `used` (the gate kept the model),
    /// `folds` (per fold: `fold`, `train_poses`, `held_out_poses`, and the geometry's and
    /// the hybrid's held-out `*_mean_mm`, `*_p95_mm`, `*_max_mm`), `mean_gain_mm` and
    /// `p95_gain_mm` (mean over the folds, fold-to-fold scatter), `coverage_1sd`,
    /// `coverage_2sd`; `None` when no model was asked for.
    #[getter]
    fn residual_model<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyDict>>> {
        let Some(outcome) = self.cal.residual() else {
            return Ok(None);
        };
        residual_dict(py, outcome).map(Some)
    }

    /// Residuals `measured − calibrated` `(n, 3)` (mm) on the identification rows (all of
    /// them, outliers included even when rejected; the rows of `identification_rows`).
    #[getter]
    fn residuals_mm<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        let (_, after) = self.points().screened_residuals();
        rows_array(py, &after)
    }

    /// Indices (0-based, into the `q_deg` given to `identify`) of the identification rows,
    /// in order: all rows, or those an `every`/`select` split chose.
    #[getter]
    fn identification_rows<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<i64>> {
        // A row's line is 1-based: the index of the row in the arrays given, plus one.
        let idx: Vec<i64> = self
            .points()
            .screened_rows
            .iter()
            .map(|r| r.line as i64 - 1)
            .collect();
        numpy::ndarray::Array1::from(idx).into_pyarray(py)
    }

    /// Every parameter of the robot (the order of docs/model.md §3) as a list of records
    /// `{"name", "unit", "free", "nominal", "start", "identified", "std_error",
    /// "identifiable"}` in display units: the rows of `parameters.json`
    /// (`pandas.DataFrame(cal.parameters)` makes the table).
    #[getter]
    fn parameters<'py>(&self, py: Python<'py>) -> PyResult<Vec<Bound<'py, PyDict>>> {
        let o = self.points();
        let layout = o.start.layout();
        let (xn, xs) = (o.nominal.robot.params(), o.start.params());
        let cov = o.fit.covariance.as_ref();
        layout
            .params()
            .iter()
            .enumerate()
            .map(|(k, info)| {
                let d = PyDict::new(py);
                d.set_item("name", info.name.as_str())?;
                d.set_item("unit", info.unit.as_str())?;
                d.set_item("free", o.free.contains(&k))?;
                d.set_item("nominal", info.to_display(xn[k]))?;
                d.set_item("start", info.to_display(xs[k]))?;
                d.set_item("identified", info.to_display(o.fit.params[k]))?;
                d.set_item("std_error", cov.and_then(|c| c.std_error(&info.name)))?;
                d.set_item(
                    "identifiable",
                    match cov {
                        Some(c) => c.parameters.contains(&info.name),
                        None => o.analysis.identifiable.iter().any(|n| *n == info.name),
                    },
                )?;
                Ok(d)
            })
            .collect()
    }

    /// Numerical rank of the identification Jacobian at the solution (the identifiable
    /// parameters' count).
    #[getter]
    fn rank(&self) -> usize {
        self.points().analysis.rank
    }

    /// Covariance `(r, r)` of the identifiable free parameters (display units: deg², deg·mm,
    /// mm²), in the order of `covariance_parameters`; `None` without degrees of freedom.
    #[getter]
    fn covariance<'py>(&self, py: Python<'py>) -> Option<Bound<'py, PyArray2<f64>>> {
        self.points()
            .fit
            .covariance
            .as_ref()
            .map(|c| matrix_array(py, c.covariance.shape(), |i, j| c.covariance[(i, j)]))
    }

    /// The names of the rows and columns of `covariance` (empty without one).
    #[getter]
    fn covariance_parameters(&self) -> Vec<String> {
        self.points()
            .fit
            .covariance
            .as_ref()
            .map_or_else(Vec::new, |c| {
                c.parameters.iter().map(|n| n.to_string()).collect()
            })
    }

    /// RMS 3-D point error of the fit on the rows it used, mm.
    #[getter]
    fn rms_mm(&self) -> f64 {
        self.points().fit.rms_mm
    }

    /// σ̂, the fit's residual scale (mm per axis); `None` without degrees of freedom.
    #[getter]
    fn sigma_hat_mm(&self) -> Option<f64> {
        self.points().fit.sigma_hat
    }

    /// Indices (into `identification_rows`) of the rows the robust screen excluded from the
    /// final fit: the gross errors by default, every flagged row with `reject_outliers=True`,
    /// none with `keep_outliers=True`.
    /// The measurements' scale factor `fit_scale=True` identified (the points were divided by
    /// it before identifying), or None (not asked, or not significant).
    #[getter]
    fn measurement_scale(&self) -> Option<f64> {
        self.points().measurement_scale.as_ref().map(|e| e.factor)
    }

    #[getter]
    fn excluded(&self) -> Vec<usize> {
        self.points()
            .robust
            .as_ref()
            .map_or_else(Vec::new, |r| r.excluded.clone())
    }

    /// Indices (into `identification_rows`) of the outliers the screen flagged
    /// (‖residual‖ > k·σ̂₃ of the final fit); those excluded are [`excluded`](Self::excluded).
    #[getter]
    fn outliers(&self) -> Vec<usize> {
        self.points()
            .screen
            .as_ref()
            .map_or_else(Vec::new, |s| s.indices())
    }

    /// Whether the measurement frame was registered onto the robot base first.
    #[getter]
    fn registered(&self) -> bool {
        self.points().registered()
    }

    /// 3-D errors on the validation rows (`validate=` or the rows an `every`/`select` split
    /// held out), mm: `{"n_poses", "before_mean_mm", "before_max_mm", "before_rms_mm",
    /// "before_p95_mm", "after_mean_mm", …}` (before: the nominal after registration;
    /// after: the calibrated robot), the figures `kincal identify` prints; `None` without
    /// validation rows.
    #[getter]
    fn validation<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyDict>>> {
        let Some(v) = &self.points().validation else {
            return Ok(None);
        };
        let d = PyDict::new(py);
        d.set_item("n_poses", v.rows.len())?;
        for (when, s) in [
            ("before", &v.table.before.norm),
            ("after", &v.table.after.norm),
        ] {
            d.set_item(format!("{when}_mean_mm"), s.mean_mm)?;
            d.set_item(format!("{when}_max_mm"), s.max_mm)?;
            d.set_item(format!("{when}_rms_mm"), s.rms_mm)?;
            d.set_item(format!("{when}_p95_mm"), s.p95_mm)?;
        }
        Ok(Some(d))
    }

    /// Wall time (ms) of the library call `calibrate::calibrate` inside `identify`, timed in
    /// Rust: what `identify` costs without the binding (array conversion, the rows' checks,
    /// the result's construction). `docs/python.md` compares the two.
    #[getter]
    fn library_ms(&self) -> f64 {
        self.library_ms
    }

    /// The console summary `kincal identify` prints for this calibration.
    fn summary(&self) -> String {
        report::calibration::summary(&self.cal)
    }

    /// Writes the files of `kincal identify --out` into `directory` as the CLI does (created
    /// if missing; the set replaced as a whole under the directory's lock):
    /// `identified.json`, `registered-nominal.json`, `parameters.json`, `report.md`,
    /// `report.html` and its plots.
    fn save(&self, py: Python<'_>, directory: PathBuf) -> PyResult<()> {
        py.detach(|| save_outputs(&directory, report::calibration::render(&self.cal)))
    }

    fn __repr__(&self) -> String {
        format!(
            "Calibration({:?}, rows={}, free={}, rank={}, rms_mm={:.4})",
            self.points().nominal.robot.name(),
            self.points().used.len(),
            self.points().free.len(),
            self.points().analysis.rank,
            self.points().fit.rms_mm
        )
    }
}

// `residual_folds = 5` in `identify`'s signature below is the library's default (a literal,
// so that Python shows it and the stub can say it).
const _: () = assert!(calibrate::residual::DEFAULT_FOLDS == 5);

/// Identifies the robot's parameters from measured points `(n, 3)` (mm) at joints `(n, N)`
/// (degrees), as `kincal identify` does on a file with the same rows. `joint_units` ("deg",
/// "rad") and `length_units` ("mm", "m", "cm", "in") declare other units. The plausibility checks
/// (radians, metres, a mirrored frame, outliers, far parameters, worse validation) refuse
/// with KincalError; `allow` (a check's name or a list of names) overrides them, as
/// `--allow` does.
#[pyfunction(name = "identify")]
#[pyo3(signature = (
    robot, q_deg, points_mm, *, params = None, validate = None, reject_outliers = false,
    keep_outliers = false, every = None, offset = 0, select = None, criterion = "d", schedule = "levenberg",
    redundant = "hold", registration = "auto", outlier_k = 3.0, worst = 10,
    joint_units = "deg", length_units = "mm", allow = None, prior = "auto",
    fit_scale = false, residual_model = "none", residual_folds = 5
))]
#[allow(clippy::too_many_arguments)]
fn py_identify<'py>(
    py: Python<'py>,
    robot: &PyRobot,
    q_deg: ArrayArg<'py>,
    points_mm: ArrayArg<'py>,
    params: Option<Bound<'py, PyAny>>,
    validate: Option<(ArrayArg<'py>, ArrayArg<'py>)>,
    reject_outliers: bool,
    keep_outliers: bool,
    every: Option<usize>,
    offset: usize,
    select: Option<usize>,
    criterion: &str,
    schedule: &str,
    redundant: &str,
    registration: &str,
    outlier_k: f64,
    worst: usize,
    joint_units: &str,
    length_units: &str,
    allow: Option<Bound<'py, PyAny>>,
    prior: &str,
    fit_scale: bool,
    residual_model: &str,
    residual_folds: usize,
) -> PyResult<PyCalibration> {
    let residual = residual_options(residual_model, residual_folds)?;
    let nominal = robot.loaded.clone();
    let n = nominal.robot.n_joints();
    let q = joint_rows(&q_deg, n, "q_deg")?;
    let p = point_rows(&points_mm, q.len(), "points_mm", "q_deg")?;
    let data = memory_set("identification arrays", n, q, Some(p));
    let validate = validate
        .map(|(vq, vp)| -> PyResult<_> {
            let q = joint_rows(&vq, n, "validate[0] (q_deg)")?;
            let p = point_rows(&vp, q.len(), "validate[1] (points_mm)", "validate[0]")?;
            Ok(memory_set("validation arrays", n, q, Some(p)))
        })
        .transpose()?;
    let request = identify_request(
        &nominal.path,
        &data.source,
        validate.as_ref().map(|v| v.source.as_str()),
        Shared {
            params,
            reject_outliers,
            keep_outliers,
            every,
            offset,
            select,
            criterion,
            schedule,
            redundant,
            registration,
            outlier_k,
            worst,
            joint_units,
            length_units,
            allow,
            prior,
            fit_scale,
        },
    )?;
    calibrate_abandonable(
        py,
        request,
        (nominal, data, validate),
        move |mut cal, library_ms| {
            let err = |e: calibrate::CalibrateError| kincal_error(&e);
            if let Some(options) = &residual {
                cal.fit_residual_model(options).map_err(err)?;
            }
            let written = |r: kinematics::Robot, label: &str| {
                calibrate::LoadedRobot::from_spec(r.to_spec(), label, "robot").map_err(err)
            };
            let identified = written(cal.identified_robot(), "identified.json")?;
            let registered = written(cal.registered_robot(), "registered-nominal.json")?;
            Ok(PyCalibration {
                cal,
                identified,
                registered,
                library_ms,
            })
        },
    )
}

/// Calibrates the in-memory sets of `request` on a detached worker
/// ([`crate::interrupt::run_abandonable`]: Ctrl-C raises at once, the identification
/// finishes in the background, dropped), then `finish` builds the result from the calibration
/// and the library's time (ms): the one place `identify` and `identify_frames` call the
/// library.
pub(crate) fn calibrate_abandonable<T: Send + 'static>(
    py: Python<'_>,
    request: calibrate::IdentifyRequest,
    (nominal, data, validate): (
        calibrate::LoadedRobot,
        measurements::MeasurementSet,
        Option<measurements::MeasurementSet>,
    ),
    finish: impl FnOnce(calibrate::Calibration, f64) -> PyResult<T> + Send + 'static,
) -> PyResult<T> {
    crate::interrupt::run_abandonable(py, move || {
        let err = |e: calibrate::CalibrateError| kincal_error(&e);
        let inputs =
            calibrate::Inputs::from_sets(&request, nominal, data, validate).map_err(err)?;
        let started = std::time::Instant::now();
        let cal = calibrate::calibrate(&request, inputs).map_err(err)?;
        finish(cal, started.elapsed().as_secs_f64() * 1e3)
    })
}

/// The cross-validation options of `identify`'s and `identify_frames`' `residual_model`
/// and `residual_folds` (`None` for `"none"`), as `--residual-model` takes them.
pub(crate) fn residual_options(
    residual_model: &str,
    residual_folds: usize,
) -> PyResult<Option<calibrate::residual::CvOptions>> {
    match residual_model {
        "none" => Ok(None),
        "gp" => Ok(Some(calibrate::residual::CvOptions {
            folds: residual_folds,
            ..Default::default()
        })),
        other => Err(pyo3::exceptions::PyValueError::new_err(format!(
            "residual_model: {other:?} is not a residual model (\"none\" or \"gp\", as \
             --residual-model takes)"
        ))),
    }
}

/// The residual model's cross-validation and decision as a dict (`Calibration` and
/// `FrameCalibration`'s `residual_model`): `used`, `folds`, the gains `(mean, scatter)`, the
/// coverage, and for 6-DoF data `orientation` — the same in degrees for the orientation
/// part, with `used` (applied).
pub(crate) fn residual_dict<'py>(
    py: Python<'py>,
    outcome: &calibrate::residual::ResidualOutcome,
) -> PyResult<Bound<'py, PyDict>> {
    let d = cv_dict(py, &outcome.cv, "mm")?;
    d.set_item("used", outcome.model.is_some())?;
    if let Some(o) = &outcome.orientation {
        let od = cv_dict(py, &o.cv_deg, "deg")?;
        od.set_item("used", o.applied)?;
        d.set_item("orientation", od)?;
    }
    Ok(d)
}

/// A cross-validation's folds, gains and coverage, its values in `unit` (`mm`, or `deg`
/// for the orientation part, whose `_mm`-named fields hold degrees).
fn cv_dict<'py>(
    py: Python<'py>,
    cv: &calibrate::residual::CrossValidation,
    unit: &str,
) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    let mut folds = Vec::with_capacity(cv.folds.len());
    for f in &cv.folds {
        let row = PyDict::new(py);
        row.set_item("fold", f.fold)?;
        row.set_item("train_poses", f.train_poses)?;
        row.set_item("held_out_poses", f.held_out_poses)?;
        for (name, stats) in [("geometry", &f.geometry), ("hybrid", &f.hybrid)] {
            row.set_item(format!("{name}_mean_{unit}"), stats.mean_mm)?;
            row.set_item(format!("{name}_p95_{unit}"), stats.p95_mm)?;
            row.set_item(format!("{name}_max_{unit}"), stats.max_mm)?;
        }
        folds.push(row);
    }
    d.set_item("folds", folds)?;
    d.set_item(
        format!("mean_gain_{unit}"),
        (cv.mean_gain.mean_mm, cv.mean_gain.scatter_mm),
    )?;
    d.set_item(
        format!("p95_gain_{unit}"),
        (cv.p95_gain.mean_mm, cv.p95_gain.scatter_mm),
    )?;
    d.set_item("coverage_1sd", cv.coverage.within_1sd)?;
    d.set_item("coverage_2sd", cv.coverage.within_2sd)?;
    Ok(d)
}

/// The calibrated robot, the registered nominal one and, unless `geometry_only`, the kept
/// residual model of a `Calibration` or a `FrameCalibration`.
type Pair = (
    calibrate::LoadedRobot,
    calibrate::LoadedRobot,
    Option<calibrate::residual::ResidualModel>,
);

/// The calibrated robot, the registered nominal one and the residual model to apply (the
/// kept one of a `Calibration`, none with `geometry_only`, as `kincal compensate
/// --geometry-only`) of a `Calibration` or a `FrameCalibration`.
fn pair(calibration: &Bound<'_, PyAny>, geometry_only: bool) -> PyResult<Pair> {
    if let Ok(c) = calibration.cast::<PyCalibration>() {
        let c = c.get();
        let model = c.kept_model().filter(|_| !geometry_only).cloned();
        return Ok((c.identified.clone(), c.registered.clone(), model));
    }
    if let Ok(c) = calibration.cast::<crate::frame_calibration::PyFrameCalibration>() {
        let c = c.get();
        let (identified, registered) = c.pair();
        let model = c.kept_model().filter(|_| !geometry_only).cloned();
        return Ok((identified.clone(), registered.clone(), model));
    }
    Err(pyo3::exceptions::PyTypeError::new_err(
        "calibration: expected a Calibration (kincal.identify) or a FrameCalibration \
         (kincal.identify_frames)",
    ))
}

/// The joints `(n, N)` (degrees) to command so that the calibrated robot reaches the points
/// the nominal robot (in the data's frame) reaches at `q_deg`, as `kincal compensate` with
/// the calibration's `identified.json` and `registered-nominal.json`. With a residual model
/// that `identify(..., residual_model="gp")` kept, the joints bring the geometry plus the
/// model's mean onto each target (`predict(q)` reaches it; docs/residual-model.md);
/// `geometry_only=True` leaves the model out, as `--geometry-only`.
#[pyfunction(name = "compensate")]
#[pyo3(signature = (calibration, q_deg, *, geometry_only = false))]
fn py_compensate<'py>(
    py: Python<'py>,
    calibration: &Bound<'py, PyAny>,
    q_deg: ArrayArg<'py>,
    geometry_only: bool,
) -> PyResult<Bound<'py, PyArrayDyn<f64>>> {
    let (identified, nominal, model) = pair(calibration, geometry_only)?;
    let n = nominal.robot.n_joints();
    let (_, single) = joints_arg(&q_deg, n, "q_deg")?;
    let set = memory_set("q_deg", n, joint_rows(&q_deg, n, "q_deg")?, None);
    let rows = py.detach(|| {
        let set = nominal
            .check_set(set, false, "target joints")
            .map_err(|e| kincal_error(&e))?;
        calibrate::compensate_set_with((&identified, model.as_ref()), &nominal, &set)
            .map_err(|e| kincal_error(&e))
    })?;
    let out = vec_rows_array(py, &rows, n);
    Ok(if single {
        out.reshape(vec![n])?
            .into_any()
            .cast_into::<PyArrayDyn<f64>>()?
    } else {
        out.into_any().cast_into::<PyArrayDyn<f64>>()?
    })
}

/// Cartesian targets: the joints `(n, N)` (degrees) to command, and the corrected targets
/// (positions `(n, 3)` mm and orientations `(n, 4)` wxyz, in the robot's base frame) for a
/// controller running the nominal model, as `kincal compensate` with a targets file without
/// joint columns. With a residual model that `identify(..., residual_model="gp")` kept, the
/// joints bring the geometry plus the model's mean onto each target position (and, with the
/// orientation part of a 6-DoF calibration's model, its orientation onto the target's);
/// `geometry_only=True` leaves it out, as `--geometry-only`.
#[pyfunction(name = "compensate_cartesian")]
#[pyo3(signature = (calibration, positions_mm, orientations_wxyz=None, *, frame="base", start_q_deg=None, geometry_only=false))]
#[allow(clippy::type_complexity)]
fn py_compensate_cartesian<'py>(
    py: Python<'py>,
    calibration: &Bound<'py, PyAny>,
    positions_mm: ArrayArg<'py>,
    orientations_wxyz: Option<ArrayArg<'py>>,
    frame: &str,
    start_q_deg: Option<Vec<f64>>,
    geometry_only: bool,
) -> PyResult<(
    Bound<'py, PyArrayDyn<f64>>,
    Bound<'py, PyArrayDyn<f64>>,
    Bound<'py, PyArrayDyn<f64>>,
)> {
    let (identified, nominal, model) = pair(calibration, geometry_only)?;
    let n = nominal.robot.n_joints();
    let frame: calibrate::TargetFrame = frame
        .parse()
        .map_err(|e: String| refuse(format!("frame: {e}")))?;
    let rows = positions_mm.shape().first().copied().unwrap_or(0);
    let points = crate::arrays::point_rows(&positions_mm, rows, "positions_mm", "the targets")?;
    let orientations = orientations_wxyz
        .as_ref()
        .map(|o| {
            crate::arrays::fixed_rows::<4>(
                o,
                rows,
                "orientations_wxyz",
                "quaternion",
                "positions_mm",
            )
        })
        .transpose()?;
    let targets = points
        .iter()
        .enumerate()
        .map(|(k, p)| {
            if let Some(v) = p.iter().find(|v| !v.is_finite()) {
                return Err(refuse(format!(
                    "positions_mm: row {k}: {v} is not a finite number"
                )));
            }
            Ok(measurements::Measurement {
                line: k + 1,
                id: Some(format!("{k}")),
                point_mm: Some(*p),
                orientation: orientations.as_ref().map(|o| o[k]),
                ..Default::default()
            })
        })
        .collect::<PyResult<Vec<_>>>()?;
    let set = measurements::MeasurementSet::new("target arrays", 0, targets);
    set.check_rows().map_err(|e| refuse(e.to_string()))?;
    let cartesian = calibrate::CartesianOptions {
        frame,
        start_deg: start_q_deg,
        ..Default::default()
    };
    let c = py.detach(|| {
        calibrate::compensate_poses_with(
            (&identified, model.as_ref()),
            &nominal,
            set,
            false,
            (&identify::CompensationOptions::default(), &cartesian),
            "compensate_cartesian",
        )
        .map_err(|e| kincal_error(&e))
    })?;
    let q: Vec<Vec<f64>> = c.corrected.iter().map(|t| t.joints_deg.clone()).collect();
    let p: Vec<Vec<f64>> = c.corrected.iter().map(|t| t.position_mm.to_vec()).collect();
    let o: Vec<Vec<f64>> = c
        .corrected
        .iter()
        .map(|t| t.orientation_wxyz.to_vec())
        .collect();
    let arr = |rows: &[Vec<f64>], k: usize| -> PyResult<Bound<'py, PyArrayDyn<f64>>> {
        Ok(vec_rows_array(py, rows, k)
            .into_any()
            .cast_into::<PyArrayDyn<f64>>()?)
    };
    Ok((arr(&q, n)?, arr(&p, 3)?, arr(&o, 4)?))
}
