//! Prismatic joints through the URDF: the PR2's lifting torso (a public URDF, BSD) imported,
//! identified from simulated measurements with a known truth, exported and re-imported.

use identify::{IdentifyOptions, ParamSet, Problem, identify};
use kinematics::{JointType, Robot, prismatic_internal};
use nalgebra::Vector3;
use urdf::{ExportOptions, ImportOptions, export, import_file, import_str};

use crate::common::{Rng, fixture, urdf_point};

const BASE: &str = "base_link";
const TIP: &str = "l_elbow_flex_link";
/// A probe 150 mm along the forearm and off its axis, mm (tip link frame).
const PROBE: [f64; 3] = [150.0, 20.0, -30.0];

fn pr2() -> urdf::Imported {
    let opts = ImportOptions {
        tool_in_tip_mm: PROBE,
        ..ImportOptions::default()
    };
    import_file(&fixture("pr2_torso_left_arm.urdf"), BASE, TIP, &opts).unwrap()
}

#[test]
fn the_pr2_torso_imports_as_a_prismatic_joint() {
    let imported = pr2();
    let spec = &imported.spec;
    let types: Vec<JointType> = spec.joints.iter().map(|j| j.joint_type).collect();
    assert_eq!(
        types,
        [
            JointType::Prismatic,
            JointType::Revolute,
            JointType::Revolute,
            JointType::Revolute,
            JointType::Revolute
        ]
    );
    // 0 … 0.33 m in the URDF, millimetres in the robot file.
    assert_eq!(spec.joints[0].limits_deg, [0.0, 330.0]);
    assert_eq!(spec.joints[0].scale_mm_per_mm, 1.0);
    assert_eq!(imported.joint_names[0], "torso_lift_joint");
    assert_eq!(imported.fixed_joints, ["l_upper_arm_joint"]);
    // The robot file's point is the URDF's, torso raised or not.
    let text = std::fs::read_to_string(fixture("pr2_torso_left_arm.urdf")).unwrap();
    let parsed = urdf_rs::read_from_string(&text).unwrap();
    let robot = Robot::from_spec(spec).unwrap();
    let mut rng = Rng(5);
    for _ in 0..500 {
        let q = rng.pose(&robot);
        let u = urdf_point(&parsed, BASE, TIP, &q, &Vector3::from(PROBE));
        assert!((robot.point(&q) - u).norm() < 1e-9, "{q:?}");
    }
    // Raising the torso by 100 mm lifts the probe by 100 mm.
    let mut q = rng.pose(&robot);
    let p0 = robot.point(&q);
    q[0] += prismatic_internal(100.0);
    assert!((robot.point(&q) - p0 - Vector3::new(0.0, 0.0, 100.0)).norm() < 1e-9);
}

/// Standard normal draws from [`Rng`] (Box–Muller).
fn normal(rng: &mut Rng) -> f64 {
    let (u1, u2) = (rng.next().max(1e-300), rng.next());
    (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
}

#[test]
fn identified_from_simulated_data_with_unit_z_scores_then_exported_and_reimported() {
    const SIGMA_MM: f64 = 0.02;
    const DRAWS: usize = 40;
    let nominal = Robot::from_spec(&pr2().spec).unwrap();
    let mut rng = Rng(17);
    let poses: Vec<f64> = (0..40).flat_map(|_| rng.pose(&nominal)).collect();
    let free = ParamSet::Minimal
        .resolve(&nominal, &poses, None, &Default::default())
        .unwrap();
    let names: Vec<&str> = free
        .iter()
        .map(|&k| nominal.layout().get(k).name.as_str())
        .collect();
    // The torso's axis scale is determined by the data (its travel moves the probe).
    assert!(names.contains(&"scale1"), "{names:?}");
    // The truth: the free (identifiable) parameters moved, the others at their nominal
    // values, so the minimal set's estimates are unbiased for it.
    let mut x = nominal.params();
    for &k in &free {
        let info = nominal.layout().get(k);
        x[k] += match info.unit {
            kinematics::Unit::Deg => 0.05_f64.to_radians() * normal(&mut rng),
            kinematics::Unit::MmPerMm => 5e-4 * normal(&mut rng),
            _ => 0.5 * normal(&mut rng),
        };
    }
    let truth = nominal.with_params(&x).unwrap();
    let clean = truth.points(&poses);
    let mut z = Vec::new();
    let mut last = None;
    for _ in 0..DRAWS {
        let meas: Vec<Vector3<f64>> = clean
            .iter()
            .map(|p| {
                p + Vector3::new(normal(&mut rng), normal(&mut rng), normal(&mut rng)) * SIGMA_MM
            })
            .collect();
        let problem = Problem::new(&nominal, &poses, &meas, free.clone()).unwrap();
        let fit = identify(&problem, &IdentifyOptions::default()).unwrap();
        assert!(fit.stop.converged(), "{}", fit.stop);
        let cov = fit.covariance.as_ref().unwrap();
        let est = fit.robot.params();
        for (i, &k) in cov.indices.iter().enumerate() {
            let info = fit.robot.layout().get(k);
            let d = info.to_display(est[k]) - info.to_display(x[k]);
            z.push(d / cov.std_errors[i]);
        }
        last = Some(fit.robot);
    }
    let n = z.len() as f64;
    let mean = z.iter().sum::<f64>() / n;
    let sd = (z.iter().map(|v| (v - mean) * (v - mean)).sum::<f64>() / (n - 1.0)).sqrt();
    assert!(
        (sd - 1.0).abs() < 0.15,
        "z-scores: mean {mean:.3}, sd {sd:.3} over {n} values"
    );
    assert!(mean.abs() < 0.15, "z-scores: mean {mean:.3}, sd {sd:.3}");

    // The identified robot, its axis scale held at 1 for a URDF (which cannot carry one).
    let identified = last.unwrap();
    let mut spec = identified.to_spec();
    assert_ne!(spec.joints[0].scale_mm_per_mm, 1.0);
    let refused = export(&spec, &ExportOptions::default())
        .unwrap_err()
        .to_string();
    assert!(refused.contains("scale1"), "{refused}");
    spec.joints[0].scale_mm_per_mm = 1.0;
    let text = export(&spec, &ExportOptions::default()).unwrap();
    assert!(text.contains("type=\"prismatic\"") && text.contains("upper=\"0.33\""));
    let back = import_str(
        &text,
        "exported",
        "measurement",
        "tool",
        &ImportOptions::default(),
    )
    .unwrap()
    .spec;
    assert_eq!(back.joints[0].joint_type, JointType::Prismatic);
    assert_eq!(back.joints[0].limits_deg, spec.joints[0].limits_deg);
    let (a, b) = (
        Robot::from_spec(&spec).unwrap(),
        Robot::from_spec(&back).unwrap(),
    );
    let parsed = urdf_rs::read_from_string(&text).unwrap();
    for q in poses.chunks_exact(5) {
        let p = a.point(q);
        assert!((p - b.point(q)).norm() < 1e-9, "re-imported: {q:?}");
        let u = urdf_point(&parsed, "measurement", "tool", q, &Vector3::zeros());
        assert!((p - u).norm() < 1e-9, "URDF: {q:?}");
    }
}
