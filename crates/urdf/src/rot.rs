//! Roll-pitch-yaw, the URDF's (and the robot file's base) rotation convention:
//! `R = Rz(yaw) · Ry(pitch) · Rx(roll)`.

use nalgebra::{Matrix3, Rotation3};

/// The rotation of URDF `rpy="roll pitch yaw"` (radians), as the kinematics crate builds the
/// base rotation.
pub(crate) fn from_rpy([roll, pitch, yaw]: [f64; 3]) -> Matrix3<f64> {
    *Rotation3::from_euler_angles(roll, pitch, yaw).matrix()
}

/// `[roll, pitch, yaw]` of a rotation matrix, by `atan2` only (full precision up to the
/// gimbal-lock pitch of ±90°, where roll is set to 0).
pub(crate) fn rpy_of(r: &Matrix3<f64>) -> [f64; 3] {
    let cp = r[(0, 0)].hypot(r[(1, 0)]);
    let pitch = (-r[(2, 0)]).atan2(cp);
    if cp > 1e-12 {
        [
            r[(2, 1)].atan2(r[(2, 2)]),
            pitch,
            r[(1, 0)].atan2(r[(0, 0)]),
        ]
    } else {
        // Gimbal lock: only yaw − roll (pitch +90°) or yaw + roll (−90°) is defined.
        [0.0, pitch, (-r[(0, 1)]).atan2(r[(1, 1)])]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rpy_round_trips_including_near_gimbal_lock() {
        let h = std::f64::consts::FRAC_PI_2;
        for rpy in [
            [0.1, 0.2, 0.3],
            [-3.0, h - 1e-7, 2.0],
            [1.0, -h + 1e-10, -0.5],
            [3.1, -0.3, 3.0],
            [0.0, h, 0.7],
        ] {
            let r = from_rpy(rpy);
            let back = from_rpy(rpy_of(&r));
            assert!(
                (r - back).abs().max() < 1e-15,
                "{rpy:?}: {}",
                (r - back).abs().max()
            );
        }
    }
}
