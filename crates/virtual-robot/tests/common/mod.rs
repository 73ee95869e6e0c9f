//! Shared helpers of the integration tests.
#![allow(dead_code)]

use kinematics::{Robot, RobotSpec};
use virtual_robot::VirtualRobotConfig;

pub const KR1000: &str = include_str!("../../../../scenarios/robots/kr1000-titan.json");

pub fn kr1000() -> Robot {
    Robot::from_spec(&RobotSpec::from_json_str(KR1000, "kr1000-titan.json").unwrap()).unwrap()
}

/// No injected error, no unmodelled error, no noise.
pub fn ideal() -> VirtualRobotConfig {
    VirtualRobotConfig::ideal()
}

/// A paper-like configuration: random errors scaled to 1.122 mm, every unmodelled error
/// on (drift included), anisotropic noise and a small residual.
pub fn everything() -> VirtualRobotConfig {
    let mut c = VirtualRobotConfig::default();
    c.truth.random = Some(Default::default());
    c.truth.scale_to = Some(Default::default());
    c.truth.explicit.insert("beta2".into(), 0.01);
    c.unmodelled.gears.enabled = true;
    c.unmodelled.gears.random_phase = true;
    c.unmodelled.drift.enabled = true;
    c.tracker.base_residual.rz_deg = 0.003;
    c.tracker.base_residual.dx_mm = 0.1;
    c.poses.identification = virtual_robot::PoseSet::Count(20);
    c.poses.validation = virtual_robot::PoseSet::Count(10);
    c
}

pub fn deg(q: &[f64]) -> Vec<f64> {
    q.iter().map(|d| d.to_radians()).collect()
}
