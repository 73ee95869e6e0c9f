//! The virtual AT960: noise statistics per beam direction, visibility window, residual.

use crate::common::{deg, ideal, kr1000};
use nalgebra::Vector3;
use virtual_robot::{
    NoiseModel, NotMeasurable, PoseSet, Purpose, Tracker, TrackerConfig, World, stream,
};

/// Per-direction σ (radial, horizontal, vertical) of `n` readings of a target at `p`,
/// through the whole chain: a world with only tracker noise measuring one pose whose point
/// is `range_m` from the head at 10° elevation.
fn world_sigmas(model: NoiseModel, fraction: f64, range_m: f64, n: usize) -> ([f64; 3], [f64; 2]) {
    let robot = kr1000();
    let q = deg(&[0.0, 0.0, 0.0, 0.0, 30.0, 0.0]);
    let p = robot.point(&q);
    let el = 10f64.to_radians();
    // Head → target direction û points back towards the robot (−x) and up 10°.
    let u = Vector3::new(-el.cos(), 0.0, el.sin());
    let head = p - u * (range_m * 1e3);
    let mut cfg = ideal();
    cfg.tracker.noise = true;
    cfg.tracker.noise_model = model;
    cfg.tracker.sigma_fraction = fraction;
    cfg.tracker.position_mm = head.into();
    let q_deg: Vec<f64> = q.iter().map(|r| r.to_degrees()).collect();
    cfg.poses.identification = PoseSet::ListDeg(vec![q_deg.clone()]);
    cfg.poses.validation = PoseSet::ListDeg(vec![q_deg]);
    let mut world = World::new(&robot, &cfg, 7, 0).unwrap();
    let truth = world.true_point(&q).unwrap();
    assert_eq!(truth, p);
    let [ur, uh, uv] = world.tracker().beam_frame(&p);
    assert!((ur - u).norm() < 1e-12);
    let mut ss = [0.0; 3];
    for _ in 0..n {
        let d = world.measure(&q).unwrap() - p;
        ss[0] += d.dot(&ur).powi(2);
        ss[1] += d.dot(&uh).powi(2);
        ss[2] += d.dot(&uv).powi(2);
    }
    let sig = ss.map(|s| (s / n as f64).sqrt());
    (sig, world.tracker().sigmas_mm(range_m))
}

#[test]
fn anisotropic_sigmas_match_the_model_at_2_4_6_m() {
    for range_m in [2.0, 4.0, 6.0] {
        let (sig, [sr, st]) = world_sigmas(NoiseModel::Anisotropic, 0.5, range_m, 100_000);
        // docs/model.md §10: σ_r = ½(10 + 0.3 r) µm, σ_⊥ = ½(15 + 6 r) µm.
        let model_r = 0.5 * (10.0 + 0.3 * range_m) * 1e-3;
        let model_t = 0.5 * (15.0 + 6.0 * range_m) * 1e-3;
        assert!((sr - model_r).abs() < 1e-15 && (st - model_t).abs() < 1e-15);
        for (k, (s, m)) in sig.iter().zip([model_r, model_t, model_t]).enumerate() {
            let rel = s / m - 1.0;
            assert!(
                rel.abs() < 0.02,
                "{range_m} m, direction {k}: σ = {s:.6} mm, model {m:.6} mm ({:+.2} %)",
                100.0 * rel
            );
        }
        if range_m == 6.0 {
            // The split is visible: 5.9 µm radial against 25.5 µm transverse.
            assert!(sig[0] < 0.3 * sig[1] && sig[0] < 0.3 * sig[2], "{sig:?}");
        }
    }
}

#[test]
fn isotropic_sigmas_are_equal_and_follow_the_fraction() {
    for (fraction, range_m) in [(0.5, 2.0), (1.0 / 3.0, 6.0)] {
        let (sig, [sr, st]) = world_sigmas(NoiseModel::Isotropic, fraction, range_m, 100_000);
        let model = fraction * (15.0 + 6.0 * range_m) * 1e-3;
        assert_eq!(sr, st);
        assert!((st - model).abs() < 1e-15);
        for s in sig {
            assert!((s / model - 1.0).abs() < 0.02, "{sig:?} vs {model}");
        }
    }
}

#[test]
fn noise_off_and_scale() {
    let mut cfg = TrackerConfig {
        noise: false,
        ..TrackerConfig::default()
    };
    let t = Tracker::new(&cfg).unwrap();
    assert_eq!(t.sigmas_mm(5.0), [0.0, 0.0]);
    let p = Vector3::new(1000.0, 200.0, 1500.0);
    let mut rng = stream(1, 0, Purpose::TrackerNoise);
    assert_eq!(t.observe(&p, &mut rng).unwrap(), p);
    cfg.noise = true;
    cfg.noise_scale = 2.0;
    let t = Tracker::new(&cfg).unwrap();
    let [sr, st] = t.sigmas_mm(4.0);
    assert!((sr - 2.0 * 0.5 * (10.0 + 1.2) * 1e-3).abs() < 1e-15);
    assert!((st - 2.0 * 0.5 * (15.0 + 24.0) * 1e-3).abs() < 1e-15);
}

#[test]
fn elevation_window_and_range() {
    let cfg = TrackerConfig {
        position_mm: [4000.0, 0.0, 1000.0],
        ..TrackerConfig::default()
    };
    let t = Tracker::new(&cfg).unwrap();
    let head = Vector3::from(cfg.position_mm);
    let at = |el_deg: f64, r_mm: f64| {
        let e = el_deg.to_radians();
        head + Vector3::new(-e.cos(), 0.0, e.sin()) * r_mm
    };
    assert!(t.check_visible(&at(44.9, 2000.0)).is_ok());
    assert!(t.check_visible(&at(-44.9, 2000.0)).is_ok());
    match t.check_visible(&at(45.1, 2000.0)) {
        Err(NotMeasurable::Elevation {
            elevation_deg,
            limit_deg,
        }) => {
            assert!((elevation_deg - 45.1).abs() < 1e-9);
            assert_eq!(limit_deg, 45.0);
        }
        other => panic!("{other:?}"),
    }
    assert!(matches!(
        t.check_visible(&at(-60.0, 2000.0)),
        Err(NotMeasurable::Elevation { .. })
    ));
    assert!(matches!(
        t.check_visible(&at(0.0, 500.0)),
        Err(NotMeasurable::Range { .. })
    ));
    assert!(matches!(
        t.check_visible(&at(0.0, 25_000.0)),
        Err(NotMeasurable::Range { .. })
    ));
}

#[test]
fn unmeasurable_pose_through_the_world() {
    let robot = kr1000();
    let mut cfg = ideal();
    // Head level with the q = 0 point: that pose is seen at ~0° elevation.
    let p0 = robot.point(&[0.0; 6]);
    cfg.tracker.position_mm = [p0.x + 2500.0, p0.y, p0.z];
    cfg.poses.identification = PoseSet::ListDeg(vec![vec![0.0; 6]]);
    cfg.poses.validation = PoseSet::ListDeg(vec![vec![0.0; 6]]);
    let mut w = World::new(&robot, &cfg, 1, 0).unwrap();
    assert!(w.measure(&[0.0; 6]).is_ok());
    // Arm folded low near the base: far below the head, steeper than 45°.
    let low = deg(&[0.0, 90.0, 0.0, 0.0, 0.0, 0.0]);
    assert!(matches!(
        w.measure(&low),
        Err(NotMeasurable::Elevation { .. })
    ));
    assert!(matches!(
        w.measure(&[0.0; 5]),
        Err(NotMeasurable::JointCount {
            expected: 6,
            found: 5
        })
    ));
    match w.measure(&deg(&[0.0, -41.0, 0.0, 0.0, 0.0, 0.0])) {
        Err(NotMeasurable::JointLimits { joint: 2, .. }) => {}
        other => panic!("{other:?}"),
    }
    // Moves: two attempted (measurable or not), limit and length errors are not moves.
    assert_eq!(w.moves(), 2);
    // An explicit pose the tracker cannot see is rejected when the world is built.
    cfg.poses.validation =
        PoseSet::ListDeg(vec![vec![0.0; 6], vec![0.0, 90.0, 0.0, 0.0, 0.0, 0.0]]);
    let err = World::new(&robot, &cfg, 1, 0).unwrap_err();
    assert!(
        err.to_string().starts_with("`poses.validation[1]`: "),
        "{err}"
    );
}

#[test]
fn residual_is_a_rigid_transform_on_every_reading() {
    let robot = kr1000();
    let mut cfg = ideal();
    cfg.tracker.base_residual.rx_deg = 0.01;
    cfg.tracker.base_residual.rz_deg = -0.02;
    cfg.tracker.base_residual.dy_mm = 0.3;
    let mut w = World::new(&robot, &cfg, 3, 0).unwrap();
    let res = cfg.tracker.base_residual.frame();
    let poses = w.identification_poses_rad().to_vec();
    for q in poses.chunks(6) {
        let m = w.measure(q).unwrap();
        assert_eq!(m, res.transform_point(&robot.point(q)));
        assert_eq!(w.true_point(q).unwrap(), m);
        // The effective robot (residual folded into the base parameters) reproduces it.
        let e = w.effective_true_robot().point(q);
        assert!((e - m).norm() < 1e-9, "{}", (e - m).norm());
    }
    let truth = w.truth();
    let rz = truth
        .parameters
        .iter()
        .find(|p| p.name == "base_rz")
        .unwrap();
    assert_eq!(rz.true_value, 0.0);
    assert!((rz.effective + 0.02).abs() < 1e-12, "{}", rz.effective);
}

/// Frame and multi-reflector readings (issue 31): with only tracker noise, the orientation
/// error `log(R_trueᵀR_meas)` of 4,000 6-DoF readings has σ = ½ × 0.01° (the T-Mac's
/// ±0.01°, `sigma_fraction` ½) per axis within sampling error (3σ/√(2n) on a σ estimate:
/// 3.4 %), the point of a frame reading is the tool point, and reflectors at offsets are
/// the true tool's points there (noise off: exact).
#[test]
fn frame_readings_have_the_datasheet_orientation_noise() {
    let robot = kr1000();
    let q = deg(&[10.0, -20.0, 30.0, 15.0, 40.0, -25.0]);
    let q_deg: Vec<f64> = q.iter().map(|r| r.to_degrees()).collect();
    let mut cfg = ideal();
    cfg.tracker.noise = true;
    cfg.poses.identification = PoseSet::ListDeg(vec![q_deg.clone()]);
    cfg.poses.validation = PoseSet::ListDeg(vec![q_deg]);
    let mut world = World::new(&robot, &cfg, 9, 0).unwrap();
    let sigma_deg = world.tracker().orientation_sigma_deg();
    assert!((sigma_deg - 0.005).abs() < 1e-15, "{sigma_deg}");
    let truth = world.true_robot().clone();
    let f = truth.flange(&q);
    let r_true = f.rot * truth.tool_rotation();
    let n = 4000;
    let mut ss = [0.0; 3];
    for _ in 0..n {
        let (_, r) = world.measure_tool(&q, &[Vector3::zeros()], true).unwrap();
        let rel = nalgebra::Rotation3::from_matrix_unchecked(r_true.transpose() * r.unwrap());
        let v = rel.scaled_axis();
        for c in 0..3 {
            ss[c] += v[c].to_degrees().powi(2);
        }
    }
    for s in ss {
        let sd = (s / n as f64).sqrt();
        assert!((sd / sigma_deg - 1.0).abs() < 0.034, "{sd} vs {sigma_deg}");
    }
    cfg.tracker.noise = false;
    let mut quiet = World::new(&robot, &cfg, 9, 0).unwrap();
    let offsets = [Vector3::zeros(), Vector3::new(100.0, 0.0, 0.0)];
    let (p, r) = quiet.measure_tool(&q, &offsets, false).unwrap();
    assert!(r.is_none());
    let t = quiet.true_robot().clone();
    let f = t.flange(&q);
    assert!((p[0] - t.point(&q)).norm() < 1e-9);
    assert!((p[1] - (f.rot * (t.tool_mm() + offsets[1]) + f.pos_mm)).norm() < 1e-9);
}
