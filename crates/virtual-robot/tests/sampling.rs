//! Pose sampling: rejection statistics, exhaustion errors, independent streams.

use crate::common::{ideal, kr1000};
use virtual_robot::{PoseSet, SimError, World};

#[test]
fn rejection_rate_is_reported() {
    let robot = kr1000();
    let w = World::new(&robot, &ideal(), 3, 0).unwrap();
    let r = w.sampling_report();
    for s in [r.identification, r.validation] {
        assert_eq!((s.wanted, s.accepted), (50, 50));
        assert_eq!(s.accepted as u64 + s.rejected(), s.draws);
        assert!(s.rejected_wrist > 0 && s.rejected_floor > 0, "{s:?}");
    }
    let rate = r.rejection_rate();
    assert!(rate > 0.0 && rate < 0.5, "{rate}");
    assert_eq!(
        rate,
        r.total().rejected() as f64 / (r.identification.draws + r.validation.draws) as f64
    );
    assert!(r.scale.is_none());
    assert_eq!(w.truth().sampling, *r);
}

#[test]
fn constraints_leaving_no_pose_fail_clearly() {
    let robot = kr1000();
    let mut cfg = ideal();
    cfg.poses.min_point_z_mm = 10_000.0;
    cfg.poses.max_draws_per_pose = 20;
    let err = World::new(&robot, &cfg, 1, 0).unwrap_err();
    match &err {
        SimError::Sampling { field, stats } => {
            assert_eq!(field, "poses.identification");
            assert_eq!((stats.wanted, stats.accepted, stats.draws), (50, 0, 1000));
            assert_eq!(stats.rejected_floor + stats.rejected_wrist, 1000);
            assert_eq!(stats.rejection_rate(), 1.0);
        }
        other => panic!("{other}"),
    }
    let msg = err.to_string();
    assert!(
        msg.starts_with("`poses.identification`: the sampling constraints left only 0 of 50 poses after 1000 draws"),
        "{msg}"
    );
    assert!(msg.contains("floor"), "{msg}");

    // A tracker window nothing fits through: rejected for elevation.
    let mut cfg = ideal();
    cfg.tracker.elevation_limit_deg = 0.05;
    cfg.poses.max_draws_per_pose = 10;
    match World::new(&robot, &cfg, 1, 0).unwrap_err() {
        SimError::Sampling { stats, .. } => {
            assert_eq!(stats.accepted, 0);
            assert!(stats.rejected_elevation > 400, "{stats:?}");
        }
        other => panic!("{other}"),
    }

    // The scaling set is named as such.
    let mut cfg = ideal();
    cfg.truth.random = Some(Default::default());
    cfg.truth.scale_to = Some(Default::default());
    cfg.poses.min_abs_q5_deg = 179.0;
    cfg.poses.max_draws_per_pose = 5;
    match World::new(&robot, &cfg, 1, 0).unwrap_err() {
        SimError::Sampling { field, .. } => assert_eq!(field, "truth.scale_to.poses"),
        other => panic!("{other}"),
    }
}

#[test]
fn scaling_zero_errors_fails_clearly() {
    let robot = kr1000();
    let mut cfg = ideal();
    cfg.truth.scale_to = Some(Default::default());
    let err = World::new(&robot, &cfg, 1, 0).unwrap_err();
    assert!(matches!(err, SimError::Scale { .. }), "{err}");
    assert!(
        err.to_string()
            .starts_with("`truth.scale_to.mean_error_mm`"),
        "{err}"
    );
}

#[test]
fn each_set_has_its_own_stream() {
    let robot = kr1000();
    let cfg = ideal();
    let a = World::new(&robot, &cfg, 5, 0).unwrap();
    assert_ne!(a.identification_poses_rad(), a.validation_poses_rad());
    // Replacing the identification set leaves the validation draws untouched.
    let mut cfg2 = cfg.clone();
    cfg2.poses.identification = PoseSet::Count(7);
    let b = World::new(&robot, &cfg2, 5, 0).unwrap();
    assert_eq!(a.validation_poses_rad(), b.validation_poses_rad());
    assert_eq!(
        &a.identification_poses_rad()[..42],
        b.identification_poses_rad()
    );
    // Other trials and seeds draw other poses.
    let c = World::new(&robot, &cfg, 5, 1).unwrap();
    assert_ne!(a.identification_poses_rad(), c.identification_poses_rad());
    let d = World::new(&robot, &cfg, 6, 0).unwrap();
    assert_ne!(a.identification_poses_rad(), d.identification_poses_rad());
}

#[test]
fn condition_limit_matches_the_svd_decision() {
    // The sampler decides `cond ≤ limit` mostly by Cholesky bounds; every accepted pose must
    // pass the exact SVD test and a tight limit must reject some.
    let robot = kr1000();
    let mut cfg = ideal();
    cfg.poses.max_condition = Some(8.0);
    cfg.poses.identification = PoseSet::Count(100);
    let w = World::new(&robot, &cfg, 2, 0).unwrap();
    for q in w.identification_poses_rad().chunks(6) {
        assert!(robot.singularity_condition(q, 1000.0) <= 8.0);
    }
    assert!(w.sampling_report().identification.rejected_condition > 20);
}
