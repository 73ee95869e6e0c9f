//! Robot files and measurement files as a calibration reads them: the robot's joint count and
//! joint limits check every row; errors name the file, line and column.

use std::path::{Path, PathBuf};

use kinematics::{Robot, RobotSpec};
use measurements::{Measurement, MeasurementError, MeasurementSet, ReadOptions, read_str};
use nalgebra::Vector3;

use crate::error::{CalibrateError, Result};

/// A robot file, parsed, with the exact degree limits of the file.
#[derive(Clone, Debug)]
pub struct LoadedRobot {
    /// The file as parsed.
    pub spec: RobotSpec,
    /// The model.
    pub robot: Robot,
    /// Where it was read from.
    pub path: PathBuf,
}

impl LoadedRobot {
    /// Loads and validates a robot model file (JSON, [`RobotSpec`]); `what` names it in
    /// errors (`"robot"`, `"nominal robot"`, …).
    pub fn load(path: &Path, what: &'static str) -> Result<Self> {
        let err = |source| CalibrateError::Robot {
            what,
            path: path.to_path_buf(),
            source,
        };
        let spec = RobotSpec::from_file(path).map_err(err)?;
        let robot = Robot::from_spec(&spec).map_err(err)?;
        Ok(LoadedRobot {
            spec,
            robot,
            path: path.to_path_buf(),
        })
    }

    /// The robot file's `prior_sd` (name → standard deviation, display units), in name order.
    pub fn prior_sd(&self) -> Vec<(String, f64)> {
        self.spec
            .prior_sd
            .iter()
            .flatten()
            .map(|(name, sd)| (name.clone(), *sd))
            .collect()
    }

    /// Joint limits in degrees, exactly as in the file (millimetres for a prismatic joint,
    /// the file's `limits_mm`).
    pub fn limits_deg(&self) -> Vec<[f64; 2]> {
        self.spec.joints.iter().map(|j| j.limits_deg).collect()
    }

    /// Each revolute joint's limits, degrees; `None` for a prismatic joint, whose column is a
    /// length and never radians (the input of [`radians_evidence`]).
    pub fn revolute_limits_deg(&self) -> Vec<Option<[f64; 2]>> {
        let revolute = |j: &kinematics::JointSpec| (!j.is_prismatic()).then_some(j.limits_deg);
        self.spec.joints.iter().map(revolute).collect()
    }

    /// The error for joint `j`'s value `value` (degrees, or millimetres for a prismatic
    /// joint) beyond its limits at `file:line`, in the joint's own unit.
    pub(crate) fn out_of_limits(
        &self,
        file: String,
        line: usize,
        column: String,
        j: usize,
        value: f64,
    ) -> MeasurementError {
        let joint = &self.spec.joints[j.min(self.spec.joints.len() - 1)];
        let [min, max] = joint.limits_deg;
        MeasurementError::JointOutOfLimits {
            file,
            line,
            column,
            value,
            min,
            max,
            unit: if joint.is_prismatic() { "mm" } else { "deg" },
        }
    }

    /// The unit factor of each joint column of a file in units of `deg_per_unit` degrees and
    /// `mm_per_unit` millimetres: a revolute joint's column is an angle (`--joint-units`),
    /// a prismatic joint's a length (`--length-units`, as the points).
    pub(crate) fn joint_factors(&self, (deg_per_unit, mm_per_unit): (f64, f64)) -> Vec<f64> {
        let factor = |j: &kinematics::JointSpec| {
            if j.is_prismatic() {
                mm_per_unit
            } else {
                deg_per_unit
            }
        };
        self.spec.joints.iter().map(factor).collect()
    }

    /// Reads a measurement file for this robot: its joint count, its joint limits, points
    /// required or not, at least `min_rows` rows (`why`, if given, explains that minimum
    /// when it is not met). `what` names the file in errors. Notices (ignored columns) are in
    /// the returned set's `notices`.
    pub fn read_set(
        &self,
        path: &Path,
        require_points: bool,
        (min_rows, why): (usize, Option<&str>),
        what: &str,
    ) -> Result<MeasurementSet> {
        self.read_set_in(path, require_points, (min_rows, why), what, (1.0, 1.0))
    }

    /// [`LoadedRobot::read_set`] of a file whose joints are in units of `deg_per_unit` degrees
    /// and points in units of `mm_per_unit` millimetres: the joint limits are checked in the
    /// file's units, and the rows are returned in degrees and millimetres.
    pub fn read_set_in(
        &self,
        path: &Path,
        require_points: bool,
        (min_rows, why): (usize, Option<&str>),
        what: &str,
        units: (f64, f64),
    ) -> Result<MeasurementSet> {
        self.read_set_with(path, require_points, (min_rows, why), what, units, None)
    }

    /// [`LoadedRobot::read_set_in`] with an Euler convention for orientation columns
    /// `rx,ry,rz` (degrees, converted on reading). The σ of the points (`sx,sy,sz`) are
    /// converted to millimetres with the points.
    pub fn read_set_with(
        &self,
        path: &Path,
        require_points: bool,
        (min_rows, why): (usize, Option<&str>),
        what: &str,
        (deg_per_unit, mm_per_unit): (f64, f64),
        euler: Option<measurements::EulerConvention>,
    ) -> Result<MeasurementSet> {
        let text = self.read_text(path, what)?;
        self.read_text_with(
            &text,
            &path.display().to_string(),
            require_points,
            (min_rows, why),
            what,
            (deg_per_unit, mm_per_unit),
            euler,
        )
    }

    /// The text of the `what` file `path`, read once, whole ([`measurements::read_text`]: a
    /// pipe or a FIFO reads as a file does); errors name the file and the robot as reading
    /// errors do.
    pub fn read_text(&self, path: &Path, what: &str) -> Result<String> {
        measurements::read_text(path).map_err(|e| {
            let source = path.display().to_string();
            self.read_error(&source, (0, None), what, (1.0, 1.0), e)
        })
    }

    /// [`LoadedRobot::read_set_with`] of a file's text, read once ([`measurements::read_text`]: a pipe
    /// cannot be read twice), named `source` in errors and in the set.
    #[allow(clippy::too_many_arguments)]
    pub fn read_text_with(
        &self,
        text: &str,
        source: &str,
        require_points: bool,
        (min_rows, why): (usize, Option<&str>),
        what: &str,
        (deg_per_unit, mm_per_unit): (f64, f64),
        euler: Option<measurements::EulerConvention>,
    ) -> Result<MeasurementSet> {
        let limits = self.limits_in((deg_per_unit, mm_per_unit));
        let factors = self.joint_factors((deg_per_unit, mm_per_unit));
        let mut opts = ReadOptions::new(self.robot.n_joints())
            .with_limits_deg(limits)
            .with_min_rows(min_rows);
        if !require_points {
            opts = opts.joints_only();
        }
        if let Some(e) = euler {
            opts = opts.with_euler(e);
        }
        let mut set = read_str(text, source, &opts).map_err(|e| {
            self.read_error(
                source,
                (min_rows, why),
                what,
                (deg_per_unit, mm_per_unit),
                e,
            )
        })?;
        to_degrees_and_mm(
            &mut set,
            (&factors, mm_per_unit),
            &self.revolute_limits_deg(),
        );
        Ok(set)
    }

    /// A reading error of the `what` file `path` in units of `deg_per_unit` degrees and
    /// `mm_per_unit` millimetres, with what was read for which robot: a joint beyond its
    /// limit, checked in the file's units, reported in degrees; too few rows with `why`.
    fn read_error(
        &self,
        path: &str,
        (_, why): (usize, Option<&str>),
        what: &str,
        (deg_per_unit, mm_per_unit): (f64, f64),
        source: MeasurementError,
    ) -> CalibrateError {
        let factors = self.joint_factors((deg_per_unit, mm_per_unit));
        // A joint beyond its limit, checked in the file's units, reported in degrees (a
        // revolute joint) or millimetres (a prismatic one).
        let source = match source {
            MeasurementError::JointOutOfLimits {
                file,
                line,
                column,
                value,
                ..
            } => {
                let j = column
                    .strip_prefix('q')
                    .and_then(|k| k.parse::<usize>().ok())
                    .map_or(0, |k| k.saturating_sub(1));
                self.out_of_limits(
                    file,
                    line,
                    column,
                    j,
                    value * factors[j.min(factors.len() - 1)],
                )
            }
            other => other,
        };
        let too_few = matches!(source, MeasurementError::TooFewRows { .. });
        let err = CalibrateError::Read {
            context: format!(
                "reading the {what} {path} for {} ({} joints)",
                self.robot.name(),
                self.robot.n_joints()
            ),
            source,
        };
        match why {
            Some(why) if too_few => err.context(why),
            _ => err,
        }
    }

    /// The joint limits in units of `deg_per_unit` degrees (`mm_per_unit` millimetres for a
    /// prismatic joint): the limits a file in those units is checked against.
    pub(crate) fn limits_in(&self, units: (f64, f64)) -> Vec<[f64; 2]> {
        self.limits_deg()
            .iter()
            .zip(self.joint_factors(units))
            .map(|(l, f)| if f == 1.0 { *l } else { [l[0] / f, l[1] / f] })
            .collect()
    }
}

/// Converts the rows of `set`, checked in the file's units (joint column i in units of
/// `joint_factors[i]` degrees, or millimetres for a prismatic joint, points in units of
/// `mm_per_unit` millimetres), to degrees and millimetres (joints, points and their σ). Rows
/// already in degrees and millimetres get the radians notice instead ([`radians_notice`]
/// against the revolute joints' `limits_deg`): declared units are not second-guessed.
pub(crate) fn to_degrees_and_mm(
    set: &mut MeasurementSet,
    (joint_factors, mm_per_unit): (&[f64], f64),
    limits_deg: &[Option<[f64; 2]>],
) {
    if joint_factors.iter().any(|f| *f != 1.0) || mm_per_unit != 1.0 {
        for r in &mut set.rows {
            r.q_deg
                .iter_mut()
                .zip(joint_factors)
                .for_each(|(q, f)| *q *= f);
            if let Some(p) = &mut r.point_mm {
                p.iter_mut().for_each(|v| *v *= mm_per_unit);
            }
            if let Some(s) = &mut r.sigma_mm {
                s.iter_mut().for_each(|v| *v *= mm_per_unit);
            }
        }
    } else if let Some(note) = radians_notice(set, limits_deg) {
        set.notices.push(note);
    }
}

/// A notice when the joint values of a file read as degrees look like radians
/// ([`radians_evidence`]). `None` otherwise.
pub fn radians_notice(set: &MeasurementSet, limits_deg: &[Option<[f64; 2]>]) -> Option<String> {
    radians_evidence(&set.source, &set.rows, limits_deg)
}

/// The evidence that joint values read as degrees are radians: at least 3 rows, every
/// revolute |q| ≤ 2π (joints such as a UR's turn beyond ±π), and a robot whose limits reach
/// beyond ±90° on some revolute joint (degrees data of such a robot that never leave ±6.3° on
/// any joint would be a strange calibration set). `limits_deg` holds each joint's limits,
/// `None` for a prismatic joint: its column is a length (a track at 0–5 mm is no evidence of
/// radians) and is left out. `None` otherwise.
pub fn radians_evidence(
    source: &str,
    rows: &[Measurement],
    limits_deg: &[Option<[f64; 2]>],
) -> Option<String> {
    let largest = largest_revolute(rows, limits_deg);
    let widest = limits_deg
        .iter()
        .flatten()
        .fold(0.0_f64, |m, l| m.max(l[0].abs()).max(l[1].abs()));
    (rows.len() >= 3 && largest <= std::f64::consts::TAU && widest > 90.0).then(|| {
        format!(
            "{source}: every joint value is within ±2π (largest |q| = {largest:.4}) although the \
             robot's limits reach ±{widest:.0}°: are these radians? Joint columns are read in \
             degrees (convert with q·180/π)"
        )
    })
}

/// The largest |q| of the revolute joints of `rows` (those whose `limits_deg` is `Some`;
/// a prismatic joint's column is a length), 0 without any.
pub(crate) fn largest_revolute(rows: &[Measurement], limits_deg: &[Option<[f64; 2]>]) -> f64 {
    rows.iter()
        .flat_map(|r| r.q_deg.iter().zip(limits_deg))
        .filter(|(_, l)| l.is_some())
        .fold(0.0_f64, |m, (q, _)| m.max(q.abs()))
}

/// The joint values of `rows`, radians, flat.
pub fn poses_rad(rows: &[Measurement]) -> Vec<f64> {
    rows.iter()
        .flat_map(|r| r.q_deg.iter().map(|q| q.to_radians()))
        .collect()
}

/// The measured points of `rows` (which must have them: read with points required), mm.
pub fn points_mm(rows: &[Measurement]) -> Vec<Vector3<f64>> {
    rows.iter()
        .map(|r| Vector3::from(r.point_mm.expect("read with points required")))
        .collect()
}

/// `V003 (line 5)` or `line 5`.
pub fn row_label(row: &Measurement) -> String {
    match &row.id {
        Some(id) => format!("{id} (line {})", row.line),
        None => format!("line {}", row.line),
    }
}

/// The file name of a path, for headers and names.
pub fn file_name(path: &Path) -> String {
    path.file_name().map_or_else(
        || path.display().to_string(),
        |n| n.to_string_lossy().into(),
    )
}
