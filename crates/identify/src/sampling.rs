//! Random measurement poses, a stand-in until the campaign crate provides scenario pose sets.
//!
//! Each joint is drawn uniformly within its limits; a draw is kept when the wrist joint is at
//! least [`PoseSampler::min_abs_wrist_deg`] from zero (the wrist singularity of a spherical
//! wrist) and the robot is well away from any other singularity:
//! [`Robot::singularity_condition`]`(q, orientation_scale_mm) ≤ max_condition`.

use kinematics::Robot;
use rand::rngs::ChaCha8Rng;
use rand::{Rng, RngExt, SeedableRng};

use crate::error::IdentifyError;

/// Rules of [`PoseSampler::sample`]. Defaults in brackets.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PoseSampler {
    /// 0-based wrist joint kept away from zero [Some(4), joint 5, for 6-joint robots; None
    /// otherwise].
    pub wrist_joint: Option<usize>,
    /// Smallest |q_wrist|, degrees [10: a margin around the wrist singularity q = 0].
    pub min_abs_wrist_deg: f64,
    /// Largest condition number of the 6 × N geometric Jacobian [100: away from shoulder and
    /// elbow singularities too].
    pub max_condition: f64,
    /// Length weighing rotation against translation in that Jacobian, mm [1000, the order of
    /// a large robot's reach].
    pub orientation_scale_mm: f64,
    /// Draws allowed per pose wanted before giving up [1000: about 87 % of draws are admissible
    /// for the KR1000].
    pub max_attempts_per_pose: usize,
}

impl PoseSampler {
    /// The defaults for `robot`.
    pub fn for_robot(robot: &Robot) -> Self {
        PoseSampler {
            wrist_joint: (robot.n_joints() == 6).then_some(4),
            min_abs_wrist_deg: 10.0,
            max_condition: 100.0,
            orientation_scale_mm: 1000.0,
            max_attempts_per_pose: 1000,
        }
    }

    /// `n` admissible poses (flat, radians) drawn from `rng`.
    pub fn sample<R: Rng + ?Sized>(
        &self,
        robot: &Robot,
        n: usize,
        rng: &mut R,
    ) -> Result<Vec<f64>, IdentifyError> {
        let nj = robot.n_joints();
        let mut out = Vec::with_capacity(n * nj);
        let mut q = vec![0.0; nj];
        let max_attempts = n.saturating_mul(self.max_attempts_per_pose);
        let mut attempts = 0;
        while out.len() < n * nj {
            if attempts >= max_attempts {
                return Err(IdentifyError::Sampling {
                    found: out.len() / nj,
                    wanted: n,
                    attempts,
                });
            }
            attempts += 1;
            for (i, qi) in q.iter_mut().enumerate() {
                let [lo, hi] = robot.limits_rad(i);
                *qi = if hi > lo {
                    rng.random_range(lo..=hi)
                } else {
                    lo
                };
            }
            if let Some(w) = self.wrist_joint
                && q[w].abs() < self.min_abs_wrist_deg.to_radians()
            {
                continue;
            }
            if robot.singularity_condition(&q, self.orientation_scale_mm) > self.max_condition {
                continue;
            }
            out.extend_from_slice(&q);
        }
        Ok(out)
    }
}

/// `n` admissible poses for `robot` from the default [`PoseSampler`] and a ChaCha8 stream
/// seeded with `seed` (reproducible across platforms and rand releases).
pub fn random_poses(robot: &Robot, n: usize, seed: u64) -> Result<Vec<f64>, IdentifyError> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    PoseSampler::for_robot(robot).sample(robot, n, &mut rng)
}
