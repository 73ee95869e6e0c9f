//! Registration: closed-form rigid fit, and real-data-like measurements in a frame rotated by
//! 120° and shifted by 3 m.

use crate::common::{TOOL, kr1000, max_point_diff, perturbed, poses};
use identify::{
    IdentifyError, IdentifyOptions, ParamSet, Problem, RegistrationPolicy, analyze, identify,
    kabsch, register_base,
};
use nalgebra::{Rotation3, Unit, Vector3};

fn far_frame() -> (Rotation3<f64>, Vector3<f64>) {
    let axis = Unit::new_normalize(Vector3::new(1.0, -2.0, 0.5));
    let rot = Rotation3::from_axis_angle(&axis, 120f64.to_radians());
    // 3 m away.
    let shift: Vector3<f64> = Vector3::new(2000.0, -2000.0, 1000.0);
    assert!((shift.norm() - 3000.0).abs() < 1e-9);
    (rot, shift)
}

#[test]
fn kabsch_recovers_a_known_transform_exactly() {
    let robot = kr1000(TOOL);
    let pts = robot.points(&poses(&robot, 20, 5));
    let (rot, shift) = far_frame();
    let moved: Vec<_> = pts.iter().map(|p| rot * p + shift).collect();
    let t = kabsch(&pts, &moved).unwrap();
    assert!((t.rotation - rot.matrix()).norm() < 1e-12);
    assert!((t.translation_mm - shift).norm() < 1e-9);
    assert!((t.angle_deg() - 120.0).abs() < 1e-9);
    // Planar points still determine the rotation (det correction, no reflection).
    let planar: Vec<_> = (0..6)
        .map(|i| Vector3::new(f64::from(i).cos() * 500.0, f64::from(i).sin() * 300.0, 0.0))
        .collect();
    let moved: Vec<_> = planar.iter().map(|p| rot * p + shift).collect();
    let t = kabsch(&planar, &moved).unwrap();
    assert!((t.rotation - rot.matrix()).norm() < 1e-12);
    assert!((t.rotation.determinant() - 1.0).abs() < 1e-12);
}

#[test]
fn kabsch_refuses_collinear_points() {
    let line: Vec<_> = (0..5)
        .map(|i| Vector3::new(f64::from(i), 0.0, 0.0))
        .collect();
    let err = kabsch(&line, &line).unwrap_err();
    assert!(matches!(err, IdentifyError::Registration { .. }));
    assert!(err.to_string().contains("collinear"), "{err}");
}

#[test]
fn measurements_in_a_far_frame_converge_after_registration() {
    let nominal = kr1000(TOOL);
    let poses_id = poses(&nominal, 50, 1);
    let poses_val = poses(&nominal, 50, 2);
    let all: Vec<usize> = (0..34).collect();
    let truth = perturbed(&nominal, &all, 31);
    let (rot, shift) = far_frame();
    let to_far = |pts: Vec<Vector3<f64>>| -> Vec<Vector3<f64>> {
        pts.iter().map(|p| rot * p + shift).collect()
    };
    let meas = to_far(truth.points(&poses_id));

    // The registered start model: base re-expressed, well inside the Euler chart.
    let (registered, rep) = register_base(&nominal, &poses_id, &meas).unwrap();
    assert!(rep.mean_error_before_mm > 1000.0);
    assert!(
        rep.mean_error_after_mm < 10.0,
        "{}",
        rep.mean_error_after_mm
    );
    assert!(
        (rep.rotation_deg - 120.0).abs() < 0.5,
        "{}",
        rep.rotation_deg
    );
    assert!(
        rep.base_after[1].abs() < 80.0,
        "base_ry {} near gimbal lock",
        rep.base_after[1]
    );
    // The minimal set resolved on the nominal model is still minimal on the registered one.
    let minimal = ParamSet::Minimal
        .resolve(&nominal, &poses_id, None, &Default::default())
        .unwrap();
    let rep = analyze(&registered, &poses_id, None, &minimal, &Default::default()).unwrap();
    assert_eq!(rep.rank, minimal.len());

    for set in [ParamSet::Paper, ParamSet::Minimal] {
        let free = set
            .resolve(&nominal, &poses_id, None, &Default::default())
            .unwrap();
        let problem = Problem::new(&nominal, &poses_id, &meas, free).unwrap();
        let fit = identify(&problem, &IdentifyOptions::default()).unwrap();
        let reg = fit.registration.as_ref().unwrap();
        assert!(
            reg.applied,
            "auto policy must register data {:.0} mm off",
            reg.mean_error_before_mm
        );
        assert!(fit.stop.converged(), "{set:?}: {}", fit.stop);
        // Held-out points, in the far frame, to 1e-6 mm.
        let predicted = fit.robot.points(&poses_val);
        let expected = to_far(truth.points(&poses_val));
        let worst = predicted
            .iter()
            .zip(&expected)
            .map(|(p, q)| (p - q).norm())
            .fold(0.0, f64::max);
        assert!(worst < 1e-6, "{set:?}: held-out error {worst:e} mm");
    }
}

#[test]
fn auto_policy_leaves_close_data_alone() {
    let nominal = kr1000(TOOL);
    let poses_id = poses(&nominal, 40, 1);
    let truth = perturbed(&nominal, &(0..34).collect::<Vec<_>>(), 8);
    let meas = truth.points(&poses_id);
    let problem = Problem::new(&nominal, &poses_id, &meas, (0..34).collect()).unwrap();
    let fit = identify(&problem, &IdentifyOptions::default()).unwrap();
    let reg = fit.registration.unwrap();
    assert!(!reg.applied);
    assert!(reg.mean_error_before_mm < 10.0);
    assert_eq!(reg.base_before, reg.base_after);
    // Always: registration of already-close data changes little and still converges.
    let opts = IdentifyOptions {
        registration: RegistrationPolicy::Always,
        ..Default::default()
    };
    let fit = identify(&problem, &opts).unwrap();
    assert!(fit.registration.unwrap().applied);
    assert!(fit.stop.converged());
    assert!(max_point_diff(&fit.robot, &truth, &poses(&nominal, 30, 2)) < 1e-6);
}
