//! The non-geometric joint-error families (issue 19, `docs/extended-model.md`): joint
//! compliance `compliance_j` and gear harmonics `gear_j_hk_sin|cos`. Their Jacobian columns
//! against central differences, the vertical axis that sees no gravity torque, names and
//! units, and the errors that name the field.

use kinematics::{
    ExtendedKind, ExtendedModel, Gravity, ModelError, ParamKind, Robot, RobotSpec, Unit,
};
use nalgebra::Vector3;

fn robot(name: &str) -> Robot {
    Robot::from_file(std::path::Path::new(&format!(
        "{}/../../scenarios/robots/{name}",
        env!("CARGO_MANIFEST_DIR")
    )))
    .unwrap()
}

/// A small deterministic generator in [−1, 1).
fn rnd(state: &mut u64) -> f64 {
    *state = state
        .wrapping_mul(6_364_136_223_846_793_005)
        .wrapping_add(1_442_695_040_888_963_407);
    ((*state >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
}

/// Every compliance parameter and the first two harmonics of every joint.
fn all_names(n: usize) -> Vec<String> {
    let mut v = Vec::new();
    for j in 1..=n {
        v.push(format!("compliance_{j}"));
        for k in 1..=2 {
            v.push(format!("gear_{j}_h{k}_sin"));
            v.push(format!("gear_{j}_h{k}_cos"));
        }
    }
    v
}

/// Random in-limit joints (within 90 % of each range, at most ±0.9π).
fn pose(robot: &Robot, s: &mut u64) -> Vec<f64> {
    (0..robot.n_joints())
        .map(|i| {
            let [lo, hi] = robot.limits_rad(i);
            let (mid, half) = (
                0.5 * (lo + hi),
                (0.45 * (hi - lo)).min(0.9 * std::f64::consts::PI),
            );
            mid + half * rnd(s)
        })
        .collect()
}

/// The weights from their definition, independently of the crate's angle-addition path:
/// τ_j by [`Gravity::torques_nm`] on `nominal` at `q`, `sin(k q_j)`, `cos(k q_j)` by `f64`.
fn reference_weights(nominal: &Robot, kinds: &[ExtendedKind], q: &[f64]) -> Vec<f64> {
    let mut tau = vec![0.0; q.len()];
    Gravity::from_spec(nominal.mass_model().unwrap()).torques_nm(nominal, q, &mut tau);
    kinds
        .iter()
        .map(|k| match *k {
            ExtendedKind::Compliance(j) => tau[j],
            ExtendedKind::GearSin { joint, harmonic } => (f64::from(harmonic) * q[joint]).sin(),
            ExtendedKind::GearCos { joint, harmonic } => (f64::from(harmonic) * q[joint]).cos(),
        })
        .collect()
}

/// The extended robot's point from the definition: its geometric chain at
/// `q̃ = q + Σ_k w_k x_k`, weights by [`reference_weights`] on `nominal`.
fn reference_point(ext: &Robot, nominal: &Robot, q: &[f64]) -> Vector3<f64> {
    let model = ext.extended().unwrap();
    let w = reference_weights(nominal, model.kinds(), q);
    let mut qe = q.to_vec();
    for ((k, wk), x) in model.kinds().iter().zip(&w).zip(model.values()) {
        qe[k.joint()] += wk * x;
    }
    ext.with_extended::<&str>(&[], "geometric")
        .unwrap()
        .point(&qe)
}

#[test]
fn jacobian_columns_match_central_differences() {
    let mut s = 7;
    for file in ["kr1000-titan.json", "ur10.json"] {
        let nominal = robot(file);
        let names = all_names(nominal.n_joints());
        // Extended on the nominal (the torques stay there), then a perturbed geometry, so
        // that torques and chain differ as in an identification.
        let ext0 = nominal.with_extended(&names, file).unwrap();
        let mut p = ext0.params();
        for (k, v) in p.iter_mut().enumerate() {
            let info = ext0.layout().get(k);
            *v += match info.kind {
                // Values of realistic size: compliance 0.01–1 µrad/(N·m), gears ±20″.
                ParamKind::Extended(e @ ExtendedKind::Compliance(_)) => {
                    e.from_display(0.5 + 0.5 * rnd(&mut s))
                }
                ParamKind::Extended(e) => e.from_display(20.0 * rnd(&mut s)),
                _ => 1e-3 * rnd(&mut s) * if info.unit == Unit::Mm { 100.0 } else { 1.0 },
            };
        }
        let ext = ext0.with_params(&p).unwrap();
        let g = nominal.n_params();
        let kinds = ext.extended().unwrap().kinds().to_vec();
        for _ in 0..20 {
            let q = pose(&nominal, &mut s);
            let mut cols = vec![Vector3::zeros(); ext.n_params()];
            let p0 = ext.point_jacobian_into(&q, &mut cols);
            assert!((p0 - reference_point(&ext, &nominal, &q)).norm() < 1e-9);
            // Extended columns: central difference in x_k with the step that moves the joint
            // by δ = 1e-5 rad (h_k = δ/|w_k|): truncation δ²/6·|∂³p/∂q³| ≲ 1e-10·4000 mm and
            // rounding ε·|p|/δ ≈ 2e-16·4000/1e-5 mm, both ≲ 1e-7 mm per rad of joint motion,
            // so the difference agrees to 1e-6 relative.
            let w = reference_weights(&nominal, &kinds, &q);
            for (i, kind) in kinds.iter().enumerate() {
                let k = g + i;
                let h = 1e-5 / w[i].abs().max(1e-3);
                let at = |d: f64| {
                    let mut v = p.clone();
                    v[k] += d;
                    ext.with_params(&v).unwrap().point(&q)
                };
                let num = (at(h) - at(-h)) / (2.0 * h);
                // Truncation error h²/6·|p'''| and rounding eps·|p|/h: with |p| ≲ 4 m and the
                // steps above, both are far below 1e-4 of a column of ≳ 1 mm per unit.
                let tol = 1e-6 * (1.0 + num.norm());
                assert!(
                    (num - cols[k]).norm() < tol,
                    "{file}: {} analytic {:?} numeric {:?}",
                    kind.name(),
                    cols[k],
                    num
                );
            }
            // Geometric columns at the effective joints.
            for k in 0..g {
                let h = 1e-6;
                let at = |d: f64| {
                    let mut v = p.clone();
                    v[k] += d;
                    ext.with_params(&v).unwrap().point(&q)
                };
                let num = (at(h) - at(-h)) / (2.0 * h);
                assert!(
                    (num - cols[k]).norm() < 1e-5 * (1.0 + num.norm()),
                    "{file}: {} analytic {:?} numeric {:?}",
                    nominal.layout().get(k).name,
                    cols[k],
                    num
                );
            }
        }
    }
}

#[test]
fn the_zero_model_is_the_geometric_model() {
    let nominal = robot("kr1000-titan.json");
    let ext = nominal.with_extended(&all_names(6), "kr").unwrap();
    let mut s = 3;
    for _ in 0..50 {
        let q = pose(&nominal, &mut s);
        assert_eq!(ext.point(&q), nominal.point(&q));
    }
}

#[test]
fn a_vertical_first_axis_sees_no_gravity_torque() {
    // Both robots' joint 1 turns about the vertical: its compliance column is zero in every
    // pose (not identifiable; the identifiability analysis reports it redundant), while the
    // shoulder's is not.
    for file in ["kr1000-titan.json", "ur10.json"] {
        let nominal = robot(file);
        let model = ExtendedModel::new(&nominal, &["compliance_1", "compliance_2"], file).unwrap();
        let mut s = 11;
        let mut shoulder = 0.0_f64;
        for _ in 0..100 {
            let q = pose(&nominal, &mut s);
            let mut w = [0.0; 2];
            model.weights(&nominal, &q, &mut w);
            let weight: f64 = nominal
                .mass_model()
                .unwrap()
                .links
                .iter()
                .map(|l| l.mass_kg)
                .sum::<f64>()
                * 9.80665;
            // |τ1| at rounding level of the torque scale (weight × reach).
            assert!(w[0].abs() < 1e-9 * weight * 4.0, "{file}: τ1 = {}", w[0]);
            shoulder = shoulder.max(w[1].abs());
        }
        assert!(shoulder > 1.0, "{file}: τ2 never above 1 N·m");
    }
}

#[test]
fn names_and_units_round_trip() {
    for kind in [
        ExtendedKind::Compliance(1),
        ExtendedKind::GearSin {
            joint: 0,
            harmonic: 1,
        },
        ExtendedKind::GearCos {
            joint: 5,
            harmonic: 12,
        },
    ] {
        assert_eq!(ExtendedKind::parse(&kind.name()), Some(kind));
        let v = 1.25;
        assert!((kind.to_display(kind.from_display(v)) - v).abs() < 1e-12);
    }
    assert_eq!(ExtendedKind::Compliance(1).name(), "compliance_2");
    assert_eq!(ExtendedKind::Compliance(1).unit(), Unit::MicroradPerNm);
    assert_eq!(ExtendedKind::Compliance(1).unit().as_str(), "urad/Nm");
    // 1 arcsec = π/648000 rad.
    let g = ExtendedKind::parse("gear_3_h2_cos").unwrap();
    assert_eq!(g.unit(), Unit::Arcsec);
    assert_eq!(g.unit().as_str(), "arcsec");
    assert!((g.from_display(1.0) - std::f64::consts::PI / 648_000.0).abs() < 1e-20);
    for bad in [
        "compliance_0",
        "compliance_x",
        "gear_1_h0_sin",
        "gear_1_h1_tan",
        "gear_1_sin",
        "theta1",
    ] {
        assert_eq!(ExtendedKind::parse(bad), None, "{bad}");
    }
}

#[test]
fn bad_models_name_the_field() {
    let kr = robot("kr1000-titan.json");
    let field = |r: &Robot, names: &[&str]| match ExtendedModel::new(r, names, "f.json") {
        Err(ModelError::Invalid {
            source_name,
            field,
            message,
        }) => {
            assert_eq!(source_name, "f.json");
            (field, message)
        }
        other => panic!("expected an error naming a field, got {other:?}"),
    };
    let (f, m) = field(&kr, &["compliance_2", "gear_7_h1_sin"]);
    assert_eq!(f, "params[1]");
    assert!(
        m.contains("joint 7 does not exist") && m.contains("6 joints"),
        "{m}"
    );
    let (f, m) = field(&kr, &["gear_1_h1_sin", "gear_1_h1_sin"]);
    assert_eq!(f, "params[1]");
    assert!(m.contains("twice"), "{m}");
    let (f, m) = field(&kr, &["compliance_two"]);
    assert_eq!(f, "params[0]");
    assert!(m.contains("compliance_J"), "{m}");
    // A robot file without a mass model: compliance is refused naming `mass_model`, gears
    // are fine.
    let mut spec = kr.to_spec();
    spec.mass_model = None;
    let bare = Robot::from_spec(&spec).unwrap();
    let (f, m) = field(&bare, &["gear_1_h1_sin", "compliance_3"]);
    assert_eq!(f, "mass_model");
    assert!(m.contains("mass model"), "{m}");
    assert!(ExtendedModel::new(&bare, &["gear_1_h1_sin"], "f.json").is_ok());
    // Negative masses are refused when the robot file is read, naming the field.
    let mut text: serde_json::Value = serde_json::from_str(&kr.to_spec().to_json_string()).unwrap();
    text["mass_model"]["links"][2]["mass_kg"] = (-800.0).into();
    match RobotSpec::from_json_str(&text.to_string(), "neg.json").unwrap_err() {
        ModelError::Invalid { field, .. } => assert_eq!(field, "mass_model.links[2].mass_kg"),
        e => panic!("{e}"),
    }
}

/// An extended robot ([`Robot::with_extended`]) with random non-geometric values.
fn extended_robot(file: &str, s: &mut u64) -> (Robot, Robot) {
    let nominal = robot(file);
    let ext = nominal
        .with_extended(&all_names(nominal.n_joints()), file)
        .unwrap();
    let mut p = ext.params();
    for (k, info) in ext.layout().params().iter().enumerate() {
        if let kinematics::ParamKind::Extended(kind) = info.kind {
            p[k] = match kind {
                ExtendedKind::Compliance(_) => kind.from_display(0.5 + 0.5 * rnd(s)),
                _ => kind.from_display(20.0 * rnd(s)),
            };
        }
    }
    (nominal, ext.with_params(&p).unwrap())
}

#[test]
fn an_extended_robot_evaluates_the_extended_model_everywhere() {
    let mut s = 19;
    for file in ["kr1000-titan.json", "ur10.json"] {
        let (nominal, ext) = extended_robot(file, &mut s);
        assert!(ext.is_extended() && !nominal.is_extended());
        let np = ext.n_params();
        assert_eq!(np, nominal.n_params() + 5 * nominal.n_joints());
        assert_eq!(ext.layout().get(np - 1).name, "gear_6_h2_cos");
        assert_eq!(
            ext.layout().get(nominal.n_params()).unit.as_str(),
            "urad/Nm"
        );
        let kinds = ext.extended().unwrap().kinds().to_vec();
        for _ in 0..20 {
            let q = pose(&nominal, &mut s);
            let p = ext.point(&q);
            assert!((p - reference_point(&ext, &nominal, &q)).norm() < 1e-9);
            assert!((p - ext.point_reference(&q)).norm() < 1e-9);
            assert!((ext.flange(&q).pos_mm - ext.flange_reference(&q).pos_mm).norm() < 1e-9);
            // Reference and fast Jacobians agree, and both match central differences.
            let mut cols = vec![Vector3::zeros(); np];
            let p_ref = ext.point_jacobian_into(&q, &mut cols);
            assert!((p_ref - p).norm() < 1e-9);
            let (pts, jac) = ext.jacobian_batch(&q);
            let w = reference_weights(&nominal, &kinds, &q);
            assert!((pts[0] - p).norm() < 1e-9);
            let x = ext.params();
            for k in 0..np {
                let fast = Vector3::new(jac[(0, k)], jac[(1, k)], jac[(2, k)]);
                assert!(
                    (fast - cols[k]).norm() < 1e-9 * (1.0 + cols[k].norm()),
                    "{file}: {}",
                    ext.layout().get(k).name
                );
                // Steps that move a joint by about 1e-5 rad (see the test above).
                let g = nominal.n_params();
                let h = if k >= g {
                    1e-5 / w[k - g].abs().max(1e-3)
                } else {
                    1e-6
                };
                let at = |d: f64| {
                    let mut v = x.clone();
                    v[k] += d;
                    ext.with_params(&v).unwrap().point(&q)
                };
                let num = (at(h) - at(-h)) / (2.0 * h);
                assert!(
                    (num - cols[k]).norm() < 1e-5 * (1.0 + num.norm()),
                    "{file}: {} analytic {:?} numeric {:?}",
                    ext.layout().get(k).name,
                    cols[k],
                    num
                );
            }
        }
        // IK through the extended model reaches a point of it exactly.
        for _ in 0..10 {
            let q = pose(&nominal, &mut s);
            let target = kinematics::IkTarget::point_with_orientation(&ext, &q);
            let mut qs: Vec<f64> = q.iter().map(|v| v + 0.01).collect();
            let opts = kinematics::IkOptions::default();
            ext.solve_ik(&target, &mut qs, &opts).unwrap();
            assert!((ext.point(&qs) - target.position_mm).norm() < 1e-6);
        }
        // Back to geometric: the same geometry, no extended parameter.
        let geo = ext.with_extended::<&str>(&[], file).unwrap();
        assert!(!geo.is_extended());
        assert_eq!(geo.n_params(), nominal.n_params());
    }
}

#[test]
fn the_robot_file_carries_the_extended_parameters() {
    let mut s = 23;
    let (_, ext) = extended_robot("ur10.json", &mut s);
    let spec = ext.to_spec();
    let list = spec.extended.as_ref().expect("an extended section");
    assert_eq!(list.len(), 30);
    assert_eq!(list[0].name, "compliance_1");
    // Through JSON and back: the same parameters and values (display units round trip).
    let text = spec.to_json_string();
    let back = Robot::from_spec(&RobotSpec::from_json_str(&text, "ext.json").unwrap()).unwrap();
    assert_eq!(back.layout(), ext.layout());
    for (a, b) in back.params().iter().zip(ext.params()) {
        assert!((a - b).abs() <= 1e-12 * b.abs().max(1e-12), "{a} vs {b}");
    }
    // A geometric file has no such section.
    assert!(robot("ur10.json").to_spec().extended.is_none());
    assert!(
        !robot("ur10.json")
            .to_spec()
            .to_json_string()
            .contains("extended")
    );
    // Errors name the file's field.
    let bad = |edit: &dyn Fn(&mut serde_json::Value)| {
        let mut v: serde_json::Value = serde_json::from_str(&text).unwrap();
        edit(&mut v);
        let spec = RobotSpec::from_json_str(&v.to_string(), "ext.json");
        match spec.and_then(|s| Robot::from_spec(&s)) {
            Err(ModelError::Invalid { field, .. }) | Err(ModelError::Parse { field, .. }) => field,
            other => panic!("expected an error naming a field, got {other:?}"),
        }
    };
    assert_eq!(
        bad(&|v| v["extended"][3]["name"] = "gear_9_h1_sin".into()),
        "extended[3]"
    );
    assert_eq!(
        bad(&|v| v["extended"][0]["unit"] = "x".into()),
        "extended[0].unit"
    );
    assert_eq!(
        bad(&|v| v["extended"][2]["value"] = "x".into()),
        "extended[2].value"
    );
    let mut no_mass: serde_json::Value = serde_json::from_str(&text).unwrap();
    no_mass.as_object_mut().unwrap().remove("mass_model");
    let err = Robot::from_spec(&RobotSpec::from_json_str(&no_mass.to_string(), "e").unwrap())
        .unwrap_err();
    assert!(err.to_string().contains("mass_model"), "{err}");
}

/// The pose-parallel kernels evaluate an extended robot from the weights cached by
/// [`PoseTrig::for_robot`]: lane by lane the one-pose kernels' bits (point and every
/// column, the extended ones included), on partial last blocks too; a `PoseTrig` without
/// the weights is refused.
#[test]
fn lane_kernels_evaluate_an_extended_robot_bit_for_bit() {
    use kinematics::{POSE_LANES, PoseTrig};
    let mut s = 23;
    for file in ["kr1000-titan.json", "ur10.json"] {
        let (nominal, ext) = extended_robot(file, &mut s);
        let n = ext.n_joints();
        let np = ext.n_params();
        for m in [5, 8, 19] {
            let poses: Vec<f64> = (0..m).flat_map(|_| pose(&nominal, &mut s)).collect();
            let trig = PoseTrig::for_robot(&ext, &poses);
            let mut jac = vec![[[0.0; POSE_LANES]; 3]; np];
            for b in 0..trig.n_blocks() {
                let lanes = trig.lanes(b);
                assert_eq!(lanes.weights.len(), 5 * n);
                let p = ext.point_lanes(lanes);
                assert_eq!(p, ext.point_jacobian_lanes(lanes, &mut jac));
                for t in 0..POSE_LANES {
                    let j = (b * POSE_LANES + t).min(m - 1);
                    let (mut jx, mut jy, mut jz) = (vec![0.0; np], vec![0.0; np], vec![0.0; np]);
                    let one = ext.point_jacobian_trig(trig.pose(j), &mut jx, &mut jy, &mut jz);
                    assert_eq!(one, ext.point_trig(trig.pose(j)));
                    assert_eq!([p[0][t], p[1][t], p[2][t]], [one.x, one.y, one.z]);
                    // And the definition (effective joints by f64 sin/cos) to rounding.
                    let q = &poses[j * n..(j + 1) * n];
                    assert!((one - reference_point(&ext, &nominal, q)).norm() < 1e-9);
                    for k in 0..np {
                        assert_eq!(
                            [jac[k][0][t], jac[k][1][t], jac[k][2][t]],
                            [jx[k], jy[k], jz[k]],
                            "{file}: column {}",
                            ext.layout().get(k).name
                        );
                    }
                }
            }
            let geometric_trig = PoseTrig::new(n, &poses);
            let refused = std::panic::catch_unwind(|| ext.point_lanes(geometric_trig.lanes(0)));
            assert!(
                refused.is_err(),
                "lanes without the weights must be refused"
            );
            // Weights of the same parameters on another torque geometry are refused too; a
            // new parameter vector of the same model is not.
            let mut x = nominal.params();
            x[1] += 1.0;
            let other = nominal
                .with_params(&x)
                .unwrap()
                .with_extended(&all_names(n), file)
                .unwrap();
            let refused = std::panic::catch_unwind(|| other.point_lanes(trig.lanes(0)));
            assert!(
                refused.is_err(),
                "weights of another torque geometry must be refused"
            );
            let scaled: Vec<f64> = ext.params().iter().map(|v| v * 1.001).collect();
            let _ = ext.with_params(&scaled).unwrap().point_lanes(trig.lanes(0));
        }
    }
}

/// A [`kinematics::PoseTrig`] of an extended robot built from the buffers a dropped geometric
/// one left on the thread (and a geometric one after an extended one) equals one built on a
/// fresh thread: the extended weights are refilled, or emptied (issue 43's kept buffers).
#[test]
fn pose_trig_of_reused_buffers_carries_the_right_weights() {
    let mut s = 43;
    let (nominal, ext) = extended_robot("kr1000-titan.json", &mut s);
    let poses: Vec<f64> = (0..11).flat_map(|_| pose(&nominal, &mut s)).collect();
    let fresh = |r: &Robot| {
        std::thread::scope(|sc| {
            sc.spawn(|| kinematics::PoseTrig::for_robot(r, &poses))
                .join()
                .unwrap()
        })
    };
    let (fresh_ext, fresh_geo) = (fresh(&ext), fresh(&nominal));
    drop(kinematics::PoseTrig::for_robot(&nominal, &poses[..6 * 3]));
    assert_eq!(kinematics::PoseTrig::for_robot(&ext, &poses), fresh_ext);
    drop(kinematics::PoseTrig::for_robot(&ext, &poses));
    assert_eq!(kinematics::PoseTrig::for_robot(&nominal, &poses), fresh_geo);
    assert_ne!(
        fresh_ext, fresh_geo,
        "the weights are part of the comparison"
    );
}

/// Buffers dropped while a thread's kept ones are being destroyed (a `PoseTrig` held in a
/// thread-local of its own) neither panic nor recurse.
#[test]
fn pose_trig_dropped_at_thread_exit() {
    thread_local! {
        static HELD: std::cell::RefCell<Option<kinematics::PoseTrig>> =
            const { std::cell::RefCell::new(None) };
    }
    let nominal = robot("kr1000-titan.json");
    std::thread::scope(|sc| {
        sc.spawn(|| {
            let q = vec![0.1; 6 * 4];
            drop(kinematics::PoseTrig::for_robot(&nominal, &q));
            HELD.with(|h| *h.borrow_mut() = Some(kinematics::PoseTrig::for_robot(&nominal, &q)));
        })
        .join()
        .unwrap()
    });
}

/// `clone_from` (which refills the target's vectors instead of allocating new ones) gives
/// the source robot, whatever the target was: geometric or extended, with more or fewer
/// joints, extended parameters or gear harmonics; equal as a value and in its points, bit
/// for bit. A field left out of a `clone_from` (a stale vector of the last robot) fails it.
#[test]
fn a_refilled_robot_is_its_source() {
    let mut s = 43;
    let kr = robot("kr1000-titan.json");
    let track = robot("kr1000-track.json");
    let (_, kr_ext) = extended_robot("kr1000-titan.json", &mut s);
    let (_, kr_ext2) = extended_robot("kr1000-titan.json", &mut s);
    let ur_gears = robot("ur10.json")
        .with_extended(&["gear_1_h1_sin", "gear_1_h2_cos"], "ur10")
        .unwrap();
    let kr_gears = kr
        .with_extended(&["gear_2_h1_sin", "gear_2_h1_cos", "compliance_3"], "kr")
        .unwrap();
    let robots = [kr, track, kr_ext, kr_ext2, ur_gears, kr_gears];
    for source in &robots {
        for start in &robots {
            let mut target = start.clone();
            target.clone_from(source);
            assert!(target == *source, "{} over {}", source.name(), start.name());
            for _ in 0..3 {
                let q = pose(source, &mut s);
                assert_eq!(
                    target.point(&q).map(f64::to_bits),
                    source.point(&q).map(f64::to_bits),
                    "{} over {}",
                    source.name(),
                    start.name()
                );
            }
        }
    }
}
