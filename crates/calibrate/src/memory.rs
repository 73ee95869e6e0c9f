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
use crate::files::{LoadedRobot, to_degrees_and_mm};
use crate::residual::ResidualModel;
use crate::workflow::{declared_radians, with_rows};
use crate::{Check, IdentifyRequest, Inputs};

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
    /// standard deviations if given, and the checks across rows
    /// ([`MeasurementSet::check_rows`]: unit quaternions, the pose rules of targets). `what`
    /// names the set in errors. Rows keep their `line`
    /// (0 is replaced by the 1-based row number, so errors and reports name the row). The
    /// radians notice is added to the set's notices as when reading. The row count is not
    /// checked here (the calibration checks it against the free parameters).
    ///
    /// # Errors
    /// [`CalibrateError::Read`] naming the set, the row and the column.
    pub fn check_set(
        &self,
        set: MeasurementSet,
        require_points: bool,
        what: &str,
    ) -> Result<MeasurementSet> {
        self.check_set_in(set, require_points, what, (1.0, 1.0))
    }

    /// [`LoadedRobot::check_set`] of rows whose joints are in units of `deg_per_unit`
    /// degrees and points in units of `mm_per_unit` millimetres, as
    /// [`LoadedRobot::read_set_in`] reads a file in those units: the joint limits are checked
    /// in the rows' units, and the rows are returned in degrees and millimetres.
    ///
    /// # Errors
    /// As [`LoadedRobot::check_set`].
    pub fn check_set_in(
        &self,
        mut set: MeasurementSet,
        require_points: bool,
        what: &str,
        (deg_per_unit, mm_per_unit): (f64, f64),
    ) -> Result<MeasurementSet> {
        let n = self.robot.n_joints();
        let limits = self.limits_in((deg_per_unit, mm_per_unit));
        let factors = self.joint_factors((deg_per_unit, mm_per_unit));
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
                    // Checked in the rows' units, reported in degrees or millimetres.
                    return Err(err(self.out_of_limits(
                        source.clone(),
                        line,
                        column,
                        j,
                        v * factors[j],
                    )));
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
        set.check_rows().map_err(err)?;
        to_degrees_and_mm(
            &mut set,
            (&factors, mm_per_unit),
            &self.revolute_limits_deg(),
        );
        Ok(set)
    }
}

impl Inputs {
    /// The inputs of `request` from sets built in memory, as [`Inputs::load`] reads them from
    /// the request's files: each set is checked by [`LoadedRobot::check_set_in`] in the
    /// request's `joint_units` and `length_units` and converted to degrees and millimetres.
    /// Rows declared radians that are degrees are refused with the evidence of the
    /// `joint-units` check (unless the request allows it), as a file is. `request.data` and
    /// `request.validate` only name the sets; the row count is checked by [`crate::calibrate`].
    ///
    /// # Errors
    /// As [`LoadedRobot::check_set`]; [`crate::Refusal::NoDataRows`] for an empty validation set;
    /// the `joint-units` refusal; [`crate::Refusal::NoDataRows`] for an empty identification set.
    pub fn from_sets(
        request: &IdentifyRequest,
        nominal: LoadedRobot,
        data: MeasurementSet,
        validate: Option<MeasurementSet>,
    ) -> Result<Inputs> {
        let units = (
            request.joint_units.deg_per_unit(),
            request.length_units.mm_per_unit(),
        );
        let checked = |set: MeasurementSet, what: &str| {
            // The rows as given, kept only where a failure may be degrees declared radians.
            let kept = (request.joint_units == crate::JointUnits::Rad
                && !request.allows(Check::JointUnits))
            .then(|| set.clone());
            nominal.check_set_in(set, true, what, units).map_err(|err| {
                declared_radians(request, &nominal, err, || {
                    kept.and_then(|deg| nominal.check_set_in(deg, true, what, (1.0, units.1)).ok())
                })
            })
        };
        let data = with_rows(checked(data, "identification data")?, "identification data")?;
        let validate = validate
            .map(|v| with_rows(checked(v, "validation data")?, "validation"))
            .transpose()?;
        Ok(Inputs {
            nominal,
            data,
            validate,
        })
    }
}

/// For each commanded pose of `targets` (joints, degrees), the joints (degrees) to command:
/// [`crate::compensate_rows`] with the default [`CompensationOptions`] (the nearest exact
/// solution; flagged rows are returned like the others), every target required reachable.
/// `nominal` must be in the calibrated robot's measurement frame (the registered nominal of
/// the same calibration). The geometry alone: [`compensate_set_with`] with no model.
///
/// # Errors
/// As [`crate::compensate_targets`] with unreachable targets refused.
pub fn compensate_set(
    calibrated: &LoadedRobot,
    nominal: &LoadedRobot,
    targets: &MeasurementSet,
) -> Result<Vec<Vec<f64>>> {
    compensate_set_with((calibrated, None), nominal, targets)
}

/// [`compensate_set`] with the learned residual model of `calibrated`, if given, applied as
/// `kincal compensate` applies it ([`crate::compensate_rows_with`]): the joints bring the
/// calibrated robot's point with the model's mean, `FK(q) + r(q)`, onto each target (to
/// [`crate::residual::FIXED_POINT_TOL_MM`] of the fixed point; one that does not converge is
/// refused as unreachable, naming it). Without a model the result is [`compensate_set`]'s.
///
/// # Errors
/// As [`compensate_set`]; a model trained on another number of joints is refused.
pub fn compensate_set_with(
    (calibrated, model): (&LoadedRobot, Option<&ResidualModel>),
    nominal: &LoadedRobot,
    targets: &MeasurementSet,
) -> Result<Vec<Vec<f64>>> {
    let c = crate::compensate_rows_with(
        (calibrated, model),
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

    /// Declared units are converted as a file's are; degrees declared radians are refused
    /// with the joint-units check's evidence, or pass (and fail on a limit) when allowed.
    #[test]
    fn inputs_from_sets_take_the_requests_units() {
        let r = ur10();
        let q_deg = [
            [10.0, -80.0, 70.0, -30.0, 60.0, 20.0],
            [-45.0, -100.0, 30.0, 10.0, -60.0, 5.0],
        ];
        let rows = |scale: f64, mm: f64| {
            let rows = q_deg
                .iter()
                .map(|q| {
                    let q: Vec<f64> = q.iter().map(|v| v * scale).collect();
                    Measurement::new(q, Some([100.0 * mm, 200.0 * mm, 300.0 * mm]))
                })
                .collect();
            set(rows)
        };
        let mut request = IdentifyRequest::new("robot.json", "arrays");
        request.joint_units = crate::JointUnits::Rad;
        request.length_units = crate::LengthUnits::M;
        let to_rad = 1.0 / request.joint_units.deg_per_unit();
        let inputs = Inputs::from_sets(
            &request,
            r.clone(),
            rows(to_rad, 1e-3),
            Some(rows(to_rad, 1e-3)),
        )
        .unwrap();
        for (got, want) in inputs.data.rows.iter().zip(&q_deg) {
            for (g, w) in got.q_deg.iter().zip(want) {
                assert!((g - w).abs() < 1e-12, "{g} vs {w}");
            }
            let p = got.point_mm.unwrap();
            assert!((p[2] - 300.0).abs() < 1e-12, "{p:?}");
        }
        assert_eq!(inputs.validate.unwrap().rows.len(), 2);
        let e = Inputs::from_sets(&request, r.clone(), rows(1.0, 1e-3), None).unwrap_err();
        assert!(e.to_string().contains("declared radians"), "{e}");
        request.allow = vec![Check::JointUnits];
        let e = Inputs::from_sets(&request, r.clone(), rows(1.0, 1e-3), None).unwrap_err();
        let text = format!("{e}: {}", std::error::Error::source(&e).unwrap());
        // Checked in radians, reported in degrees: 10 rad on q1 against the UR10's ±360°.
        let q1 = 10.0 * request.joint_units.deg_per_unit();
        assert!(
            text.contains(&format!(
                "joint value {q1} deg is outside its limits [-360, 360] deg"
            )),
            "{text}"
        );
        let e = Inputs::from_sets(&request, r, rows(to_rad, 1e-3), Some(set(vec![]))).unwrap_err();
        assert!(e.to_string().contains("no data rows"), "{e}");
    }

    /// A file in radians with a joint beyond its limit: the error gives the value and the
    /// limits in degrees, as the in-memory check does.
    #[test]
    fn a_joint_beyond_its_limit_in_radians_is_reported_in_degrees() {
        let r = ur10();
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("rad.csv");
        std::fs::write(
            &path,
            "q1,q2,q3,q4,q5,q6,x,y,z\n0.1,0.2,0.3,0.4,0.5,10,1,2,3\n",
        )
        .unwrap();
        let deg = crate::JointUnits::Rad.deg_per_unit();
        let e = r
            .read_set_in(&path, true, (0, None), "data", (deg, 1.0))
            .unwrap_err();
        let text = format!("{e}: {}", std::error::Error::source(&e).unwrap());
        let q6 = 10.0 * deg;
        assert!(
            text.contains(&format!(
                "column \"q6\": joint value {q6} deg is outside its limits [-360, 360] deg"
            )),
            "{text}"
        );
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

    #[test]
    fn compensating_with_a_residual_model_brings_the_point_with_its_mean_onto_the_target() {
        // A smooth residual of a few tenths of a millimetre learnt on 40 poses; the robot
        // compensated onto itself then needs FK(q) + r(q) = FK(q_commanded).
        let r = ur10();
        let poses: Vec<Vec<f64>> = (0..40)
            .map(|k| {
                let t = f64::from(k) * 0.37;
                vec![
                    40.0 * t.sin(),
                    -80.0 + 20.0 * (1.3 * t).cos(),
                    70.0 + 15.0 * (0.7 * t).sin(),
                    -30.0 + 25.0 * t.cos(),
                    60.0 + 20.0 * (1.1 * t).sin(),
                    20.0 * t.cos(),
                ]
            })
            .collect();
        let residual = |q: &[f64]| {
            let (a, b) = (q[1].to_radians(), q[2].to_radians());
            [0.3 * a.sin(), 0.2 * b.cos(), 0.1 * (a + b).sin()]
        };
        let rs: Vec<[f64; 3]> = poses.iter().map(|q| residual(q)).collect();
        let model =
            ResidualModel::fit(&poses, &rs, &crate::residual::GpOptions::default()).unwrap();
        let q = vec![10.0, -80.0, 70.0, -30.0, 60.0, 20.0];
        let targets = MeasurementSet::new("t", 6, vec![Measurement::new(q.clone(), None)]);
        let plain = compensate_set(&r, &r, &targets).unwrap();
        assert_eq!(
            compensate_set_with((&r, None), &r, &targets).unwrap(),
            plain
        );
        let out = compensate_set_with((&r, Some(&model)), &r, &targets).unwrap();
        let rad = |q: &[f64]| q.iter().map(|v| v.to_radians()).collect::<Vec<_>>();
        let target = r.robot.point(&rad(&q));
        let mean = model.predict(std::slice::from_ref(&out[0])).unwrap()[0].mean_mm;
        let reached = r.robot.point(&rad(&out[0])) + nalgebra::Vector3::from(mean);
        assert!(
            (reached - target).norm() < 1e-5,
            "{}",
            (reached - target).norm()
        );
        let moved = out[0]
            .iter()
            .zip(&plain[0])
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        assert!(
            moved > 1e-4,
            "the model moved the joints by {moved} deg only"
        );
    }
}
