//! The world and the simulation: exactness, determinism, scaling, each unmodelled error.

use crate::common::{deg, everything, ideal, kr1000};
use measurements::{ReadOptions, read_str};
use virtual_robot::{
    ErrorDistribution, PoseSet, RandomErrors, ScaleTarget, Setup, Simulation, Truth, World,
    simulate,
};

#[test]
fn all_errors_off_measures_forward_kinematics_bit_for_bit() {
    let robot = kr1000();
    let cfg = ideal();
    let mut w = World::new(&robot, &cfg, 11, 4).unwrap();
    assert_eq!(w.true_robot(), &robot);
    assert!(w.errors_internal().iter().all(|e| *e == 0.0));
    let poses = w.identification_poses_rad().to_vec();
    for q in poses.chunks(6) {
        let m = w.measure(q).unwrap();
        let p = robot.point(q);
        assert_eq!(m.map(f64::to_bits), p.map(f64::to_bits));
    }
    // Through the files: reading the CSV back and converting degrees gives the same bits.
    let sim = simulate(&robot, &cfg, 11, 4).unwrap();
    let text = sim.identification_csv().unwrap();
    let set = read_str(&text, "identification.csv", &ReadOptions::new(6)).unwrap();
    assert_eq!(set.rows.len(), 50);
    for row in &set.rows {
        let q: Vec<f64> = row.q_deg.iter().map(|d| d.to_radians()).collect();
        let p = robot.point(&q);
        assert_eq!(row.point_mm.unwrap(), [p.x, p.y, p.z]);
    }
}

fn render(sim: &Simulation) -> (String, String, String) {
    (
        sim.identification_csv().unwrap(),
        sim.validation_csv().unwrap(),
        sim.truth_json(),
    )
}

#[test]
fn same_seed_same_bytes_different_seed_differs() {
    let robot = kr1000();
    let cfg = everything();
    let a = render(&simulate(&robot, &cfg, 2024, 3).unwrap());
    let b = render(&simulate(&robot, &cfg, 2024, 3).unwrap());
    assert_eq!(a.0.as_bytes(), b.0.as_bytes());
    assert_eq!(a.1.as_bytes(), b.1.as_bytes());
    assert_eq!(a.2.as_bytes(), b.2.as_bytes());
    let c = render(&simulate(&robot, &cfg, 2025, 3).unwrap());
    assert_ne!(a.0, c.0);
    assert_ne!(a.1, c.1);
    assert_ne!(a.2, c.2);
    let d = render(&simulate(&robot, &cfg, 2024, 4).unwrap());
    assert_ne!(a.0, d.0);
    // The truth file parses back into the same truth.
    let t: Truth = serde_json::from_str(&a.2).unwrap();
    assert_eq!(t, simulate(&robot, &cfg, 2024, 3).unwrap().truth);
}

#[test]
fn trial_k_does_not_depend_on_earlier_trials() {
    let robot = kr1000();
    let cfg = everything();
    let setup = Setup::new(&robot, &cfg, 99).unwrap();
    let direct = render(&setup.simulate(3).unwrap());
    for k in 0..3 {
        setup.simulate(k).unwrap();
    }
    let after = render(&setup.simulate(3).unwrap());
    assert_eq!(direct, after);
    let fresh = render(&simulate(&robot, &cfg, 99, 3).unwrap());
    assert_eq!(direct, fresh);
}

#[test]
fn scaling_hits_the_target() {
    let robot = kr1000();
    for (target, dist) in [
        (1.122, ErrorDistribution::Normal),
        (0.25, ErrorDistribution::Uniform),
        (5.0, ErrorDistribution::Normal),
    ] {
        let mut cfg = ideal();
        cfg.truth.random = Some(RandomErrors {
            distribution: dist,
            ..RandomErrors::default()
        });
        cfg.truth.scale_to = Some(ScaleTarget {
            mean_error_mm: target,
            poses: 100,
        });
        for trial in 0..3 {
            let w = World::new(&robot, &cfg, 5, trial).unwrap();
            let poses = w.scale_poses_rad();
            assert_eq!(poses.len(), 600);
            let mean = poses
                .chunks(6)
                .map(|q| (w.true_robot().point(q) - robot.point(q)).norm())
                .sum::<f64>()
                / 100.0;
            assert!(
                ((mean - target) / target).abs() < 1e-9,
                "target {target}: mean {mean}"
            );
            let s = w.scale_outcome().unwrap();
            assert!((s.mean_error_mm - mean).abs() < 1e-12 * target);
            // The scaled truth is the drawn truth times the factor.
            let unscaled = World::new(&robot, &ideal_with(&cfg), 5, trial).unwrap();
            for (a, b) in w.errors_internal().iter().zip(unscaled.errors_internal()) {
                assert!((a - s.factor * b).abs() <= 1e-15 * a.abs().max(1e-300));
            }
        }
    }
}

/// `cfg` without the scaling.
fn ideal_with(cfg: &virtual_robot::VirtualRobotConfig) -> virtual_robot::VirtualRobotConfig {
    let mut c = cfg.clone();
    c.truth.scale_to = None;
    c
}

#[test]
fn explicit_values_override_draws_and_truth_reports_them() {
    let robot = kr1000();
    let mut cfg = ideal();
    cfg.truth.explicit.insert("a2".into(), 0.4);
    cfg.truth.explicit.insert("theta3".into(), -0.01);
    let w = World::new(&robot, &cfg, 1, 0).unwrap();
    let t = w.truth();
    assert_eq!(t.parameters.len(), 34);
    for p in &t.parameters {
        let expected = match p.name.as_str() {
            "a2" => 0.4,
            "theta3" => -0.01,
            _ => 0.0,
        };
        assert!(
            (p.error - expected).abs() < 1e-12,
            "{}: {}",
            p.name,
            p.error
        );
        assert!((p.true_value - p.nominal - p.error).abs() < 1e-9);
    }
    let a2 = t.parameters.iter().find(|p| p.name == "a2").unwrap();
    assert_eq!(
        (a2.unit.as_str(), a2.nominal, a2.true_value),
        ("mm", 1400.0, 1400.4)
    );
    // With random draws too, the explicit value still wins.
    cfg.truth.random = Some(RandomErrors::default());
    let w = World::new(&robot, &cfg, 1, 0).unwrap();
    let e = w.errors_display();
    assert!((e[robot.layout().index_of("a2").unwrap()] - 0.4).abs() < 1e-12);
    assert!(e.iter().filter(|v| **v != 0.0).count() == 34);
}

#[test]
fn drift_grows_linearly_with_the_move_index() {
    let robot = kr1000();
    let mut cfg = ideal();
    cfg.unmodelled.drift.enabled = true;
    cfg.unmodelled.drift.rate_per_move.insert("a2".into(), 0.01);
    let mut w = World::new(&robot, &cfg, 1, 0).unwrap();
    let q = w.identification_poses_rad()[..6].to_vec();
    let p0 = robot.params();
    let rates = w.unmodelled().drift_per_move().unwrap().to_vec();
    for k in 0..20u64 {
        let p: Vec<f64> = p0
            .iter()
            .zip(&rates)
            .map(|(a, r)| a + k as f64 * r)
            .collect();
        let expected = robot.with_params(&p).unwrap().point(&q);
        assert_eq!(w.measure(&q).unwrap(), expected, "move {k}");
    }
    // true_point ignores drift.
    assert_eq!(w.true_point(&q).unwrap(), robot.point(&q));
    assert_eq!(w.moves(), 20);
}

#[test]
fn gear_errors_follow_the_sine_model() {
    let robot = kr1000();
    let mut cfg = ideal();
    cfg.unmodelled.gears.enabled = true;
    let w = World::new(&robot, &cfg, 1, 0).unwrap();
    assert_eq!(
        w.unmodelled().gear_phases_deg(),
        vec![0.0, 60.0, 120.0, 180.0, 240.0, 300.0]
    );
    let poses = w.validation_poses_rad().to_vec();
    for q in poses.chunks(6) {
        let mut qa = q.to_vec();
        for t in &cfg.unmodelled.gears.terms {
            let a = (t.amplitude_arcsec / 3600.0).to_radians();
            qa[t.joint - 1] += a * (t.harmonic * q[t.joint - 1] + t.phase_deg.to_radians()).sin();
        }
        assert_eq!(w.true_point(q).unwrap(), robot.point(&qa));
    }
    // Random phases differ between trials and are reported.
    cfg.unmodelled.gears.random_phase = true;
    let a = World::new(&robot, &cfg, 1, 0)
        .unwrap()
        .truth()
        .gear_phases_deg;
    let b = World::new(&robot, &cfg, 1, 1)
        .unwrap()
        .truth()
        .gear_phases_deg;
    assert_ne!(a, b);
    assert!(a.iter().all(|p| (0.0..360.0).contains(p)));
}

#[test]
fn compliance_lowers_the_arm_and_grows_with_payload() {
    let robot = kr1000();
    let mut cfg = ideal();
    cfg.unmodelled.compliance.enabled = true;
    let q = deg(&[0.0, 0.0, 0.0, 0.0, 30.0, 0.0]);
    let w = World::new(&robot, &cfg, 1, 0).unwrap();
    let d0 = w.true_point(&q).unwrap() - robot.point(&q);
    assert!(d0.z < -0.1, "{d0:?}");
    cfg.unmodelled.compliance.payload_kg = 1000.0;
    let w = World::new(&robot, &cfg, 1, 0).unwrap();
    let d1 = w.true_point(&q).unwrap() - robot.point(&q);
    assert!(d1.z < 3.0 * d0.z, "{d0:?} {d1:?}");
    // No gravity, no deflection.
    cfg.unmodelled.compliance.gravity_m_per_s2 = 0.0;
    let w = World::new(&robot, &cfg, 1, 0).unwrap();
    assert_eq!(w.true_point(&q).unwrap(), robot.point(&q));
}

#[test]
fn sampled_poses_satisfy_the_constraints_and_files_are_written() {
    let robot = kr1000();
    let cfg = everything();
    let w = World::new(&robot, &cfg, 8, 0).unwrap();
    let head = w.tracker().head_mm();
    for q in w
        .identification_poses_rad()
        .chunks(6)
        .chain(w.validation_poses_rad().chunks(6))
    {
        assert!(robot.in_limits(q));
        assert!(q[4].abs() >= 10f64.to_radians());
        assert!(robot.singularity_condition(q, 1000.0) <= 100.0);
        let p = w.true_point(q).unwrap();
        assert!(p.z >= 300.0 - 1.0);
        let d = p - head;
        assert!(d.z.abs() <= d.x.hypot(d.y));
    }
    for (deg, rad) in w
        .identification_poses_deg()
        .iter()
        .zip(w.identification_poses_rad())
    {
        assert_eq!(deg.to_radians(), *rad);
    }
    let sim = simulate(&robot, &cfg, 8, 0).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("run");
    sim.write(&out).unwrap();
    let read = |name: &str| std::fs::read_to_string(out.join(name)).unwrap();
    assert_eq!(
        read("identification.csv"),
        sim.identification_csv().unwrap()
    );
    assert_eq!(read("validation.csv"), sim.validation_csv().unwrap());
    assert_eq!(read("truth.json"), sim.truth_json());
    let v = read_str(&read("validation.csv"), "v", &ReadOptions::new(6)).unwrap();
    assert_eq!(v.rows.len(), 10);
    assert_eq!(v.rows[0].id.as_deref(), Some("V001"));
    assert_eq!(sim.truth.moves, 30);
    // Only the three files, no temporary leftovers.
    let mut names: Vec<_> = std::fs::read_dir(&out)
        .unwrap()
        .map(|e| e.unwrap().file_name().into_string().unwrap())
        .collect();
    names.sort();
    assert_eq!(
        names,
        ["identification.csv", "truth.json", "validation.csv"]
    );
    // A directory path that is a file fails cleanly.
    let file = dir.path().join("plain");
    std::fs::write(&file, "x").unwrap();
    assert!(sim.write(&file).is_err());
}

#[test]
fn explicit_pose_lists_are_used_as_given() {
    let robot = kr1000();
    let mut cfg = ideal();
    let rows = vec![
        vec![0.0, 10.0, -20.0, 0.0, 45.0, 0.0],
        vec![30.0, 20.0, -10.0, 5.0, 60.0, 0.0],
    ];
    cfg.poses.validation = PoseSet::ListDeg(rows.clone());
    let w = World::new(&robot, &cfg, 1, 0).unwrap();
    assert_eq!(w.validation_poses_deg(), rows.concat().as_slice());
    let r = w.sampling_report();
    assert_eq!((r.validation.draws, r.validation.accepted), (0, 2));
}

/// Measuring a sampled pose reuses the point its sampling computed: the same bits as the
/// uncached `true_point`, in any order and repeatedly (noise, scatter and drift off).
#[test]
fn measuring_sampled_poses_gives_the_uncached_point_bit_for_bit() {
    let robot = kr1000();
    let mut cfg = everything();
    cfg.unmodelled.drift.enabled = false;
    cfg.unmodelled.repeatability.enabled = false;
    cfg.tracker.noise = false;
    for trial in 0..3 {
        let mut w = World::new(&robot, &cfg, 3, trial).unwrap();
        let mut poses = w.identification_poses_rad().to_vec();
        poses.extend_from_slice(w.validation_poses_rad());
        let m = poses.len() / 6;
        let order = (0..m).chain((0..m).rev()).chain((0..m).step_by(3));
        for j in order {
            let q = &poses[6 * j..6 * j + 6];
            let measured = w.measure(q).unwrap();
            let expected = w.true_point(q).unwrap();
            assert_eq!(measured.map(f64::to_bits), expected.map(f64::to_bits));
        }
        // A pose that was not sampled is computed.
        let mut q = poses[..6].to_vec();
        q[0] += 1e-3;
        let measured = w.measure(&q).unwrap();
        assert_eq!(
            measured.map(f64::to_bits),
            w.true_point(&q).unwrap().map(f64::to_bits)
        );
    }
}

/// [`World::extended_truth`] is the injected physics in the extended family: with the
/// compliance and first-harmonic gear terms (random phases, a counterbalance, a base-frame
/// residual) its points are the world's true points to rounding, with a torque geometry
/// and mass model of its own; a term the family lacks (a second harmonic) or a family
/// without compliance leaves a difference of the size of the missing term.
#[test]
fn the_extended_truth_reaches_the_true_points() {
    let robot = kr1000();
    let mut cfg = everything();
    cfg.unmodelled.drift.enabled = false;
    cfg.unmodelled.compliance.counterbalance_fraction = vec![0.0, 0.58, 0.0, 0.0, 0.0, 0.0];
    // A mass model unlike the robot file's: the truth must take the virtual robot's.
    cfg.unmodelled.compliance.payload_kg = 250.0;
    let w = World::new(&robot, &cfg, 5, 1).unwrap();
    let mut names: Vec<String> = (1..=6).map(|j| format!("compliance_{j}")).collect();
    for j in 1..=6 {
        names.push(format!("gear_{j}_h1_sin"));
        names.push(format!("gear_{j}_h1_cos"));
    }
    let truth = w.extended_truth(&names).unwrap();
    let gears_only = w.extended_truth(&names[6..]).unwrap();
    let poses = w.identification_poses_rad().to_vec();
    let mut missing = 0.0_f64;
    for q in poses.chunks(6) {
        let p = w.true_point(q).unwrap();
        assert!(
            (truth.point(q) - p).norm() < 1e-9,
            "{}",
            (truth.point(q) - p).norm()
        );
        missing = missing.max((gears_only.point(q) - p).norm());
    }
    assert!(
        missing > 0.1,
        "compliance left out moves the point: {missing} mm"
    );

    // A second harmonic on joint 2 is outside the family: the difference is its size
    // (10″ at the ~3.7 m reach of joint 2: up to ~0.2 mm).
    cfg.unmodelled.gears.terms.push(virtual_robot::GearTerm {
        joint: 2,
        amplitude_arcsec: 10.0,
        harmonic: 2.0,
        phase_deg: 0.0,
    });
    let w = World::new(&robot, &cfg, 5, 1).unwrap();
    let truth = w.extended_truth(&names).unwrap();
    let worst = poses
        .chunks(6)
        .map(|q| (truth.point(q) - w.true_point(q).unwrap()).norm())
        .fold(0.0, f64::max);
    assert!(worst > 0.01 && worst < 0.3, "{worst} mm");
}

/// A nominal model with non-geometric parameters (an identified robot file with an
/// `extended` section) is refused by the virtual robot, naming the field and the way out.
#[test]
fn an_extended_nominal_model_is_refused() {
    let robot = kr1000()
        .with_extended(&["compliance_2", "gear_1_h1_sin"], "kr1000")
        .unwrap();
    let Err(err) = Setup::new(&robot, &everything(), 1) else {
        panic!("an extended nominal model was accepted");
    };
    let text = err.to_string();
    assert!(text.starts_with("`robot`:"), "{text}");
    assert!(
        text.contains("compliance_2, gear_1_h1_sin") && text.contains("unmodelled"),
        "{text}"
    );
}

/// A world refilled in place (`Setup::world_into`) is the world `Setup::world` builds, bit
/// for bit, whatever it held before: a world of another setup (other pose counts, errors
/// off), of another trial, or one whose measurements drifted and filled its caches; and
/// its simulation (poses, measurements with drift, gears, scatter and noise, the truth)
/// renders to the same bytes. A list of poses refills as well.
#[test]
fn a_refilled_world_is_a_fresh_one() {
    let robot = kr1000();
    let everything_setup = Setup::new(&robot, &everything(), 2024).unwrap();
    let mut small = ideal();
    small.poses.identification = PoseSet::Count(5);
    small.poses.validation = PoseSet::Count(70);
    let other = Setup::new(&robot, &small, 7).unwrap();
    let mut listed = everything();
    listed.truth.scale_to = None;
    listed.poses.validation = PoseSet::ListDeg(vec![
        vec![0.0, 10.0, 0.0, 0.0, 30.0, 0.0],
        vec![-15.0, 30.0, 20.0, 5.0, -40.0, 10.0],
    ]);
    let listed_setup = Setup::new(&robot, &listed, 5).unwrap();
    let mut kept = other.world(1).unwrap();
    kept.simulate().unwrap();
    for (setup, trial) in [
        (&everything_setup, 3),
        (&everything_setup, 4),
        (&listed_setup, 0),
        (&everything_setup, 3),
    ] {
        setup.world_into(trial, &mut kept).unwrap();
        let fresh = setup.world(trial).unwrap();
        assert_eq!(kept.truth(), fresh.truth(), "trial {trial}");
        assert_eq!(
            kept.identification_poses_rad(),
            fresh.identification_poses_rad()
        );
        assert_eq!(kept.validation_poses_rad(), fresh.validation_poses_rad());
        let a = render(&kept.simulate().unwrap());
        let b = render(&setup.simulate(trial).unwrap());
        assert_eq!(a, b, "trial {trial}");
    }
    // The comparisons can tell trials apart: trial 4's drawn errors differ from trial 3's.
    everything_setup.world_into(4, &mut kept).unwrap();
    assert_ne!(
        kept.truth().parameters,
        everything_setup.world(3).unwrap().truth().parameters
    );
}
