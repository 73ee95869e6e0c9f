//! The generic pose set: the one definition of "poses in general position" on which the
//! structural questions are answered — which parameters form the minimal identifiable set
//! (`design`'s default parameters) and how many parameters are free (`calibrate`'s count of
//! rows needed).
//!
//! [`GENERIC_POSE_COUNT`] admissible poses from the workspace's one pose sampler
//! ([`kinematics::sampling::PoseSampler`], default rule) and a ChaCha8 stream seeded with
//! [`GENERIC_POSE_SEED`] (reproducible across platforms and `rand` releases). Sixty poses
//! give 180 rows, more than the longest parameter vector, so the rank they show is the
//! model's structural rank, not the pose set's.

use kinematics::Robot;
use kinematics::sampling::PoseSampler;
use rand::SeedableRng;
use rand::rngs::ChaCha8Rng;

use crate::error::IdentifyError;

/// Poses of the generic pose set.
pub const GENERIC_POSE_COUNT: usize = 60;

/// Seed of the generic pose set's stream (ASCII "generic").
pub const GENERIC_POSE_SEED: u64 = 0x67_656e_6572_6963;

/// The generic pose set of `robot` (flat, stride N, radians; see the module docs).
pub fn generic_poses(robot: &Robot) -> Result<Vec<f64>, IdentifyError> {
    let mut rng = ChaCha8Rng::seed_from_u64(GENERIC_POSE_SEED);
    Ok(PoseSampler::default()
        .sample(robot, GENERIC_POSE_COUNT, &mut rng)?
        .rad)
}
