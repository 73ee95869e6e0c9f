//! Known-truth and property tests of forward kinematics, the identification Jacobian,
//! inverse kinematics and model-file validation.

use kinematics::{
    BaseSpec, Frame, IkError, IkOptions, IkTarget, JointSpec, JointType, MAX_JOINTS, ModelError,
    POSE_LANES, PoseTrig, Robot, RobotSpec, Unit,
};
use nalgebra::Vector3;
use proptest::prelude::*;

const KR1000: &str = include_str!("../../../scenarios/robots/kr1000-titan.json");

fn kr1000() -> Robot {
    Robot::from_spec(&RobotSpec::from_json_str(KR1000, "kr1000-titan.json").unwrap()).unwrap()
}

#[test]
fn kr1000_target_at_zero_pose() {
    let mut r = kr1000();
    r.set_tool_mm(Vector3::zeros());
    let p = r.point(&[0.0; 6]);
    assert!(
        (p - Vector3::new(2172.0, 0.0, 2565.0)).norm() < 1e-9,
        "q = 0 target at {p:?}, docs/model.md §2 says (2172, 0, 2565)"
    );
}

#[test]
fn kr1000_layout_is_the_papers_34() {
    let r = kr1000();
    let names = r.layout().names();
    assert_eq!(names.len(), 34);
    assert_eq!(&names[..4], &["theta1", "d1", "a1", "alpha1"]);
    assert_eq!(names[23], "alpha6");
    assert_eq!(names[24], "beta2");
    assert_eq!(
        &names[25..],
        &[
            "base_rx", "base_ry", "base_rz", "base_dx", "base_dy", "base_dz", "tool_x", "tool_y",
            "tool_z"
        ]
    );
    assert_eq!(r.layout().get(24).unit, Unit::Deg);
    assert_eq!(r.layout().get(1).unit, Unit::Mm);
    assert!(r.layout().select(&["d7"]).is_err());
    assert_eq!(
        r.layout().select(&["tool_z", "d1", "d1"]).unwrap(),
        vec![1, 33]
    );
}

#[test]
fn spec_round_trip_preserves_parameters() {
    let r = kr1000();
    let mut p = r.params();
    for (k, v) in p.iter_mut().enumerate() {
        *v += 1e-3 * (k as f64 + 1.0);
    }
    let r2 = r.with_params(&p).unwrap();
    let text = r2.to_spec().to_json_string();
    let r3 = Robot::from_spec(&RobotSpec::from_json_str(&text, "round-trip").unwrap()).unwrap();
    for (a, b) in r2.params().iter().zip(r3.params()) {
        assert!((a - b).abs() <= 1e-12 * a.abs().max(1.0), "{a} vs {b}");
    }
}

/// A 7-joint chain with random geometry; twists drawn from {0, ±90°, arbitrary} so that
/// some joints get a β parameter.
fn random_chain(u: &[f64]) -> Robot {
    random_chain_of(7, u)
}

/// [`random_chain`] with `n` joints (`u`: 6n + 9 draws).
fn random_chain_of(n: usize, u: &[f64]) -> Robot {
    let b = &u[6 * n..];
    let joints = (0..n)
        .map(|i| {
            let w = &u[6 * i..6 * i + 6];
            let alpha_deg = match (w[3] * 4.0) as usize {
                0 => 0.0,
                1 => 90.0,
                2 => -90.0,
                _ => 180.0 * w[4] - 90.0,
            };
            JointSpec {
                theta_deg: 360.0 * w[0] - 180.0,
                d_mm: 1500.0 * w[1] - 500.0,
                a_mm: 1500.0 * w[2] - 500.0,
                alpha_deg,
                beta_deg: if alpha_deg == 0.0 {
                    4.0 * w[5] - 2.0
                } else {
                    0.0
                },
                limits_deg: [-170.0, 170.0],
                joint_type: JointType::Revolute,
                scale_mm_per_mm: 1.0,
            }
        })
        .collect();
    let spec = RobotSpec {
        name: format!("random {n}R"),
        joints,
        base: BaseSpec {
            rx_deg: 40.0 * b[0] - 20.0,
            ry_deg: 40.0 * b[1] - 20.0,
            rz_deg: 360.0 * b[2] - 180.0,
            dx_mm: 2000.0 * b[3] - 1000.0,
            dy_mm: 2000.0 * b[4] - 1000.0,
            dz_mm: 500.0 * b[5],
        },
        tool_mm: [200.0 * b[6] - 100.0, 200.0 * b[7] - 100.0, 300.0 * b[8]],
        joint_names: None,
        mass_model: None,
        extended: None,
        tool_rotation_deg: None,
        targets: None,
        prior_sd: None,
        controller: None,
        provenance: None,
    };
    Robot::from_spec(&spec).unwrap()
}

/// Perturbs every parameter by up to ±0.5° or ±1 mm (a calibrated-like robot).
fn perturbed(r: &Robot, u: &[f64]) -> Robot {
    let p: Vec<f64> = r
        .params()
        .iter()
        .zip(r.layout().params())
        .zip(u)
        .map(|((v, info), w)| v + info.from_display((2.0 * w - 1.0) * 0.5))
        .collect();
    r.with_params(&p).unwrap()
}

fn in_limit_pose(r: &Robot, u: &[f64]) -> Vec<f64> {
    (0..r.n_joints())
        .map(|i| {
            let [lo, hi] = r.limits_rad(i);
            lo + (hi - lo) * u[i]
        })
        .collect()
}

/// Compares each analytic column with a central difference, relative to the column norm
/// (floored at 1 mm per unit so that near-zero columns are held to an absolute 1e-6), plus
/// the central difference's own rounding error, `8·ε·‖p‖/h`: the point's coordinates carry
/// ε·‖p‖ each, divided by the step. It matters for a short column at a point far out — the
/// scale of a prismatic joint near its zero with the robot 8 m along its track gives
/// 8·2.2e-16·8000/1e-6 = 1.4e-5 against a column of 0.7 —, and is negligible elsewhere (a
/// wrong column is off by the order of the column itself).
pub(crate) fn check_jacobian(r: &Robot, q: &[f64]) -> Result<(), TestCaseError> {
    let np = r.n_params();
    let mut cols = vec![Vector3::zeros(); np];
    let p0 = r.point_jacobian_into(q, &mut cols);
    prop_assert!((p0 - r.point(q)).norm() < 1e-9);
    let base = r.params();
    for k in 0..np {
        let h = match r.layout().get(k).unit {
            Unit::Deg => 1e-6,
            Unit::Mm => 1e-4,
            Unit::MmPerMm => 1e-6,
            // Geometric robots only here (tests/extended.rs covers the others).
            Unit::MicroradPerNm | Unit::Arcsec => unreachable!("a geometric robot"),
        };
        let mut p = base.clone();
        p[k] = base[k] + h;
        let plus = r.with_params(&p).unwrap().point(q);
        p[k] = base[k] - h;
        let minus = r.with_params(&p).unwrap().point(q);
        let fd = (plus - minus) / (2.0 * h);
        let rounding_mm = 8.0 * f64::EPSILON * p0.norm() / h;
        let err = (cols[k] - fd).norm() / (cols[k].norm().max(1.0) + rounding_mm / 1e-6);
        prop_assert!(
            err < 1e-6,
            "column {} ({}): analytic {:?} vs numeric {:?}, relative error {:e}",
            k,
            r.layout().get(k).name,
            cols[k],
            fd,
            err
        );
    }
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(10_000))]

    #[test]
    fn kr1000_jacobian_matches_central_differences(
        uq in prop::collection::vec(0.0..1.0f64, 6),
        up in prop::collection::vec(0.0..1.0f64, 34),
    ) {
        let r = perturbed(&kr1000(), &up);
        check_jacobian(&r, &in_limit_pose(&r, &uq))?;
    }

    #[test]
    fn random_7r_jacobian_matches_central_differences(
        ug in prop::collection::vec(0.0..1.0f64, 51),
        uq in prop::collection::vec(0.0..1.0f64, 7),
        up in prop::collection::vec(0.0..1.0f64, 7 * 5 + 9),
    ) {
        let r = random_chain(&ug);
        let r = perturbed(&r, &up);
        check_jacobian(&r, &in_limit_pose(&r, &uq))?;
    }

    /// The fast kernels (sin/cos once per pose, the point backwards, frames by column
    /// mixing) against the straightforward composition, within 1e-12 relative to the reach.
    #[test]
    fn fast_kernels_match_the_reference(
        ug in prop::collection::vec(0.0..1.0f64, 51),
        uq in prop::collection::vec(0.0..1.0f64, 7),
        up in prop::collection::vec(0.0..1.0f64, 7 * 5 + 9),
    ) {
        let r = perturbed(&random_chain(&ug), &up);
        check_fast_against_reference(&r, &in_limit_pose(&r, &uq))?;
        let k = perturbed(&kr1000(), &up[..34]);
        check_fast_against_reference(&k, &in_limit_pose(&k, &uq[..6]))?;
    }
}

/// The pose-parallel kernels give, lane by lane, the one-pose kernels' bits.
#[test]
fn lane_kernels_match_the_one_pose_kernels_bit_for_bit() {
    let mut u = Uniform(7);
    for case in 0..20 {
        let r = perturbed(&random_chain(&u.vec(51)), &u.vec(44));
        let r = if case % 2 == 0 {
            r
        } else {
            perturbed(&kr1000(), &u.vec(34))
        };
        let n = r.n_joints();
        let m = 3 + case; // partial last blocks too
        let poses: Vec<f64> = (0..m).flat_map(|_| in_limit_pose(&r, &u.vec(n))).collect();
        let trig = PoseTrig::new(n, &poses);
        let np = r.n_params();
        let mut jac = vec![[[0.0; POSE_LANES]; 3]; np];
        for b in 0..trig.n_blocks() {
            let lanes = trig.lanes(b);
            let p = r.point_lanes(lanes);
            let pj = r.point_jacobian_lanes(lanes, &mut jac);
            assert_eq!(p, pj);
            // The selected columns in the slots asked for, the others nowhere (a
            // sentinel stays in the spare slot).
            let chosen: Vec<usize> = (0..np).filter(|k| (k + case) % 3 != 0).collect();
            let mut slot = vec![usize::MAX; np];
            for (c, &k) in chosen.iter().enumerate() {
                slot[k] = chosen.len() - 1 - c;
            }
            let sentinel = [[f64::NAN; POSE_LANES]; 3];
            let mut out = vec![sentinel; chosen.len() + 1];
            let pm = r.point_jacobian_lanes_to(lanes, &slot, &mut out);
            assert_eq!(p, pm);
            for (c, &k) in chosen.iter().enumerate() {
                assert_eq!(out[chosen.len() - 1 - c], jac[k], "column {k}");
            }
            assert!(out[chosen.len()].iter().flatten().all(|v| v.is_nan()));
            for t in 0..POSE_LANES {
                let j = (b * POSE_LANES + t).min(m - 1);
                let (mut jx, mut jy, mut jz) = (vec![0.0; np], vec![0.0; np], vec![0.0; np]);
                let one = r.point_jacobian_trig(trig.pose(j), &mut jx, &mut jy, &mut jz);
                assert_eq!(one, r.point(&poses[j * n..(j + 1) * n]));
                assert_eq!([p[0][t], p[1][t], p[2][t]], [one.x, one.y, one.z]);
                for k in 0..np {
                    assert_eq!(
                        [jac[k][0][t], jac[k][1][t], jac[k][2][t]],
                        [jx[k], jy[k], jz[k]]
                    );
                }
            }
        }
    }
}

fn check_fast_against_reference(r: &Robot, q: &[f64]) -> Result<(), TestCaseError> {
    let tol = 1e-12 * 1e4;
    let reference = r.flange_reference(q);
    let fast = r.flange(q);
    prop_assert!((fast.pos_mm - reference.pos_mm).norm() < tol);
    prop_assert!((fast.rot - reference.rot).norm() < 1e-12);
    let mut frames = [Frame::identity(); MAX_JOINTS + 1];
    r.frames_into(q, &mut frames);
    prop_assert_eq!(frames[r.n_joints()], fast);
    prop_assert!((r.point(q) - r.point_reference(q)).norm() < tol);
    let trig = PoseTrig::new(r.n_joints(), q);
    prop_assert_eq!(r.point_trig(trig.pose(0)), r.point(q));
    // Jacobian: reference columns vs the fast rows.
    let np = r.n_params();
    let mut cols = vec![Vector3::zeros(); np];
    r.point_jacobian_into(q, &mut cols);
    let (mut jx, mut jy, mut jz) = (vec![0.0; np], vec![0.0; np], vec![0.0; np]);
    let p = r.point_jacobian_trig(trig.pose(0), &mut jx, &mut jy, &mut jz);
    prop_assert_eq!(p, r.point(q));
    for k in 0..np {
        let d = (Vector3::new(jx[k], jy[k], jz[k]) - cols[k]).norm();
        prop_assert!(d <= 1e-12 * cols[k].norm().max(1e4), "column {k}: {d:e}");
    }
    let (pts, jac) = r.jacobian_batch(q);
    prop_assert_eq!(pts[0], p);
    for k in 0..np {
        prop_assert_eq!(jac[(0, k)], jx[k]);
    }
    Ok(())
}

/// xorshift64*: a fixed, dependency-free uniform stream so the IK sample is the same on
/// every run (the kinematics crate has no randomness of its own).
struct Uniform(u64);
impl Uniform {
    fn next(&mut self) -> f64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        (self.0.wrapping_mul(0x2545_F491_4F6C_DD1D) >> 11) as f64 / (1u64 << 53) as f64
    }
    fn vec(&mut self, n: usize) -> Vec<f64> {
        (0..n).map(|_| self.next()).collect()
    }
}

/// IK round trip on 10,000 random in-limit poses of perturbed (calibrated-like) KR1000s,
/// from a start 5° away on every joint, for both target forms. Poses are kept away from
/// singularities — condition number of the scaled geometric Jacobian ≤ 50 and |q5| ≥ 10°
/// (what the pose sampler enforces) — because nearer than that a start 5° away can lie on
/// the other side of the singularity, where the nearest solution is another branch, often
/// outside the joint limits. There IK reports failure instead (measured: 2 in ~50,000
/// poses at cond ≤ 50, ~40 in 20,000 with no exclusion).
#[test]
fn ik_round_trip_on_calibrated_like_kr1000s() {
    let nominal = kr1000();
    let mut u = Uniform(0x9E37_79B9_7F4A_7C15);
    let mut solved = 0;
    while solved < 10_000 {
        let r = perturbed(&nominal, &u.vec(34));
        let q = in_limit_pose(&r, &u.vec(6));
        if q[4].abs() < 10f64.to_radians() || r.singularity_condition(&q, 1000.0) > 50.0 {
            continue;
        }
        let mut start: Vec<f64> = q
            .iter()
            .enumerate()
            .map(|(i, v)| {
                let d = 5f64.to_radians();
                if v + d <= r.limits_rad(i)[1] {
                    v + d
                } else {
                    v - d
                }
            })
            .collect();
        let target = if solved % 2 == 0 {
            IkTarget::point_with_orientation(&r, &q)
        } else {
            IkTarget::flange(&r.flange(&q))
        };
        let rep = r.solve_ik(&target, &mut start, &IkOptions::default());
        assert!(rep.is_ok(), "IK failed from q = {q:?}: {rep:?}");
        let f = r.flange(&start);
        let p = f.transform_point(&target.point_in_flange_mm);
        assert!((p - target.position_mm).norm() < 1e-6);
        // ‖R* − R‖_F = 2√2·sin(θ/2) ≈ √2·θ: an orientation check independent of the solver.
        let angle = (target.rotation - f.rot).norm() / 2f64.sqrt();
        assert!(angle < 1e-9, "orientation error {angle:e} rad");
        assert!(r.in_limits(&start));
        solved += 1;
    }
}

#[test]
fn ik_reports_unreachable_targets() {
    let r = kr1000();
    let q = [0.3, 0.2, -0.4, 0.5, 0.6, 0.7];
    // 10 m away: outside the workspace.
    let mut target = IkTarget::flange(&r.flange(&q));
    target.position_mm += Vector3::new(10_000.0, 0.0, 0.0);
    let mut start = q;
    match r.solve_ik(&target, &mut start, &IkOptions::default()) {
        Err(IkError::NotConverged { pos_err_mm, .. }) => assert!(pos_err_mm > 1000.0),
        other => panic!("expected NotConverged, got {other:?}"),
    }
    // Reachable geometrically but only with q2 beyond its 107.5° limit.
    let q_out = [0.0, 125f64.to_radians(), -0.4, 0.0, 0.6, 0.0];
    let target = IkTarget::flange(&r.flange(&q_out));
    let mut start = [0.0, 100f64.to_radians(), -0.4, 0.0, 0.6, 0.0];
    let res = r.solve_ik(&target, &mut start, &IkOptions::default());
    assert!(matches!(res, Err(IkError::NotConverged { .. })), "{res:?}");
    assert!(
        r.in_limits(&start),
        "failed IK must still leave q within limits"
    );
}

fn spec_error(text: &str) -> String {
    match RobotSpec::from_json_str(text, "bad.json") {
        Ok(_) => panic!("accepted a bad model"),
        Err(e) => e.to_string(),
    }
}

#[test]
fn bad_robot_files_name_the_field() {
    let missing = KR1000.replacen("\"d_mm\": 0,    \"a_mm\": 1400", "\"a_mm\": 1400", 1);
    let msg = spec_error(&missing);
    assert!(msg.contains("joints[1]") && msg.contains("d_mm"), "{msg}");

    let nan = KR1000.replacen("\"a_mm\": 1400", "\"a_mm\": NaN", 1);
    let msg = spec_error(&nan);
    assert!(
        msg.contains("bad.json") && msg.contains("joints[1].a_mm"),
        "{msg}"
    );

    let reversed = KR1000.replacen("[-40, 107.5]", "[107.5, -40]", 1);
    let msg = spec_error(&reversed);
    assert!(msg.contains("joints[1].limits_deg"), "{msg}");

    let unknown = KR1000.replacen("\"tool_mm\"", "\"payload_kg\": 5, \"tool_mm\"", 1);
    let msg = spec_error(&unknown);
    assert!(msg.contains("payload_kg"), "{msg}");

    let unknown_in_joint = KR1000.replacen("\"beta_deg\": 0,", "\"beta_deg\": 0, \"gear\": 1,", 1);
    let msg = spec_error(&unknown_in_joint);
    assert!(msg.contains("joints[0]") && msg.contains("gear"), "{msg}");

    let overflow = KR1000.replacen("\"a_mm\": 1400", "\"a_mm\": 1e999", 1);
    let msg = spec_error(&overflow);
    assert!(msg.contains("joints[1].a_mm"), "{msg}");

    let r = Robot::from_file(std::path::Path::new("/nonexistent/robot.json"));
    assert!(matches!(r, Err(ModelError::Io { .. })));
}

/// One base-frame type, two formats: the robot file's `base` requires all six fields; the
/// scenario's form ([`BaseSpec::deserialize_omitted_zero`]) lets them be omitted (zero).
/// Both refuse unknown fields, and both give the same transform for the same values.
#[test]
fn base_spec_requires_six_in_the_robot_file_and_defaults_in_the_scenario_form() {
    let partial = KR1000.replacen(", \"dz_mm\": 0 }", " }", 1);
    assert_ne!(partial, KR1000);
    let msg = spec_error(&partial);
    assert!(msg.contains("base") && msg.contains("dz_mm"), "{msg}");
    let nan = KR1000.replacen("\"dy_mm\": 0", "\"dy_mm\": NaN", 1);
    let msg = spec_error(&nan);
    assert!(msg.contains("base.dy_mm"), "{msg}");

    #[derive(serde::Deserialize)]
    struct Scenario {
        #[serde(deserialize_with = "BaseSpec::deserialize_omitted_zero")]
        base: BaseSpec,
    }
    let read = |text: &str| serde_json::from_str::<Scenario>(text).map(|s| s.base);
    let b = read(r#"{ "base": { "rz_deg": 0.002, "dx_mm": 0.05 } }"#).unwrap();
    assert_eq!(b.values(), [0.0, 0.0, 0.002, 0.05, 0.0, 0.0]);
    assert!(!b.is_zero() && read(r#"{ "base": {} }"#).unwrap().is_zero());
    let e = read(r#"{ "base": { "rz_deg": 1, "gear": 1 } }"#).unwrap_err();
    assert!(e.to_string().contains("unknown field `gear`"), "{e}");
    let e = read(r#"{ "base": { "rz_deg": 1, "rz_deg": 2 } }"#).unwrap_err();
    assert!(e.to_string().contains("duplicate field `rz_deg`"), "{e}");
    let full: BaseSpec = serde_json::from_str(
        r#"{ "rx_deg": 1, "ry_deg": -2, "rz_deg": 3, "dx_mm": 4, "dy_mm": 5, "dz_mm": 6 }"#,
    )
    .unwrap();
    let same = read(
        r#"{ "base": { "dz_mm": 6, "dy_mm": 5, "dx_mm": 4, "rz_deg": 3, "ry_deg": -2, "rx_deg": 1 } }"#,
    )
    .unwrap();
    assert_eq!(full, same);
    assert_eq!(full.frame(), same.frame());
    // The robot's base frame is the same transform of the same values.
    let mut spec = RobotSpec::from_json_str(KR1000, "kr1000").unwrap();
    spec.base = full.clone();
    let robot = Robot::from_spec(&spec).unwrap();
    assert_eq!(robot.base_frame(), full.frame());
}

/// A robot file that starts with a UTF-8 byte-order mark (as some Windows editors save
/// JSON) reads as the same robot, where it gave "expected value at line 1 column 1".
#[test]
fn a_robot_file_with_a_byte_order_mark_reads_as_without() {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../scenarios/robots/ur10.json"
    );
    let text = std::fs::read_to_string(path).unwrap();
    let plain = RobotSpec::from_json_str(&text, "ur10.json").unwrap();
    let marked = RobotSpec::from_json_str(&format!("\u{feff}{text}"), "ur10.json").unwrap();
    assert_eq!(plain.to_json_string(), marked.to_json_string());
}

/// A CSV (or anything but a JSON object) given as a robot file is refused saying what it
/// starts with and what a robot file is, where serde said "expected value at line 1 column
/// 1"; an empty file is called empty.
#[test]
fn a_csv_given_as_a_robot_file_is_named_as_such() {
    let e = RobotSpec::from_json_str("id,q1,q2,q3,q4,q5,q6,x,y,z\n1,0,0,0,0,0,0,1,2,3\n", "m.csv")
        .unwrap_err()
        .to_string();
    assert!(e.starts_with("m.csv: "), "{e}");
    assert!(
        e.contains("starts with `id,q1,q2,q3,q4,q5,q6,x,y,z`"),
        "{e}"
    );
    assert!(e.contains("JSON object"), "{e}");
    assert!(!e.contains("expected value"), "{e}");
    let e = RobotSpec::from_json_str(" \n", "e.json")
        .unwrap_err()
        .to_string();
    assert!(e.contains("the file is empty"), "{e}");
}

/// σ_max/σ_min of the allocating (dynamic) Jacobian's SVD, ∞ at a singularity: what
/// `Robot::singularity_condition` computes on a fixed-size matrix.
fn allocating_condition(r: &Robot, q: &[f64]) -> f64 {
    let sv = r
        .geometric_jacobian(q, &Vector3::zeros(), 1000.0)
        .singular_values();
    if sv.min() > 0.0 {
        sv.max() / sv.min()
    } else {
        f64::INFINITY
    }
}

/// The condition number of every chain length with a fixed-size Jacobian (1 to 8,
/// `stack_linalg::SVD_COLUMNS`) and one beyond it is bit
/// for bit the SVD of the allocating Jacobian, on random revolute chains and on the track's
/// prismatic joint: a transposed fill of the stack matrix, or another decomposition, fails
/// it.
#[test]
fn every_fixed_size_condition_is_the_allocating_svds() {
    let mut u = Uniform(0x9E37_79B9_7F4A_7C15);
    for n in 1..=*stack_linalg::SVD_COLUMNS.end() + 1 {
        for k in 0..40 {
            let r = random_chain_of(n, &u.vec(6 * n + 9));
            let q = in_limit_pose(&r, &u.vec(n));
            let expected = allocating_condition(&r, &q);
            let got = r.singularity_condition(&q, 1000.0);
            assert_eq!(got.to_bits(), expected.to_bits(), "{n} joints, pose {k}");
        }
    }
    // A prismatic joint's columns (zeros in the orientation rows): the seven-joint track.
    let track = Robot::from_file(std::path::Path::new(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../scenarios/robots/kr1000-track.json"
    )))
    .unwrap();
    for k in 0..100 {
        let q = in_limit_pose(&track, &u.vec(7));
        let expected = allocating_condition(&track, &q);
        let got = track.singularity_condition(&q, 1000.0);
        assert_eq!(got.to_bits(), expected.to_bits(), "track, pose {k}");
    }
}

/// The six-joint condition number (a fixed-size SVD on the stack, issue 43) is bit for bit
/// the SVD of the allocating Jacobian, near the wrist singularity too; `param(k)` reads
/// what `set_params` wrote.
#[test]
fn six_joint_condition_is_the_allocating_svds_and_param_reads_params() {
    let nominal = kr1000();
    let mut u = Uniform(0x2545_F491_4F6C_DD1D);
    for k in 0..400 {
        let r = perturbed(&nominal, &u.vec(34));
        let mut q = in_limit_pose(&r, &u.vec(6));
        if k % 4 == 0 {
            q[4] = 1e-7 * k as f64;
        }
        let expected = allocating_condition(&r, &q);
        let got = r.singularity_condition(&q, 1000.0);
        assert_eq!(
            got.to_bits(),
            expected.to_bits(),
            "pose {k}: {got} vs {expected}"
        );
        let mut set = r.clone();
        let values: Vec<f64> = (0..34)
            .map(|i| 1e-3 * (i as f64 + 1.0) * u.vec(1)[0])
            .collect();
        set.set_params(&values).unwrap();
        for (i, v) in values.iter().enumerate() {
            assert_eq!(set.param(i).to_bits(), v.to_bits(), "parameter {i}");
        }
    }
}

/// A [`PoseTrig`] built from the buffers a dropped one left on the thread (a larger pose
/// set) equals one built on a fresh thread.
#[test]
fn pose_trig_from_reused_buffers_is_a_fresh_ones() {
    let r = kr1000();
    let mut u = Uniform(0x9E37_79B9_7F4A_7C15);
    let pose_set = |u: &mut Uniform, m: usize| -> Vec<f64> {
        (0..m).flat_map(|_| in_limit_pose(&r, &u.vec(6))).collect()
    };
    let (big, small) = (pose_set(&mut u, 37), pose_set(&mut u, 5));
    let fresh = std::thread::scope(|s| s.spawn(|| PoseTrig::for_robot(&r, &small)).join().unwrap());
    drop(PoseTrig::for_robot(&r, &big));
    let reused = PoseTrig::for_robot(&r, &small);
    assert_eq!(reused, fresh);
    assert_eq!(reused.n_poses(), 5);
}
