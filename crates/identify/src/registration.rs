//! Closed-form rigid registration of the start model's predictions to the measurements,
//! re-expressed in the robot's base parameters.
//!
//! Real data arrive in the tracker's frame, metres and any rotation away from the robot base.
//! LM linearises; from a start that far it may fail or stop in a local minimum. The rigid
//! transform `T = (R, t)` minimising `Σ_j ‖R·p_j + t − p_j^meas‖²` (no scale) is found in
//! closed form (Kabsch/Umeyama): with centroids `p̄`, `p̄^meas` and
//! `H = Σ_j (p_j − p̄)(p_j^meas − p̄^meas)ᵀ = U Σ Vᵀ`,
//! `R = V diag(1, 1, det(V Uᵀ)) Uᵀ`, `t = p̄^meas − R p̄`.
//!
//! The new base is `T · T_base`: rotation `R·R_base`, translation `R·d_base + t`, written back
//! as `base_rx, base_ry, base_rz` (with `T_base = Trans(d)·Rz·Ry·Rx`, nalgebra's
//! `Rotation3::euler_angles`) and `base_dx, base_dy, base_dz`. Every other parameter is
//! untouched. Note the Euler parametrisation is singular at base_ry = ±90°; there base_rx and
//! base_rz become confounded, which the identifiability report then shows.

use kinematics::{ParamKind, Robot};
use nalgebra::{Matrix3, Rotation3, Vector3};
use serde::{Deserialize, Serialize};

use crate::error::IdentifyError;
use crate::problem::check_poses_and_points;

fn default_threshold_mm() -> f64 {
    10.0
}

/// When to register the base before identification.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "lowercase", deny_unknown_fields)]
pub enum RegistrationPolicy {
    /// Never: LM starts from the start model as given (the paper's procedure).
    Never,
    /// Always register first.
    Always,
    /// Register when the start model's mean point error exceeds `threshold_mm`.
    Auto {
        /// Mean 3-D point error above which the data are taken to be in another frame [10 mm:
        /// geometric errors of a real robot give 1–3 mm (the paper: 1.12 mm mean, 2.56 mm
        /// max), so a larger mean means a frame offset, which LM's linearisation handles badly
        /// and the closed form handles exactly].
        #[serde(default = "default_threshold_mm")]
        threshold_mm: f64,
    },
}

impl Default for RegistrationPolicy {
    fn default() -> Self {
        RegistrationPolicy::Auto {
            threshold_mm: default_threshold_mm(),
        }
    }
}

/// A rigid transform `x ↦ R·x + t`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RigidTransform {
    /// Rotation R.
    pub rotation: Matrix3<f64>,
    /// Translation t, mm.
    pub translation_mm: Vector3<f64>,
}

impl RigidTransform {
    /// `R·p + t`.
    pub fn apply(&self, p: &Vector3<f64>) -> Vector3<f64> {
        self.rotation * p + self.translation_mm
    }

    /// Rotation angle, degrees.
    pub fn angle_deg(&self) -> f64 {
        Rotation3::from_matrix_unchecked(self.rotation)
            .angle()
            .to_degrees()
    }
}

/// The least-squares rigid transform taking `from` onto `to` (Kabsch, no scale). Fails when
/// fewer than three points are given, lengths differ, a value is not finite, or the points
/// are (nearly) collinear so the rotation is undetermined.
pub fn kabsch(from: &[Vector3<f64>], to: &[Vector3<f64>]) -> Result<RigidTransform, IdentifyError> {
    if from.len() != to.len() {
        return Err(IdentifyError::Registration {
            reason: format!("{} predicted points but {} measured", from.len(), to.len()),
        });
    }
    if from.len() < 3 {
        return Err(IdentifyError::Registration {
            reason: format!("{} points; at least 3 non-collinear are needed", from.len()),
        });
    }
    if !from
        .iter()
        .chain(to)
        .all(|p| p.iter().all(|v| v.is_finite()))
    {
        return Err(IdentifyError::Registration {
            reason: "a point is not finite".into(),
        });
    }
    let n = from.len() as f64;
    let ca = from.iter().sum::<Vector3<f64>>() / n;
    let cb = to.iter().sum::<Vector3<f64>>() / n;
    let h: Matrix3<f64> = from
        .iter()
        .zip(to)
        .map(|(a, b)| (a - ca) * (b - cb).transpose())
        .sum();
    let svd = h.svd(true, true);
    let (u, v_t) = (svd.u.unwrap(), svd.v_t.unwrap());
    let mut s: Vec<f64> = svd.singular_values.iter().copied().collect();
    s.sort_by(|a, b| b.total_cmp(a));
    if s[1].is_nan() || s[1] <= 1e-9 * s[0] {
        return Err(IdentifyError::Registration {
            reason: "the points are (nearly) collinear: the rotation about their line is \
                     undetermined"
                .into(),
        });
    }
    let v = v_t.transpose();
    let d = (v * u.transpose()).determinant().signum();
    let rotation = v * Matrix3::from_diagonal(&Vector3::new(1.0, 1.0, d)) * u.transpose();
    Ok(RigidTransform {
        rotation,
        translation_mm: cb - rotation * ca,
    })
}

/// What registration did.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RegistrationReport {
    /// Whether the base was changed.
    pub applied: bool,
    /// Mean 3-D point error of the start model, mm.
    pub mean_error_before_mm: f64,
    /// Mean 3-D point error after registration (= before when not applied), mm.
    pub mean_error_after_mm: f64,
    /// Rotation angle of the correction, degrees (0 when not applied).
    pub rotation_deg: f64,
    /// Translation of the correction, mm (zeros when not applied).
    pub translation_mm: [f64; 3],
    /// Base parameters before, `[rx, ry, rz]` deg and `[dx, dy, dz]` mm.
    pub base_before: [f64; 6],
    /// Base parameters after.
    pub base_after: [f64; 6],
}

/// Mean 3-D distance between `robot`'s predictions and the measured points, mm.
pub fn mean_point_error(robot: &Robot, poses_rad: &[f64], points_mm: &[Vector3<f64>]) -> f64 {
    let n = robot.n_joints();
    let m = points_mm.len().max(1) as f64;
    poses_rad
        .chunks_exact(n)
        .zip(points_mm)
        .map(|(q, p)| (p - robot.point(q)).norm())
        .sum::<f64>()
        / m
}

/// Indices of `base_rx … base_dz` in the robot's parameter vector.
fn base_indices(robot: &Robot) -> [usize; 6] {
    let kinds = [
        ParamKind::BaseRx,
        ParamKind::BaseRy,
        ParamKind::BaseRz,
        ParamKind::BaseDx,
        ParamKind::BaseDy,
        ParamKind::BaseDz,
    ];
    let params = robot.layout().params();
    kinds.map(|kind| {
        params
            .iter()
            .position(|p| p.kind == kind)
            .expect("every layout has the base parameters")
    })
}

fn base_display(robot: &Robot, x: &[f64]) -> [f64; 6] {
    let layout = robot.layout();
    base_indices(robot).map(|k| layout.get(k).to_display(x[k]))
}

/// Registers `robot`'s base to the measurements: returns the robot with its base re-expressed
/// so that its predictions best match `points_mm` rigidly, and a report.
pub fn register_base(
    robot: &Robot,
    poses_rad: &[f64],
    points_mm: &[Vector3<f64>],
) -> Result<(Robot, RegistrationReport), IdentifyError> {
    check_poses_and_points(robot, poses_rad, points_mm)?;
    let predicted = robot.points(poses_rad);
    let t = kabsch(&predicted, points_mm)?;
    let before = mean_point_error(robot, poses_rad, points_mm);
    let bf = robot.base_frame();
    // Orthonormal to rounding (Kabsch SVD times a rotation): no re-orthogonalisation needed.
    let rot = Rotation3::from_matrix_unchecked(t.rotation * bf.rot);
    let (rx, ry, rz) = rot.euler_angles();
    let d = t.rotation * bf.pos_mm + t.translation_mm;
    let mut x = robot.params();
    let x_before = x.clone();
    let idx = base_indices(robot);
    for (k, v) in idx.iter().zip([rx, ry, rz, d.x, d.y, d.z]) {
        x[*k] = v;
    }
    let registered = robot.with_params(&x)?;
    let after = mean_point_error(&registered, poses_rad, points_mm);
    Ok((
        registered,
        RegistrationReport {
            applied: true,
            mean_error_before_mm: before,
            mean_error_after_mm: after,
            rotation_deg: t.angle_deg(),
            translation_mm: t.translation_mm.into(),
            base_before: base_display(robot, &x_before),
            base_after: base_display(robot, &x),
        },
    ))
}

/// A report for "not registered".
pub(crate) fn not_applied(robot: &Robot, before_mm: f64) -> RegistrationReport {
    let x = robot.params();
    let b = base_display(robot, &x);
    RegistrationReport {
        applied: false,
        mean_error_before_mm: before_mm,
        mean_error_after_mm: before_mm,
        rotation_deg: 0.0,
        translation_mm: [0.0; 3],
        base_before: b,
        base_after: b,
    }
}
