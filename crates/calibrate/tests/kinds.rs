//! Issue 37: one pipeline for every kind of measurement. Each plausibility check runs for
//! point, 6-DoF and multi-target data alike: the same corruption of the same simulated
//! KR1000 recording, given as points, as 6-DoF poses and as three targets per pose, is refused
//! by the same check on each kind, and passes that check when the request allows it.

use std::path::PathBuf;

use calibrate::{
    CalibrateError, Calibration, Check, IdentifyRequest, Inputs, LoadedRobot, MeasurementKind,
    Refusal, Split,
};
use kinematics::Robot;
use measurements::{Measurement, MeasurementSet};
use nalgebra::{Rotation3, UnitQuaternion, Vector3};

/// The kinds of data of these tests.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Data {
    Points,
    SixDof,
    Targets,
}

const KINDS: [Data; 3] = [Data::Points, Data::SixDof, Data::Targets];

/// Three reflectors in the flange frame, mm (120° apart on a 100 mm circle, 50 mm out).
const TARGETS: [[f64; 3]; 3] = [
    [100.0, 0.0, 50.0],
    [-50.0, 86.602_540_378_443_86, 50.0],
    [-50.0, -86.602_540_378_443_86, 50.0],
];

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn kr1000() -> LoadedRobot {
    LoadedRobot::load(&root().join("scenarios/robots/kr1000-titan.json"), "robot").unwrap()
}

/// The measured robot: the nominal with small geometric errors (a2 +0.4 mm among them).
fn truth(nominal: &Robot) -> Robot {
    let mut x = nominal.params();
    for (name, d) in [
        ("a2", 0.4),
        ("d4", -0.3),
        ("theta2", 0.002),
        ("alpha3", -0.001),
        ("tool_z", 0.5),
    ] {
        x[nominal.layout().index_of(name).unwrap()] += d;
    }
    nominal.with_params(&x).unwrap()
}

/// `n` poses of the truth measured as `kind`, in a tracker frame 2 m away turned 30° about z,
/// with ±0.02 mm of deterministic noise on the points: a row per pose (points, 6-DoF) or per
/// reflector (targets, `id` and `target` named).
fn measured(kind: Data, n: usize) -> Vec<Measurement> {
    measured_q6(kind, n, None)
}

/// [`measured`] with q6 within `[10°, 10° + range]` when `q6_range` is given (a wrist that
/// barely moves: weak excitation).
fn measured_q6(kind: Data, n: usize, q6_range: Option<f64>) -> Vec<Measurement> {
    let robot = kr1000();
    let truth = truth(&robot.robot);
    let limits = robot.limits_deg();
    let mut state = 0x2545_f491_4f6c_dd1d_u64;
    let mut next = || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state >> 11) as f64 / (1u64 << 53) as f64
    };
    let rot = Rotation3::from_axis_angle(&Vector3::z_axis(), 30f64.to_radians());
    let shift = Vector3::new(2000.0, -500.0, 300.0);
    // The probe's frame in the flange frame (6-DoF): turned 20° about x.
    let tool_rot = Rotation3::from_axis_angle(&Vector3::x_axis(), 20f64.to_radians());
    let mut rows = Vec::new();
    for i in 0..n {
        let q: Vec<f64> = (0..6)
            .map(|j| {
                let [lo, hi] = limits[j];
                let u = next();
                match q6_range {
                    Some(r) if j == 5 => 10.0 + r * u,
                    _ => 0.5 * (lo + (hi - lo) * u) + 0.25 * (lo + hi),
                }
            })
            .collect();
        let qr: Vec<f64> = q.iter().map(|v| v.to_radians()).collect();
        let flange = truth.flange(&qr);
        let noise = |k: usize, c: usize| 0.02 * (((7 * (i + k) + 3 * c) % 5) as f64 - 2.0) / 2.0;
        let row = |p: Vector3<f64>, k: usize| {
            let p = rot * p + shift;
            Measurement {
                line: rows_len(i, k, kind),
                q_deg: q.clone(),
                point_mm: Some([p.x + noise(k, 0), p.y + noise(k, 1), p.z + noise(k, 2)]),
                ..Default::default()
            }
        };
        match kind {
            Data::Points => rows.push(row(truth.point(&qr), 0)),
            Data::SixDof => {
                let r = rot.matrix() * flange.rot * tool_rot.matrix();
                let u = UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(r));
                rows.push(Measurement {
                    orientation: Some([u.w, u.i, u.j, u.k]),
                    ..row(truth.point(&qr), 0)
                });
            }
            Data::Targets => {
                for (k, o) in TARGETS.iter().enumerate() {
                    let p = flange.rot * Vector3::from(*o) + flange.pos_mm;
                    rows.push(Measurement {
                        id: Some(format!("p{i}")),
                        target: Some(format!("T{k}")),
                        ..row(p, k)
                    });
                }
            }
        }
    }
    rows
}

/// The file line of row `k` of pose `i` (a header line first).
fn rows_len(i: usize, k: usize, kind: Data) -> usize {
    let per = if kind == Data::Targets { 3 } else { 1 };
    2 + per * i + k
}

/// The library's calibration of `rows` (and `validate`) with `request`, from memory, as the
/// Python package and `kincal identify` give them; the kind it chose is `kind`'s.
fn calibrate(
    kind: Data,
    nominal: &LoadedRobot,
    request: &IdentifyRequest,
    rows: Vec<Measurement>,
    validate: Option<Vec<Measurement>>,
) -> Result<Calibration, Box<CalibrateError>> {
    let set = |name: &str, rows| MeasurementSet::new(name, 6, rows);
    let inputs = Inputs::from_sets(
        request,
        nominal.clone(),
        set("id.csv", rows),
        validate.map(|v| set("val.csv", v)),
    )?;
    let cal = calibrate::calibrate(request, inputs).map_err(Box::new)?;
    let expected = match kind {
        Data::Points => MeasurementKind::Points,
        Data::SixDof => MeasurementKind::SixDof { targets: 1 },
        Data::Targets => MeasurementKind::Targets { targets: 3 },
    };
    assert_eq!(cal.kind(), expected);
    Ok(cal)
}

/// The check a refusal names, if it is a plausibility refusal.
fn refused_by(e: &CalibrateError) -> Option<Check> {
    match e {
        CalibrateError::Refused(Refusal::Implausible { check, .. }) => Some(*check),
        _ => None,
    }
}

fn request(allow: &[Check]) -> IdentifyRequest {
    IdentifyRequest {
        allow: allow.to_vec(),
        ..IdentifyRequest::new("kr1000.json", "id.csv")
    }
}

/// `corrupt` applied to the rows of each kind is refused by `check` (the message holding
/// `says`), and not by it when the request allows it.
fn refused_on_every_kind(
    check: Check,
    says: &str,
    base: &IdentifyRequest,
    corrupt: impl Fn(&mut Vec<Measurement>),
) {
    let nominal = kr1000();
    for kind in KINDS {
        let mut rows = measured(kind, 40);
        corrupt(&mut rows);
        let e = calibrate(kind, &nominal, base, rows.clone(), None)
            .err()
            .unwrap_or_else(|| panic!("{kind:?}: not refused by {}", check.name()));
        assert_eq!(refused_by(&e), Some(check), "{kind:?}: {e}");
        assert!(e.to_string().contains(says), "{kind:?}: {e}");
        let allowed = IdentifyRequest {
            allow: [base.allow.clone(), vec![check]].concat(),
            ..base.clone()
        };
        if let Err(e) = calibrate(kind, &nominal, &allowed, rows, None) {
            assert_ne!(refused_by(&e), Some(check), "{kind:?} allowed: {e}");
        }
    }
}

/// Clean data of each kind pass every check and identify a2 (+0.4 mm) to 0.05 mm, a fold
/// holding out every other pose validating better than the nominal.
#[test]
fn every_kind_calibrates_clean_data() {
    let nominal = kr1000();
    let k = nominal.robot.layout().index_of("a2").unwrap();
    let split = IdentifyRequest {
        split: Split::Every {
            every: 2,
            offset: 0,
        },
        ..request(&[])
    };
    for kind in KINDS {
        let cal = calibrate(kind, &nominal, &split, measured(kind, 60), None).unwrap();
        let a2 = cal.identified_robot().params()[k] - nominal.robot.params()[k];
        assert!((a2 - 0.4).abs() < 0.05, "{kind:?}: a2 {a2:+.4}");
        assert!(cal.warnings().is_empty(), "{kind:?}: {:?}", cal.warnings());
        let (before, after) = match &cal {
            Calibration::Points(c) => {
                let v = c.validation.as_ref().unwrap();
                (v.table.before.norm.mean_mm, v.table.after.norm.mean_mm)
            }
            Calibration::ToolFrame(c) => {
                let (_, b, a) = c.validation.as_ref().unwrap();
                (b.position_mm.0, a.position_mm.0)
            }
        };
        assert!(
            after < 0.1 && after < before,
            "{kind:?}: {before} → {after}"
        );
    }
}

/// Joints in radians read as degrees.
#[test]
fn the_joint_units_check_runs_for_every_kind() {
    refused_on_every_kind(
        Check::JointUnits,
        "are these radians",
        &request(&[]),
        |rows| {
            for r in rows {
                for q in &mut r.q_deg {
                    *q = q.to_radians();
                }
            }
        },
    );
}

/// Points in metres.
#[test]
fn the_length_units_check_runs_for_every_kind() {
    refused_on_every_kind(Check::LengthUnits, "metres", &request(&[]), |rows| {
        for r in rows {
            let p = r.point_mm.as_mut().unwrap();
            for v in p {
                *v /= 1000.0;
            }
        }
    });
}

/// A left-handed measurement frame (x and y swapped).
#[test]
fn the_mirror_check_runs_for_every_kind() {
    refused_on_every_kind(Check::Mirror, "left-handed", &request(&[]), |rows| {
        for r in rows {
            let p = r.point_mm.as_mut().unwrap();
            p.swap(0, 1);
        }
    });
}

/// An outlier factor below the minimum, and a rejection that drops more than 35 % of the
/// units (rows, or poses): 16 of 40 poses moved by 800 mm, beyond what the robust screen
/// separates (the default screen and `reject_outliers` alike).
#[test]
fn the_outliers_check_runs_for_every_kind() {
    let low_k = IdentifyRequest {
        outlier_k: 1.0,
        ..request(&[])
    };
    refused_on_every_kind(Check::Outliers, "below 2", &low_k, |_| {});
    let allow = [Check::LengthUnits, Check::Mirror, Check::Parameters];
    let corrupt = |rows: &mut Vec<Measurement>| {
        for r in rows {
            let pose = (r.line - 2) / if r.target.is_some() { 3 } else { 1 };
            if pose % 5 < 2 {
                r.point_mm.as_mut().unwrap()[0] += 800.0;
            }
        }
    };
    refused_on_every_kind(Check::Outliers, "more than 35 %", &request(&allow), corrupt);
    let rejecting = IdentifyRequest {
        reject_outliers: true,
        ..request(&allow)
    };
    refused_on_every_kind(Check::Outliers, "more than 35 %", &rejecting, corrupt);
}

/// 15 % of the units (6 of 40 poses) 800 mm off: the default robust screen drops exactly
/// them, for every kind (one rule for points and for blocks of rows).
#[test]
fn the_default_screen_drops_gross_errors_for_every_kind() {
    let nominal = kr1000();
    for kind in KINDS {
        let mut rows = measured(kind, 40);
        for r in &mut rows {
            let pose = (r.line - 2) / if r.target.is_some() { 3 } else { 1 };
            if pose % 7 == 3 {
                r.point_mm.as_mut().unwrap()[0] += 800.0;
            }
        }
        let cal = calibrate(kind, &nominal, &request(&[]), rows, None)
            .unwrap_or_else(|e| panic!("{kind:?}: {e}"));
        let excluded = match &cal {
            Calibration::Points(c) => c.robust.as_ref().unwrap().excluded.clone(),
            Calibration::ToolFrame(c) => c.robust.as_ref().unwrap().excluded.clone(),
        };
        assert_eq!(excluded, vec![3, 10, 17, 24, 31, 38], "{kind:?}");
    }
}

/// Every point 2 % too large (a tracker's scale): the lengths all move in proportion.
#[test]
fn the_scale_check_runs_for_every_kind() {
    refused_on_every_kind(Check::Scale, "scaled by 1.02", &request(&[]), |rows| {
        for r in rows {
            if let Some(p) = &mut r.point_mm {
                p.iter_mut().for_each(|v| *v *= 1.02);
            }
        }
    });
}

/// A robot file whose a2 is 150 mm shorter than the robot measured.
#[test]
fn the_parameters_check_runs_for_every_kind() {
    let mut nominal = kr1000();
    let mut x = nominal.robot.params();
    x[nominal.robot.layout().index_of("a2").unwrap()] -= 150.0;
    nominal.robot = nominal.robot.with_params(&x).unwrap();
    for kind in KINDS {
        let rows = measured(kind, 40);
        let e = calibrate(kind, &nominal, &request(&[]), rows.clone(), None).unwrap_err();
        assert_eq!(refused_by(&e), Some(Check::Parameters), "{kind:?}: {e}");
        assert!(e.to_string().contains("a2 +150"), "{kind:?}: {e}");
        let allowed = request(&[Check::Parameters]);
        let cal = calibrate(kind, &nominal, &allowed, rows, None).unwrap();
        let k = nominal.robot.layout().index_of("a2").unwrap();
        let moved = cal.identified_robot().params()[k] - nominal.robot.params()[k];
        assert!((moved - 150.4).abs() < 0.05, "{kind:?}: a2 {moved:+.4}");
    }
}

/// Validation rows whose points carry three times the opposite of the start model's errors:
/// the calibrated model predicts them worse than the start model.
#[test]
fn the_validation_check_runs_for_every_kind() {
    let nominal = kr1000();
    for kind in KINDS {
        let mut rows = measured(kind, 40);
        let per = if kind == Data::Targets { 3 } else { 1 };
        let val = rows.split_off(30 * per);
        let cal = calibrate(kind, &nominal, &request(&[]), rows.clone(), None).unwrap();
        // The start model's point of each validation row.
        let start = |r: &Measurement| -> Vector3<f64> {
            let q: Vec<f64> = r.q_deg.iter().map(|v| v.to_radians()).collect();
            match &cal {
                Calibration::Points(c) => c.start.point(&q),
                Calibration::ToolFrame(c) => {
                    let f = c.start.robot.flange(&q);
                    let t = match r.target.as_deref() {
                        Some(name) => c.data.target_names.iter().position(|n| n == name).unwrap(),
                        None => 0,
                    };
                    f.rot * c.start.targets_mm[t] + f.pos_mm
                }
            }
        };
        let flipped: Vec<Measurement> = val
            .iter()
            .map(|r| {
                let (p0, p) = (start(r), Vector3::from(r.point_mm.unwrap()));
                let f = p0 - 3.0 * (p - p0);
                Measurement {
                    point_mm: Some([f.x, f.y, f.z]),
                    ..r.clone()
                }
            })
            .collect();
        let e = calibrate(
            kind,
            &nominal,
            &request(&[]),
            rows.clone(),
            Some(flipped.clone()),
        )
        .unwrap_err();
        assert_eq!(refused_by(&e), Some(Check::Validation), "{kind:?}: {e}");
        assert!(e.to_string().contains("predicts worse"), "{kind:?}: {e}");
        let allowed = request(&[Check::Validation]);
        calibrate(kind, &nominal, &allowed, rows, Some(flipped)).unwrap();
    }
}

/// A validation file listing the targets in another order validates the same (its rows are
/// renumbered to the identification data's targets); one naming a target the identification
/// data do not measure is refused, naming it.
#[test]
fn validation_targets_are_matched_by_name() {
    let nominal = kr1000();
    let mut rows = measured(Data::Targets, 40);
    let val = rows.split_off(90);
    let reversed: Vec<Measurement> = val
        .chunks(3)
        .flat_map(|p| p.iter().rev().cloned())
        .collect();
    let errors = |v: Vec<Measurement>| {
        let cal = calibrate(
            Data::Targets,
            &nominal,
            &request(&[]),
            rows.clone(),
            Some(v),
        )
        .unwrap();
        let c = cal.tool_frame().unwrap();
        let (_, before, after) = c.validation.clone().unwrap();
        (before, after)
    };
    let same = errors(val.clone());
    assert!(same.1.position_mm.0 < 0.1, "{same:?}");
    // The same errors, summed in another row order (to rounding).
    let other = errors(reversed);
    for (a, b) in [(other.0, same.0), (other.1, same.1)] {
        assert_eq!(a.poses, b.poses);
        assert!(
            (a.position_mm.0 - b.position_mm.0).abs() < 1e-9,
            "{a:?} {b:?}"
        );
        assert!(
            (a.position_mm.1 - b.position_mm.1).abs() < 1e-9,
            "{a:?} {b:?}"
        );
    }
    let unknown: Vec<Measurement> = val
        .iter()
        .map(|r| Measurement {
            target: r.target.as_deref().map(|t| t.replace("T2", "T9")),
            ..r.clone()
        })
        .collect();
    let e = calibrate(Data::Targets, &nominal, &request(&[]), rows, Some(unknown)).unwrap_err();
    assert!(
        matches!(*e, CalibrateError::Refused(Refusal::ValidationTarget { ref target, .. }) if target == "T9"),
        "{e}"
    );
}

/// Weak excitation and the prior, on every kind. A wrist (q6) moving 3° leaves the point
/// fit's wrist parameters undetermined (the prior holds them by default, the warning names
/// the joint); 6-DoF and multi-target data of the same poses determine them (the orientation
/// or the three reflectors see the wrist), so no prior is applied by default and the fit is
/// the least-squares one to the bit. An explicit prior applies to every kind: a 1 µm prior
/// on a2 holds it at the robot file's value. And the parameters check of every kind reads
/// the diagnosis: a parameter with a standard error beyond half its tolerance that moved too
/// far is weak excitation ("do not determine", what to measure), a determined one the robot
/// file, units and frame.
#[test]
fn weak_excitation_and_the_prior_apply_to_every_kind() {
    let nominal = kr1000();
    let k = nominal.robot.layout().index_of("a2").unwrap();
    for kind in KINDS {
        let rows = measured_q6(kind, 60, Some(3.0));
        let with = |prior: &str| IdentifyRequest {
            prior: prior.parse().unwrap(),
            ..request(&[])
        };
        let run = |prior: &str| {
            calibrate(kind, &nominal, &with(prior), rows.clone(), None)
                .unwrap_or_else(|e| panic!("{kind:?} --prior {prior}: {e}"))
        };
        let (auto, none) = (run("auto"), run("none"));
        let (diag, posterior) = match &auto {
            Calibration::Points(c) => (
                calibrate::excitation::diagnose(&c.start, &c.used, &c.fit),
                c.fit.posterior.clone(),
            ),
            Calibration::ToolFrame(c) => (
                calibrate::excitation::diagnose_frames(&c.start.robot, &c.data, &c.fit),
                c.fit.posterior.clone(),
            ),
        };
        assert_eq!(diag.small_joints, [5], "{kind:?}: {diag:?}");
        let w = auto.warnings().join("\n");
        if kind == Data::Points {
            let held = posterior.expect("the prior holds the wrist by default");
            assert!(!held.held_by_prior().is_empty());
            assert!(w.contains("weak excitation") && w.contains("q6 ("), "{w}");
        } else {
            assert!(diag.undetermined.is_empty(), "{kind:?}: {diag:?}");
            assert!(posterior.is_none() && w.is_empty(), "{kind:?}: {w}");
            assert_eq!(
                auto.identified_robot().params(),
                none.identified_robot().params(),
                "{kind:?}: auto is least squares when the data determine every parameter"
            );
        }
        // An explicit prior of 1 µm on a2 holds a2 within a tenth of its error (0.4 mm) of
        // the robot file's value.
        let a2 = |c: &Calibration| c.identified_robot().params()[k] - nominal.robot.params()[k];
        let held = run("tolerance,a2=0.001");
        assert!(a2(&none) > 0.3, "{kind:?}: a2 {:+.4}", a2(&none));
        assert!(
            a2(&held).abs() < 0.04,
            "{kind:?}: a2 {:+.4} held",
            a2(&held)
        );
        // The parameters check reads the diagnosis: standard errors beyond half the
        // tolerance (as weak data give) on theta5 make it undetermined.
        let robot = none.identified_robot();
        let mut weak = diag.clone();
        weak.undetermined = vec![calibrate::excitation::Undetermined {
            name: "theta5".into(),
            std_error: 14.0,
            tolerance: 5.0,
        }];
        weak.recommended_deg = Some(60.0);
        let moved = |name: &str, by: f64| {
            let mut x = robot.params();
            x[robot.layout().index_of(name).unwrap()] += by;
            let far = robot.with_params(&x).unwrap();
            let free: Vec<usize> = (0..robot.n_params()).collect();
            calibrate::excitation::parameters(&robot, &far, &free, &weak)
                .unwrap_err()
                .to_string()
        };
        let e = moved("theta5", 0.5);
        assert!(
            e.contains("do not determine") && e.contains("joint 6"),
            "{kind:?}: {e}"
        );
        assert!(moved("a2", 150.0).contains("units and frame"), "{kind:?}");
    }
}
