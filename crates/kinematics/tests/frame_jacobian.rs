//! The flange frame's analytic derivatives ([`Robot::frame_jacobian_into`]) against central
//! differences, and the robot file's optional tool frame and targets.

use kinematics::{Robot, RobotSpec};
use nalgebra::{Matrix3, Vector3};

fn robot(name: &str) -> Robot {
    let path = format!(
        "{}/../../scenarios/robots/{name}",
        env!("CARGO_MANIFEST_DIR")
    );
    Robot::from_file(std::path::Path::new(&path)).expect("robot file")
}

/// The rotation vector ω with `R1 ≈ exp([ω]×)·R0` for nearby rotations: `vee(R1·R0ᵀ − I)`
/// to first order, antisymmetrised.
fn small_rotation(r1: &Matrix3<f64>, r0: &Matrix3<f64>) -> Vector3<f64> {
    let d = r1 * r0.transpose();
    Vector3::new(
        d[(2, 1)] - d[(1, 2)],
        d[(0, 2)] - d[(2, 0)],
        d[(1, 0)] - d[(0, 1)],
    ) * 0.5
}

fn check(r: &Robot, q: &[f64]) {
    let np = r.n_params();
    let (mut lin, mut ang) = (vec![Vector3::zeros(); np], vec![Vector3::zeros(); np]);
    let f = r.frame_jacobian_into(q, &mut lin, &mut ang);
    let f0 = r.flange(q);
    assert!((f.pos_mm - f0.pos_mm).norm() < 1e-9 && (f.rot - f0.rot).norm() < 1e-12);
    let x = r.params();
    for k in 0..np {
        let h = if r.layout().get(k).unit == kinematics::Unit::Mm {
            1e-4
        } else {
            1e-7
        };
        let (mut xp, mut xm) = (x.clone(), x.clone());
        xp[k] += h;
        xm[k] -= h;
        let (fp, fm) = (
            r.with_params(&xp).unwrap().flange(q),
            r.with_params(&xm).unwrap().flange(q),
        );
        let dlin = (fp.pos_mm - fm.pos_mm) / (2.0 * h);
        let dang = small_rotation(&fp.rot, &fm.rot) / (2.0 * h);
        let name = &r.layout().get(k).name;
        assert!(
            (dlin - lin[k]).norm() < 1e-5 * (1.0 + lin[k].norm()),
            "{name}: ∂o analytic {:?} numeric {:?}",
            lin[k],
            dlin
        );
        assert!(
            (dang - ang[k]).norm() < 1e-7 * (1.0 + ang[k].norm()),
            "{name}: ω analytic {:?} numeric {:?}",
            ang[k],
            dang
        );
    }
    // A point fixed in the flange: ∂p = ∂o + ω × (R t) is the point Jacobian.
    let mut cols = vec![Vector3::zeros(); np];
    let p = r.point_jacobian_into(q, &mut cols);
    let rt = f.rot * r.tool_mm();
    assert!((p - (f.pos_mm + rt)).norm() < 1e-9);
    for k in 0..np - 9 {
        let d = lin[k] + ang[k].cross(&rt);
        assert!((d - cols[k]).norm() < 1e-9 * (1.0 + d.norm()), "{k}");
    }
}

#[test]
fn flange_frame_jacobian_matches_central_differences() {
    for (name, q) in [
        ("kr1000-titan.json", [0.3, -1.2, 1.0, 0.4, 0.7, -0.5]),
        ("ur10.json", [-0.9, -1.5, 1.9, -1.1, -2.0, 0.2]),
    ] {
        let mut spec = robot(name).to_spec();
        // Off-nominal base and Hayati β so every column is exercised.
        spec.base = kinematics::BaseSpec::from_values([0.7, -1.1, 23.0, 150.0, -2400.0, 80.0]);
        spec.joints[1].beta_deg = 0.05;
        check(&Robot::from_spec(&spec).unwrap(), &q);
    }
}

#[test]
fn flange_frame_jacobian_of_an_extended_robot_matches_central_differences() {
    let r = robot("ur10.json")
        .with_extended(&["compliance_2", "gear_3_h1_sin"], "ur10")
        .unwrap();
    let mut x = r.params();
    let n = x.len();
    x[n - 2] = 3e-6;
    x[n - 1] = 1e-4;
    check(
        &r.with_params(&x).unwrap(),
        &[-0.9, -1.5, 1.9, -1.1, -2.0, 0.2],
    );
}

#[test]
fn tool_frame_and_targets_are_optional_and_round_trip() {
    let path = format!(
        "{}/../../scenarios/robots/ur10.json",
        env!("CARGO_MANIFEST_DIR")
    );
    let text = std::fs::read_to_string(&path).unwrap();
    let spec = RobotSpec::from_json_str(&text, "ur10").unwrap();
    assert!(spec.tool_rotation_deg.is_none() && spec.targets.is_none());
    // Without them the file writes as before: no new keys.
    let out = Robot::from_spec(&spec).unwrap().to_spec().to_json_string();
    assert!(!out.contains("tool_rotation_deg") && !out.contains("targets"));
    let with = text.replacen(
        "\"tool_mm\": [0, 0, 109],",
        "\"tool_mm\": [0, 0, 109], \"tool_rotation_deg\": [10, -20, 30], \
         \"targets\": [{\"name\": \"A\", \"point_mm\": [50, 0, 100]}],",
        1,
    );
    let spec2 = RobotSpec::from_json_str(&with, "ur10-tool").unwrap();
    let r2 = Robot::from_spec(&spec2).unwrap();
    let back = r2.to_spec();
    let rot = back.tool_rotation_deg.unwrap();
    for (a, b) in rot.iter().zip([10.0, -20.0, 30.0]) {
        assert!((a - b).abs() < 1e-12);
    }
    assert_eq!(back.targets, spec2.targets);
    let m = r2.tool_rotation();
    assert!((m.determinant() - 1.0).abs() < 1e-12 && (m - Matrix3::identity()).norm() > 0.1);
    // A repeated target name is refused, naming the field.
    let bad = with.replacen(
        "[{\"name\": \"A\", \"point_mm\": [50, 0, 100]}]",
        "[{\"name\": \"A\", \"point_mm\": [50, 0, 100]}, {\"name\": \"A\", \"point_mm\": [0, 0, 1]}]",
        1,
    );
    let e = RobotSpec::from_json_str(&bad, "ur10-bad")
        .unwrap_err()
        .to_string();
    assert!(e.contains("targets[1].name"), "{e}");
}
