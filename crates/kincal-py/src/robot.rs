//! `kincal.Robot`: a robot model, loaded from a robot file or a URDF, written back, and its
//! forward kinematics.

use std::path::PathBuf;

use numpy::PyArrayDyn;
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::arrays::{ArrayArg, fk_array, orientation_array};
use crate::errors::{kincal_error, refuse, write_file};
use crate::options::allow_arg;

/// Registers `Robot`.
pub(crate) fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<PyRobot>()
}

/// A robot model: the nominal or calibrated kinematics of a serial robot (a kincal robot file,
/// `docs/model.md` §4). Angles in degrees, lengths in millimetres.
///
/// It holds the robot file's values exactly (`spec`, whose degree limits check joint data as
/// the CLI's readers do) and where it came from (`path`, a file or a label).
#[pyclass(module = "kincal", name = "Robot", frozen)]
pub(crate) struct PyRobot {
    pub(crate) loaded: calibrate::LoadedRobot,
}

impl PyRobot {
    fn new(spec: kinematics::RobotSpec, path: PathBuf) -> PyResult<Self> {
        let loaded =
            calibrate::LoadedRobot::from_spec(spec, path, "robot").map_err(|e| kincal_error(&e))?;
        Ok(PyRobot { loaded })
    }

    pub(crate) fn robot(&self) -> &kinematics::Robot {
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
            return Err(refuse(format!(
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
        (0..r.n_joints())
            .map(|i| r.joint_type(i).as_str())
            .collect()
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
                d.set_item("name", info.name.as_str())?;
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
        q_deg: ArrayArg<'py>,
    ) -> PyResult<Bound<'py, PyArrayDyn<f64>>> {
        fk_array(py, self.robot(), &q_deg)
    }

    /// The measured frame's orientation (in the measurement frame) for joint angles in
    /// degrees as unit quaternions `w, x, y, z` (scalar first, `w ≥ 0`), shape `(n, N)` →
    /// `(n, 4)` or `(N,)` → `(4,)`: the flange rotation times the tool orientation
    /// (`tool_rotation_deg`), the columns `qw, qx, qy, qz` of `kincal predict`; `None` for a
    /// robot without a tool orientation.
    fn fk_orientation<'py>(
        &self,
        py: Python<'py>,
        q_deg: ArrayArg<'py>,
    ) -> PyResult<Option<Bound<'py, PyArrayDyn<f64>>>> {
        orientation_array(py, self.robot(), &q_deg)
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
