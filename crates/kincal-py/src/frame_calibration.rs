//! `kincal.identify_frames` → `kincal.FrameCalibration` (the 6-DoF / multi-target
//! calibration of `kincal identify`).

use std::path::PathBuf;

use numpy::PyArrayDyn;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyTuple};

use crate::arrays::{
    ArrayArg, fixed_rows, fk_array, joint_rows, memory_set, orientation_array, point_rows,
    residual_array, residual_orientation_array, string_rows,
};
use crate::errors::{kincal_error, refuse, save_outputs};
use crate::options::{Shared, identify_request};
use crate::robot::PyRobot;

/// Registers `FrameCalibration` and `identify_frames`.
pub(crate) fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<PyFrameCalibration>()?;
    m.add_function(wrap_pyfunction!(py_identify_frames, m)?)?;
    Ok(())
}

/// A measurement set of 6-DoF / multi-target rows built in memory: the rows of a file with
/// `qw,qx,qy,qz` (orientations), `target` and `id` (pose ids) columns. `names` name the five
/// arguments in errors.
#[allow(clippy::too_many_arguments)]
fn frame_set(
    source: &str,
    n: usize,
    q: &ArrayArg<'_>,
    points: &ArrayArg<'_>,
    orientations: Option<&ArrayArg<'_>>,
    targets: Option<&Bound<'_, PyAny>>,
    ids: Option<&Bound<'_, PyAny>>,
    names: [&str; 5],
) -> PyResult<measurements::MeasurementSet> {
    let q = joint_rows(q, n, names[0])?;
    let rows = q.len();
    let p = point_rows(points, rows, names[1], names[0])?;
    let o = orientations
        .map(|o| fixed_rows(o, rows, names[2], "unit quaternion w, x, y, z", names[0]))
        .transpose()?;
    let t = targets
        .map(|t| string_rows(t, rows, names[3]))
        .transpose()?;
    let ids = ids.map(|i| string_rows(i, rows, names[4])).transpose()?;
    if t.is_some() && ids.is_none() {
        return Err(refuse(format!(
            "{}: with targets every row needs a pose id (the rows with the same id are one pose)",
            names[4]
        )));
    }
    let mut set = memory_set(source, n, q, Some(p));
    for (k, r) in set.rows.iter_mut().enumerate() {
        r.orientation = o.as_ref().map(|o| o[k]);
        r.target = t.as_ref().map(|t| t[k].clone());
        r.id = ids.as_ref().map(|i| i[k].clone());
    }
    Ok(set)
}

/// Identifies the robot and its tool frame from 6-DoF measurements (points and unit
/// quaternions `w, x, y, z` of the probe) and/or several named targets per pose, as
/// `kincal identify` does on a file with `qw,qx,qy,qz` or `target` columns (`docs/model.md`
/// §5, §6.4). The options are `identify`'s; `orientation_weight` is `--orientation-weight`
/// (mm per degree, default 5). `residual_model="gp"` cross-validates the learned residual
/// model on 6-DoF data as `--residual-model gp` does (position and orientation parts;
/// docs/residual-model.md), `residual_folds` its folds.
#[pyfunction(name = "identify_frames")]
#[pyo3(signature = (
    robot, q_deg, points_mm, *, orientations_wxyz = None, targets = None, pose_ids = None,
    orientation_weight = None, params = None, validate = None, reject_outliers = false,
    keep_outliers = false, every = None, offset = 0, select = None, criterion = "d", schedule = "levenberg",
    redundant = "hold", registration = "auto", outlier_k = 3.0, worst = 10,
    joint_units = "deg", length_units = "mm", allow = None, prior = "auto",
    fit_scale = false, residual_model = "none", residual_folds = 5
))]
#[allow(clippy::too_many_arguments)]
fn py_identify_frames<'py>(
    py: Python<'py>,
    robot: &PyRobot,
    q_deg: ArrayArg<'py>,
    points_mm: ArrayArg<'py>,
    orientations_wxyz: Option<ArrayArg<'py>>,
    targets: Option<Bound<'py, PyAny>>,
    pose_ids: Option<Bound<'py, PyAny>>,
    orientation_weight: Option<f64>,
    params: Option<Bound<'py, PyAny>>,
    validate: Option<Bound<'py, PyTuple>>,
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
) -> PyResult<PyFrameCalibration> {
    let residual = crate::calibration::residual_options(residual_model, residual_folds)?;
    if orientations_wxyz.is_none() && targets.is_none() {
        return Err(refuse(
            "identify_frames: give orientations_wxyz or targets (points alone: kincal.identify)",
        ));
    }
    if let Some(w) = orientation_weight
        && !(w.is_finite() && w > 0.0)
    {
        return Err(refuse(format!(
            "orientation_weight: {w} mm per degree (a positive number)"
        )));
    }
    let nominal = robot.loaded.clone();
    let n = nominal.robot.n_joints();
    let data = frame_set(
        "identification arrays",
        n,
        &q_deg,
        &points_mm,
        orientations_wxyz.as_ref(),
        targets.as_ref(),
        pose_ids.as_ref(),
        [
            "q_deg",
            "points_mm",
            "orientations_wxyz",
            "targets",
            "pose_ids",
        ],
    )?;
    let validate = match validate {
        None => None,
        Some(v) => {
            if !(2..=5).contains(&v.len()) {
                return Err(refuse(format!(
                    "validate: expected (q_deg, points_mm[, orientations_wxyz[, targets[, \
                     pose_ids]]]), got a tuple of {}",
                    v.len()
                )));
            }
            // Item k, `None` where absent or given as None.
            let item = |k: usize| v.get_item(k).ok().filter(|x| !x.is_none());
            let array = |x: Bound<'py, PyAny>| -> PyResult<ArrayArg<'py>> { x.extract() };
            let (vq, vp) = match (item(0), item(1)) {
                (Some(q), Some(p)) => (array(q)?, array(p)?),
                _ => {
                    return Err(refuse("validate: q_deg and points_mm are required"));
                }
            };
            let vo = item(2).map(array).transpose()?;
            Some(frame_set(
                "validation arrays",
                n,
                &vq,
                &vp,
                vo.as_ref(),
                item(3).as_ref(),
                item(4).as_ref(),
                [
                    "validate[0] (q_deg)",
                    "validate[1] (points_mm)",
                    "validate[2] (orientations_wxyz)",
                    "validate[3] (targets)",
                    "validate[4] (pose_ids)",
                ],
            )?)
        }
    };
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
    let request = calibrate::IdentifyRequest {
        weighting: calibrate::Weighting {
            mm_per_deg: orientation_weight,
            sigma: false,
        },
        ..request
    };
    crate::calibration::calibrate_abandonable(
        py,
        request,
        (nominal, data, validate),
        move |mut cal, library_ms| {
            if cal.tool_frame().is_none() {
                return Err(refuse(
                    "identify_frames: the arrays give neither orientations nor targets (use identify)",
                ));
            }
            if let Some(options) = &residual {
                cal.fit_residual_model(options)
                    .map_err(|e| kincal_error(&e))?;
            }
            let identified = calibrate::LoadedRobot::from_spec(
                cal.identified_robot().to_spec(),
                "identified.json",
                "robot",
            )
            .map_err(|e| kincal_error(&e))?;
            let registered = calibrate::LoadedRobot::from_spec(
                cal.registered_robot().to_spec(),
                "registered-nominal.json",
                "robot",
            )
            .map_err(|e| kincal_error(&e))?;
            Ok(PyFrameCalibration {
                cal,
                identified,
                registered,
                library_ms,
            })
        },
    )
}

/// The errors of a model on a set of poses, as a dict.
fn frame_errors<'py>(
    py: Python<'py>,
    e: &calibrate::tool_frame::PoseErrors,
) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("n_poses", e.poses)?;
    d.set_item("position_mean_mm", e.position_mm.0)?;
    d.set_item("position_max_mm", e.position_mm.1)?;
    d.set_item("orientation_mean_deg", e.orientation_deg.0)?;
    d.set_item("orientation_max_deg", e.orientation_deg.1)?;
    Ok(d)
}

/// The result of `kincal.identify_frames`: the 6-DoF / multi-target calibration the CLI's
/// `kincal identify` computes on the same data, with its calibrated robot (tool frame and
/// targets included), unknowns, position and orientation errors; `save(dir)` writes the
/// files of `kincal identify --out`.
#[pyclass(module = "kincal", name = "FrameCalibration", frozen)]
pub(crate) struct PyFrameCalibration {
    cal: calibrate::Calibration,
    /// The calibrated robot as written to `identified.json`.
    identified: calibrate::LoadedRobot,
    /// The nominal robot in the data's frame, as `registered-nominal.json`.
    registered: calibrate::LoadedRobot,
    /// Wall time of the library call `calibrate::calibrate`, ms.
    library_ms: f64,
}

impl PyFrameCalibration {
    /// The calibrated robot and the registered nominal one: the pair `compensate` takes.
    pub(crate) fn pair(&self) -> (&calibrate::LoadedRobot, &calibrate::LoadedRobot) {
        (&self.identified, &self.registered)
    }

    /// The learned residual model, when one was asked for and the gate kept it.
    pub(crate) fn kept_model(&self) -> Option<&calibrate::residual::ResidualModel> {
        self.cal.residual().and_then(|o| o.model.as_ref())
    }

    /// The calibration from 6-DoF or multi-target data (checked by `identify_frames`).
    fn tool(&self) -> &calibrate::ToolFrameCalibration {
        self.cal.tool_frame().expect("checked by identify_frames")
    }
}

#[pymethods]
impl PyFrameCalibration {
    /// The calibrated robot with its tool frame (`tool_mm`, `tool_rotation_deg` where
    /// orientation was measured, `targets` where named), as `identified.json` holds it.
    #[getter]
    fn robot(&self) -> PyRobot {
        PyRobot {
            loaded: self.identified.clone(),
        }
    }

    /// The calibrated robot's prediction at `q_deg` (degrees, `(n, N)`, or `(N,)`): a tuple
    /// `(points_mm, orientations_wxyz)`, the points `(n, 3)` (mm, the measurement frame) and
    /// the measured frame's orientation `(n, 4)` (unit quaternions, scalar first, `w ≥ 0`;
    /// `None` when no orientation was measured): `kincal predict`'s `x, y, z` and
    /// `qw, qx, qy, qz`, `(robot.fk(q_deg), robot.fk_orientation(q_deg))`. With a residual
    /// model that `identify_frames(..., residual_model="gp")` kept, the points add its mean
    /// and the orientations turn by its orientation part's mean where that part was applied,
    /// as `kincal predict` with the calibration's files; `geometry_only=True` leaves the
    /// model out.
    #[pyo3(signature = (q_deg, *, geometry_only = false))]
    #[allow(clippy::type_complexity)]
    fn predict<'py>(
        &self,
        py: Python<'py>,
        q_deg: ArrayArg<'py>,
        geometry_only: bool,
    ) -> PyResult<(
        Bound<'py, PyArrayDyn<f64>>,
        Option<Bound<'py, PyArrayDyn<f64>>>,
    )> {
        let robot = &self.identified.robot;
        match self.kept_model().filter(|_| !geometry_only) {
            Some(model) => Ok((
                residual_array(py, robot, model, &q_deg, true)?,
                residual_orientation_array(py, robot, model, &q_deg)?,
            )),
            None => Ok((
                fk_array(py, robot, &q_deg)?,
                orientation_array(py, robot, &q_deg)?,
            )),
        }
    }

    /// The learned residual model's predictive standard deviation of the points `(n, 3)`
    /// (mm, per axis; `(3,)` for one pose) at `q_deg`, as `kincal predict --with-sd` writes
    /// `sx, sy, sz`; `None` without a kept model.
    fn predict_sd<'py>(
        &self,
        py: Python<'py>,
        q_deg: ArrayArg<'py>,
    ) -> PyResult<Option<Bound<'py, PyArrayDyn<f64>>>> {
        self.kept_model()
            .map(|model| residual_array(py, &self.identified.robot, model, &q_deg, false))
            .transpose()
    }

    /// The residual model's cross-validation and decision (`identify_frames(...,
    /// residual_model="gp")`; docs/residual-model.md), as `Calibration.residual_model`, with
    /// `orientation`: the orientation part's folds, gains and coverage in degrees and
    /// whether it is applied (`used`); `None` when no model was asked for.
    #[getter]
    fn residual_model<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyDict>>> {
        self.cal
            .residual()
            .map(|o| crate::calibration::residual_dict(py, o))
            .transpose()
    }

    /// The nominal robot in the data's measurement frame, as `registered-nominal.json`
    /// holds it: the nominal controller's model of compensation.
    #[getter]
    fn registered_nominal(&self) -> PyRobot {
        PyRobot {
            loaded: self.registered.clone(),
        }
    }

    /// The unknowns of the fit as records `{"name", "unit", "start", "identified",
    /// "std_error"}` (display units; `tool_rx, tool_ry, tool_rz` are the rotation vector from
    /// the start orientation): the table of `report.md`.
    #[getter]
    fn parameters<'py>(&self, py: Python<'py>) -> PyResult<Vec<Bound<'py, PyDict>>> {
        self.tool()
            .fit
            .estimates
            .iter()
            .map(|e| {
                let d = PyDict::new(py);
                d.set_item("name", &e.name)?;
                d.set_item("unit", e.unit.as_str())?;
                d.set_item("start", e.start)?;
                d.set_item("identified", e.value)?;
                d.set_item("std_error", e.std_error)?;
                Ok(d)
            })
            .collect()
    }

    /// Candidates held at their start values as confounded with the tool frame or with kept
    /// parameters (names).
    /// The measurements' scale factor `fit_scale=True` identified, or None.
    #[getter]
    fn measurement_scale(&self) -> Option<f64> {
        self.tool().measurement_scale.as_ref().map(|e| e.factor)
    }

    #[getter]
    fn held(&self) -> Vec<String> {
        self.tool().held.clone()
    }

    /// Errors on the identification poses: `{"start": {...}, "identified": {...}}`, each
    /// `{"n_poses", "position_mean_mm", "position_max_mm", "orientation_mean_deg",
    /// "orientation_max_deg"}`.
    #[getter]
    fn fit_errors<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let d = PyDict::new(py);
        d.set_item("start", frame_errors(py, &self.tool().fit_errors.0)?)?;
        d.set_item("identified", frame_errors(py, &self.tool().fit_errors.1)?)?;
        Ok(d)
    }

    /// Errors on the validation poses (`validate=` or the poses an `every`/`select` split
    /// held out), as `fit_errors` (start: the registered nominal with the closed-form tool
    /// frame); `None` without validation poses.
    #[getter]
    fn validation<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyDict>>> {
        let Some((_, start, identified)) = &self.tool().validation else {
            return Ok(None);
        };
        let d = PyDict::new(py);
        d.set_item("start", frame_errors(py, start)?)?;
        d.set_item("identified", frame_errors(py, identified)?)?;
        Ok(Some(d))
    }

    /// The poses the outlier screen flagged (largest ratio first), as records `{"row",
    /// "ratio", "position_mm", "orientation_deg", "excluded"}`: `row` the 0-based index of
    /// the pose's first row in the arrays given; `excluded` whether it was dropped from the
    /// final fit (the gross ones by default, all with `reject_outliers=True`, none with
    /// `keep_outliers=True`).
    #[getter]
    fn outliers<'py>(&self, py: Python<'py>) -> PyResult<Vec<Bound<'py, PyDict>>> {
        let cal = self.tool();
        let excluded = cal
            .robust
            .as_ref()
            .map_or(&[][..], |r| r.excluded.as_slice());
        cal.outlier_poses()
            .iter()
            .map(|o| {
                let d = PyDict::new(py);
                d.set_item("row", o.line - 1)?;
                d.set_item("ratio", o.ratio)?;
                d.set_item("position_mm", o.position_mm)?;
                d.set_item("orientation_deg", o.orientation_deg)?;
                d.set_item("excluded", excluded.binary_search(&o.pose).is_ok())?;
                Ok(d)
            })
            .collect()
    }

    /// σ̂ of the weighted fit.
    #[getter]
    fn sigma_hat(&self) -> f64 {
        self.tool().fit.sigma_hat
    }

    /// Wall time (ms) of the library call `calibrate::calibrate` inside
    /// `identify_frames`, timed in Rust.
    #[getter]
    fn library_ms(&self) -> f64 {
        self.library_ms
    }

    /// The console summary `kincal identify` prints for this calibration.
    fn summary(&self) -> String {
        report::calibration::summary(&self.cal)
    }

    /// Writes the files of `kincal identify --out` on the same data into `directory` as the
    /// CLI does (created if missing; the set replaced as a whole under the directory's
    /// lock): `identified.json`, `registered-nominal.json`, `parameters.json`, `report.md`,
    /// `report.html` and its plots.
    fn save(&self, py: Python<'_>, directory: PathBuf) -> PyResult<()> {
        py.detach(|| save_outputs(&directory, report::calibration::render(&self.cal)))
    }

    fn __repr__(&self) -> String {
        format!(
            "FrameCalibration({:?}, poses={}, unknowns={}, sigma_hat={:.4})",
            self.tool().nominal.robot.name(),
            self.tool().data.n_poses(),
            self.tool().fit.estimates.len(),
            self.tool().fit.sigma_hat
        )
    }
}
