//! Rotation maths, the one place of the workspace: `log`/`exp` of SO(3), the skew matrix,
//! the inverse left Jacobian, the projection of a matrix on SO(3), and roll-pitch-yaw angles
//! in the base convention `R = Rz(yaw)·Ry(pitch)·Rx(roll)` (the robot file's base, the URDF's
//! `rpy`, [`crate::Frame::from_base_pose`]). Inverse kinematics, the 6-DoF identification and
//! the URDF reader and writer use these; none writes its own.

use nalgebra::{Matrix3, Rotation3, UnitQuaternion, Vector3};

/// Below this `sin θ` (with `cos θ ≤ 0`, i.e. within 30° of π) [`log_so3`] takes the axis
/// from the symmetric part of `R`: the skew part `sin θ·a` loses relative accuracy as
/// `ε / sin θ` there, while the symmetric part `(1 − cos θ)·a aᵀ` is largest [0.5: above it
/// the skew part is accurate to 2ε relative].
const NEAR_PI_SIN: f64 = 0.5;

/// The rotation vector (axis · angle, rad, angle in [0, π]) of the rotation matrix `r`:
/// `log` of SO(3).
///
/// Accurate to rounding at every angle: away from π from the skew part `v = (R − Rᵀ)/2 =
/// sin θ·a` with `θ = atan2(‖v‖, (tr R − 1)/2)` (an `acos` of the trace loses half the digits
/// near 0); within 30° of π, where `‖v‖ = sin θ` is small, from the unit quaternion of `R`
/// (built on its largest diagonal element, so from the symmetric part): `φ = 2·atan2(‖q_v‖,
/// |q_w|)·q_v/‖q_v‖`.
pub fn log_so3(r: &Matrix3<f64>) -> Vector3<f64> {
    let v = Vector3::new(
        r[(2, 1)] - r[(1, 2)],
        r[(0, 2)] - r[(2, 0)],
        r[(1, 0)] - r[(0, 1)],
    ) * 0.5;
    let s = v.norm();
    let c = ((r.trace() - 1.0) * 0.5).clamp(-1.0, 1.0);
    if c > 0.0 || s >= NEAR_PI_SIN {
        if s == 0.0 {
            return Vector3::zeros();
        }
        let angle = s.atan2(c);
        if angle < 1e-6 {
            // sin θ ≈ θ: v itself is the rotation vector to machine precision.
            return v * (1.0 + angle * angle / 6.0);
        }
        return v * (angle / s);
    }
    // Near π: the quaternion from the largest diagonal element (the symmetric part).
    let q = UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(*r));
    let (mut w, mut qv) = (q.w, q.imag());
    if w < 0.0 {
        w = -w;
        qv = -qv;
    }
    let n = qv.norm();
    qv * (2.0 * n.atan2(w) / n)
}

/// The rotation `r` as a unit quaternion `[w, x, y, z]`, scalar first, normalised, with
/// `w ≥ 0` (the sign that makes it unique, as the measurement files' orientation columns
/// and the measurement reader's Euler conversion write it).
pub fn unit_quaternion(r: &Matrix3<f64>) -> [f64; 4] {
    let q = UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(*r));
    let s = if q.w < 0.0 { -1.0 } else { 1.0 };
    [s * q.w, s * q.i, s * q.j, s * q.k]
}

/// `exp` of SO(3): the rotation by the rotation vector `v` (rad).
pub fn exp_so3(v: &Vector3<f64>) -> Matrix3<f64> {
    *Rotation3::new(*v).matrix()
}

/// The skew matrix `[v]×`, with `[v]× u = v × u`.
pub fn skew(v: &Vector3<f64>) -> Matrix3<f64> {
    Matrix3::new(0.0, -v.z, v.y, v.z, 0.0, -v.x, -v.y, v.x, 0.0)
}

/// The inverse left Jacobian of SO(3) at `φ`:
/// `J_l⁻¹(φ) = I − ½[φ]× + (1/θ² − (1+cos θ)/(2θ sin θ))[φ]×²` (series `1/12 + θ²/720` near
/// θ = 0).
pub fn inv_left_jacobian(phi: &Vector3<f64>) -> Matrix3<f64> {
    let t2 = phi.norm_squared();
    let t = t2.sqrt();
    let c = if t < 1e-4 {
        1.0 / 12.0 + t2 / 720.0
    } else {
        1.0 / t2 - (1.0 + t.cos()) / (2.0 * t * t.sin())
    };
    let k = skew(phi);
    Matrix3::identity() - k * 0.5 + (k * k) * c
}

/// The rotation nearest to `m` (Frobenius): `U·diag(1,1,det(UVᵀ))·Vᵀ` of its SVD.
pub fn project_so3(m: &Matrix3<f64>) -> Matrix3<f64> {
    let svd = m.svd(true, true);
    let (u, vt) = (svd.u.expect("u"), svd.v_t.expect("v_t"));
    let d = (u * vt).determinant().signum();
    u * Matrix3::from_diagonal(&Vector3::new(1.0, 1.0, d)) * vt
}

/// The rotation `Rz(yaw)·Ry(pitch)·Rx(roll)` of `[roll, pitch, yaw]` (rad): the base
/// convention (URDF `rpy`).
pub fn from_rpy([roll, pitch, yaw]: [f64; 3]) -> Matrix3<f64> {
    *Rotation3::from_euler_angles(roll, pitch, yaw).matrix()
}

/// `[roll, pitch, yaw]` (rad) of a rotation matrix in the base convention, by `atan2` only
/// (full precision up to the gimbal-lock pitch of ±90°, where roll is set to 0).
pub fn rpy_of(r: &Matrix3<f64>) -> [f64; 3] {
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
    use std::f64::consts::PI;

    /// `unit_quaternion` is `(cos θ/2, sin θ/2 · axis)` of the rotation, unit, `w ≥ 0`
    /// (the axis flipped past π), at small, medium and near-π angles.
    #[test]
    fn unit_quaternion_is_the_half_angle_form_with_w_non_negative() {
        for (axis, angle) in [
            (Vector3::new(1.0, 2.0, 3.0), 1e-9),
            (Vector3::new(0.3, -0.2, 0.9), 1.3),
            (Vector3::new(0.0, 1.0, 1.0), PI - 1e-7),
            (Vector3::new(1.0, -1.0, 0.5), 4.0),
        ] {
            let a = axis.normalize();
            let q = unit_quaternion(&exp_so3(&(a * angle)));
            let (s, c) = (0.5 * angle).sin_cos();
            let want = if c < 0.0 {
                [-c, -s * a.x, -s * a.y, -s * a.z]
            } else {
                [c, s * a.x, s * a.y, s * a.z]
            };
            assert!(q[0] >= 0.0, "{q:?}");
            let n = q.iter().map(|v| v * v).sum::<f64>().sqrt();
            assert!((n - 1.0).abs() < 1e-15, "{n}");
            for k in 0..4 {
                assert!((q[k] - want[k]).abs() < 1e-14, "{angle}: {q:?} vs {want:?}");
            }
        }
    }

    #[test]
    fn logarithm_matches_axis_angle_small_medium_and_near_pi() {
        for (axis, angle) in [
            (Vector3::new(1.0, 2.0, 3.0), 1e-11),
            (Vector3::new(-1.0, 0.5, 0.2), 1e-4),
            (Vector3::new(0.3, -0.2, 0.9), 1.3),
            (Vector3::new(0.3, -0.2, 0.9), 2.5),
            (Vector3::new(0.0, 1.0, 1.0), PI - 1e-3),
            (Vector3::new(0.0, 1.0, 1.0), PI - 1e-7),
            (Vector3::new(1.0, -1.0, 0.5), PI),
        ] {
            let v = axis.normalize() * angle;
            let back = log_so3(&exp_so3(&v));
            assert!(
                (back - v).norm() <= 1e-12 * angle.max(1e-3) + 1e-15,
                "angle {angle}: {back:?} vs {v:?}"
            );
        }
        assert_eq!(log_so3(&Matrix3::identity()), Vector3::zeros());
    }

    /// The skew part of a rotation made by products (with rounding in every entry) carries
    /// an absolute error ε: near π, where its norm is sin θ, an axis taken from it is off by
    /// ε / sin θ. The one `log_so3` stays at rounding level there; the skew-part formula
    /// (what inverse kinematics used before) loses five digits at 1e-5 rad from π.
    #[test]
    fn logarithm_near_pi_of_a_product_is_accurate_to_rounding() {
        let skew_only = |r: &Matrix3<f64>| {
            let v = Vector3::new(
                r[(2, 1)] - r[(1, 2)],
                r[(0, 2)] - r[(2, 0)],
                r[(1, 0)] - r[(0, 1)],
            ) * 0.5;
            let c = ((r.trace() - 1.0) * 0.5).clamp(-1.0, 1.0);
            v * (v.norm().atan2(c) / v.norm())
        };
        let mut worst = (0.0f64, 0.0f64);
        for k in 0..200 {
            let t = k as f64 * 0.37;
            let axis = Vector3::new(t.sin(), (1.3 * t).cos(), 0.4 + (0.7 * t).sin()).normalize();
            // A rotation about `axis` by π − 1e-5, composed from two parts of it through an
            // unrelated frame: R = B·exp(θ1 a)·exp(θ2 a)·Bᵀ, its vector B·(θ1 + θ2)·a.
            let b = exp_so3(&Vector3::new(0.3 * t.cos(), -0.2, 0.5 * t.sin()));
            let (t1, t2) = (1.1 + 0.01 * k as f64, PI - 1e-5 - 1.1 - 0.01 * k as f64);
            let r = b * exp_so3(&(axis * t1)) * exp_so3(&(axis * t2)) * b.transpose();
            let truth = b * axis * (t1 + t2);
            worst.0 = worst.0.max((log_so3(&r) - truth).norm());
            worst.1 = worst.1.max((skew_only(&r) - truth).norm());
        }
        assert!(worst.0 < 1e-14, "log_so3 off by {:e}", worst.0);
        assert!(worst.1 > 1e-12, "skew part off by only {:e}", worst.1);
    }

    #[test]
    fn inv_left_jacobian_inverts_the_left_jacobian() {
        // J_l(φ) = I + (1 − cos θ)/θ² [φ]× + (θ − sin θ)/θ³ [φ]×², in closed form.
        for phi in [
            Vector3::new(1e-6, -2e-6, 3e-7),
            Vector3::new(0.3, -0.2, 0.5),
            Vector3::new(1.0, 2.0, -0.5),
        ] {
            let t = phi.norm();
            let k = skew(&phi);
            let jl = Matrix3::identity()
                + k * ((1.0 - t.cos()) / (t * t))
                + (k * k) * ((t - t.sin()) / (t * t * t));
            let e = (inv_left_jacobian(&phi) * jl - Matrix3::identity())
                .abs()
                .max();
            assert!(e < 1e-9, "{phi:?}: {e:e}");
        }
    }

    #[test]
    fn project_so3_recovers_a_perturbed_rotation() {
        let r = exp_so3(&Vector3::new(0.4, -1.2, 2.0));
        let p = project_so3(&(r * 3.0));
        assert!((p - r).abs().max() < 1e-14);
        assert!((p.determinant() - 1.0).abs() < 1e-14);
    }

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
