//! The Python package `kincal` (`docs/python.md`): a thin binding of the library crates.
//!
//! This module converts types (paths, numpy arrays, parameter records), releases the GIL
//! around the library calls, and maps library errors to `kincal.KincalError`. It computes
//! nothing itself: forward kinematics is `kinematics::Robot::point`, parameter values are
//! converted by `ParamInfo::to_display`, URDF goes through the `urdf` crate and every file is
//! written by `measurements::write_atomically`, so Python and the CLI give the same numbers.

use std::path::PathBuf;

use numpy::ndarray::{Array1, Array2};
use numpy::{
    AllowTypeChange, IntoPyArray, PyArray1, PyArray2, PyArrayDyn, PyArrayLikeDyn, PyArrayMethods,
    PyUntypedArrayMethods,
};
use pyo3::create_exception;
use pyo3::prelude::*;
use pyo3::types::PyDict;

create_exception!(
    kincal,
    KincalError,
    pyo3::exceptions::PyValueError,
    "An error of kincal: a malformed or unreadable file, an invalid value or an array of the \
     wrong shape. A subclass of ValueError; its message is the library's (file, line, field)."
);

/// A library error as a `KincalError` whose message is the error's own text followed by the
/// causes that the text does not already include.
fn kincal_error(e: &(dyn std::error::Error + 'static)) -> PyErr {
    let mut msg = e.to_string();
    let mut source = e.source();
    while let Some(s) = source {
        let text = s.to_string();
        if !msg.contains(&text) {
            msg.push_str(": ");
            msg.push_str(&text);
        }
        source = s.source();
    }
    KincalError::new_err(msg)
}

/// Writes a calibration's rendered files into `directory` as `kincal identify --out` does
/// (`measurements::OutputDir`): under the directory's advisory lock (another run writing
/// there is refused, named), the set replacing the previous one as a whole, the user's own
/// files kept; a path that is not a directory is refused.
fn save_outputs(
    directory: &std::path::Path,
    files: Result<Vec<(String, String)>, report::PlotError>,
) -> PyResult<()> {
    let files = files.map_err(|e| kincal_error(&e))?;
    let context = |e: measurements::OutputError| {
        let msg = e.to_string();
        let dir = directory.display().to_string();
        KincalError::new_err(if msg.contains(&dir) {
            msg
        } else {
            format!("writing the outputs into {dir}: {msg}")
        })
    };
    measurements::OutputDir::lock(directory)
        .map_err(context)?
        .write_set(&files)
        .map_err(context)
}

/// Writes a file the way every kincal front end does (atomically: temporary file, rename).
fn write_file(path: &std::path::Path, text: &str) -> PyResult<()> {
    measurements::write_atomically(path, text.as_bytes()).map_err(|e| {
        let (msg, file) = (e.to_string(), path.display().to_string());
        KincalError::new_err(if msg.contains(&file) {
            msg
        } else {
            format!("writing {file}: {msg}")
        })
    })
}

/// A robot model: the nominal or calibrated kinematics of a serial robot (a kincal robot file,
/// `docs/model.md` §4). Angles in degrees, lengths in millimetres.
///
/// It holds the robot file's values exactly (`spec`, whose degree limits check joint data as
/// the CLI's readers do) and where it came from (`path`, a file or a label).
#[pyclass(module = "kincal", name = "Robot", frozen)]
struct PyRobot {
    loaded: calibrate::LoadedRobot,
}

impl PyRobot {
    fn new(spec: kinematics::RobotSpec, path: PathBuf) -> PyResult<Self> {
        let loaded =
            calibrate::LoadedRobot::from_spec(spec, path, "robot").map_err(|e| kincal_error(&e))?;
        Ok(PyRobot { loaded })
    }

    fn robot(&self) -> &kinematics::Robot {
        &self.loaded.robot
    }
}

#[pymethods]
impl PyRobot {
    /// Reads a robot file (JSON, `docs/model.md` §4).
    ///
    /// Raises KincalError naming the file and the field when it cannot be read or is invalid.
    #[staticmethod]
    fn load(py: Python<'_>, path: PathBuf) -> PyResult<Self> {
        let spec = py
            .detach(|| kinematics::RobotSpec::from_file(&path))
            .map_err(|e| kincal_error(&e))?;
        PyRobot::new(spec, path)
    }

    /// Converts the serial chain from link `base` to link `tip` of a plain URDF (xacro
    /// expanded first) into a robot, exactly (`docs/urdf.md`); `base`'s frame becomes the
    /// measurement frame and the measured point is `tool_mm` in `tip`'s frame. A robot whose
    /// reach is not a robot arm's (a URDF in millimetres) is refused unless `allow` names
    /// `"length-units"`, as `kincal urdf import --allow length-units`.
    #[staticmethod]
    #[pyo3(
        signature = (path, base, tip, *, tool_mm = (0.0, 0.0, 0.0), name = None, allow = None),
        text_signature = "(path, base, tip, *, tool_mm=(0.0, 0.0, 0.0), name=None, allow=None)"
    )]
    fn from_urdf(
        py: Python<'_>,
        path: PathBuf,
        base: &str,
        tip: &str,
        tool_mm: (f64, f64, f64),
        name: Option<String>,
        allow: Option<Bound<'_, PyAny>>,
    ) -> PyResult<Self> {
        let allow = allow_arg(allow.as_ref())?;
        if let Some(other) = allow.iter().find(|c| **c != calibrate::Check::LengthUnits) {
            return Err(KincalError::new_err(format!(
                "allow: `{}` is not a check of a URDF import (only length-units)",
                other.name()
            )));
        }
        let opts = urdf::ImportOptions {
            tool_in_tip_mm: [tool_mm.0, tool_mm.1, tool_mm.2],
            name,
            allow_implausible_size: !allow.is_empty(),
        };
        let spec = py
            .detach(|| urdf::import_file(&path, base, tip, &opts))
            .map_err(|e| kincal_error(&e))?
            .spec;
        PyRobot::new(spec, path)
    }

    /// Writes the robot file (JSON), as `kincal urdf import` and `identify` write theirs.
    fn save(&self, py: Python<'_>, path: PathBuf) -> PyResult<()> {
        py.detach(|| write_file(&path, &self.robot().to_spec().to_json_string()))
    }

    /// Writes the robot as a URDF rooted at the measurement frame, with a fixed link `tool` at
    /// the measured point, as `kincal urdf export` does (`docs/urdf.md`).
    #[pyo3(signature = (path, *, joint_names = None))]
    fn to_urdf(
        &self,
        py: Python<'_>,
        path: PathBuf,
        joint_names: Option<Vec<String>>,
    ) -> PyResult<()> {
        let opts = urdf::ExportOptions {
            joint_names,
            robot_name: None,
        };
        py.detach(|| {
            let text =
                urdf::export(&self.robot().to_spec(), &opts).map_err(|e| kincal_error(&e))?;
            write_file(&path, &text)
        })
    }

    /// The robot's name (from the robot file).
    #[getter]
    fn name(&self) -> &str {
        self.robot().name()
    }

    /// Number of joints N.
    #[getter]
    fn n_joints(&self) -> usize {
        self.robot().n_joints()
    }

    /// The type of each joint, base to flange: `"revolute"` or `"prismatic"` (a prismatic
    /// joint's values and limits are millimetres where a revolute joint's are degrees).
    #[getter]
    fn joint_types(&self) -> Vec<&'static str> {
        let r = self.robot();
        (0..r.n_joints()).map(|i| r.joint_type(i).as_str()).collect()
    }

    /// Number of entries in the parameter vector.
    #[getter]
    fn n_params(&self) -> usize {
        self.robot().n_params()
    }

    /// The parameter vector in the order of `docs/model.md` §3, as a list of records
    /// `{"name": str, "value": float, "unit": "deg" | "mm" | …}` with values in display units
    /// (`pandas.DataFrame(robot.parameters)` makes a table).
    #[getter]
    fn parameters<'py>(&self, py: Python<'py>) -> PyResult<Vec<Bound<'py, PyDict>>> {
        let values = self.robot().params();
        self.robot()
            .layout()
            .params()
            .iter()
            .zip(values)
            .map(|(info, v)| {
                let d = PyDict::new(py);
                d.set_item("name", &info.name)?;
                d.set_item("value", info.to_display(v))?;
                d.set_item("unit", info.unit.as_str())?;
                Ok(d)
            })
            .collect()
    }

    /// Forward kinematics: the measured point (mm, in the measurement frame) for joint angles
    /// in degrees, shape `(n, N)` → `(n, 3)` or `(N,)` → `(3,)`.
    fn fk<'py>(
        &self,
        py: Python<'py>,
        q_deg: PyArrayLikeDyn<'py, f64, AllowTypeChange>,
    ) -> PyResult<Bound<'py, PyArrayDyn<f64>>> {
        fk_array(py, self.robot(), q_deg)
    }

    fn __repr__(&self) -> String {
        format!(
            "Robot({:?}, n_joints={}, n_params={})",
            self.robot().name(),
            self.robot().n_joints(),
            self.robot().n_params()
        )
    }
}

fn shape_text(shape: &[usize]) -> String {
    match shape {
        [k] => format!("({k},)"),
        _ => format!(
            "({})",
            shape
                .iter()
                .map(|k| k.to_string())
                .collect::<Vec<_>>()
                .join(", ")
        ),
    }
}

/// The joint angles of `q_deg` (degrees), checked to be `(n, N)` or `(N,)` for an N-joint
/// robot: the flat values and whether it was one pose.
fn joints_arg(
    q_deg: &PyArrayLikeDyn<'_, f64, AllowTypeChange>,
    n: usize,
    name: &str,
) -> PyResult<(Vec<f64>, bool)> {
    let shape = q_deg.shape().to_vec();
    let single = match shape[..] {
        [k] if k == n => true,
        [_, k] if k == n => false,
        _ => {
            return Err(KincalError::new_err(format!(
                "{name}: expected shape (n, {n}) or ({n},) (joint angles in degrees of this \
                 {n}-joint robot), got {}",
                shape_text(&shape)
            )));
        }
    };
    Ok((q_deg.as_array().iter().copied().collect(), single))
}

/// `(n, N)` joints (`(N,)` is one row) as rows of N values.
fn joint_rows(
    q_deg: &PyArrayLikeDyn<'_, f64, AllowTypeChange>,
    n: usize,
    name: &str,
) -> PyResult<Vec<Vec<f64>>> {
    let (flat, _) = joints_arg(q_deg, n, name)?;
    Ok(flat.chunks_exact(n).map(<[f64]>::to_vec).collect())
}

/// `(n, 3)` points as rows, `n` rows expected (`what` names the joints they go with).
fn point_rows(
    points: &PyArrayLikeDyn<'_, f64, AllowTypeChange>,
    rows: usize,
    name: &str,
    what: &str,
) -> PyResult<Vec<[f64; 3]>> {
    fixed_rows(points, rows, name, "point in mm", what)
}

/// `(n, K)` values as rows of K, `n` rows expected; the error says what each row is (`each`)
/// and names the joints they go with (`what`).
fn fixed_rows<const K: usize>(
    a: &PyArrayLikeDyn<'_, f64, AllowTypeChange>,
    rows: usize,
    name: &str,
    each: &str,
    what: &str,
) -> PyResult<Vec<[f64; K]>> {
    let shape = a.shape().to_vec();
    if shape[..] != [rows, K] {
        return Err(KincalError::new_err(format!(
            "{name}: expected shape ({rows}, {K}) (one {each} per row of {what}), got {}",
            shape_text(&shape)
        )));
    }
    let flat: Vec<f64> = a.as_array().iter().copied().collect();
    Ok(flat
        .chunks_exact(K)
        .map(|r| std::array::from_fn(|k| r[k]))
        .collect())
}

/// A measurement set of joint rows (and points) built in memory, named `source`.
fn memory_set(
    source: &str,
    n: usize,
    q: Vec<Vec<f64>>,
    points: Option<Vec<[f64; 3]>>,
) -> measurements::MeasurementSet {
    let rows = match points {
        Some(p) => q
            .into_iter()
            .zip(p)
            .map(|(q, p)| measurements::Measurement::new(q, Some(p)))
            .collect(),
        None => q
            .into_iter()
            .map(|q| measurements::Measurement::new(q, None))
            .collect(),
    };
    measurements::MeasurementSet::new(source, n, rows)
}

/// Forward kinematics of `robot` on `q_deg` as a numpy array (see `Robot.fk`).
fn fk_array<'py>(
    py: Python<'py>,
    robot: &kinematics::Robot,
    q_deg: PyArrayLikeDyn<'py, f64, AllowTypeChange>,
) -> PyResult<Bound<'py, PyArrayDyn<f64>>> {
    let n = robot.n_joints();
    let (flat_deg, single) = joints_arg(&q_deg, n, "q_deg")?;
    if let Some(k) = flat_deg.iter().position(|v| !v.is_finite()) {
        let at = if single {
            format!("{k}")
        } else {
            format!("{}, {}", k / n, k % n)
        };
        return Err(KincalError::new_err(format!(
            "q_deg[{at}] is {}: joint angles must be finite",
            flat_deg[k]
        )));
    }
    let q_rad: Vec<f64> = flat_deg.iter().map(|d| d.to_radians()).collect();
    let flat: Vec<f64> = py.detach(|| {
        robot
            .points(&q_rad)
            .iter()
            .flat_map(|p| [p.x, p.y, p.z])
            .collect()
    });
    let out = if single {
        Array1::from(flat).into_dyn()
    } else {
        Array2::from_shape_vec((flat.len() / 3, 3), flat)
            .expect("three coordinates per pose")
            .into_dyn()
    };
    Ok(out.into_pyarray(py))
}

/// `(n, k)` rows as a 2-D array.
fn rows_array<'py, const K: usize>(
    py: Python<'py>,
    rows: &[[f64; K]],
) -> Bound<'py, PyArray2<f64>> {
    let flat: Vec<f64> = rows.iter().flatten().copied().collect();
    Array2::from_shape_vec((rows.len(), K), flat)
        .expect("K values per row")
        .into_pyarray(py)
}

/// Variable-length rows of equal length `k` as a 2-D array.
fn vec_rows_array<'py>(py: Python<'py>, rows: &[Vec<f64>], k: usize) -> Bound<'py, PyArray2<f64>> {
    let flat: Vec<f64> = rows.iter().flatten().copied().collect();
    Array2::from_shape_vec((rows.len(), k), flat)
        .expect("k values per row")
        .into_pyarray(py)
}

/// The result of `kincal.identify`: the calibration the CLI's `kincal identify` computes on
/// the same data, with its calibrated robot, residuals, parameter table, covariance and
/// validation; `save(dir)` writes the files of `kincal identify --out`.
#[pyclass(module = "kincal", name = "Calibration", frozen)]
struct PyCalibration {
    cal: calibrate::Calibration,
    /// The calibrated robot as written to (and read back from) `identified.json`.
    identified: calibrate::LoadedRobot,
    /// The nominal robot in the data's frame, as `registered-nominal.json`.
    registered: calibrate::LoadedRobot,
    /// Wall time of the library call `calibrate::calibrate`, ms.
    library_ms: f64,
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
    /// (`(n, N)`, or `(N,)` → `(3,)`): `calibration.robot.fk(q_deg)`.
    fn predict<'py>(
        &self,
        py: Python<'py>,
        q_deg: PyArrayLikeDyn<'py, f64, AllowTypeChange>,
    ) -> PyResult<Bound<'py, PyArrayDyn<f64>>> {
        fk_array(py, &self.identified.robot, q_deg)
    }

    /// Residuals `measured − calibrated` `(n, 3)` (mm) on the identification rows (all of
    /// them, outliers included even when rejected; the rows of `identification_rows`).
    #[getter]
    fn residuals_mm<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        let (_, after) = self.cal.screened_residuals();
        rows_array(py, &after)
    }

    /// Indices (0-based, into the `q_deg` given to `identify`) of the identification rows,
    /// in order: all rows, or those an `every`/`select` split chose.
    #[getter]
    fn identification_rows<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<i64>> {
        let idx: Vec<i64> = self
            .cal
            .screened_rows
            .iter()
            .map(|r| r.line as i64 - 1)
            .collect();
        Array1::from(idx).into_pyarray(py)
    }

    /// Every parameter of the robot (the order of docs/model.md §3) as a list of records
    /// `{"name", "unit", "free", "nominal", "start", "identified", "std_error",
    /// "identifiable"}` in display units: the rows of `parameters.json`
    /// (`pandas.DataFrame(cal.parameters)` makes the table).
    #[getter]
    fn parameters<'py>(&self, py: Python<'py>) -> PyResult<Vec<Bound<'py, PyDict>>> {
        let o = &self.cal;
        let layout = o.start.layout();
        let (xn, xs) = (o.nominal.robot.params(), o.start.params());
        let cov = o.fit.covariance.as_ref();
        layout
            .params()
            .iter()
            .enumerate()
            .map(|(k, info)| {
                let d = PyDict::new(py);
                d.set_item("name", &info.name)?;
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
                        None => o.analysis.identifiable.contains(&info.name),
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
        self.cal.analysis.rank
    }

    /// Covariance `(r, r)` of the identifiable free parameters (display units: deg², deg·mm,
    /// mm²), in the order of `covariance_parameters`; `None` without degrees of freedom.
    #[getter]
    fn covariance<'py>(&self, py: Python<'py>) -> Option<Bound<'py, PyArray2<f64>>> {
        self.cal.fit.covariance.as_ref().map(|c| {
            let r = c.parameters.len();
            vec_rows_array(py, &c.covariance, r)
        })
    }

    /// The names of the rows and columns of `covariance` (empty without one).
    #[getter]
    fn covariance_parameters(&self) -> Vec<String> {
        self.cal
            .fit
            .covariance
            .as_ref()
            .map_or_else(Vec::new, |c| c.parameters.clone())
    }

    /// RMS 3-D point error of the fit on the rows it used, mm.
    #[getter]
    fn rms_mm(&self) -> f64 {
        self.cal.fit.rms_mm
    }

    /// σ̂, the fit's residual scale (mm per axis); `None` without degrees of freedom.
    #[getter]
    fn sigma_hat_mm(&self) -> Option<f64> {
        self.cal.fit.sigma_hat
    }

    /// Indices (into `identification_rows`) of the outliers the screen flagged
    /// (‖residual‖ > k·σ̂₃); excluded from the final fit with `reject_outliers=True`.
    #[getter]
    fn outliers(&self) -> Vec<usize> {
        self.cal
            .screen
            .as_ref()
            .map_or_else(Vec::new, |s| s.indices())
    }

    /// Whether the measurement frame was registered onto the robot base first.
    #[getter]
    fn registered(&self) -> bool {
        self.cal.registered()
    }

    /// 3-D errors on the validation rows (`validate=` or the rows an `every`/`select` split
    /// held out), mm: `{"n_poses", "before_mean_mm", "before_max_mm", "before_rms_mm",
    /// "before_p95_mm", "after_mean_mm", …}` (before: the nominal after registration;
    /// after: the calibrated robot), the figures `kincal identify` prints; `None` without
    /// validation rows.
    #[getter]
    fn validation<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyDict>>> {
        let Some(v) = &self.cal.validation else {
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
            self.cal.nominal.robot.name(),
            self.cal.used.len(),
            self.cal.free.len(),
            self.cal.analysis.rank,
            self.cal.fit.rms_mm
        )
    }
}

/// The checks an `allow` argument names: `None`, a check's name or a sequence of names.
fn allow_arg(allow: Option<&Bound<'_, PyAny>>) -> PyResult<Vec<calibrate::Check>> {
    let Some(a) = allow else {
        return Ok(Vec::new());
    };
    a.extract::<String>()
        .map(|s| vec![s])
        .or_else(|_| a.extract::<Vec<String>>())
        .map_err(|_| KincalError::new_err("allow: expected a check's name or a list of names"))?
        .iter()
        .map(|name| {
            name.parse::<calibrate::Check>()
                .map_err(|e| KincalError::new_err(format!("allow: {e}")))
        })
        .collect()
}

/// A spec given as a string or a sequence of names (joined by commas).
fn params_arg(params: &Bound<'_, PyAny>) -> PyResult<identify::ParamSpec> {
    let text = match params.extract::<String>() {
        Ok(s) => s,
        Err(_) => params
            .extract::<Vec<String>>()
            .map_err(|_| {
                KincalError::new_err(
                    "params: expected a spec string (\"paper\", \"minimal\", \
                     \"paper+compliance\", \"theta2,d3\") or a list of parameter names",
                )
            })?
            .join(","),
    };
    Ok(text.parse().expect("a parameter spec always parses"))
}

/// The options `identify` and `identify_frames` share: the flags of `kincal identify`.
struct Shared<'a, 'py> {
    params: Option<Bound<'py, PyAny>>,
    reject_outliers: bool,
    every: Option<usize>,
    offset: usize,
    select: Option<usize>,
    criterion: &'a str,
    schedule: &'a str,
    redundant: &'a str,
    registration: &'a str,
    outlier_k: f64,
    worst: usize,
    joint_units: &'a str,
    length_units: &'a str,
    allow: Option<Bound<'py, PyAny>>,
}

/// The request `kincal identify` builds from its flags, for the robot `robot`, the data
/// named `data` and the validation set named `validate`.
fn identify_request(
    robot: &std::path::Path,
    data: &str,
    validate: Option<&str>,
    o: Shared<'_, '_>,
) -> PyResult<calibrate::IdentifyRequest> {
    let Shared {
        params,
        reject_outliers,
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
    } = o;
    let refuse = |name: &str, value: &str, allowed: &str| {
        KincalError::new_err(format!("{name}: unknown value {value:?} ({allowed})"))
    };
    let split = match (every, select) {
        (Some(_), Some(_)) => {
            return Err(KincalError::new_err(
                "every and select: give one split of the data, not both",
            ));
        }
        (Some(every), None) => calibrate::Split::Every { every, offset },
        (None, Some(poses)) => calibrate::Split::Select {
            poses,
            criterion: criterion.parse().map_err(KincalError::new_err)?,
        },
        (None, None) => calibrate::Split::All,
    };
    if offset != 0 && every.is_none() {
        return Err(KincalError::new_err("offset: only with every"));
    }
    let damping = match schedule {
        "levenberg" => identify::Damping::levenberg(),
        "marquardt" => identify::Damping::marquardt(),
        "nielsen" => identify::Damping::nielsen(),
        other => return Err(refuse("schedule", other, "levenberg, marquardt, nielsen")),
    };
    let redundant = match redundant {
        "hold" => identify::Redundant::Hold,
        "damp" => identify::Redundant::Damp,
        other => return Err(refuse("redundant", other, "hold, damp")),
    };
    let registration = match registration {
        "auto" => identify::RegistrationPolicy::default(),
        "always" => identify::RegistrationPolicy::Always,
        "never" => identify::RegistrationPolicy::Never,
        other => return Err(refuse("registration", other, "auto, always, never")),
    };
    let params = match &params {
        Some(p) => params_arg(p)?,
        None => identify::ParamSpec::default(),
    };
    let joint_units = [calibrate::JointUnits::Deg, calibrate::JointUnits::Rad]
        .into_iter()
        .find(|u| u.name() == joint_units)
        .ok_or_else(|| refuse("joint_units", joint_units, "deg, rad"))?;
    let length_units = [
        calibrate::LengthUnits::Mm,
        calibrate::LengthUnits::M,
        calibrate::LengthUnits::In,
    ]
    .into_iter()
    .find(|u| u.name() == length_units)
    .ok_or_else(|| refuse("length_units", length_units, "mm, m, in"))?;
    let allow = allow_arg(allow.as_ref())?;
    Ok(calibrate::IdentifyRequest {
        validate: validate.map(PathBuf::from),
        split,
        params,
        damping,
        redundant,
        registration,
        reject_outliers,
        outlier_k,
        worst,
        joint_units,
        length_units,
        allow,
        ..calibrate::IdentifyRequest::new(robot, data)
    })
}

/// Identifies the robot's parameters from measured points `(n, 3)` (mm) at joints `(n, N)`
/// (degrees), as `kincal identify` does on a file with the same rows. `joint_units` ("deg",
/// "rad") and `length_units` ("mm", "m", "in") declare other units. The plausibility checks
/// (radians, metres, a mirrored frame, outliers, far parameters, worse validation) refuse
/// with KincalError; `allow` (a check's name or a list of names) overrides them, as
/// `--allow` does.
#[pyfunction(name = "identify")]
#[pyo3(signature = (
    robot, q_deg, points_mm, *, params = None, validate = None, reject_outliers = false,
    every = None, offset = 0, select = None, criterion = "d", schedule = "levenberg",
    redundant = "hold", registration = "auto", outlier_k = 3.0, worst = 10,
    joint_units = "deg", length_units = "mm", allow = None
))]
#[allow(clippy::too_many_arguments)]
fn py_identify<'py>(
    py: Python<'py>,
    robot: &PyRobot,
    q_deg: PyArrayLikeDyn<'py, f64, AllowTypeChange>,
    points_mm: PyArrayLikeDyn<'py, f64, AllowTypeChange>,
    params: Option<Bound<'py, PyAny>>,
    validate: Option<(
        PyArrayLikeDyn<'py, f64, AllowTypeChange>,
        PyArrayLikeDyn<'py, f64, AllowTypeChange>,
    )>,
    reject_outliers: bool,
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
) -> PyResult<PyCalibration> {
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
        },
    )?;
    py.detach(|| {
        let err = |e: calibrate::CalibrateError| kincal_error(&e);
        let inputs =
            calibrate::Inputs::from_sets(&request, nominal, data, validate).map_err(err)?;
        let started = std::time::Instant::now();
        let cal = calibrate::calibrate(&request, inputs).map_err(err)?;
        let library_ms = started.elapsed().as_secs_f64() * 1e3;
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
    })
}

/// `n` strings (target names or pose ids), or an error naming `name`.
fn string_rows(v: &Bound<'_, PyAny>, rows: usize, name: &str) -> PyResult<Vec<String>> {
    let v: Vec<String> = v.extract().map_err(|_| {
        KincalError::new_err(format!("{name}: expected a sequence of {rows} strings"))
    })?;
    if v.len() != rows {
        return Err(KincalError::new_err(format!(
            "{name}: expected {rows} strings (one per row), got {}",
            v.len()
        )));
    }
    Ok(v)
}

/// A measurement set of 6-DoF / multi-target rows built in memory: the rows of a file with
/// `qw,qx,qy,qz` (orientations), `target` and `id` (pose ids) columns. `names` name the five
/// arguments in errors.
#[allow(clippy::too_many_arguments)]
fn frame_set(
    source: &str,
    n: usize,
    q: &PyArrayLikeDyn<'_, f64, AllowTypeChange>,
    points: &PyArrayLikeDyn<'_, f64, AllowTypeChange>,
    orientations: Option<&PyArrayLikeDyn<'_, f64, AllowTypeChange>>,
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
        return Err(KincalError::new_err(format!(
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
/// (mm per degree, default 5).
#[pyfunction(name = "identify_frames")]
#[pyo3(signature = (
    robot, q_deg, points_mm, *, orientations_wxyz = None, targets = None, pose_ids = None,
    orientation_weight = None, params = None, validate = None, reject_outliers = false,
    every = None, offset = 0, select = None, criterion = "d", schedule = "levenberg",
    redundant = "hold", registration = "auto", outlier_k = 3.0, worst = 10,
    joint_units = "deg", length_units = "mm", allow = None
))]
#[allow(clippy::too_many_arguments)]
fn py_identify_frames<'py>(
    py: Python<'py>,
    robot: &PyRobot,
    q_deg: PyArrayLikeDyn<'py, f64, AllowTypeChange>,
    points_mm: PyArrayLikeDyn<'py, f64, AllowTypeChange>,
    orientations_wxyz: Option<PyArrayLikeDyn<'py, f64, AllowTypeChange>>,
    targets: Option<Bound<'py, PyAny>>,
    pose_ids: Option<Bound<'py, PyAny>>,
    orientation_weight: Option<f64>,
    params: Option<Bound<'py, PyAny>>,
    validate: Option<Bound<'py, pyo3::types::PyTuple>>,
    reject_outliers: bool,
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
) -> PyResult<PyFrameCalibration> {
    if orientations_wxyz.is_none() && targets.is_none() {
        return Err(KincalError::new_err(
            "identify_frames: give orientations_wxyz or targets (points alone: kincal.identify)",
        ));
    }
    if let Some(w) = orientation_weight
        && !(w.is_finite() && w > 0.0)
    {
        return Err(KincalError::new_err(format!(
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
                return Err(KincalError::new_err(format!(
                    "validate: expected (q_deg, points_mm[, orientations_wxyz[, targets[, \
                     pose_ids]]]), got a tuple of {}",
                    v.len()
                )));
            }
            // Item k, `None` where absent or given as None.
            let item = |k: usize| v.get_item(k).ok().filter(|x| !x.is_none());
            let array =
                |x: Bound<'py, PyAny>| -> PyResult<PyArrayLikeDyn<'py, f64, AllowTypeChange>> {
                    x.extract()
                };
            let (vq, vp) = match (item(0), item(1)) {
                (Some(q), Some(p)) => (array(q)?, array(p)?),
                _ => {
                    return Err(KincalError::new_err(
                        "validate: q_deg and points_mm are required",
                    ));
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
        },
    )?;
    let options = calibrate::frames::FrameOptions {
        mm_per_deg: orientation_weight,
        sigma: false,
    };
    py.detach(|| {
        let err = |e: calibrate::CalibrateError| kincal_error(&e);
        let inputs =
            calibrate::Inputs::from_sets(&request, nominal, data, validate).map_err(err)?;
        let started = std::time::Instant::now();
        let cal = calibrate::frames::calibrate_frames(&request, inputs, &options).map_err(err)?;
        let library_ms = started.elapsed().as_secs_f64() * 1e3;
        let identified = calibrate::LoadedRobot::from_spec(
            cal.identified_robot().to_spec(),
            "identified.json",
            "robot",
        )
        .map_err(err)?;
        Ok(PyFrameCalibration {
            cal,
            identified,
            library_ms,
        })
    })
}

/// The errors of a model on a set of poses, as a dict.
fn frame_errors<'py>(
    py: Python<'py>,
    e: &calibrate::frames::FrameErrors,
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
struct PyFrameCalibration {
    cal: calibrate::frames::FrameCalibration,
    /// The calibrated robot as written to `identified.json`.
    identified: calibrate::LoadedRobot,
    /// Wall time of the library call `calibrate::frames::calibrate_frames`, ms.
    library_ms: f64,
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

    /// The unknowns of the fit as records `{"name", "unit", "start", "identified",
    /// "std_error"}` (display units; `tool_rx, tool_ry, tool_rz` are the rotation vector from
    /// the start orientation): the table of `report.md`.
    #[getter]
    fn parameters<'py>(&self, py: Python<'py>) -> PyResult<Vec<Bound<'py, PyDict>>> {
        self.cal
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
    #[getter]
    fn held(&self) -> Vec<String> {
        self.cal.held.clone()
    }

    /// Errors on the identification poses: `{"start": {...}, "identified": {...}}`, each
    /// `{"n_poses", "position_mean_mm", "position_max_mm", "orientation_mean_deg",
    /// "orientation_max_deg"}`.
    #[getter]
    fn fit_errors<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let d = PyDict::new(py);
        d.set_item("start", frame_errors(py, &self.cal.fit_errors.0)?)?;
        d.set_item("identified", frame_errors(py, &self.cal.fit_errors.1)?)?;
        Ok(d)
    }

    /// Errors on the validation poses (`validate=` or the poses an `every`/`select` split
    /// held out), as `fit_errors` (start: the registered nominal with the closed-form tool
    /// frame); `None` without validation poses.
    #[getter]
    fn validation<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyDict>>> {
        let Some((_, start, identified)) = &self.cal.validation else {
            return Ok(None);
        };
        let d = PyDict::new(py);
        d.set_item("start", frame_errors(py, start)?)?;
        d.set_item("identified", frame_errors(py, identified)?)?;
        Ok(Some(d))
    }

    /// The poses the outlier screen flagged (largest ratio first), as records `{"row",
    /// "ratio", "position_mm", "orientation_deg"}`: `row` the 0-based index of the pose's
    /// first row in the arrays given; excluded from the final fit with
    /// `reject_outliers=True`.
    #[getter]
    fn outliers<'py>(&self, py: Python<'py>) -> PyResult<Vec<Bound<'py, PyDict>>> {
        self.cal
            .outlier_poses()
            .iter()
            .map(|o| {
                let d = PyDict::new(py);
                d.set_item("row", o.line - 1)?;
                d.set_item("ratio", o.ratio)?;
                d.set_item("position_mm", o.position_mm)?;
                d.set_item("orientation_deg", o.orientation_deg)?;
                Ok(d)
            })
            .collect()
    }

    /// σ̂ of the weighted fit.
    #[getter]
    fn sigma_hat(&self) -> f64 {
        self.cal.fit.sigma_hat
    }

    /// Wall time (ms) of the library call `calibrate::frames::calibrate_frames` inside
    /// `identify_frames`, timed in Rust.
    #[getter]
    fn library_ms(&self) -> f64 {
        self.library_ms
    }

    /// The console summary `kincal identify` prints for this calibration.
    fn summary(&self) -> String {
        report::calibration::frames::summary(&self.cal)
    }

    /// Writes the files of `kincal identify --out` on the same data into `directory` as the
    /// CLI does (created if missing; the set replaced as a whole under the directory's
    /// lock): `identified.json`, `report.md`, `report.html` and its plots.
    fn save(&self, py: Python<'_>, directory: PathBuf) -> PyResult<()> {
        py.detach(|| save_outputs(&directory, report::calibration::frames::render(&self.cal)))
    }

    fn __repr__(&self) -> String {
        format!(
            "FrameCalibration({:?}, poses={}, unknowns={}, sigma_hat={:.4})",
            self.cal.nominal_name,
            self.cal.data.n_poses(),
            self.cal.fit.estimates.len(),
            self.cal.fit.sigma_hat
        )
    }
}

/// The joints `(n, N)` (degrees) to command so that the calibrated robot reaches the points
/// the nominal robot (in the data's frame) reaches at `q_deg`, as `kincal compensate` with
/// the calibration's `identified.json` and `registered-nominal.json`.
#[pyfunction(name = "compensate")]
fn py_compensate<'py>(
    py: Python<'py>,
    calibration: &PyCalibration,
    q_deg: PyArrayLikeDyn<'py, f64, AllowTypeChange>,
) -> PyResult<Bound<'py, PyArrayDyn<f64>>> {
    let nominal = &calibration.registered;
    let n = nominal.robot.n_joints();
    let (_, single) = joints_arg(&q_deg, n, "q_deg")?;
    let set = memory_set("q_deg", n, joint_rows(&q_deg, n, "q_deg")?, None);
    let rows = py.detach(|| {
        let set = nominal
            .check_set(set, false, "target joints")
            .map_err(|e| kincal_error(&e))?;
        calibrate::compensate_set(&calibration.identified, nominal, &set)
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

/// Indices (into the candidates) of the `n` poses the design criterion chooses, as
/// `kincal design --candidates` does with the same rows.
#[pyfunction(name = "design")]
#[pyo3(signature = (
    robot, candidates_q_deg, n, *, criterion = "d", workspace_q_deg = None,
    params = None, seed = 1, restarts = 0
))]
#[allow(clippy::too_many_arguments)]
fn py_design<'py>(
    py: Python<'py>,
    robot: &PyRobot,
    candidates_q_deg: PyArrayLikeDyn<'py, f64, AllowTypeChange>,
    n: usize,
    criterion: &str,
    workspace_q_deg: Option<PyArrayLikeDyn<'py, f64, AllowTypeChange>>,
    params: Option<Bound<'py, PyAny>>,
    seed: u64,
    restarts: usize,
) -> PyResult<Bound<'py, PyArray1<i64>>> {
    let loaded = &robot.loaded;
    let nj = loaded.robot.n_joints();
    let criterion: design::Criterion = criterion.parse().map_err(KincalError::new_err)?;
    let spec = match &params {
        Some(p) => params_arg(p)?,
        None => "minimal".parse().expect("a parameter spec always parses"),
    };
    let cand = memory_set(
        "candidates",
        nj,
        joint_rows(&candidates_q_deg, nj, "candidates_q_deg")?,
        None,
    );
    let work = workspace_q_deg
        .map(|w| -> PyResult<_> {
            Ok(memory_set(
                "workspace",
                nj,
                joint_rows(&w, nj, "workspace_q_deg")?,
                None,
            ))
        })
        .transpose()?;
    let chosen = py.detach(|| -> PyResult<Vec<usize>> {
        let err = |e: &(dyn std::error::Error + 'static)| kincal_error(e);
        let candidates = loaded
            .check_set(cand, false, "candidates")
            .map_err(|e| err(&e))?;
        let workspace = work
            .map(|w| loaded.check_set(w, false, "workspace").map_err(|e| err(&e)))
            .transpose()?;
        let spec_err = |e: identify::IdentifyError| {
            KincalError::new_err(format!("params `{spec}`: {}", {
                let mut m = e.to_string();
                let mut s = std::error::Error::source(&e);
                while let Some(x) = s {
                    m.push_str(&format!(": {x}"));
                    s = x.source();
                }
                m
            }))
        };
        let model_robot = spec
            .apply(&loaded.robot, &loaded.path.display().to_string())
            .map_err(spec_err)?;
        let names = spec.listed(&model_robot).map_err(spec_err)?;
        let indices = names
            .map(|p| model_robot.layout().select(&p))
            .transpose()
            .map_err(|e| err(&e))?;
        let pool = design::Candidates::from_set(&candidates);
        let ws = workspace.map(|w| design::Candidates::from_set(&w));
        let model = design::InfoModel::new(
            &model_robot,
            &pool.q_rad,
            ws.as_ref().map(|w| w.q_rad.as_slice()),
            indices.as_deref(),
            &design::Scale::default(),
        )
        .map_err(|e| err(&e))?;
        let mut opts = design::DesignOptions::new(criterion, n);
        opts.seed = seed;
        opts.restarts = restarts;
        Ok(design::select(&model, &opts).map_err(|e| err(&e))?.selected)
    })?;
    Ok(Array1::from(chosen.into_iter().map(|i| i as i64).collect::<Vec<_>>()).into_pyarray(py))
}

/// A scenario given as a path or a dict (JSON-serialisable, the file's fields; a relative
/// `robot` path is taken from the current directory), loaded and checked by the campaign
/// crate as `kincal campaign` loads a file.
fn scenario_arg(py: Python<'_>, scenario: &Bound<'_, PyAny>) -> PyResult<campaign::LoadedScenario> {
    if let Ok(path) = scenario.extract::<PathBuf>() {
        return py
            .detach(|| campaign::Scenario::from_file(&path))
            .map_err(|e| kincal_error(&e));
    }
    let text: String = py
        .import("json")?
        .call_method1("dumps", (scenario,))
        .map_err(|e| {
            KincalError::new_err(format!(
                "scenario: expected a path or a JSON-serialisable dict ({e})"
            ))
        })?
        .extract()?;
    let label = "scenario dict";
    py.detach(|| {
        campaign::Scenario::from_json_str(&text, label)
            .and_then(|s| s.load(std::path::Path::new("."), label))
    })
    .map_err(|e| kincal_error(&e))
}

/// Counts the progress of a campaign from the worker threads (atomics only; the Python
/// callback is called on the calling thread).
#[derive(Default)]
struct Progress {
    done: std::sync::atomic::AtomicU64,
    total: std::sync::atomic::AtomicU64,
}

impl campaign::Observer for Progress {
    fn phase_started(&self, _phase: campaign::Phase, total: u64) {
        self.total
            .fetch_add(total, std::sync::atomic::Ordering::Relaxed);
    }
    fn trials_done(&self, k: u64) {
        self.done.fetch_add(k, std::sync::atomic::Ordering::Relaxed);
    }
}

/// Runs a Monte Carlo campaign of a scenario (a file or a dict) and returns its summary, the
/// contents of the `summary.json` that `kincal campaign` writes for the same scenario and
/// options, as a dict.
#[pyfunction(name = "campaign")]
#[pyo3(signature = (
    scenario, *, trials = None, threads = None, seed = None, progress = None, iso = true,
    budget = true
))]
#[allow(clippy::too_many_arguments)]
fn py_campaign<'py>(
    py: Python<'py>,
    scenario: Bound<'py, PyAny>,
    trials: Option<u64>,
    threads: Option<usize>,
    seed: Option<u64>,
    progress: Option<Bound<'py, PyAny>>,
    iso: bool,
    budget: bool,
) -> PyResult<Bound<'py, PyAny>> {
    if trials == Some(0) {
        return Err(KincalError::new_err("trials must be at least 1"));
    }
    if threads == Some(0) {
        return Err(KincalError::new_err("threads must be at least 1"));
    }
    let mut loaded = scenario_arg(py, &scenario)?;
    let s = &mut loaded.scenario;
    s.iso.enabled &= iso;
    s.residual_budget.enabled &= budget;
    if let Some(t) = trials {
        s.trials = t;
    }
    if let Some(seed) = seed {
        s.seed = seed;
    }
    let counter = Progress::default();
    let mut callback_error = None;
    let outcome = std::thread::scope(|scope| {
        let worker = scope.spawn(|| campaign::summarize(loaded, threads, &counter));
        let mut reported = (u64::MAX, u64::MAX);
        loop {
            let finished = py.detach(|| {
                let until = std::time::Instant::now() + std::time::Duration::from_millis(100);
                while !worker.is_finished() && std::time::Instant::now() < until {
                    std::thread::sleep(std::time::Duration::from_millis(2));
                }
                worker.is_finished()
            });
            if let (Some(cb), None) = (&progress, &callback_error) {
                let now = (
                    counter.done.load(std::sync::atomic::Ordering::Relaxed),
                    counter.total.load(std::sync::atomic::Ordering::Relaxed),
                );
                if now != reported {
                    reported = now;
                    if let Err(e) = cb.call1(now) {
                        callback_error = Some(e);
                    }
                }
            }
            if finished {
                break;
            }
        }
        worker.join().expect("the campaign thread does not panic")
    });
    if let Some(e) = callback_error {
        return Err(e);
    }
    let outcome = outcome.map_err(|e| kincal_error(&e))?;
    py.import("json")?
        .call_method1("loads", (outcome.summary.to_json(),))
}

/// A simulated measurement set of trial `trial` of a scenario (a file or a dict): what
/// `kincal simulate` writes as `identification.csv` and `validation.csv`, as arrays
/// `{"identification_q_deg", "identification_points_mm", "validation_q_deg",
/// "validation_points_mm"}`.
#[pyfunction(name = "simulate")]
#[pyo3(signature = (scenario, *, seed = None, trial = 0))]
fn py_simulate<'py>(
    py: Python<'py>,
    scenario: Bound<'py, PyAny>,
    seed: Option<u64>,
    trial: u64,
) -> PyResult<Bound<'py, PyDict>> {
    let loaded = scenario_arg(py, &scenario)?;
    let seed = seed.unwrap_or(loaded.scenario.seed);
    let sim = py
        .detach(|| {
            virtual_robot::simulate_with(
                &loaded.nominal,
                &loaded.virtual_robot(),
                seed,
                trial,
                &loaded.scenario.measurement.probe(),
            )
        })
        .map_err(|e| {
            KincalError::new_err(format!(
                "simulating trial {trial} of {}: {}",
                loaded.source,
                {
                    let mut m = e.to_string();
                    let mut s = std::error::Error::source(&e);
                    while let Some(x) = s {
                        m.push_str(&format!(": {x}"));
                        s = x.source();
                    }
                    m
                }
            ))
        })?;
    let n = loaded.nominal.n_joints();
    let d = PyDict::new(py);
    for (name, set) in [
        ("identification", &sim.identification),
        ("validation", &sim.validation),
    ] {
        let q: Vec<Vec<f64>> = set.rows.iter().map(|r| r.q_deg.clone()).collect();
        let p: Vec<[f64; 3]> = set
            .rows
            .iter()
            .map(|r| r.point_mm.unwrap_or([f64::NAN; 3]))
            .collect();
        d.set_item(format!("{name}_q_deg"), vec_rows_array(py, &q, n))?;
        d.set_item(format!("{name}_points_mm"), rows_array(py, &p))?;
        if set.has_orientation() {
            let o: Vec<[f64; 4]> = set
                .rows
                .iter()
                .map(|r| r.orientation.unwrap_or([f64::NAN; 4]))
                .collect();
            d.set_item(format!("{name}_orientations_wxyz"), rows_array(py, &o))?;
        }
        if set.has_targets() {
            let column = |f: fn(&measurements::Measurement) -> Option<&String>| -> Vec<String> {
                set.rows
                    .iter()
                    .map(|r| f(r).cloned().unwrap_or_default())
                    .collect()
            };
            d.set_item(format!("{name}_targets"), column(|r| r.target.as_ref()))?;
            d.set_item(format!("{name}_pose_ids"), column(|r| r.id.as_ref()))?;
        }
    }
    Ok(d)
}

/// kincal's compiled core; import `kincal`, which re-exports it.
#[pymodule]
fn _kincal(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add("KincalError", m.py().get_type::<KincalError>())?;
    m.add_class::<PyRobot>()?;
    m.add_class::<PyCalibration>()?;
    m.add_class::<PyFrameCalibration>()?;
    m.add_function(wrap_pyfunction!(py_identify, m)?)?;
    m.add_function(wrap_pyfunction!(py_identify_frames, m)?)?;
    m.add_function(wrap_pyfunction!(py_compensate, m)?)?;
    m.add_function(wrap_pyfunction!(py_design, m)?)?;
    m.add_function(wrap_pyfunction!(py_campaign, m)?)?;
    m.add_function(wrap_pyfunction!(py_simulate, m)?)?;
    Ok(())
}
