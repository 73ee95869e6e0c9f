//! Export: the URDF reproduces the robot file's points; robot file → URDF → robot file keeps
//! every point to machine precision.

use crate::common::{Rng, urdf_point};
use kinematics::{Robot, RobotSpec};
use nalgebra::Vector3;
use proptest::prelude::*;
use urdf::{ExportOptions, ImportOptions, export, import_str, offsets_json};

fn repo_robot(name: &str) -> RobotSpec {
    let p = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../scenarios/robots")
        .join(name);
    RobotSpec::from_file(&p).unwrap()
}

/// Worst distance between the robot file's points and (a) the exported URDF's own
/// kinematics, (b) the re-imported robot file's, on `poses` random in-limit poses.
fn round_trip(spec: &RobotSpec, poses: usize, seed: u64) -> (f64, f64) {
    let text = export(spec, &ExportOptions::default()).unwrap();
    let parsed = urdf_rs::read_from_string(&text).unwrap();
    assert!(!text.contains("calibration"));
    let back = import_str(
        &text,
        "exported",
        "measurement",
        "tool",
        &ImportOptions::default(),
    )
    .unwrap();
    assert_eq!(back.spec.joints.len(), spec.joints.len());
    for (a, b) in spec.joints.iter().zip(&back.spec.joints) {
        for k in 0..2 {
            assert!((a.limits_deg[k] - b.limits_deg[k]).abs() < 1e-12);
        }
    }
    assert_eq!(
        back.joint_names,
        (1..=spec.joints.len())
            .map(|i| format!("joint_{i}"))
            .collect::<Vec<_>>()
    );
    let robot = Robot::from_spec(spec).unwrap();
    let robot2 = Robot::from_spec(&back.spec).unwrap();
    let mut rng = Rng(seed);
    let (mut urdf_worst, mut back_worst) = (0.0_f64, 0.0_f64);
    for _ in 0..poses {
        let q = rng.pose(&robot);
        let p = robot.point(&q);
        let u = urdf_point(&parsed, "measurement", "tool", &q, &Vector3::zeros());
        urdf_worst = urdf_worst.max((p - u).norm());
        back_worst = back_worst.max((p - robot2.point(&q)).norm());
    }
    (urdf_worst, back_worst)
}

#[test]
fn kr1000_and_ur10_round_trip_to_machine_precision() {
    for name in ["kr1000-titan.json", "ur10.json"] {
        let (u, b) = round_trip(&repo_robot(name), 1000, 11);
        println!("{name}: URDF vs robot file {u:e} mm, re-imported vs robot file {b:e} mm");
        assert!(u < 1e-9 && b < 1e-9, "{name}: {u:e} {b:e}");
    }
}

#[test]
fn export_is_deterministic_and_names_what_it_is_given() {
    let spec = repo_robot("ur10.json");
    let names: Vec<String> = [
        "shoulder_pan_joint",
        "shoulder_lift_joint",
        "elbow_joint",
        "wrist_1_joint",
        "wrist_2_joint",
        "wrist_3_joint",
    ]
    .map(String::from)
    .to_vec();
    let opts = ExportOptions {
        joint_names: Some(names.clone()),
        robot_name: Some("ur10_calibrated".into()),
    };
    let a = export(&spec, &opts).unwrap();
    assert_eq!(a, export(&spec, &opts).unwrap());
    let parsed = urdf_rs::read_from_string(&a).unwrap();
    assert_eq!(parsed.name, "ur10_calibrated");
    let back = import_str(&a, "x", "measurement", "tool", &ImportOptions::default()).unwrap();
    assert_eq!(back.joint_names, names);
    // The wrong number of names is refused.
    let bad = ExportOptions {
        joint_names: Some(names[..5].to_vec()),
        robot_name: None,
    };
    assert!(
        export(&spec, &bad)
            .unwrap_err()
            .to_string()
            .contains("5 joint names")
    );
}

#[test]
fn joint_names_survive_the_robot_file_and_the_robot() {
    let mut spec = repo_robot("ur10.json");
    assert_eq!(spec.joint_names, None);
    let names: Vec<String> = (1..=6).map(|i| format!("axis {i}")).collect();
    spec.joint_names = Some(names.clone());
    let text = spec.to_json_string();
    let back = RobotSpec::from_json_str(&text, "t").unwrap();
    assert_eq!(Robot::from_spec(&back).unwrap().to_spec(), spec);
    let urdf_text = export(&spec, &ExportOptions::default()).unwrap();
    assert!(urdf_text.contains("<joint name=\"axis 6\" type=\"revolute\">"));
    // A file without names reads and writes as before; a wrong count is refused.
    let plain = repo_robot("kr1000-titan.json");
    assert!(!plain.to_json_string().contains("joint_names"));
    let bad = text.replace("\"axis 6\"", "\"axis 5\"");
    let e = RobotSpec::from_json_str(&bad, "t").unwrap_err().to_string();
    assert!(
        e.contains("joint_names[5]") && e.contains("repeated"),
        "{e}"
    );
}

#[test]
fn offsets_file_lists_theta_and_its_change() {
    let nominal = repo_robot("ur10.json");
    let mut cal = nominal.clone();
    cal.joints[1].theta_deg = 0.25;
    let text = offsets_json(&cal, Some(&nominal), &ExportOptions::default()).unwrap();
    let v: serde_json::Value = serde_json::from_str(&text).unwrap();
    assert_eq!(v["joints"][1]["name"], "joint_2");
    assert_eq!(v["joints"][1]["delta_deg"], 0.25);
    assert_eq!(v["joints"][0]["delta_deg"], 0.0);
}

/// A robot file with every parameter perturbed (angles in degrees, lengths in mm).
fn perturbed(base: &RobotSpec, d: &[f64]) -> RobotSpec {
    let mut s = base.clone();
    let mut k = 0;
    let mut next = |scale: f64| {
        let v = d[k % d.len()] * scale;
        k += 1;
        v
    };
    for j in &mut s.joints {
        j.theta_deg += next(20.0);
        j.d_mm += next(20.0);
        j.a_mm += next(20.0);
        j.alpha_deg += next(5.0);
        j.beta_deg += next(2.0);
    }
    s.base.rx_deg += next(60.0);
    s.base.ry_deg += next(60.0);
    s.base.rz_deg += next(180.0);
    s.base.dx_mm += next(3000.0);
    s.base.dy_mm += next(3000.0);
    s.base.dz_mm += next(1000.0);
    for t in &mut s.tool_mm {
        *t += next(200.0);
    }
    s
}

/// Sum of every length of a robot file, mm.
fn lengths(s: &RobotSpec) -> f64 {
    s.joints
        .iter()
        .map(|j| j.d_mm.abs() + j.a_mm.abs())
        .sum::<f64>()
        + s.base.dx_mm.abs()
        + s.base.dy_mm.abs()
        + s.base.dz_mm.abs()
        + s.tool_mm.iter().map(|v| v.abs()).sum::<f64>()
}

fn reimport(spec: &RobotSpec) -> RobotSpec {
    let text = export(spec, &ExportOptions::default()).unwrap();
    import_str(&text, "x", "measurement", "tool", &ImportOptions::default())
        .unwrap()
        .spec
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(48))]
    #[test]
    fn round_trip_of_perturbed_robots(
        d in proptest::collection::vec(-1.0f64..1.0, 48),
        seed in 0u64..1000,
        ur in any::<bool>(),
    ) {
        let base = repo_robot(if ur { "ur10.json" } else { "kr1000-titan.json" });
        let spec = perturbed(&base, &d);
        let (u, b) = round_trip(&spec, 50, seed);
        // Machine precision of the lengths involved: axes a few degrees from parallel
        // (beyond the robot file's 1° for Hayati's β) get a common normal metres away.
        let tol = 1e-10 + 1e-13 * (lengths(&spec) + lengths(&reimport(&spec)));
        prop_assert!(u < tol && b < tol, "{u:e} {b:e} (tolerance {tol:e})");
    }
}

/// The identified tool frame of a 6-DoF calibration (`tool_rotation_deg`) is the
/// `tool_fixed` joint's rotation; without it the export is as before (identity rpy).
#[test]
fn export_carries_the_tool_orientation() {
    let spec = repo_robot("ur10.json");
    let plain = export(&spec, &ExportOptions::default()).unwrap();
    let tool_line = |text: &str| {
        let at = text.find("<joint name=\"tool_fixed\"").unwrap();
        text[at..]
            .lines()
            .find(|l| l.contains("<origin"))
            .unwrap()
            .to_string()
    };
    assert!(
        tool_line(&plain).contains("rpy=\"0 0 0\""),
        "{}",
        tool_line(&plain)
    );
    let mut with = spec.clone();
    with.tool_rotation_deg = Some([0.0, 0.0, -90.0]);
    let text = export(&with, &ExportOptions::default()).unwrap();
    let line = tool_line(&text);
    assert!(line.contains("rpy=\"0 0 -1.5707963267948"), "{line}");
}
