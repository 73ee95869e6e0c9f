//! Shared helpers of the integration tests.
#![allow(dead_code)]

pub mod compensation_targets;

use kinematics::{PoseSampler, Robot, RobotSpec};
use nalgebra::Vector3;
use rand::rngs::ChaCha8Rng;
use rand::{RngExt, SeedableRng};
use rand_distr::{Distribution, Normal};

/// The KR1000 nominal model with the given ball offset.
pub fn kr1000(tool_mm: [f64; 3]) -> Robot {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../scenarios/robots/kr1000-titan.json"
    );
    let text = std::fs::read_to_string(path).expect("robot file");
    let mut spec = RobotSpec::from_json_str(&text, path).expect("robot spec");
    spec.tool_mm = tool_mm;
    Robot::from_spec(&spec).expect("robot")
}

/// The scenario's ball offset, off the flange axis.
pub const TOOL: [f64; 3] = [60.0, 20.0, 150.0];

/// Poses for identification and for validation (different seeds).
pub fn poses(robot: &Robot, n: usize, seed: u64) -> Vec<f64> {
    PoseSampler::default()
        .sample(robot, n, &mut ChaCha8Rng::seed_from_u64(seed))
        .expect("poses")
        .rad
}

/// A "true" robot: the nominal one with realistic errors on the parameters selected by
/// `which` (indices): angles ~0.05° (joint), 0.1° (base), lengths ~0.5 mm (joint), a few mm
/// (base), ~1 mm (tool). Uniform in ±1 × the size, from `seed`.
pub fn perturbed(nominal: &Robot, which: &[usize], seed: u64) -> Robot {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut x = nominal.params();
    let layout = nominal.layout();
    for &k in which {
        let name = layout.get(k).name.as_str();
        let size = if name.starts_with("base_r") {
            0.1_f64.to_radians()
        } else if name.starts_with("base_d") {
            3.0
        } else if name.starts_with("tool") {
            1.0
        } else if name.starts_with('d') || name.starts_with("a") && !name.starts_with("alpha") {
            0.5
        } else {
            0.05_f64.to_radians()
        };
        x[k] += size * rng.random_range(-1.0..=1.0);
    }
    nominal.with_params(&x).expect("perturbed robot")
}

/// Isotropic Gaussian noise σ per axis added to every point.
pub fn noisy(points: &[Vector3<f64>], sigma_mm: f64, seed: u64) -> Vec<Vector3<f64>> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let normal = Normal::new(0.0, sigma_mm).expect("normal");
    points
        .iter()
        .map(|p| {
            p + Vector3::new(
                normal.sample(&mut rng),
                normal.sample(&mut rng),
                normal.sample(&mut rng),
            )
        })
        .collect()
}

/// Largest 3-D distance between two robots' points over the poses, mm.
pub fn max_point_diff(a: &Robot, b: &Robot, poses: &[f64]) -> f64 {
    a.points(poses)
        .iter()
        .zip(b.points(poses))
        .map(|(p, q)| (p - q).norm())
        .fold(0.0, f64::max)
}

/// RMS 3-D distance between two robots' points over the poses, mm.
pub fn rms_point_diff(a: &Robot, b: &Robot, poses: &[f64]) -> f64 {
    let d: Vec<f64> = a
        .points(poses)
        .iter()
        .zip(b.points(poses))
        .map(|(p, q)| (p - q).norm_squared())
        .collect();
    (d.iter().sum::<f64>() / d.len() as f64).sqrt()
}
