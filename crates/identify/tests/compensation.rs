//! Compensation that stays near the robot's pose (issue 29): on random KR1000 targets for a
//! calibrated-like robot, every compensated row is an exact solution within the limits, a
//! row is flagged exactly when it moves a joint by more than the threshold (with a reason),
//! and a target is called unreachable only when an independent solver — a multi-start
//! damped Newton on finite-difference Jacobians of the forward kinematics, written here —
//! finds no exact solution within the limits either; nor does it find a solution nearer the
//! commanded joints than a flagged row's.

use identify::{CompensationOptions, compensate_nearest, compensation_target};
use kinematics::{IkTarget, IkUnreachable, Robot};
use nalgebra::{DMatrix, DVector, Rotation3, Vector3};

use crate::common::compensation_targets::{Rng, kr1000_pair, random_poses};

/// The 6-D error (mm; rad × 1000 mm) of the flange-held point at `q`.
fn error(robot: &Robot, target: &IkTarget, q: &[f64]) -> DVector<f64> {
    let f = robot.flange(q);
    let p = f.transform_point(&target.point_in_flange_mm);
    let m = target.rotation * f.rot.transpose();
    // The skew part (sin θ · axis) near zero, where the trace-based angle loses half the
    // digits; the axis-angle vector elsewhere (the skew part vanishes again at π).
    let skew = Vector3::new(
        m[(2, 1)] - m[(1, 2)],
        m[(0, 2)] - m[(2, 0)],
        m[(1, 0)] - m[(0, 1)],
    ) * 0.5;
    let w = if m.trace() > 2.99 {
        skew * 1000.0
    } else {
        Rotation3::from_matrix_unchecked(m).scaled_axis() * 1000.0
    };
    let e = target.position_mm - p;
    DVector::from_vec(vec![e.x, e.y, e.z, w.x, w.y, w.z])
}

/// Independent IK: damped Newton (Levenberg–Marquardt, central differences of the forward
/// kinematics, steps clamped into the limits) from `start`; the solution if it reaches the
/// target within 1e-6 mm and 1e-9 rad.
fn newton(robot: &Robot, target: &IkTarget, start: &[f64]) -> Option<Vec<f64>> {
    let n = start.len();
    let mut q = start.to_vec();
    let limits: Vec<[f64; 2]> = (0..n).map(|i| robot.limits_rad(i)).collect();
    let mut e = error(robot, target, &q);
    let mut lambda = 1e-3;
    for _ in 0..300 {
        if e.rows(0, 3).norm() < 1e-7 && e.rows(3, 3).norm() < 1e-7 {
            return Some(q);
        }
        let mut j = DMatrix::zeros(6, n);
        for i in 0..n {
            let h = 1e-7;
            let (mut a, mut b) = (q.clone(), q.clone());
            a[i] += h;
            b[i] -= h;
            let d = (error(robot, target, &b) - error(robot, target, &a)) / (2.0 * h);
            j.set_column(i, &d);
        }
        let jt = j.transpose();
        let mut a = &jt * &j;
        for k in 0..n {
            a[(k, k)] += lambda * (1.0 + a[(k, k)]);
        }
        let Some(step) = a.cholesky().map(|c| c.solve(&(&jt * &e))) else {
            lambda *= 10.0;
            continue;
        };
        let trial: Vec<f64> = (0..n)
            .map(|i| (q[i] + step[i].clamp(-0.3, 0.3)).clamp(limits[i][0], limits[i][1]))
            .collect();
        let et = error(robot, target, &trial);
        if et.norm() < e.norm() {
            q = trial;
            e = et;
            lambda = (lambda * 0.2).max(1e-12);
        } else {
            lambda *= 10.0;
            if lambda > 1e10 {
                return None;
            }
        }
    }
    None
}

/// Largest joint change, rad.
fn change(a: &[f64], b: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f64::max)
}

#[test]
fn nearest_compensation_flags_large_changes_and_calls_unreachable_only_what_is() {
    let (nominal, identified) = kr1000_pair();
    let opts = CompensationOptions::default();
    let poses = random_poses(&nominal, 500, 29);
    let mut rng = Rng(77);
    let (mut flagged, mut unreachable) = (0, 0);
    for (k, q0) in poses.iter().enumerate() {
        let target = compensation_target(&nominal, &identified, q0);
        let mut q = q0.clone();
        match compensate_nearest(&nominal, &identified, &mut q, &opts) {
            Ok(c) => {
                // Exact, within the limits, and the change reported is the change made.
                let e = error(&identified, &target, &q);
                assert!(e.norm() < 1e-5, "target {k}: error {e}");
                assert!(identified.in_limits(&q), "target {k}: {q:?}");
                let dq = change(&q, q0).to_degrees();
                assert!((dq - c.max_change_deg).abs() < 1e-9, "target {k}");
                assert_eq!(
                    c.flags.is_empty(),
                    dq <= opts.flag_change_deg,
                    "target {k}: change {dq}°, flags {:?}",
                    c.flags
                );
                if !c.flags.is_empty() {
                    flagged += 1;
                    // No solution nearer the commanded joints from starts around them.
                    for _ in 0..40 {
                        let s: Vec<f64> = q0
                            .iter()
                            .map(|v| v + (2.0 * rng.unit() - 1.0) * dq.to_radians())
                            .collect();
                        if let Some(other) = newton(&identified, &target, &s) {
                            let d = change(&other, q0).to_degrees();
                            assert!(
                                d >= dq - 1e-3,
                                "target {k}: the independent solver found a solution {d}° \
                                 away, nearer than {dq}°"
                            );
                        }
                    }
                }
            }
            Err(why) => {
                unreachable += 1;
                assert!(
                    matches!(
                        why,
                        IkUnreachable::BeyondLimit { .. } | IkUnreachable::BeyondReach { .. }
                    ),
                    "target {k}: {why}"
                );
                assert_eq!(&q, q0, "target {k}: the commanded joints are restored");
                // The independent solver, from the commanded joints and 300 random starts
                // within the limits, finds no exact solution within them either.
                let mut starts = vec![q0.clone()];
                starts.extend(random_poses(&identified, 300, 1000 + k as u64));
                for s in &starts {
                    assert!(
                        newton(&identified, &target, s).is_none(),
                        "target {k} ({why}): the independent solver reached it from {s:?}"
                    );
                }
            }
        }
    }
    println!("500 targets: {flagged} flagged, {unreachable} unreachable");
    // The draws are seeded: these counts are regression figures (the 10,000-target run of
    // `examples/compensation_count.rs` gives 549 and 53).
    assert!(flagged > 10 && unreachable > 0, "{flagged} {unreachable}");
}

/// A stretched elbow whose calibrated arm is a millimetre shorter: the target is beyond
/// reach on every branch, and the reason says so; one just past joint 1's limit is beyond
/// that limit.
#[test]
fn unreachable_targets_name_their_reason() {
    let (nominal, _) = kr1000_pair();
    let layout = nominal.layout();
    let mut p = nominal.params();
    p[layout.index_of("a2").unwrap()] -= 1.0;
    let shorter = nominal.with_params(&p).unwrap();
    // q3 such that the wrist centre, axis 2 and axis 3 are collinear: the elbow stretched.
    let elbow = |q3: f64| {
        nominal
            .arm_singularity(&[0.3, 0.2, q3, 0.4, 0.9, 0.1])
            .unwrap()
            .elbow_deg
    };
    // Golden-section search of the elbow angle's minimum over q3 in [−120°, −60°].
    let (mut lo, mut hi) = (-120f64.to_radians(), -60f64.to_radians());
    for _ in 0..100 {
        let (a, b) = (hi - 0.618 * (hi - lo), lo + 0.618 * (hi - lo));
        if elbow(a) < elbow(b) { hi = b } else { lo = a }
    }
    let stretched = 0.5 * (lo + hi);
    let q0 = [0.3, 0.2, stretched, 0.4, 0.9, 0.1];
    let s = nominal.arm_singularity(&q0).unwrap();
    assert!(s.elbow_deg < 0.01, "{s:?}");
    let mut q = q0;
    let why = compensate_nearest(&nominal, &shorter, &mut q, &CompensationOptions::default())
        .unwrap_err();
    assert!(
        matches!(why, IkUnreachable::BeyondReach { pos_err_mm, .. } if pos_err_mm > 0.01),
        "{why}"
    );
    assert!(why.to_string().starts_with("beyond reach"), "{why}");

    // Joint 1 at its limit, the calibrated θ1 0.1° further: beyond q1's limit.
    let mut p = nominal.params();
    p[layout.index_of("theta1").unwrap()] -= 0.1f64.to_radians();
    let turned = nominal.with_params(&p).unwrap();
    let q0 = [150.0f64.to_radians(), 0.2, -1.2, 0.4, 0.9, 0.1];
    let mut q = q0;
    let why =
        compensate_nearest(&nominal, &turned, &mut q, &CompensationOptions::default()).unwrap_err();
    assert!(
        matches!(why, IkUnreachable::BeyondLimit { joint: 0, value_rad, .. }
            if (value_rad.to_degrees() - 150.1).abs() < 1e-6),
        "{why}"
    );
}
