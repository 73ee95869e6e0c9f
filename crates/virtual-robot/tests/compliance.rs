//! The compliance table of the crate docs, and the share of the deflection a geometric
//! calibration cannot absorb.

use crate::common::{deg, kr1000};
use nalgebra::DVector;
use virtual_robot::{
    ComplianceConfig, ComplianceModel, KR1000_BASE_MASS_KG, KR1000_LINKS, VirtualRobotConfig, World,
};

const TABLE_POSES_DEG: [[f64; 6]; 5] = [
    [0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
    [0.0, 45.0, 0.0, 0.0, 45.0, 0.0],
    [0.0, 60.0, -60.0, 0.0, 30.0, 0.0],
    [0.0, -30.0, -90.0, 0.0, 90.0, 0.0],
    [0.0, 30.0, 30.0, 0.0, 60.0, 0.0],
];

/// `-3` → `−3` (the docs use the minus sign).
fn num(v: f64) -> String {
    format!("{v}").replace('-', "−")
}

#[test]
fn compliance_table_matches_the_docs() {
    let docs = include_str!("../src/lib.rs");
    let robot = kr1000();
    let unloaded = ComplianceModel::new(&ComplianceConfig::default(), 6).unwrap();
    let loaded = ComplianceModel::new(
        &ComplianceConfig {
            payload_kg: 1000.0,
            ..ComplianceConfig::default()
        },
        6,
    )
    .unwrap();
    // The shipped paper-kr1000 scenario: no payload, the balancer carrying 58 %.
    let shipped = ComplianceModel::new(
        &ComplianceConfig {
            counterbalance_fraction: vec![0.0, 0.58, 0.0, 0.0, 0.0, 0.0],
            ..ComplianceConfig::default()
        },
        6,
    )
    .unwrap();
    for qd in TABLE_POSES_DEG {
        let q = deg(&qd);
        let p = robot.point(&q);
        let d0 = unloaded.point_deflection_mm(&robot, &q).norm();
        let d1 = loaded.point_deflection_mm(&robot, &q).norm();
        let ds = shipped.point_deflection_mm(&robot, &q).norm();
        let row = format!(
            "//! | ({}) | ({}, {}, {}) | {:.3} | {:.3} | {:.3} |",
            qd.map(num).join(", "),
            num(p.x.round()),
            num(p.y.round()),
            num(p.z.round()),
            d0,
            d1,
            ds
        );
        assert!(docs.contains(&row), "the docs lack the row\n{row}");
        // A payload always adds deflection here.
        assert!(d1 > d0);
    }
    // The mass split adds up to the data sheet's 4690 kg.
    let total: f64 = KR1000_LINKS.iter().map(|(m, _)| m).sum::<f64>() + KR1000_BASE_MASS_KG;
    assert_eq!(total, 4690.0);
}

#[test]
fn torques_match_a_hand_calculation_at_the_zero_pose() {
    // q = 0: upper arm vertical, forearm horizontal along +x. Axes 2 and 3 are horizontal
    // (along the base y axis) and lie on the same vertical line x = 600 mm, so both carry
    // the moment of everything beyond the elbow: Σ m·g·(x_c − 600 mm).
    let robot = kr1000();
    let cfg = ComplianceConfig::default();
    let model = ComplianceModel::new(&cfg, 6).unwrap();
    let mut tau = [0.0; 6];
    model.torques_nm(&robot, &[0.0; 6], &mut tau);
    // Centres of mass along +x at q = 0: link 3 at 600 + 300, link 4 at 1800 − 400,
    // link 5 at 1800 + 150, link 6 at 1800 + 372 − 20 (mm).
    let g = cfg.gravity_m_per_s2;
    let moment = g * (800.0 * 0.3 + 200.0 * 0.8 + 70.0 * 1.35 + 20.0 * 1.552);
    // The z axes of joints 2 and 3 point along the base +y axis here, and
    // ẑ·(r × F) = ŷ·((x, 0, 0) × (0, 0, −m g)) = +x m g: positive, i.e. towards positive q2,
    // which leans the arm forward and down.
    assert!(
        (tau[1] - moment).abs() < 1e-6 * moment,
        "{tau:?} vs {moment}"
    );
    assert!((tau[2] - tau[1]).abs() < 1e-6 * moment, "{tau:?}");
    assert!(tau[0].abs() < 1e-9 * moment, "axis 1 is vertical: {tau:?}");
}

/// Mean ‖·‖ of the deflections left after the best linear fit of the 34 parameters
/// (projection onto the column space of the column-scaled identification Jacobian).
fn left_after_fit(poses: &[f64], d: &[nalgebra::Vector3<f64>]) -> f64 {
    let robot = kr1000();
    let (_, mut j) = robot.jacobian_batch(poses);
    for c in 0..j.ncols() {
        let n = j.column(c).norm();
        j.column_mut(c).scale_mut(1.0 / n);
    }
    let svd = j.svd(true, false);
    let u = svd.u.unwrap();
    let tol = 1e-8 * svd.singular_values.max();
    let b = DVector::from_iterator(3 * d.len(), d.iter().flat_map(|v| [v.x, v.y, v.z]));
    let mut r = b.clone();
    for (i, s) in svd.singular_values.iter().enumerate() {
        if *s > tol {
            let ui = u.column(i);
            r -= ui * ui.dot(&b);
        }
    }
    (0..d.len())
        .map(|k| r.fixed_rows::<3>(3 * k).norm())
        .sum::<f64>()
        / d.len() as f64
}

#[test]
fn compliance_left_after_a_linear_fit() {
    // The crate docs size the default stiffness so that ≈ 0.2 mm of self-weight deflection
    // survives a geometric calibration on 50 poses (55 % of the paper's 0.340 mm).
    let robot = kr1000();
    let model = ComplianceModel::new(&ComplianceConfig::default(), 6).unwrap();
    let mut left = 0.0;
    let seeds = 4;
    for seed in 0..seeds {
        let w = World::new(&robot, &VirtualRobotConfig::ideal(), seed, 0).unwrap();
        let poses = w.identification_poses_rad();
        let d: Vec<_> = poses
            .chunks(6)
            .map(|q| model.point_deflection_mm(&robot, q))
            .collect();
        left += left_after_fit(poses, &d);
    }
    left /= seeds as f64;
    assert!(
        (0.15..0.25).contains(&left),
        "{left:.3} mm left after the fit"
    );
}

/// The compliance parameter family of the kinematics crate (issue 19) contains the virtual
/// robot's compliance truth exactly: with `compliance_j = (1 − c_j)/k_j` and the torques on
/// the same robot, the extended model's point is the deflected point, to the bit (one
/// implementation of the gravity torque, `kinematics::Gravity`).
#[test]
fn the_compliance_family_contains_the_truth() {
    let robot = kr1000();
    let cfg = ComplianceConfig {
        payload_kg: 300.0,
        counterbalance_fraction: vec![0.0, 0.58, 0.0, 0.0, 0.0, 0.0],
        ..ComplianceConfig::default()
    };
    let truth = ComplianceModel::new(&cfg, 6).unwrap();
    // The robot file's mass model with the same masses (the committed file carries them,
    // tests/mass_model.rs), plus the payload.
    let mut spec = robot.to_spec();
    let mm = spec
        .mass_model
        .as_mut()
        .expect("the KR1000 file has a mass model");
    mm.payload_kg = cfg.payload_kg;
    mm.payload_com_mm = cfg.payload_com_mm;
    let with_mass = kinematics::Robot::from_spec(&spec).unwrap();
    let names: Vec<String> = (1..=6).map(|j| format!("compliance_{j}")).collect();
    let mut ext = kinematics::ExtendedModel::new(&with_mass, &names, "kr1000").unwrap();
    let gains: Vec<f64> = (0..6)
        .map(|i| (1.0 - cfg.counterbalance_fraction[i]) / cfg.stiffness_nm_per_rad[i])
        .collect();
    ext.set_values(&gains).unwrap();
    // The same parameters in an extended robot, which is what identifies and compensates.
    let ext_robot = with_mass.with_extended(&names, "kr1000").unwrap();
    let mut x = ext_robot.params();
    x[with_mass.n_params()..].copy_from_slice(&gains);
    let ext_robot = ext_robot.with_params(&x).unwrap();
    for q in TABLE_POSES_DEG {
        let q = deg(&q);
        let expected = robot.point(&q) + truth.point_deflection_mm(&robot, &q);
        let got = ext_robot.point(&q);
        // p(q + Δq) − p(q) + p(q) may round differently from p(q + Δq) in the last bit.
        assert!((got - expected).norm() < 1e-9, "{got} vs {expected}");
        let mut dq = [0.0; 6];
        truth.deflection_rad(&robot, &q, &mut dq);
        let mut w = [0.0; 6];
        ext.weights(&with_mass, &q, &mut w);
        let mut qe = [0.0; 6];
        ext.effective_joints(&q, &w, &mut qe);
        for i in 0..6 {
            assert_eq!(qe[i], q[i] + dq[i], "joint {i}");
        }
    }
}
