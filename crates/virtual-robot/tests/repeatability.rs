//! Repeatability scatter alone gives the KR1000's RP ≈ 0.1 mm (ISO 9283 RP_l).

use crate::common::{deg, ideal, kr1000};
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
