//! Calibration inputs built in memory (by a binding such as the Python package) rather than
//! read from files, with the checks a file gets when it is read: the robot's joint count and
//! joint limits on every row, finite values, points where they are required, the radians
//! notice. Compensation of joints held in memory, as [`crate::compensate_targets`] does for a
//! file.
//!
//! Rows built in memory carry `line = k + 1` for the k-th row (0-based), so an error or a
//! report names row `k + 1` of the set's source, as it names a line of a file.

use std::path::PathBuf;

use identify::CompensationOptions;
use kinematics::{Robot, RobotSpec};
use measurements::{MeasurementError, MeasurementSet};

use crate::error::{CalibrateError, Result};
use crate::files::{LoadedRobot, radians_notice};

impl LoadedRobot {
    /// A robot not read from a file: `spec` validated into a model; `label` stands where a
    /// file's path would (in errors, reports and `parameters.json`). `what` names it in
    /// errors (`"robot"`, …). The joint limits that check the data are the spec's, exactly.
    ///
    /// # Errors
    /// [`CalibrateError::Robot`] for an invalid spec.
    pub fn from_spec(
        spec: RobotSpec,
        label: impl Into<PathBuf>,
        what: &'static str,
    ) -> Result<Self> {
        let path = label.into();
        let robot = Robot::from_spec(&spec).map_err(|source| CalibrateError::Robot {
            what,
            path: path.clone(),
            source,
        })?;
        Ok(LoadedRobot { spec, robot, path })
    }

    /// Checks a measurement set built in memory as [`LoadedRobot::read_set`] checks a file:
    /// every row has this robot's N joint values, finite and within the joint limits (as in
    /// the robot file), a finite point where `require_points`, finite orientations and
    /// standard deviations if given. `what` names the set in errors. Rows keep their `line`
    /// (0 is replaced by the 1-based row number, so errors and reports name the row). The
    /// radians notice is added to the set's notices as when reading. The row count is not
    /// checked here (the calibration checks it against the free parameters).
    ///
    /// # Errors
    /// [`CalibrateError::Read`] naming the set, the row and the column.
    pub fn check_set(
        &self,
        mut set: MeasurementSet,
        require_points: bool,
        what: &str,
    ) -> Result<MeasurementSet> {
        let n = self.robot.n_joints();
        let limits = self.limits_deg();
        let source = set.source.clone();
        let err = |source_err: MeasurementError| CalibrateError::Read {
            context: format!(
                "checking the {what} {source} for {} ({n} joints)",
                self.robot.name()
            ),
            source: source_err,
        };
        for (k, row) in set.rows.iter_mut().enumerate() {
            if row.line == 0 {
                row.line = k + 1;
            }
            let line = row.line;
            let non_finite = |column: String, v: f64| MeasurementError::NonFinite {
                file: source.clone(),
                line,
                column,
                text: v.to_string(),
            };
            if row.q_deg.len() != n {
                return Err(err(MeasurementError::InvalidField {
                    file: source.clone(),
                    line,
                    column: "q".into(),
                    reason: format!(
                        "{} joint values, but the robot has {n} joints",
                        row.q_deg.len()
                    ),
                }));
            }
            for (j, (&v, &[min, max])) in row.q_deg.iter().zip(&limits).enumerate() {
                let column = format!("q{}", j + 1);
                if !v.is_finite() {
                    return Err(err(non_finite(column, v)));
                }
                if !(min..=max).contains(&v) {
                    return Err(err(MeasurementError::JointOutOfLimits {
                        file: source.clone(),
                        line,
                        column,
                        value_deg: v,
                        min_deg: min,
                        max_deg: max,
                    }));
                }
            }
            match row.point_mm {
                Some(p) => {
                    for (c, v) in ["x", "y", "z"].into_iter().zip(p) {
                        if !v.is_finite() {
                            return Err(err(non_finite(c.into(), v)));
                        }
                    }
                }
                None if require_points => {
                    return Err(err(MeasurementError::InvalidField {
                        file: source.clone(),
                        line,
                        column: "x".into(),
                        reason: "no measured point (x, y, z are required)".into(),
                    }));
                }
                None => {}
            }
            let extra = [
                ("qw", row.orientation.map(|q| q.to_vec())),
                ("sx", row.sigma_mm.map(|s| s.to_vec())),
                ("srx", row.sigma_deg.map(|s| s.to_vec())),
            ];
            for (column, values) in extra {
                if let Some(v) = values.iter().flatten().find(|v| !v.is_finite()) {
                    return Err(err(non_finite(column.into(), *v)));
                }
            }
        }
        if let Some(note) = radians_notice(&set, &limits) {
            set.notices.push(note);
        }
        Ok(set)
    }
}

/// For each commanded pose of `targets` (joints, degrees), the joints (degrees) to command:
/// [`crate::compensate_rows`] with the default [`CompensationOptions`] (the nearest exact
/// solution; flagged rows are returned like the others), every target required reachable.
/// `nominal` must be in the calibrated robot's measurement frame (the registered nominal of
/// the same calibration).
///
/// # Errors
/// As [`crate::compensate_targets`] with unreachable targets refused.
pub fn compensate_set(
    calibrated: &LoadedRobot,
    nominal: &LoadedRobot,
    targets: &MeasurementSet,
) -> Result<Vec<Vec<f64>>> {
    let c = crate::compensate_rows(
        calibrated,
        nominal,
        targets.clone(),
        false,
        &CompensationOptions::default(),
        "compensated joints",
    )?;
    Ok(c.joints_deg)
}

#[cfg(test)]
mod tests {
    use measurements::Measurement;

    use super::*;

    fn ur10() -> LoadedRobot {
        let path = concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../scenarios/robots/ur10.json"
        );
        LoadedRobot::load(std::path::Path::new(path), "robot").unwrap()
    }

    fn set(rows: Vec<Measurement>) -> MeasurementSet {
        MeasurementSet::new("arrays", 6, rows)
    }

    #[test]
    fn from_spec_keeps_the_exact_limits_and_checks_like_the_reader() {
        let file = ur10();
        let mem = LoadedRobot::from_spec(file.spec.clone(), "mem", "robot").unwrap();
        assert_eq!(mem.limits_deg(), file.limits_deg());
        let ok = Measurement::new(vec![10.0; 6], Some([1.0, 2.0, 3.0]));
        let checked = mem
            .check_set(set(vec![ok.clone(), ok.clone()]), true, "data")
            .unwrap();
        assert_eq!(checked.rows[1].line, 2);
        assert!(checked.notices.is_empty());
        // A joint beyond its limit, named as the reader names it.
        let hi = file.limits_deg()[2][1];
        let mut bad = ok.clone();
        bad.q_deg[2] = hi + 1.0;
        let e = mem
            .check_set(set(vec![ok.clone(), bad]), true, "data")
            .unwrap_err();
        let text = format!("{}: {}", e, std::error::Error::source(&e).unwrap());
        assert!(text.contains("arrays:2: column \"q3\""), "{text}");
        assert!(text.contains("outside its limits"), "{text}");
        // Exactly at the limit is accepted, as by the reader (inclusive).
        let mut edge = ok.clone();
        edge.q_deg[2] = hi;
        mem.check_set(set(vec![edge]), true, "data").unwrap();
        // Non-finite values, wrong joint counts, missing points.
        let mut nan = ok.clone();
        nan.point_mm = Some([0.0, f64::NAN, 0.0]);
        let e = mem.check_set(set(vec![nan]), true, "data").unwrap_err();
        assert!(format!("{}", std::error::Error::source(&e).unwrap()).contains("column \"y\""));
        let short = Measurement::new(vec![0.0; 5], Some([0.0; 3]));
        assert!(mem.check_set(set(vec![short]), true, "data").is_err());
        let joints_only = Measurement::new(vec![0.0; 6], None);
        assert!(
            mem.check_set(set(vec![joints_only.clone()]), true, "data")
                .is_err()
        );
        mem.check_set(set(vec![joints_only]), false, "targets")
            .unwrap();
    }

    #[test]
    fn radians_notice_as_when_reading() {
        let mem = ur10();
        let rows = (0..3)
            .map(|k| Measurement::new(vec![0.1 * k as f64; 6], Some([0.0; 3])))
            .collect();
        let checked = mem.check_set(set(rows), true, "data").unwrap();
        assert_eq!(checked.notices.len(), 1, "{:?}", checked.notices);
    }

    #[test]
    fn compensating_a_robot_onto_itself_changes_nothing_much() {
        let r = ur10();
        let q = vec![10.0, -80.0, 70.0, -30.0, 60.0, 20.0];
        let targets = MeasurementSet::new("t", 6, vec![Measurement::new(q.clone(), None)]);
        let out = compensate_set(&r, &r, &targets).unwrap();
        for (a, b) in out[0].iter().zip(&q) {
            assert!((a - b).abs() < 1e-6, "{a} vs {b}");
        }
    }
}
