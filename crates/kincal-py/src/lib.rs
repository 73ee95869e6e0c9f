//! The Python package `kincal` (`docs/python.md`): a thin binding of the library crates.
//!
//! This module converts types (paths, numpy arrays, parameter records), releases the GIL
//! around the library calls, and maps library errors to `kincal.KincalError`. It computes
//! nothing itself: forward kinematics is `kinematics::Robot::point`, parameter values are
//! converted by `ParamInfo::to_display`, URDF goes through the `urdf` crate and every file is
//! written by `measurements::write_atomically`, so Python and the CLI give the same numbers.

use std::path::PathBuf;

use numpy::ndarray::{Array1, Array2};
use numpy::{AllowTypeChange, IntoPyArray, PyArrayDyn, PyArrayLikeDyn, PyUntypedArrayMethods};
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
#[pyclass(module = "kincal", name = "Robot", frozen)]
struct PyRobot {
    robot: kinematics::Robot,
}

#[pymethods]
impl PyRobot {
    /// Reads a robot file (JSON, `docs/model.md` §4).
    ///
    /// Raises KincalError naming the file and the field when it cannot be read or is invalid.
    #[staticmethod]
    fn load(py: Python<'_>, path: PathBuf) -> PyResult<Self> {
        let robot = py
            .detach(|| kinematics::Robot::from_file(&path))
            .map_err(|e| kincal_error(&e))?;
        Ok(PyRobot { robot })
    }

    /// Converts the serial chain from link `base` to link `tip` of a plain URDF (xacro
    /// expanded first) into a robot, exactly (`docs/urdf.md`); `base`'s frame becomes the
    /// measurement frame and the measured point is `tool_mm` in `tip`'s frame.
    #[staticmethod]
    #[pyo3(
        signature = (path, base, tip, *, tool_mm = (0.0, 0.0, 0.0), name = None),
        text_signature = "(path, base, tip, *, tool_mm=(0.0, 0.0, 0.0), name=None)"
    )]
    fn from_urdf(
        py: Python<'_>,
        path: PathBuf,
        base: &str,
        tip: &str,
        tool_mm: (f64, f64, f64),
        name: Option<String>,
    ) -> PyResult<Self> {
        let opts = urdf::ImportOptions {
            tool_in_tip_mm: [tool_mm.0, tool_mm.1, tool_mm.2],
            name,
        };
        let spec = py
            .detach(|| urdf::import_file(&path, base, tip, &opts))
            .map_err(|e| kincal_error(&e))?
            .spec;
        let robot = kinematics::Robot::from_spec(&spec).map_err(|e| kincal_error(&e))?;
        Ok(PyRobot { robot })
    }

    /// Writes the robot file (JSON), as `kincal urdf import` and `identify` write theirs.
    fn save(&self, py: Python<'_>, path: PathBuf) -> PyResult<()> {
        py.detach(|| write_file(&path, &self.robot.to_spec().to_json_string()))
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
            let text = urdf::export(&self.robot.to_spec(), &opts).map_err(|e| kincal_error(&e))?;
            write_file(&path, &text)
        })
    }

    /// The robot's name (from the robot file).
    #[getter]
    fn name(&self) -> &str {
        self.robot.name()
    }

    /// Number of joints N.
    #[getter]
    fn n_joints(&self) -> usize {
        self.robot.n_joints()
    }

    /// Number of entries in the parameter vector.
    #[getter]
    fn n_params(&self) -> usize {
        self.robot.n_params()
    }

    /// The parameter vector in the order of `docs/model.md` §3, as a list of records
    /// `{"name": str, "value": float, "unit": "deg" | "mm" | …}` with values in display units
    /// (`pandas.DataFrame(robot.parameters)` makes a table).
    #[getter]
    fn parameters<'py>(&self, py: Python<'py>) -> PyResult<Vec<Bound<'py, PyDict>>> {
        let values = self.robot.params();
        self.robot
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
        let n = self.robot.n_joints();
        let shape = q_deg.shape().to_vec();
        let single = match shape[..] {
            [k] if k == n => true,
            [_, k] if k == n => false,
            _ => {
                return Err(KincalError::new_err(format!(
                    "q_deg: expected shape (n, {n}) or ({n},) (joint angles in degrees of this \
                     {n}-joint robot), got {}",
                    shape_text(&shape)
                )));
            }
        };
        let q_rad: Vec<f64> = q_deg.as_array().iter().map(|d| d.to_radians()).collect();
        if let Some(k) = q_rad.iter().position(|v| !v.is_finite()) {
            let at = if single {
                format!("{k}")
            } else {
                format!("{}, {}", k / n, k % n)
            };
            return Err(KincalError::new_err(format!(
                "q_deg[{at}] is {}: joint angles must be finite",
                q_deg.as_array().iter().nth(k).copied().unwrap_or(f64::NAN)
            )));
        }
        let flat: Vec<f64> = py.detach(|| {
            self.robot
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

    fn __repr__(&self) -> String {
        format!(
            "Robot({:?}, n_joints={}, n_params={})",
            self.robot.name(),
            self.robot.n_joints(),
            self.robot.n_params()
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

/// kincal's compiled core; import `kincal`, which re-exports it.
#[pymodule]
fn _kincal(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add("KincalError", m.py().get_type::<KincalError>())?;
    m.add_class::<PyRobot>()?;
    Ok(())
}
