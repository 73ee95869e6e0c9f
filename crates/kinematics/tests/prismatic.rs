//! Prismatic joints (`docs/model.md` §2): the robot file's `type`, forward kinematics against
//! a known truth, the identification Jacobian against central differences, the fast kernels
//! against the reference chain, IK of a seven-joint chain with a linear track.

use kinematics::{
    JointType, ParamKind, PoseTrig, Robot, RobotSpec, Unit, joint_sin_cos, prismatic_internal,
};
use nalgebra::Vector3;
use proptest::prelude::*;

use crate::kinematics::check_jacobian;

const TRACK: &str = include_str!("../../../scenarios/robots/kr1000-track.json");
const KR1000: &str = include_str!("../../../scenarios/robots/kr1000-titan.json");

fn track() -> Robot {
    Robot::from_spec(&RobotSpec::from_json_str(TRACK, "kr1000-track.json").unwrap()).unwrap()
}

/// The KR1000 without its mass model (a prismatic chain refuses one).
fn kr1000() -> Robot {
    let mut spec = RobotSpec::from_json_str(KR1000, "kr1000-titan.json").unwrap();
    spec.mass_model = None;
    Robot::from_spec(&spec).unwrap()
}

#[test]
fn the_track_carries_the_kr1000_along_world_y() {
    let track = track();
    let arm = kr1000();
    let q_arm = [0.3, -0.2, 0.4, 1.0, 0.7, -0.5];
    for t_mm in [0.0, 2500.0, 10_000.0] {
        let mut q = vec![prismatic_internal(t_mm)];
        q.extend_from_slice(&q_arm);
        // Frame 1 of the track robot is the world frame moved by t along y, so the arm's
        // point (its own base frame = world) moves by (0, t, 0).
        let expected = arm.point(&q_arm) + Vector3::new(0.0, t_mm, 0.0);
        for p in [track.point(&q), track.point_reference(&q)] {
            assert!(
                (p - expected).norm() < 1e-9,
                "t = {t_mm} mm: {p:?} vs {expected:?}"
            );
        }
    }
}

#[test]
fn layout_adds_the_axis_scale_after_the_betas() {
    let r = track();
    let names = r.layout().names();
    // 7 joints × 4, beta3 (axes 3 and 4 of the chain are the KR1000's parallel 2 and 3),
    // scale1, 6 base, 3 tool.
    assert_eq!(names.len(), 28 + 1 + 1 + 9);
    assert_eq!(names[28], "beta3");
    assert_eq!(names[29], "scale1");
    assert_eq!(r.layout().get(29).kind, ParamKind::Scale(0));
    assert_eq!(r.layout().get(29).unit, Unit::MmPerMm);
    assert_eq!(names[30], "base_rx");
    assert_eq!(r.joint_type(0), JointType::Prismatic);
    assert_eq!(r.joint_type(1), JointType::Revolute);
    assert_eq!(r.wrist_joint(), Some(5));
}

#[test]
fn robot_file_round_trips_and_refuses_mixed_units() {
    let spec = RobotSpec::from_json_str(TRACK, "t").unwrap();
    let again = Robot::from_spec(&spec).unwrap().to_spec();
    // The prismatic joint exactly; revolute limits pass through radians as before.
    assert_eq!(again.joints[0], spec.joints[0]);
    for (a, b) in again.joints.iter().zip(&spec.joints) {
        assert_eq!(a.joint_type, b.joint_type);
        assert!((a.limits_deg[0] - b.limits_deg[0]).abs() < 1e-12);
    }
    let text = again.to_json_string();
    assert!(text.contains("\"type\": \"prismatic\"") && text.contains("\"limits_mm\""));
    assert_eq!(RobotSpec::from_json_str(&text, "t").unwrap(), again);
    // A revolute joint writes neither `type` nor `scale_mm_per_mm`.
    let kr = RobotSpec::from_json_str(KR1000, "k")
        .unwrap()
        .to_json_string();
    assert!(!kr.contains("\"type\"") && !kr.contains("scale_mm_per_mm"));
    for (from, to, what) in [
        (
            "\"limits_mm\": [0, 10000]",
            "\"limits_deg\": [0, 10000]",
            "limits_mm",
        ),
        (
            "\"scale_mm_per_mm\": 1 ",
            "\"scale_mm_per_mm\": 0 ",
            "scale_mm_per_mm",
        ),
    ] {
        let bad = TRACK.replacen(from, to, 1);
        assert_ne!(bad, TRACK);
        let e = RobotSpec::from_json_str(&bad, "t").unwrap_err().to_string();
        assert!(e.contains(what), "{e}");
    }
    let bad = KR1000.replacen(
        "\"limits_deg\": [-150, 150]",
        "\"limits_mm\": [-150, 150]",
        1,
    );
    let e = RobotSpec::from_json_str(&bad, "k").unwrap_err().to_string();
    assert!(e.contains("limits_mm"), "{e}");
    // The gravity model is revolute only.
    let mut with_mass = spec.clone();
    with_mass.mass_model = RobotSpec::from_json_str(KR1000, "k").unwrap().mass_model;
    assert!(with_mass.validate("t").is_err());
}

/// A robot with prismatic joints at the start and in the middle of the chain, scales ≠ 1,
/// and every parameter perturbed.
fn mixed(u: &[f64]) -> Robot {
    let mut spec = RobotSpec::from_json_str(TRACK, "t").unwrap();
    spec.joints[0].scale_mm_per_mm = 1.0 + 1e-3 * (u[0] - 0.5);
    // Joint 4 (the KR1000's A3) becomes a prismatic joint too.
    spec.joints[3].joint_type = JointType::Prismatic;
    spec.joints[3].limits_deg = [-300.0, 300.0];
    spec.joints[3].scale_mm_per_mm = 0.999;
    let r = Robot::from_spec(&spec).unwrap();
    let p: Vec<f64> = r
        .params()
        .iter()
        .zip(r.layout().params())
        .zip(u.iter().cycle().skip(1))
        .map(|((v, info), w)| match info.unit {
            Unit::MmPerMm => v + 1e-3 * (w - 0.5),
            _ => v + info.from_display((2.0 * w - 1.0) * 0.5),
        })
        .collect();
    r.with_params(&p).unwrap()
}

fn pose(r: &Robot, u: &[f64]) -> Vec<f64> {
    (0..r.n_joints())
        .map(|i| {
            let [lo, hi] = r.limits_rad(i);
            lo + (hi - lo) * u[i]
        })
        .collect()
}

/// The case that found the central difference's rounding error (`check_jacobian`'s doc): the
/// track far out, joint 4 (prismatic) near its zero, so that its scale column is short. With
/// the tolerance relative to the column alone it failed at 1.36e-6.
#[test]
fn a_short_column_far_out_is_held_to_the_difference_rounding() {
    let u = [
        0.0,
        0.6773153086063265,
        0.4047772917154892,
        0.3265685045976125,
        0.47586924905493827,
        0.21444574665566993,
        0.0,
        0.6380031070179886,
        0.04253662780471812,
        0.8451625352338811,
        0.7742702249026628,
        0.39405032930644235,
        0.0,
        0.30471887921380636,
        0.04594020641187881,
        0.12923368831772708,
        0.7300576330099909,
        0.29332029958085126,
        0.07094892995248173,
        0.2359786957753673,
        0.20694690352117123,
        0.6194142067367848,
        0.6548206028963814,
        0.8945723352441819,
        0.0,
        0.8708584834588371,
        0.08108769375096819,
        0.3835792238632053,
        0.22547960829906946,
        0.5849666877160905,
        0.4392650383277182,
        0.0,
        0.8218166830261259,
        0.5152806715477081,
        0.3440137232833693,
        0.0,
        0.0,
        0.0,
        0.3206022116963957,
        0.45094480486787725,
        0.7859822622871236,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
    ];
    let uq = [
        0.7486642554360231,
        0.8405709592372356,
        0.998962172770164,
        0.4988188526341384,
        0.0,
        0.7882226634936842,
        0.9798215989706418,
    ];
    let r = mixed(&u);
    check_jacobian(&r, &pose(&r, &uq)).unwrap();
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(300))]

    #[test]
    fn prismatic_jacobian_matches_central_differences(
        u in prop::collection::vec(0.0..1.0f64, 50),
        uq in prop::collection::vec(0.0..1.0f64, 7),
    ) {
        let r = mixed(&u);
        check_jacobian(&r, &pose(&r, &uq))?;
    }

    #[test]
    fn fast_kernels_match_the_reference_chain_and_each_other(
        u in prop::collection::vec(0.0..1.0f64, 50),
        uq in prop::collection::vec(0.0..1.0f64, 7 * 11),
    ) {
        let r = mixed(&u);
        let poses: Vec<f64> = uq.chunks_exact(7).flat_map(|c| pose(&r, c)).collect();
        let trig = PoseTrig::for_robot(&r, &poses);
        let np = r.n_params();
        let mut jx = vec![0.0; np];
        let mut jy = vec![0.0; np];
        let mut jz = vec![0.0; np];
        let mut cols = vec![Vector3::zeros(); np];
        for (j, q) in poses.chunks_exact(7).enumerate() {
            let p = r.point(q);
            let reference = r.point_reference(q);
            prop_assert!((p - reference).norm() <= 1e-9 * reference.norm().max(1.0));
            prop_assert_eq!(p, r.point_trig(trig.pose(j)));
            let f = r.flange(q);
            let fr = r.flange_reference(q);
            prop_assert!((f.pos_mm - fr.pos_mm).norm() < 1e-8 && (f.rot - fr.rot).norm() < 1e-12);
            let pj = r.point_jacobian_trig(trig.pose(j), &mut jx, &mut jy, &mut jz);
            prop_assert_eq!(pj, p);
            r.point_jacobian_into(q, &mut cols);
            for k in 0..np {
                let fast = Vector3::new(jx[k], jy[k], jz[k]);
                prop_assert!((fast - cols[k]).norm() <= 1e-9 * cols[k].norm().max(1.0), "column {k}");
            }
        }
        // The lane kernels give the one-pose bits, lane by lane.
        let mut jac = vec![[[0.0; kinematics::POSE_LANES]; 3]; np];
        for b in 0..trig.n_blocks() {
            let lanes = r.point_jacobian_lanes(trig.lanes(b), &mut jac);
            for t in 0..kinematics::POSE_LANES {
                let j = (b * kinematics::POSE_LANES + t).min(trig.n_poses() - 1);
                let p = r.point_jacobian_trig(trig.pose(j), &mut jx, &mut jy, &mut jz);
                prop_assert_eq!([lanes[0][t], lanes[1][t], lanes[2][t]], [p.x, p.y, p.z]);
                for k in 0..np {
                    prop_assert_eq!([jac[k][0][t], jac[k][1][t], jac[k][2][t]], [jx[k], jy[k], jz[k]]);
                }
            }
        }
    }
}

#[test]
#[should_panic(expected = "prismatic joint")]
fn pairs_built_without_the_joint_types_are_refused() {
    let r = track();
    let q = [prismatic_internal(5000.0), 0.1, 0.2, 0.3, 0.4, 0.5, 0.6];
    let mut sc = [[0.0; 2]; 7];
    joint_sin_cos(&q, &mut sc);
    let _ = r.point_trig(&sc);
}

#[test]
fn geometric_jacobian_of_the_track_is_its_axis() {
    let r = track();
    let q = [prismatic_internal(4000.0), 0.3, 0.2, -0.1, 0.5, 0.6, 0.2];
    let j = r.geometric_jacobian(&q, &Vector3::zeros(), 1000.0);
    // ∂p/∂q_1 per internal unit: 180/π mm along world y, no rotation.
    let v = 180.0 / std::f64::consts::PI;
    for (row, want) in [0.0, v, 0.0, 0.0, 0.0, 0.0].iter().enumerate() {
        assert!(
            (j[(row, 0)] - want).abs() < 1e-9,
            "row {row}: {}",
            j[(row, 0)]
        );
    }
    // Central difference of the flange origin.
    let h = 1e-6;
    let mut qp = q;
    qp[0] += h;
    let mut qm = q;
    qm[0] -= h;
    let fd = (r.flange(&qp).pos_mm - r.flange(&qm).pos_mm) / (2.0 * h);
    assert!((fd - Vector3::new(j[(0, 0)], j[(1, 0)], j[(2, 0)])).norm() < 1e-5);
}

#[test]
fn ik_holds_the_track_unless_asked_otherwise() {
    let r = mixed(&[0.3; 50]);
    let q_true = pose(&r, &[0.8, 0.4, 0.6, 0.5, 0.55, 0.7, 0.4]);
    let target = kinematics::IkTarget::point_with_orientation(&r, &q_true);
    let reached = |r: &Robot, q: &[f64]| {
        (r.flange(q).transform_point(&r.tool_mm()) - target.position_mm).norm()
    };
    let opts = kinematics::IkOptions::default();
    // Seven joints: the first prismatic one (the track) is held where it was commanded.
    assert_eq!(
        &r.ik_held()[..7],
        &[true, false, false, false, false, false, false]
    );
    let mut q = q_true.clone();
    for v in &mut q[1..] {
        *v += 0.05;
    }
    r.solve_ik(&target, &mut q, &opts)
        .expect("the arm alone reaches it");
    assert_eq!(q[0], q_true[0], "the held track did not move");
    assert!(reached(&r, &q) < 1e-5);
    // Held 200 mm away the arm cannot make up the distance...
    let mut q = q_true.clone();
    q[0] -= prismatic_internal(200.0);
    assert!(r.solve_ik(&target, &mut q, &opts).is_err());
    // ... freed, the track moves back.
    let mut free = r.clone();
    free.set_ik_held(Some(&[]));
    let mut q = q_true.clone();
    q[0] -= prismatic_internal(200.0);
    free.solve_ik(&target, &mut q, &opts)
        .expect("converges with the track free");
    assert!(reached(&free, &q) < 1e-5);
}
