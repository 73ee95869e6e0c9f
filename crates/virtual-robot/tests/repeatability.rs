//! Repeatability scatter alone gives the KR1000's RP ≈ 0.1 mm (ISO 9283 RP_l).

use crate::common::{deg, everything, ideal, kr1000};
use evaluate::point_stats;
use virtual_robot::{PoseSet, World};

#[test]
fn rp_l_of_30_cycles_is_0_1_mm() {
    let robot = kr1000();
    let mut cfg = ideal();
    cfg.unmodelled.repeatability.enabled = true;
    let pose = vec![10.0, 30.0, -20.0, 0.0, 45.0, 0.0];
    cfg.poses.identification = PoseSet::ListDeg(vec![pose.clone()]);
    cfg.poses.validation = PoseSet::ListDeg(vec![pose.clone()]);
    let q = deg(&pose);
    let commanded = robot.point(&q);
    let seeds = 50;
    let mut sum = 0.0;
    for seed in 0..seeds {
        let mut w = World::new(&robot, &cfg, seed, 0).unwrap();
        let attained: Vec<[f64; 3]> = (0..30).map(|_| w.measure(&q).unwrap().into()).collect();
        let s = point_stats(commanded.into(), &attained).unwrap();
        // Pure scatter: no systematic offset beyond the barycentre's own noise.
        assert!(s.ap_p_mm < 0.05, "seed {seed}: AP {}", s.ap_p_mm);
        sum += s.rp_l_mm;
    }
    let rp = sum / seeds as f64;
    assert!(
        (rp - 0.1).abs() < 0.01,
        "mean RP_l over {seeds} seeds = {rp:.4} mm"
    );
}

#[test]
fn repeatability_off_means_identical_repeats() {
    let robot = kr1000();
    let cfg = ideal();
    let mut w = World::new(&robot, &cfg, 1, 0).unwrap();
    let q = w.identification_poses_rad()[..6].to_vec();
    let a = w.measure(&q).unwrap();
    assert_eq!(w.measure(&q).unwrap(), a);
}

/// Joints outside the sampled sets (compensated targets, the ISO test's P1–P5) are measured
/// again and again; the world keeps the reached points of the last few (a ring) and a kept
/// point must be the bits a fresh computation gives. With compliance and gear errors on and
/// the noise off, 20 joint sets measured twice in a row, then all 20 again (the ring holds
/// fewer, so the first ones come back recomputed and the others kept), each equal bit for bit
/// to the measurement of a fresh world of the same trial.
#[test]
fn kept_points_of_repeated_joints_are_the_computed_bits() {
    let robot = kr1000();
    let mut cfg = everything();
    cfg.unmodelled.drift.enabled = false;
    cfg.unmodelled.repeatability.enabled = false;
    cfg.tracker.noise = false;
    let joints: Vec<Vec<f64>> = (0..20)
        .map(|k| {
            let t = f64::from(k);
            deg(&[
                10.0 + t,
                20.0 - 0.5 * t,
                -15.0 + t,
                5.0 * t,
                40.0 + t,
                -3.0 * t,
            ])
        })
        .collect();
    let fresh = |q: &[f64]| World::new(&robot, &cfg, 7, 3).unwrap().measure(q).unwrap();
    let mut w = World::new(&robot, &cfg, 7, 3).unwrap();
    let order = (0..20).flat_map(|k| [k, k]).chain(0..20);
    for k in order {
        let (got, want) = (w.measure(&joints[k]).unwrap(), fresh(&joints[k]));
        assert_eq!(got.map(f64::to_bits), want.map(f64::to_bits), "joints {k}");
    }
}
