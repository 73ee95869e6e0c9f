//! Shared test helpers: a direct URDF forward kinematics (origins and axis rotations
//! composed as the URDF states them), fixtures, a seeded pose generator.
#![allow(dead_code)]

use std::path::PathBuf;

use nalgebra::{Matrix3, Rotation3, Unit, Vector3};

pub fn fixture(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("tests/fixtures")
        .join(name)
}

/// The point `p_tip_mm` of link `tip` in link `base`'s frame, mm, for the revolute joints
/// and prismatic joints of the chain set to `q` (internal units: radians, and millimetres
/// as `kinematics::prismatic_internal` stores them; base to tip), straight from the URDF.
pub fn urdf_point(
    robot: &urdf_rs::Robot,
    base: &str,
    tip: &str,
    q: &[f64],
    p_tip_mm: &Vector3<f64>,
) -> Vector3<f64> {
    let mut chain = Vec::new();
    let mut link = tip.to_string();
    while link != base {
        let j = robot
            .joints
            .iter()
            .find(|j| j.child.link == link)
            .expect("tip below base");
        chain.push(j);
        link = j.parent.link.clone();
    }
    chain.reverse();
    let mut rot = Matrix3::identity();
    let mut pos = Vector3::zeros();
    let mut k = 0;
    for j in chain {
        let [r, p, y] = j.origin.rpy.0;
        let o_rot = *Rotation3::from_euler_angles(r, p, y).matrix();
        let o_pos = Vector3::from(j.origin.xyz.0) * 1000.0;
        pos += rot * o_pos;
        rot *= o_rot;
        if j.joint_type == urdf_rs::JointType::Revolute {
            let axis = Unit::new_normalize(Vector3::from(j.axis.xyz.0));
            rot *= *Rotation3::from_axis_angle(&axis, q[k]).matrix();
            k += 1;
        } else if j.joint_type == urdf_rs::JointType::Prismatic {
            // Along the axis by q (the robot file's millimetres, in internal units).
            let axis = Vector3::from(j.axis.xyz.0).normalize();
            pos += rot * axis * kinematics::prismatic_mm(q[k]);
            k += 1;
        }
    }
    assert_eq!(k, q.len());
    rot * p_tip_mm + pos
}

/// A small deterministic generator (SplitMix64) of uniform values in [0, 1).
pub struct Rng(pub u64);

impl Rng {
    pub fn next(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^= z >> 31;
        (z >> 11) as f64 / (1u64 << 53) as f64
    }

    /// A joint vector uniformly within the robot's limits, radians.
    pub fn pose(&mut self, robot: &kinematics::Robot) -> Vec<f64> {
        (0..robot.n_joints())
            .map(|i| {
                let [lo, hi] = robot.limits_rad(i);
                lo + (hi - lo) * self.next()
            })
            .collect()
    }
}
