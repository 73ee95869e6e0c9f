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
    let (registered, base_before, base_after) = base_moved_by(robot, &t)?;
    let after = mean_point_error(&registered, poses_rad, points_mm);
    Ok((
        registered,
        RegistrationReport {
            applied: true,
            mean_error_before_mm: before,
            mean_error_after_mm: after,
            rotation_deg: t.angle_deg(),
            translation_mm: t.translation_mm.into(),
            base_before,
            base_after,
        },
    ))
}

/// `robot` with its base re-expressed as `T · T_base` (the rigid `t` carries the robot's
/// predictions onto the measurement frame), and the base parameters before and after
/// (display units): what every registration applies, with or without the tool.
pub(crate) fn base_moved_by(
    robot: &Robot,
    t: &RigidTransform,
) -> Result<(Robot, [f64; 6], [f64; 6]), IdentifyError> {
    let bf = robot.base_frame();
    // Orthonormal to rounding (Kabsch SVD times a rotation): no re-orthogonalisation needed.
    let rot = Rotation3::from_matrix_unchecked(t.rotation * bf.rot);
    let (rx, ry, rz) = rot.euler_angles();
    let d = t.rotation * bf.pos_mm + t.translation_mm;
    let mut x = robot.params();
    let before = base_display(robot, &x);
    for (k, v) in base_indices(robot).iter().zip([rx, ry, rz, d.x, d.y, d.z]) {
        x[*k] = v;
    }
    Ok((robot.with_params(&x)?, before, base_display(robot, &x)))
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

/// Inlier cut of [`register_base_robust`], in multiples of the median 3-D residual [3.5: for
/// Gaussian noise of σ per axis the median 3-D residual is 1.54 σ, so the cut is 5.4 σ, the
/// outlier screen's 3 σ̂₃ = 5.2 σ; a clean recording loses no point (P ≈ 2·10⁻⁶ each) and a
/// gross error of a few times the noise is out].
pub const ROBUST_INLIER_FACTOR: f64 = 3.5;

/// Deterministic starts of [`register_base_robust`] besides the all-point fit [24].
const ROBUST_STARTS: usize = 24;

/// A robust registration: which points it kept, and its median errors.
#[derive(Clone, Debug, PartialEq)]
pub struct RobustRegistration {
    /// The robot with its base registered (on the inliers).
    pub robot: Robot,
    /// The registration report (means over all points).
    pub report: RegistrationReport,
    /// Indices of the points the final closed form used (residual ≤
    /// [`ROBUST_INLIER_FACTOR`] × the median residual of the robust estimate), ascending.
    pub inliers: Vec<usize>,
    /// Median 3-D point error of the start model, mm.
    pub median_before_mm: f64,
    /// Median 3-D point error after registration, mm.
    pub median_after_mm: f64,
}

fn median(v: &[f64]) -> f64 {
    let mut s = v.to_vec();
    s.sort_by(f64::total_cmp);
    let n = s.len();
    if n == 0 {
        return 0.0;
    }
    if n % 2 == 1 {
        s[n / 2]
    } else {
        0.5 * (s[n / 2 - 1] + s[n / 2])
    }
}

fn residual_norms(t: &RigidTransform, from: &[Vector3<f64>], to: &[Vector3<f64>]) -> Vec<f64> {
    from.iter()
        .zip(to)
        .map(|(a, b)| (t.apply(a) - b).norm())
        .collect()
}

fn subset(v: &[Vector3<f64>], idx: &[usize]) -> Vec<Vector3<f64>> {
    idx.iter().map(|&i| v[i]).collect()
}

/// Indices of the `h` smallest of `r` (ties by index), ascending.
fn smallest(r: &[f64], h: usize) -> Vec<usize> {
    let mut idx: Vec<usize> = (0..r.len()).collect();
    idx.sort_by(|&a, &b| r[a].total_cmp(&r[b]).then(a.cmp(&b)));
    idx.truncate(h);
    idx.sort_unstable();
    idx
}

/// The robust rigid transform taking `from` onto `to`: least trimmed squares (the `h = ⌊(n +
/// 4)/2⌋` best points, concentration steps as in FAST-LTS) from the all-point Kabsch fit and
/// from `ROBUST_STARTS` deterministic 4-point subsets spread over the data, the start with
/// the least median residual (LMedS) kept; then the closed form on its inliers (residual ≤
/// [`ROBUST_INLIER_FACTOR`] × median). On clean data every point is an inlier and the result
/// is [`kabsch`] on all points. Returns the transform and the inliers.
///
/// # Errors
/// As [`kabsch`].
pub fn kabsch_robust(
    from: &[Vector3<f64>],
    to: &[Vector3<f64>],
) -> Result<(RigidTransform, Vec<usize>), IdentifyError> {
    let all = kabsch(from, to)?;
    let n = from.len();
    if n < 5 {
        return Ok((all, (0..n).collect()));
    }
    let h = (n + 4) / 2;
    let mut starts = vec![all];
    for s in 0..ROBUST_STARTS.min(n) {
        // Four points a quarter of the data apart, the first s/ROBUST_STARTS of the way in.
        let first = s * n / ROBUST_STARTS.min(n);
        let idx: Vec<usize> = (0..4).map(|k| (first + k * n / 4) % n).collect();
        if let Ok(t) = kabsch(&subset(from, &idx), &subset(to, &idx)) {
            starts.push(t);
        }
    }
    let mut best: Option<(f64, RigidTransform)> = None;
    for start in starts {
        let mut t = start;
        let mut kept = smallest(&residual_norms(&t, from, to), h);
        for _ in 0..20 {
            let Ok(next) = kabsch(&subset(from, &kept), &subset(to, &kept)) else {
                break;
            };
            t = next;
            let again = smallest(&residual_norms(&t, from, to), h);
            if again == kept {
                break;
            }
            kept = again;
        }
        let med = median(&residual_norms(&t, from, to));
        if best.as_ref().is_none_or(|(m, _)| med < *m) {
            best = Some((med, t));
        }
    }
    let (med, t) = best.expect("the all-point start");
    let r = residual_norms(&t, from, to);
    let cut = (ROBUST_INLIER_FACTOR * med).max(1e-6);
    let inliers: Vec<usize> = (0..n).filter(|&i| r[i] <= cut).collect();
    if inliers.len() == n {
        return Ok((kabsch(from, to)?, inliers));
    }
    let t = kabsch(&subset(from, &inliers), &subset(to, &inliers)).unwrap_or(t);
    Ok((t, inliers))
}

/// [`register_base`] with the robust closed form of [`kabsch_robust`]: a gross error in a few
/// points does not tilt the frame. The report's means are over all points; the medians and
/// the inliers say what the robust estimate saw.
///
/// # Errors
/// As [`register_base`].
pub fn register_base_robust(
    robot: &Robot,
    poses_rad: &[f64],
    points_mm: &[Vector3<f64>],
) -> Result<RobustRegistration, IdentifyError> {
    check_poses_and_points(robot, poses_rad, points_mm)?;
    let predicted = robot.points(poses_rad);
    let (t, inliers) = kabsch_robust(&predicted, points_mm)?;
    let before: Vec<f64> = predicted
        .iter()
        .zip(points_mm)
        .map(|(a, b)| (a - b).norm())
        .collect();
    let bf = robot.base_frame();
    let rot = Rotation3::from_matrix_unchecked(t.rotation * bf.rot);
    let (rx, ry, rz) = rot.euler_angles();
    let d = t.rotation * bf.pos_mm + t.translation_mm;
    let mut x = robot.params();
    let x_before = x.clone();
    for (k, v) in base_indices(robot).iter().zip([rx, ry, rz, d.x, d.y, d.z]) {
        x[*k] = v;
    }
    let registered = robot.with_params(&x)?;
    let after: Vec<f64> = registered
        .points(poses_rad)
        .iter()
        .zip(points_mm)
        .map(|(a, b)| (a - b).norm())
        .collect();
    let m = before.len().max(1) as f64;
    Ok(RobustRegistration {
        robot: registered,
        report: RegistrationReport {
            applied: true,
            mean_error_before_mm: before.iter().sum::<f64>() / m,
            mean_error_after_mm: after.iter().sum::<f64>() / m,
            rotation_deg: t.angle_deg(),
            translation_mm: t.translation_mm.into(),
            base_before: base_display(robot, &x_before),
            base_after: base_display(robot, &x),
        },
        inliers,
        median_before_mm: median(&before),
        median_after_mm: median(&after),
    })
}

/// Indices of `base_rx … base_dz` in `robot`'s parameter vector (every layout has them).
pub fn base_parameter_indices(robot: &Robot) -> [usize; 6] {
    base_indices(robot)
}

/// The best rigid fit of `from` onto `to` with a reflection (determinant −1), and its RMS
/// residual, mm, beside the best proper one's: `(proper_rms_mm, improper_rms_mm)`. A frame
/// written with two axes swapped or one negated fits far better improperly.
///
/// # Errors
/// As [`kabsch`].
pub fn proper_and_improper_rms(
    from: &[Vector3<f64>],
    to: &[Vector3<f64>],
) -> Result<(f64, f64), IdentifyError> {
    let proper = kabsch(from, to)?;
    // Reflect `to` through its centroid's x: a proper fit onto the mirrored points is the best
    // improper fit onto the originals.
    let flip = Matrix3::from_diagonal(&Vector3::new(-1.0, 1.0, 1.0));
    let mirrored: Vec<Vector3<f64>> = to.iter().map(|p| flip * p).collect();
    let improper = kabsch(from, &mirrored)?;
    let rms = |t: &RigidTransform, b: &[Vector3<f64>]| {
        let r = residual_norms(t, from, b);
        (r.iter().map(|v| v * v).sum::<f64>() / r.len().max(1) as f64).sqrt()
    };
    Ok((rms(&proper, to), rms(&improper, &mirrored)))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// 40 spread points, a known rotation and translation, ±0.01 mm of deterministic noise;
    /// 8 of them (20 %) moved by 50–200 mm. The robust fit recovers the transform to the noise
    /// and keeps exactly the clean points; the plain closed form is tilted by the bad ones.
    #[test]
    fn gross_errors_do_not_tilt_the_robust_fit() {
        let from: Vec<Vector3<f64>> = (0..40)
            .map(|i| {
                let t = i as f64;
                Vector3::new(
                    900.0 * (0.7 * t).sin(),
                    700.0 * (1.3 * t).cos(),
                    300.0 + 400.0 * (0.37 * t).sin(),
                )
            })
            .collect();
        let rot = Rotation3::from_euler_angles(0.1, -0.2, 0.35);
        let shift = Vector3::new(3000.0, -1200.0, 450.0);
        let mut to: Vec<Vector3<f64>> = from
            .iter()
            .enumerate()
            .map(|(i, p)| rot * p + shift + Vector3::repeat(0.01 * ((i % 3) as f64 - 1.0)))
            .collect();
        let bad = [3, 7, 11, 19, 23, 29, 31, 37];
        for (k, &i) in bad.iter().enumerate() {
            to[i] += Vector3::new(50.0 + 20.0 * k as f64, -30.0, 10.0 * k as f64);
        }
        let (t, inliers) = kabsch_robust(&from, &to).unwrap();
        let clean: Vec<usize> = (0..40).filter(|i| !bad.contains(i)).collect();
        assert_eq!(inliers, clean);
        let err = (t.rotation - rot.matrix()).abs().max();
        // ±0.01 mm over a spread of ~500 mm: rotation to ~2e-5 rad.
        assert!(err < 1e-4, "rotation off by {err}");
        assert!((t.translation_mm - shift).norm() < 0.05);
        let plain = kabsch(&from, &to).unwrap();
        assert!((plain.translation_mm - shift).norm() > 1.0);
        // A reflection of the points fits improperly far better than properly.
        let mirrored: Vec<Vector3<f64>> =
            from.iter().map(|p| Vector3::new(p.z, p.y, p.x)).collect();
        let (proper, improper) = proper_and_improper_rms(&from, &mirrored).unwrap();
        assert!(improper < 1e-6 && proper > 100.0, "{proper} {improper}");
    }
}
