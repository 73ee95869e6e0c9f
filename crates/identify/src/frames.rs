//! Identification from full-frame (6-DoF) measurements and from several targets per pose
//! (`docs/model.md` §5 and §6.4).
//!
//! A dense formulation used when a measurement set carries orientations or named targets,
//! solved by the one damped least-squares solver of the point path ([`crate::lm`]: this
//! module's problem implements [`crate::LeastSquares`]; [`fit_frames`]). Its unknowns are
//! - the robot's free parameters (layout indices, the tool point `tool_x/y/z` excluded: the
//!   targets below replace it),
//! - the tool orientation `R_tool` (the measured frame's axes in the flange frame), moved by
//!   a rotation vector `δ` in the tool frame: `R_tool ← R_tool · exp([δ]×)` (rad),
//! - one point per target `t_k` in the flange frame (mm); target 0 is the tool point when the
//!   data name no targets.
//!
//! Residuals, measured − model, per measured row (pose j, target k, flange frame `F_j`):
//! - position (3 rows, mm, measurement frame): `e_p = p_meas − (o_j + R_j t_k)`;
//! - orientation (3 rows, **radians**, tool frame), where measured:
//!   `e_r = log(R_modelᵀ · R_meas)`, `R_model = R_j · R_tool`, the rotation vector of the
//!   residual rotation (reported in degrees).
//!
//! Analytic Jacobian (with `lin_i`, `ω_i` of [`Robot::frame_jacobian_into`], `J_l⁻¹` the
//! inverse left Jacobian of SO(3), `J_l⁻¹(φ) = I − ½[φ]× + (1/θ² − (1+cos θ)/(2θ sin θ))[φ]×²`):
//! - `∂e_p/∂x_i = −(lin_i + ω_i × R_j t_k)`, `∂e_p/∂t_k = −R_j`, `∂e_p/∂δ = 0`;
//! - `∂e_r/∂x_i = −J_l⁻¹(e_r) · R_modelᵀ ω_i`, `∂e_r/∂δ = −J_l⁻¹(e_r)`, `∂e_r/∂t_k = 0`.
//!
//! Rows are weighted by 1/σ: position rows per axis by the row's `σ_mm`, orientation rows by
//! one scalar `1/σ_rot` (σ_rot the root mean square of the row's three σ, in rad) — or, when
//! the data carry no σ, by the documented default ratio [`DEFAULT_MM_PER_DEG`] (position
//! weight 1/mm, orientation weight `DEFAULT_MM_PER_DEG` per degree).
//!
//! Everything is dense and summed in a fixed order (pose by pose, row by row), with plain
//! multiplications and additions (no fused multiply-add): the same inputs give the same bits.

use kinematics::rotation::{exp_so3, inv_left_jacobian, log_so3, project_so3, rpy_of};
use kinematics::{Frame, Robot, Unit};
use nalgebra::{DMatrix, DVector, Matrix3, Vector3};

use crate::error::IdentifyError;
use crate::identifiability::{IdentifiabilityOptions, analyze_matrix, free_priority};
use crate::lm::{
    Damping, LeastSquares, LmOptions, Redundant, StopReason, TraceEntry, least_squares,
};

/// Default equivalence of orientation and position residuals: 1° of orientation error
/// weighs as much as this many mm of position error [5 mm/°: the ratio of the typical σ a
/// laser tracker's 6-DoF probe states (≈ 0.01 mm and 0.002° on the public UR10 data of
/// `data/ur10-ipa`, series B), i.e. equal confidence in both].
pub const DEFAULT_MM_PER_DEG: f64 = 5.0;

/// One measured row: a point of target `target` at pose `pose`, and optionally the measured
/// frame's orientation.
#[derive(Clone, Debug, PartialEq)]
pub struct FrameRow {
    /// Index of the pose (into [`FrameData::poses_rad`], in joint vectors).
    pub pose: usize,
    /// Index of the target (into [`FrameData::target_names`]; 0 without named targets).
    pub target: usize,
    /// The measured point, mm, measurement frame.
    pub point_mm: Vector3<f64>,
    /// The measured orientation (the measured frame's axes in measurement coordinates).
    pub rotation: Option<Matrix3<f64>>,
    /// Weights of the three position rows, 1/mm (1/σ).
    pub w_pos: [f64; 3],
    /// Weight of the three orientation rows, 1/rad (1/σ).
    pub w_rot: f64,
}

/// Measured data: poses and rows.
#[derive(Clone, Debug, PartialEq)]
pub struct FrameData {
    /// Joint vectors, radians, flat.
    pub poses_rad: Vec<f64>,
    /// Number of joints.
    pub n_joints: usize,
    /// Target names (one unnamed target `""` when the data name none).
    pub target_names: Vec<String>,
    /// The measured rows.
    pub rows: Vec<FrameRow>,
}

impl FrameData {
    /// Number of poses.
    pub fn n_poses(&self) -> usize {
        self.poses_rad.len() / self.n_joints.max(1)
    }

    /// The joint vector of pose `j`.
    pub fn pose(&self, j: usize) -> &[f64] {
        &self.poses_rad[j * self.n_joints..(j + 1) * self.n_joints]
    }

    /// Whether any row has an orientation.
    pub fn has_orientation(&self) -> bool {
        self.rows.iter().any(|r| r.rotation.is_some())
    }

    /// Residual equations: 3 per point, 3 per orientation.
    pub fn n_equations(&self) -> usize {
        self.rows
            .iter()
            .map(|r| if r.rotation.is_some() { 6 } else { 3 })
            .sum()
    }

    /// The rows of the poses `poses` (ascending pose indices), renumbered.
    pub fn subset(&self, poses: &[usize]) -> FrameData {
        let n = self.n_joints;
        let mut map = vec![usize::MAX; self.n_poses()];
        let mut poses_rad = Vec::with_capacity(poses.len() * n);
        for (new, &old) in poses.iter().enumerate() {
            map[old] = new;
            poses_rad.extend_from_slice(self.pose(old));
        }
        let rows = self
            .rows
            .iter()
            .filter(|r| map[r.pose] != usize::MAX)
            .map(|r| FrameRow {
                pose: map[r.pose],
                ..r.clone()
            })
            .collect();
        FrameData {
            poses_rad,
            n_joints: n,
            target_names: self.target_names.clone(),
            rows,
        }
    }

    fn check(&self, robot: &Robot) -> Result<(), IdentifyError> {
        if self.n_joints != robot.n_joints() || !self.poses_rad.len().is_multiple_of(self.n_joints)
        {
            return Err(IdentifyError::PoseLength {
                len: self.poses_rad.len(),
                n_joints: robot.n_joints(),
            });
        }
        if self.rows.is_empty() {
            return Err(IdentifyError::NoPoses);
        }
        for (i, r) in self.rows.iter().enumerate() {
            let bad = |detail: String| IdentifyError::NonFinite {
                what: "measured row",
                index: i,
                detail,
            };
            if r.pose >= self.n_poses() || r.target >= self.target_names.len() {
                return Err(bad(format!(
                    "pose {} of {}, target {} of {}",
                    r.pose,
                    self.n_poses(),
                    r.target,
                    self.target_names.len()
                )));
            }
            if r.point_mm.iter().any(|v| !v.is_finite()) {
                return Err(bad(format!("point {:?}", r.point_mm)));
            }
            if r.w_pos.iter().any(|w| !(w.is_finite() && *w > 0.0))
                || !(r.w_rot.is_finite() && r.w_rot > 0.0)
            {
                return Err(bad(format!("weights {:?}, {}", r.w_pos, r.w_rot)));
            }
            if let Some(m) = &r.rotation
                && m.iter().any(|v| !v.is_finite())
            {
                return Err(bad("orientation".into()));
            }
        }
        Ok(())
    }
}

/// The model of a 6-DoF / multi-target problem: the robot and the tool frame with its
/// targets.
#[derive(Clone, Debug, PartialEq)]
pub struct FrameModel {
    /// The robot (its tool point is ignored: [`FrameModel::targets_mm`] replace it).
    pub robot: Robot,
    /// The measured frame's orientation in the flange frame.
    pub tool_rotation: Matrix3<f64>,
    /// One point per target in the flange frame, mm (target 0 is the tool point when the
    /// data name no targets).
    pub targets_mm: Vec<Vector3<f64>>,
}

impl FrameModel {
    /// The robot with the tool frame written into it: `tool_mm` = target 0, the tool
    /// orientation (Euler, the base convention) and, with named targets, the targets.
    pub fn to_robot(&self, target_names: &[String], orientation: bool) -> Robot {
        let mut r = self.robot.clone();
        r.set_tool_mm(self.targets_mm[0]);
        if orientation {
            r.set_tool_rotation_rad(Some(rpy_of(&self.tool_rotation)));
        }
        if target_names.len() > 1 || target_names.first().is_some_and(|n| !n.is_empty()) {
            r.set_targets(Some(
                target_names
                    .iter()
                    .cloned()
                    .zip(self.targets_mm.iter().copied())
                    .collect(),
            ));
        }
        r
    }

    /// Per row: position error `p_meas − p_model` (mm) and, where measured, the orientation
    /// error `log(R_modelᵀ R_meas)` (degrees, tool frame).
    pub fn errors(&self, data: &FrameData) -> Vec<(Vector3<f64>, Option<Vector3<f64>>)> {
        let flanges: Vec<Frame> = (0..data.n_poses())
            .map(|j| self.robot.flange(data.pose(j)))
            .collect();
        data.rows
            .iter()
            .map(|r| {
                let f = &flanges[r.pose];
                let p = f.rot * self.targets_mm[r.target] + f.pos_mm;
                let o = r.rotation.map(|m| {
                    log_so3(&((f.rot * self.tool_rotation).transpose() * m)) * (180.0 / PI)
                });
                (r.point_mm - p, o)
            })
            .collect()
    }
}

use std::f64::consts::PI;

/// Which unknowns move: robot parameters (layout indices, no tool point), the tool
/// orientation, the targets.
#[derive(Clone, Debug, PartialEq)]
pub struct FrameFree {
    /// Free robot parameters, layout order.
    pub robot: Vec<usize>,
    /// Whether the tool orientation moves (only with orientation data).
    pub rotation: bool,
    /// Number of targets (all move).
    pub n_targets: usize,
}

impl FrameFree {
    /// Number of unknowns.
    pub fn len(&self) -> usize {
        self.robot.len() + 3 * usize::from(self.rotation) + 3 * self.n_targets
    }

    /// Whether nothing moves.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Names of the unknowns: the robot's, then `tool_rx, tool_ry, tool_rz` (the rotation
    /// vector δ, tool frame), then `target_x/y/z` (or `tool_x/y/z` for the unnamed target).
    pub fn names(&self, robot: &Robot, target_names: &[String]) -> Vec<String> {
        let mut v: Vec<String> = self
            .robot
            .iter()
            .map(|&k| robot.layout().get(k).name.to_string())
            .collect();
        if self.rotation {
            v.extend(["tool_rx", "tool_ry", "tool_rz"].map(String::from));
        }
        for name in target_names.iter().take(self.n_targets) {
            for c in ["x", "y", "z"] {
                v.push(if name.is_empty() {
                    format!("tool_{c}")
                } else {
                    format!("{name}_{c}")
                });
            }
        }
        v
    }

    /// Units of the unknowns (display: deg, mm).
    pub fn units(&self, robot: &Robot) -> Vec<Unit> {
        let mut v: Vec<Unit> = self
            .robot
            .iter()
            .map(|&k| robot.layout().get(k).unit)
            .collect();
        if self.rotation {
            v.extend([Unit::Deg; 3]);
        }
        v.extend(std::iter::repeat_n(Unit::Mm, 3 * self.n_targets));
        v
    }
}

/// The weighted residual `e` and (if `jac`) the weighted Jacobian `∂e/∂unknowns` of the
/// module docs; rows row by row in data order (3 position rows, then 3 orientation rows
/// where measured).
pub fn residual_jacobian(
    model: &FrameModel,
    data: &FrameData,
    free: &FrameFree,
    jac: Option<&mut DMatrix<f64>>,
) -> DVector<f64> {
    let neq = data.n_equations();
    let np = model.robot.n_params();
    let pf = free.len();
    let mut e = DVector::zeros(neq);
    let mut lin = vec![Vector3::zeros(); np];
    let mut ang = vec![Vector3::zeros(); np];
    let mut jac = jac;
    if let Some(j) = jac.as_deref_mut()
        && j.shape() != (neq, pf)
    {
        *j = DMatrix::zeros(neq, pf);
    }
    let nr = free.robot.len();
    let rot0 = nr;
    let tgt0 = nr + 3 * usize::from(free.rotation);
    let mut pose_done = usize::MAX;
    let mut f = Frame::identity();
    let mut row = 0;
    for r in &data.rows {
        if r.pose != pose_done {
            f = if jac.is_some() {
                model
                    .robot
                    .frame_jacobian_into(data.pose(r.pose), &mut lin, &mut ang)
            } else {
                model.robot.flange(data.pose(r.pose))
            };
            pose_done = r.pose;
        }
        let rt = f.rot * model.targets_mm[r.target];
        let p = rt + f.pos_mm;
        let ep = r.point_mm - p;
        for c in 0..3 {
            e[row + c] = r.w_pos[c] * ep[c];
        }
        if let Some(j) = jac.as_deref_mut() {
            for (col, &k) in free.robot.iter().enumerate() {
                let d = lin[k] + ang[k].cross(&rt);
                for c in 0..3 {
                    j[(row + c, col)] = -r.w_pos[c] * d[c];
                }
            }
            for col in tgt0..pf {
                for c in 0..3 {
                    j[(row + c, col)] = 0.0;
                }
            }
            let t = tgt0 + 3 * r.target;
            for c in 0..3 {
                for cc in 0..3 {
                    j[(row + c, t + cc)] = -r.w_pos[c] * f.rot[(c, cc)];
                }
                if free.rotation {
                    for cc in 0..3 {
                        j[(row + c, rot0 + cc)] = 0.0;
                    }
                }
            }
        }
        row += 3;
        if let Some(meas) = &r.rotation {
            let rm = f.rot * model.tool_rotation;
            let phi = log_so3(&(rm.transpose() * meas));
            for c in 0..3 {
                e[row + c] = r.w_rot * phi[c];
            }
            if let Some(j) = jac.as_deref_mut() {
                let jl = inv_left_jacobian(&phi);
                let a = jl * rm.transpose();
                for (col, &k) in free.robot.iter().enumerate() {
                    let d = a * ang[k];
                    for c in 0..3 {
                        j[(row + c, col)] = -r.w_rot * d[c];
                    }
                }
                for c in 0..3 {
                    if free.rotation {
                        for cc in 0..3 {
                            j[(row + c, rot0 + cc)] = -r.w_rot * jl[(c, cc)];
                        }
                    }
                    for col in tgt0..pf {
                        j[(row + c, col)] = 0.0;
                    }
                }
            }
            row += 3;
        }
    }
    e
}

/// The model with the unknowns moved by `step` (robot parameters added, `R_tool ←
/// R_tool·exp([δ]×)`, targets added).
pub fn apply_step(
    model: &FrameModel,
    free: &FrameFree,
    step: &DVector<f64>,
) -> Result<FrameModel, IdentifyError> {
    let mut x = model.robot.params();
    for (col, &k) in free.robot.iter().enumerate() {
        x[k] += step[col];
    }
    let mut out = model.clone();
    out.robot.set_params(&x)?;
    let mut at = free.robot.len();
    if free.rotation {
        let d = Vector3::new(step[at], step[at + 1], step[at + 2]);
        out.tool_rotation = model.tool_rotation * exp_so3(&d);
        at += 3;
    }
    for k in 0..free.n_targets {
        out.targets_mm[k] +=
            Vector3::new(step[at + 3 * k], step[at + 3 * k + 1], step[at + 3 * k + 2]);
    }
    Ok(out)
}

/// `JᵀJ` and `Jᵀe`, summed row by row in order (upper triangle, mirrored).
fn normal(j: &DMatrix<f64>, e: &DVector<f64>) -> (DMatrix<f64>, DVector<f64>) {
    let (m, p) = j.shape();
    let mut a = DMatrix::zeros(p, p);
    let mut g = DVector::zeros(p);
    for r in 0..m {
        for b in 0..p {
            let jb = j[(r, b)];
            if jb == 0.0 {
                continue;
            }
            g[b] += jb * e[r];
            for c in b..p {
                a[(b, c)] += jb * j[(r, c)];
            }
        }
    }
    for b in 0..p {
        for c in 0..b {
            a[(b, c)] = a[(c, b)];
        }
    }
    (a, g)
}

/// The closed-form start of the tool frame from data and a robot already in the data's
/// frame (registered): `R_tool` the chordal mean of `R_jᵀ R_meas,j` over the rows with an
/// orientation (projected on SO(3)); each target `t_k` the mean of `R_jᵀ (p_meas − o_j)`
/// over its rows. Targets given in `known` (Some) are kept.
pub fn closed_form_tool(
    robot: &Robot,
    data: &FrameData,
    known_rotation: Option<Matrix3<f64>>,
    known: &[Option<Vector3<f64>>],
) -> FrameModel {
    let flanges: Vec<Frame> = (0..data.n_poses())
        .map(|j| robot.flange(data.pose(j)))
        .collect();
    let mut sum = Matrix3::zeros();
    let nt = data.target_names.len();
    let mut t_sum = vec![Vector3::zeros(); nt];
    let mut t_n = vec![0usize; nt];
    for r in &data.rows {
        let f = &flanges[r.pose];
        if let Some(m) = &r.rotation {
            sum += f.rot.transpose() * m;
        }
        t_sum[r.target] += f.rot.transpose() * (r.point_mm - f.pos_mm);
        t_n[r.target] += 1;
    }
    let tool_rotation = known_rotation.unwrap_or_else(|| {
        if sum == Matrix3::zeros() {
            Matrix3::identity()
        } else {
            project_so3(&sum)
        }
    });
    let targets_mm = (0..nt)
        .map(|k| {
            known.get(k).copied().flatten().unwrap_or_else(|| {
                if t_n[k] == 0 {
                    Vector3::zeros()
                } else {
                    t_sum[k] / t_n[k] as f64
                }
            })
        })
        .collect();
    FrameModel {
        robot: robot.clone(),
        tool_rotation,
        targets_mm,
    }
}

/// The identifiable unknowns among `candidates` (robot parameters; the tool point excluded
/// automatically) plus the tool orientation and the targets, on the weighted Jacobian at
/// `model`, decided as every other rank decision ([`crate::identifiability`], default
/// [`IdentifiabilityOptions`]): the columns scaled to unit norm, the rank from the singular
/// values (`σ_i > rank_rtol·σ_1`), and the redundant ones dropped from the lowest priority up,
/// the priority being the tool frame (orientation, then the targets) first, then the robot
/// parameters in [`crate::keep_priority`] order. Returns the free set and the candidates dropped
/// (layout indices, ascending).
///
/// # Errors
/// The data's errors; [`IdentifyError::ToolFrameNotIdentifiable`] when the data leave part of
/// the tool frame itself undetermined (e.g. a target measured at one pose only).
pub fn select_free(
    model: &FrameModel,
    data: &FrameData,
    candidates: &[usize],
) -> Result<(FrameFree, Vec<usize>), IdentifyError> {
    data.check(&model.robot)?;
    let layout = model.robot.layout();
    let cand: Vec<usize> = (0..layout.len())
        .filter(|k| candidates.contains(k))
        .filter(|&k| {
            !matches!(
                layout.get(k).kind,
                kinematics::ParamKind::ToolX
                    | kinematics::ParamKind::ToolY
                    | kinematics::ParamKind::ToolZ
            )
        })
        .collect();
    let all = FrameFree {
        robot: cand.clone(),
        rotation: data.has_orientation(),
        n_targets: data.target_names.len(),
    };
    let mut j = DMatrix::zeros(0, 0);
    residual_jacobian(model, data, &all, Some(&mut j));
    let nr = cand.len();
    // Tool frame columns first, then the candidates in keep-priority order.
    let priority: Vec<usize> = (nr..all.len())
        .chain(free_priority(layout, &cand))
        .collect();
    let an = analyze_matrix(j, &priority, &IdentifiabilityOptions::default())?;
    if an.dropped.iter().any(|&c| c >= nr) {
        let names = all.names(&model.robot, &data.target_names);
        return Err(IdentifyError::ToolFrameNotIdentifiable {
            unknowns: an
                .dropped
                .iter()
                .filter(|&&c| c >= nr)
                .map(|&c| names[c].clone())
                .collect(),
        });
    }
    let robot: Vec<usize> = an
        .kept
        .iter()
        .filter(|&&c| c < nr)
        .map(|&c| cand[c])
        .collect();
    let dropped: Vec<usize> = an.dropped.iter().map(|&c| cand[c]).collect();
    Ok((
        FrameFree {
            robot,
            rotation: all.rotation,
            n_targets: all.n_targets,
        },
        dropped,
    ))
}

/// Per pose of `data`: the norm of its weighted residual rows at `model` (those of
/// [`residual_jacobian`], summed in row order) and their number d (3 per point, 3 per
/// orientation): the blocks [`crate::outliers::screen_blocks`] screens.
pub fn pose_blocks(model: &FrameModel, data: &FrameData) -> Vec<(f64, usize)> {
    let none = FrameFree {
        robot: Vec::new(),
        rotation: false,
        n_targets: 0,
    };
    let e = residual_jacobian(model, data, &none, None);
    let mut sq = vec![0.0; data.n_poses()];
    let mut rows = vec![0usize; data.n_poses()];
    let mut at = 0;
    for r in &data.rows {
        let d = if r.rotation.is_some() { 6 } else { 3 };
        for i in at..at + d {
            sq[r.pose] += e[i] * e[i];
        }
        rows[r.pose] += d;
        at += d;
    }
    sq.into_iter().map(f64::sqrt).zip(rows).collect()
}

/// The outlier screen of the poses of `data` after `fit` (its model and per-row σ̂): the
/// rule of [`crate::outliers`] on each pose's block of rows, `‖e_pose‖ > k·√d·σ̂` (block
/// indices are pose indices). `None` when the fit has no residual degrees of freedom (σ̂
/// undefined), as for points.
///
/// # Errors
/// `k` not finite and positive.
pub fn screen_poses(
    fit: &FrameFit,
    data: &FrameData,
    k: f64,
) -> Result<Option<crate::BlockScreen>, IdentifyError> {
    if fit.dof == 0 || !fit.sigma_hat.is_finite() {
        return Ok(None);
    }
    crate::outliers::screen_blocks(&pose_blocks(&fit.model, data), fit.sigma_hat, k).map(Some)
}

/// One unknown's estimate (display units: deg, mm). The tool orientation's three unknowns
/// are the components of the rotation vector δ (tool frame) from the start orientation.
#[derive(Clone, Debug, PartialEq)]
pub struct FrameEstimate {
    /// Name.
    pub name: String,
    /// Unit.
    pub unit: Unit,
    /// Start value (0 for δ).
    pub start: f64,
    /// Identified value.
    pub value: f64,
    /// Standard error `σ̂·√((JᵀJ)⁻¹_kk)`.
    pub std_error: f64,
}

/// The result of [`fit_frames`].
#[derive(Clone, Debug)]
pub struct FrameFit {
    /// The identified model.
    pub model: FrameModel,
    /// The unknowns.
    pub free: FrameFree,
    /// Per unknown: start, value, standard error.
    pub estimates: Vec<FrameEstimate>,
    /// The schedule used.
    pub damping: Damping,
    /// Iterations (accepted and rejected).
    pub iterations: usize,
    /// Accepted steps.
    pub accepted_steps: usize,
    /// Why the solver stopped ([`StopReason::converged`] for the three convergence tests; a
    /// damping blow-up is [`StopReason::TooManyRejections`]).
    pub stop: StopReason,
    /// max_k |J_kᵀe| / (‖J_k‖‖e‖) at the solution.
    pub gradient_cosine: f64,
    /// Per-iteration trace.
    pub trace: Vec<TraceEntry>,
    /// Weighted residual sum of squares at the start and at the solution.
    pub cost: (f64, f64),
    /// Equations and degrees of freedom.
    pub n_equations: usize,
    /// `n_equations − unknowns`.
    pub dof: usize,
    /// σ̂ = √(cost/dof) (1 when the weights are the true 1/σ).
    pub sigma_hat: f64,
    /// Condition number of the column-scaled Jacobian at the solution.
    pub condition_number: f64,
    /// Covariance of the unknowns (internal units: rad, mm), `σ̂²(JᵀJ)⁻¹`: the data's alone,
    /// also with a prior (as for points).
    pub covariance: DMatrix<f64>,
    /// With a prior ([`fit_frames_with_prior`]): the posterior of the free robot parameters
    /// and which of them the prior rather than the data determine (`crate::prior`).
    pub posterior: Option<crate::prior::Posterior>,
}

/// The 6-DoF / multi-target problem as the one solver ([`crate::lm::least_squares`]) sees
/// it: the residual of the module docs on the unknowns `free`.
struct FrameProblem<'d> {
    data: &'d FrameData,
    free: &'d FrameFree,
    jac: DMatrix<f64>,
    /// A prior on the free robot parameters (the first columns), if any (`crate::prior`).
    prior: Option<&'d crate::prior::PriorTerm>,
}

impl FrameProblem<'_> {
    /// The prior's cost at `m` (0 without one).
    fn prior_cost_at(&self, m: &FrameModel) -> f64 {
        self.prior
            .map_or(0.0, |p| p.cost(&m.robot.params(), &self.free.robot))
    }
}

impl LeastSquares for FrameProblem<'_> {
    type Model = FrameModel;

    fn n_unknowns(&self) -> usize {
        self.free.len()
    }

    fn normal_equations(
        &mut self,
        m: &FrameModel,
        a: &mut DMatrix<f64>,
        g: &mut DVector<f64>,
    ) -> f64 {
        let e = residual_jacobian(m, self.data, self.free, Some(&mut self.jac));
        let (na, ng) = normal(&self.jac, &e);
        // The solver's `g` is `−(∂e/∂x)ᵀe` (its `J` is the model's derivative, −∂e/∂x).
        (*a, *g) = (na, -ng);
        e.norm_squared()
    }

    fn cost(&mut self, m: &FrameModel, _likely_accepted: bool) -> f64 {
        residual_jacobian(m, self.data, self.free, None).norm_squared() + self.prior_cost_at(m)
    }

    /// The default's assembly and scaling, plus the prior's rows (`crate::prior`).
    fn accept(
        &mut self,
        m: &FrameModel,
        a: &mut DMatrix<f64>,
        g: &mut DVector<f64>,
        s: &[f64],
        sa: &mut DMatrix<f64>,
        sg: &mut DVector<f64>,
        _cost_trial: f64,
    ) -> f64 {
        let cost = self.normal_equations(m, a, g);
        crate::lm::scale_system(a, g, s, sa, sg);
        self.add_prior_scaled(m, s, sa, sg);
        cost + self.prior_cost_at(m)
    }

    fn prior_cost(&self, m: &FrameModel) -> Option<f64> {
        self.prior.map(|_| self.prior_cost_at(m))
    }

    fn add_prior_scaled(
        &self,
        m: &FrameModel,
        s: &[f64],
        sa: &mut DMatrix<f64>,
        sg: &mut DVector<f64>,
    ) {
        if let Some(p) = self.prior {
            p.add_scaled(&m.robot.params(), &self.free.robot, s, sa, sg);
        }
    }

    fn step(&self, m: &FrameModel, dx: &[f64], out: &mut FrameModel) -> Result<(), IdentifyError> {
        *out = apply_step(m, self.free, &DVector::from_column_slice(dx))?;
        Ok(())
    }

    /// The unknowns' values: the free robot parameters, the tool orientation's rotation
    /// vector (rad), the targets (mm).
    fn scaled_norm(&self, m: &FrameModel, s: &[f64]) -> f64 {
        let x = m.robot.params();
        let mut values: Vec<f64> = self.free.robot.iter().map(|&k| x[k]).collect();
        if self.free.rotation {
            values.extend(log_so3(&m.tool_rotation).iter());
        }
        for t in m.targets_mm.iter().take(self.free.n_targets) {
            values.extend(t.iter());
        }
        values
            .iter()
            .zip(s)
            .map(|(v, s)| (v / s).powi(2))
            .sum::<f64>()
            .sqrt()
    }
}

/// Identifies `free` from `data`, starting at `start`: the one damped least-squares solver
/// ([`crate::lm::least_squares`], with the schedule and stopping tests of `options`) on the
/// residual of the module docs, then the covariance `σ̂²(JᵀJ)⁻¹` of its normal matrix.
///
/// Redundant unknowns are decided before the fit, once ([`select_free`] holds them):
/// [`LmOptions::redundant`] must be [`Redundant::Hold`].
///
/// # Errors
/// The data's errors; an option out of range ([`Redundant::Damp`] included); no unknowns or
/// fewer equations than unknowns; the solver's errors; a singular normal matrix at the
/// solution.
pub fn fit_frames(
    start: &FrameModel,
    data: &FrameData,
    free: &FrameFree,
    options: &LmOptions,
) -> Result<FrameFit, IdentifyError> {
    fit_frames_with_prior(start, data, free, options, None)
}

/// [`fit_frames`] with a Gaussian prior on the free robot parameters (`crate::prior`: its rows
/// `√λ_k (x_k − x0_k)` join the residual's; the tool frame and the targets have none): the
/// maximum a posteriori fit. `None` is [`fit_frames`], bit for bit. σ̂ and the covariance are
/// the data's alone (the residual without the prior's rows); [`FrameFit::posterior`] is the
/// posterior `σ_e² (JᵀJ + Λ)⁻¹` of the robot parameters.
///
/// # Errors
/// As [`fit_frames`]; a prior whose length is not the robot's parameter count.
pub fn fit_frames_with_prior(
    start: &FrameModel,
    data: &FrameData,
    free: &FrameFree,
    options: &LmOptions,
    prior: Option<&crate::prior::PriorTerm>,
) -> Result<FrameFit, IdentifyError> {
    data.check(&start.robot)?;
    if let Some(p) = prior
        && (p.mean.len() != start.robot.n_params() || p.weight.len() != p.mean.len())
    {
        return Err(IdentifyError::InvalidOption {
            name: "prior",
            value: format!("{} parameters", p.mean.len()),
            reason: "a prior has one mean and one weight per parameter of the robot",
        });
    }
    if options.redundant != Redundant::Hold {
        return Err(IdentifyError::InvalidOption {
            name: "redundant",
            value: "damp".into(),
            reason: "6-DoF and multi-target fits hold the redundant unknowns \
                     (select_free decides them before the fit): only \"hold\" applies",
        });
    }
    let neq = data.n_equations();
    let pf = free.len();
    if pf == 0 {
        return Err(IdentifyError::NoFreeParameters);
    }
    if neq < pf {
        return Err(IdentifyError::TooFewEquations {
            equations: neq,
            poses: data.n_poses(),
            free: pf,
            needed_poses: pf.div_ceil(neq.div_ceil(data.n_poses().max(1)).max(1)),
        });
    }
    let mut problem = FrameProblem {
        data,
        free,
        jac: DMatrix::zeros(neq, pf),
        prior,
    };
    let sol = least_squares(&mut problem, start, options)?;
    // The data's cost alone: with a prior the solver's holds the prior's rows too.
    let cov = match prior {
        None => sol.covariance(neq)?,
        Some(_) => crate::covariance::normal_covariance(
            &sol.normal_matrix,
            residual_jacobian(&sol.model, data, free, None).norm_squared(),
            neq,
            sol.iterations,
        )?,
    };
    let posterior = prior.and_then(|p| {
        crate::prior::posterior_from(sol.normal_matrix.clone(), p, &sol.model.robot, &free.robot)
    });
    let model = &sol.model;
    let names = free.names(&model.robot, &data.target_names);
    let units = free.units(&model.robot);
    let (x0, x1) = (start.robot.params(), model.robot.params());
    let layout = model.robot.layout();
    let nr = free.robot.len();
    let delta = log_so3(&(start.tool_rotation.transpose() * model.tool_rotation));
    let estimates = (0..pf)
        .map(|c| {
            let se = cov.covariance[(c, c)].sqrt();
            let (s0, v, se) = if c < nr {
                let info = layout.get(free.robot[c]);
                (
                    info.to_display(x0[free.robot[c]]),
                    info.to_display(x1[free.robot[c]]),
                    info.to_display(se),
                )
            } else if free.rotation && c < nr + 3 {
                (0.0, delta[c - nr].to_degrees(), se.to_degrees())
            } else {
                let t = c - nr - 3 * usize::from(free.rotation);
                (
                    start.targets_mm[t / 3][t % 3],
                    model.targets_mm[t / 3][t % 3],
                    se,
                )
            };
            FrameEstimate {
                name: names[c].clone(),
                unit: units[c],
                start: s0,
                value: v,
                std_error: se,
            }
        })
        .collect();
    Ok(FrameFit {
        model: sol.model,
        free: free.clone(),
        estimates,
        damping: sol.damping,
        iterations: sol.iterations,
        accepted_steps: sol.accepted_steps,
        stop: sol.stop,
        gradient_cosine: sol.gradient_cosine,
        trace: sol.trace,
        cost: (sol.initial_cost, sol.cost),
        n_equations: neq,
        dof: cov.dof,
        sigma_hat: cov.sigma_hat,
        condition_number: cov.condition_number,
        covariance: cov.covariance,
        posterior,
    })
}
