//! The information model of frame (6-DoF) and multi-target measurements: blocks of 6 or 3k
//! rows per pose, the rows of `identify::frames` (see [`crate::measure`]).
//!
//! A candidate's block is `identify::frames::residual_jacobian` at the nominal model on the
//! noise-free reading of that pose (residual zero, so `J_l⁻¹ = I`), rows weighted as the
//! identification weighs them without per-row σ — position 1/mm, orientation
//! [`DEFAULT_MM_PER_DEG`] per degree — and columns multiplied by the physical [`Scale`]. So
//! `M = Σ B_iᵀB_i = S·JᵀWJ·S` of the identification that will run. The unknowns are those
//! the identification frees ([`select_free`] on the generic pose set): the tool frame (the
//! orientation for `frame`, one point per target) first, then the robot's parameters in
//! keep-priority order, each kept when the rows show it.

use identify::frames::{
    DEFAULT_MM_PER_DEG, FrameData, FrameFree, FrameModel, FrameRow, residual_jacobian, select_free,
};
use identify::generic_poses;
use kinematics::Robot;
use nalgebra::DMatrix;

use crate::error::DesignError;
use crate::measure::Measure;
use crate::model::{InfoModel, Scale, add_outer, check_candidates, pool_full_rank};

/// The frame model a `measure` identifies on `robot`: its tool orientation (identity when
/// the file gives none) and its targets (`frame`: the tool point, unnamed; `targets`: the
/// robot file's `targets`), with the target names.
///
/// # Errors
/// `targets` on a robot file without targets; `point` (not a frame measurement).
pub fn frame_model(
    robot: &Robot,
    measure: Measure,
) -> Result<(FrameModel, Vec<String>), DesignError> {
    let (names, targets_mm) = match measure {
        Measure::Point => {
            return Err(DesignError::InvalidOption {
                name: "measure",
                message: "a point measurement has no frame model".into(),
            });
        }
        Measure::Frame => (vec![String::new()], vec![robot.tool_mm()]),
        Measure::Targets => match robot.targets() {
            Some(t) if !t.is_empty() => (
                t.iter().map(|(n, _)| n.clone()).collect(),
                t.iter().map(|(_, p)| *p).collect(),
            ),
            _ => {
                return Err(DesignError::InvalidOption {
                    name: "targets",
                    message: "the robot file names no targets (its `targets` field): nothing \
                              to measure several of per pose"
                        .into(),
                });
            }
        },
    };
    Ok((
        FrameModel {
            robot: robot.clone(),
            tool_rotation: robot.tool_rotation(),
            targets_mm,
        },
        names,
    ))
}

/// The noise-free rows `measure` reads at `poses_rad` (flat, stride N) on `model`: one row
/// per target per pose, with the orientation for `frame`; weights position 1/mm and
/// orientation [`DEFAULT_MM_PER_DEG`] per degree (in 1/rad), as the identification weighs
/// rows without σ.
pub fn nominal_rows(
    model: &FrameModel,
    names: &[String],
    poses_rad: &[f64],
    measure: Measure,
) -> FrameData {
    let n = model.robot.n_joints();
    let w_rot = DEFAULT_MM_PER_DEG.to_degrees();
    let mut rows = Vec::new();
    for (j, q) in poses_rad.chunks_exact(n).enumerate() {
        let f = model.robot.flange(q);
        for (k, t) in model.targets_mm.iter().enumerate() {
            rows.push(FrameRow {
                pose: j,
                target: k,
                point_mm: f.rot * t + f.pos_mm,
                rotation: (measure == Measure::Frame).then(|| f.rot * model.tool_rotation),
                w_pos: [1.0; 3],
                w_rot,
            });
        }
    }
    FrameData {
        poses_rad: poses_rad.to_vec(),
        n_joints: n,
        target_names: names.to_vec(),
        rows,
    }
}

/// Column scales of `free` (internal units): the robot's from `scale`, the tool orientation
/// [`Scale::tool_rotation_rad`], every target coordinate the tool point's (`tool_x`).
fn column_scales(robot: &Robot, free: &FrameFree, scale: &Scale) -> Result<Vec<f64>, DesignError> {
    let all = scale.internal(robot)?;
    let tool = robot
        .layout()
        .index_of("tool_x")
        .map(|k| all[k])
        .unwrap_or(0.5);
    let mut s: Vec<f64> = free.robot.iter().map(|&k| all[k]).collect();
    if free.rotation {
        s.extend([scale.tool_rotation_rad(); 3]);
    }
    s.extend(std::iter::repeat_n(tool, 3 * free.n_targets));
    Ok(s)
}

/// Scaled blocks (candidate-major, `rows` × p each) of `poses_rad`.
fn frame_blocks(
    model: &FrameModel,
    names: &[String],
    poses_rad: &[f64],
    measure: Measure,
    free: &FrameFree,
    scale: &[f64],
) -> Vec<f64> {
    let n = model.robot.n_joints();
    let p = free.len();
    let mut out = Vec::new();
    const CHUNK: usize = 256;
    let mut jac = DMatrix::zeros(0, 0);
    for chunk in poses_rad.chunks(CHUNK * n) {
        let data = nominal_rows(model, names, chunk, measure);
        residual_jacobian(model, &data, free, Some(&mut jac));
        for row in 0..jac.nrows() {
            for (k, &s) in scale.iter().enumerate().take(p) {
                out.push(jac[(row, k)] * s);
            }
        }
    }
    out
}

impl Scale {
    /// The expected size of the tool orientation's error (rad): `angle_deg` of a per-unit
    /// scale; a per-parameter scale has no tool orientation entry and takes the default
    /// 0.02°.
    pub fn tool_rotation_rad(&self) -> f64 {
        match self {
            Scale::PerUnit { angle_deg, .. } => angle_deg.to_radians(),
            Scale::PerParameter(_) => 0.02f64.to_radians(),
        }
    }
}

impl InfoModel {
    /// The model of the candidate pool for `measure` (see [`InfoModel::new`] for the
    /// arguments; `point` is [`InfoModel::new`] itself, the same bits). For `frame` and
    /// `targets` (module docs): `params` are the robot parameters to consider (`None`: all
    /// of them), of which the identification's [`select_free`] on the generic pose set keeps
    /// the identifiable ones; the tool frame's unknowns are added. [`InfoModel::params`]
    /// then holds the robot's columns, which come first; [`InfoModel::names`] names every
    /// column (`tool_rx…`, `tool_x…` or `<target>_x…`).
    pub fn with_measure(
        robot: &Robot,
        candidates_rad: &[f64],
        workspace_rad: Option<&[f64]>,
        params: Option<&[usize]>,
        scale: &Scale,
        measure: Measure,
    ) -> Result<InfoModel, DesignError> {
        if measure == Measure::Point {
            return InfoModel::new(robot, candidates_rad, workspace_rad, params, scale);
        }
        let n = robot.n_joints();
        let k_count = check_candidates(robot, candidates_rad, workspace_rad)?;
        let (fm, names) = frame_model(robot, measure)?;
        let candidates: Vec<usize> = match params {
            Some(p) => {
                if p.is_empty() || p.iter().any(|&k| k >= robot.n_params()) {
                    return Err(DesignError::InvalidOption {
                        name: "params",
                        message: "empty or out of range".into(),
                    });
                }
                p.to_vec()
            }
            None => (0..robot.n_params()).collect(),
        };
        let generic = generic_poses(robot)?;
        let (free, _) = select_free(
            &fm,
            &nominal_rows(&fm, &names, &generic, measure),
            &candidates,
        )?;
        let scale = column_scales(robot, &free, scale)?;
        let p = free.len();
        let rows = names.len() * 3 + if measure == Measure::Frame { 3 } else { 0 };
        let blocks = frame_blocks(&fm, &names, candidates_rad, measure, &free, &scale);
        let mut model = InfoModel {
            n_joints: n,
            params: free.robot.clone(),
            names: free.names(robot, &names),
            scale,
            p,
            n_candidates: k_count,
            measure,
            rows,
            blocks,
            workspace: DMatrix::zeros(p, p),
        };
        let all: Vec<usize> = (0..k_count).collect();
        let pool = model.information(&all);
        if !pool_full_rank(&pool) {
            // The identification's own choice on the pool names what it cannot observe.
            let (_, dropped) = select_free(
                &fm,
                &nominal_rows(&fm, &names, candidates_rad, measure),
                &free.robot,
            )?;
            let names: Vec<String> = dropped
                .iter()
                .map(|&k| robot.layout().get(k).name.to_string())
                .collect();
            return Err(DesignError::RankDeficientPool {
                detail: "dependent on the tool frame and the parameters kept before them".into(),
                names,
                candidates: k_count,
            });
        }
        model.workspace = match workspace_rad {
            None => pool / k_count as f64,
            Some(w) => {
                let wb = frame_blocks(&fm, &names, w, measure, &free, &model.scale);
                let mut acc = DMatrix::zeros(p, p);
                for blk in wb.chunks_exact(rows * p) {
                    add_outer(&mut acc, blk, rows, p, 1.0);
                }
                acc / (w.len() / n) as f64
            }
        };
        Ok(model)
    }

    /// The rank one pose adds and the rank counted once, `(d, s)`: the information matrix of
    /// N poses has rank at most `d·N + s`. A point: (3, 0); a frame: (6, 0); k targets on
    /// one rigid tool: each pose moves a rigid body (6, or 5 for two targets: the rotation
    /// about their line is not seen, 3 for one) and the targets' shape (3k − 6 coordinates
    /// beyond a rigid motion, 1 for two, 0 for one) is the same at every pose.
    pub fn rank_per_pose(&self) -> (usize, usize) {
        match (self.measure, self.rows / 3) {
            (Measure::Point, _) => (3, 0),
            (Measure::Frame, _) => (6, 0),
            (Measure::Targets, 1) => (3, 0),
            (Measure::Targets, 2) => (5, 1),
            (Measure::Targets, k) => (6, 3 * k - 6),
        }
    }

    /// The fewest poses whose information matrix can have full rank: `⌈(p − s)/d⌉` with
    /// `(d, s)` of [`InfoModel::rank_per_pose`].
    pub fn min_poses(&self) -> usize {
        let (d, s) = self.rank_per_pose();
        self.p.saturating_sub(s).div_ceil(d).max(1)
    }
}
