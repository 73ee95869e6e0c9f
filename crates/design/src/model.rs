//! The information model of a candidate pool: the scaled 3 × p blocks of every candidate on
//! the minimal identifiable set, and the workspace matrix W of the I criterion.

use identify::{IdentifiabilityOptions, ParamSet, analyze, generic_poses};
use kinematics::{ParamKind, Robot, Unit};
use nalgebra::DMatrix;
use serde::{Deserialize, Serialize};

use crate::criterion::{Criterion, dense_value};
use crate::error::DesignError;
use crate::measure::Measure;

/// The physical scale `s_k` that multiplies column k of every block, so that mm and rad are
/// comparable: the expected size of parameter k's error. A scaled column is "mm of point
/// motion for an error of the expected size".
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Scale {
    /// One size per unit: every length `length_mm`, every angle `angle_deg`.
    PerUnit {
        /// Expected error of a length (d, a, base translation, tool), mm.
        length_mm: f64,
        /// Expected error of an angle (θ, α, β, base rotation), degrees.
        angle_deg: f64,
    },
    /// One size per parameter of the robot (layout order, display units: mm or degrees).
    PerParameter(Vec<f64>),
}

impl Default for Scale {
    /// 0.5 mm and 0.02°: the per-class error sizes (σ) of the shipped scenarios' error
    /// budget (`truth.random.length_sigma_mm`, `joint_angle_sigma_deg`), i.e. a KR1000
    /// leaving the factory. 0.02° moves a point 1.8 m away by 0.6 mm, the same order as the
    /// 0.5 mm lengths, so neither class dominates.
    fn default() -> Self {
        Scale::PerUnit {
            length_mm: 0.5,
            angle_deg: 0.02,
        }
    }
}

impl Scale {
    /// The scale of every robot parameter in internal units (mm, rad).
    pub fn internal(&self, robot: &Robot) -> Result<Vec<f64>, DesignError> {
        let layout = robot.layout();
        let display: Vec<f64> = match self {
            Scale::PerUnit {
                length_mm,
                angle_deg,
            } => layout
                .params()
                .iter()
                .map(|p| match p.unit {
                    Unit::Mm => *length_mm,
                    Unit::Deg => *angle_deg,
                    Unit::MicroradPerNm => EXTENDED_COMPLIANCE_SCALE,
                    Unit::Arcsec => EXTENDED_GEAR_SCALE_ARCSEC,
                    Unit::MmPerMm => AXIS_SCALE_SCALE,
                })
                .collect(),
            Scale::PerParameter(v) => {
                if v.len() != layout.len() {
                    return Err(DesignError::InvalidOption {
                        name: "scale",
                        message: format!("{} values for {} parameters", v.len(), layout.len()),
                    });
                }
                v.clone()
            }
        };
        if let Some(bad) = display.iter().find(|v| !(v.is_finite() && **v > 0.0)) {
            return Err(DesignError::InvalidOption {
                name: "scale",
                message: format!("{bad} is not a positive size"),
            });
        }
        Ok(layout
            .params()
            .iter()
            .zip(&display)
            .map(|(p, &v)| p.from_display(v))
            .collect())
    }

    /// Per-parameter sizes from a per-class error budget (display units): joint angles
    /// (θ, α, β), lengths (d, a), base rotations, base translations, tool. A zero or missing
    /// class falls back to [`Scale::default`]'s size of its unit.
    pub fn from_classes(
        robot: &Robot,
        joint_angle_deg: f64,
        length_mm: f64,
        base_rotation_deg: f64,
        base_translation_mm: f64,
        tool_mm: f64,
    ) -> Scale {
        let pick = |v: f64, fallback: f64| {
            if v > 0.0 && v.is_finite() {
                v
            } else {
                fallback
            }
        };
        Scale::PerParameter(
            robot
                .layout()
                .params()
                .iter()
                .map(|p| match p.kind {
                    ParamKind::Theta(_) | ParamKind::Alpha(_) | ParamKind::Beta(_) => {
                        pick(joint_angle_deg, 0.02)
                    }
                    ParamKind::D(_) | ParamKind::A(_) => pick(length_mm, 0.5),
                    ParamKind::BaseRx | ParamKind::BaseRy | ParamKind::BaseRz => {
                        pick(base_rotation_deg, 0.02)
                    }
                    ParamKind::BaseDx | ParamKind::BaseDy | ParamKind::BaseDz => {
                        pick(base_translation_mm, 0.5)
                    }
                    ParamKind::ToolX | ParamKind::ToolY | ParamKind::ToolZ => pick(tool_mm, 0.5),
                    ParamKind::Scale(_) => AXIS_SCALE_SCALE,
                    ParamKind::Extended(kinematics::ExtendedKind::Compliance(_)) => {
                        EXTENDED_COMPLIANCE_SCALE
                    }
                    ParamKind::Extended(_) => EXTENDED_GEAR_SCALE_ARCSEC,
                })
                .collect(),
        )
    }
}

/// Column scale of a joint-compliance parameter, µrad/(N·m): the order of a large robot's
/// main-axis compliance (1/k with k ≈ 10⁷ N·m/rad is 0.1 µrad/(N·m)).
pub const EXTENDED_COMPLIANCE_SCALE: f64 = 0.1;
/// Column scale of a gear-harmonic parameter, arcsec (the paper scenario's 10–20″).
pub const EXTENDED_GEAR_SCALE_ARCSEC: f64 = 10.0;
/// Column scale of a prismatic joint's axis scale, mm/mm (100 ppm, a rack's or an
/// encoder's order of error).
pub const AXIS_SCALE_SCALE: f64 = 1e-4;

/// Rounding allowance at a joint limit (a limit read in degrees and converted).
const LIMIT_TOL_RAD: f64 = 1e-12;
/// λ_min/λ_max of the pool's unit-diagonal information matrix below which the pool is
/// checked by the identifiability analysis (σ ratio 10⁻⁷, far above rounding).
const POOL_RANK_RTOL: f64 = 1e-14;
/// The most candidates the identifiability analysis of a suspect pool looks at (an evenly
/// spaced subset; the SVD of a 3K × p matrix beyond this is slow and adds nothing).
const POOL_ANALYSIS_MAX: usize = 3000;

/// The information model of a candidate pool (see the module docs).
#[derive(Clone, Debug)]
pub struct InfoModel {
    /// Joints per pose.
    pub n_joints: usize,
    /// The minimal identifiable set: indices into the robot's parameter vector.
    pub params: Vec<usize>,
    /// Their names.
    pub names: Vec<String>,
    /// Their scales, internal units.
    pub scale: Vec<f64>,
    /// p = `params.len()`.
    pub p: usize,
    /// Number of candidates K.
    pub n_candidates: usize,
    /// What one pose measures.
    pub measure: Measure,
    /// Rows per candidate's block r: 3 (point), 6 (frame), 3k (k targets).
    pub rows: usize,
    /// Blocks, candidate-major: candidate i, row r, column k at `(rows·i + r)·p + k`.
    pub(crate) blocks: Vec<f64>,
    /// The workspace matrix W (p × p).
    pub workspace: DMatrix<f64>,
}

pub(crate) fn check_poses(
    robot: &Robot,
    poses_rad: &[f64],
    what: &'static str,
) -> Result<(), DesignError> {
    let n = robot.n_joints();
    if n == 0 || !poses_rad.len().is_multiple_of(n) {
        return Err(DesignError::BadPose {
            what,
            index: poses_rad.len() / n.max(1),
            id: None,
            message: format!("the pose buffer is not a multiple of {n} joints"),
        });
    }
    for (index, q) in poses_rad.chunks_exact(n).enumerate() {
        if let Some(j) = q.iter().position(|v| !v.is_finite()) {
            return Err(DesignError::BadPose {
                what,
                index,
                id: None,
                message: format!("q{} is not a number ({})", j + 1, q[j]),
            });
        }
        for (j, &v) in q.iter().enumerate() {
            let [lo, hi] = robot.limits_rad(j);
            if v < lo - LIMIT_TOL_RAD || v > hi + LIMIT_TOL_RAD {
                return Err(DesignError::BadPose {
                    what,
                    index,
                    id: None,
                    message: format!(
                        "q{} = {:.6}° is outside the joint limits [{}, {}]°",
                        j + 1,
                        v.to_degrees(),
                        lo.to_degrees(),
                        hi.to_degrees()
                    ),
                });
            }
        }
    }
    Ok(())
}

/// Scaled blocks of `poses_rad` on `params` (candidate-major, see [`InfoModel`]).
fn blocks_of(robot: &Robot, poses_rad: &[f64], params: &[usize], scale: &[f64]) -> Vec<f64> {
    let n = robot.n_joints();
    let m = poses_rad.len() / n;
    let p = params.len();
    let mut out = vec![0.0; 3 * m * p];
    const CHUNK: usize = 256;
    for (c, chunk) in poses_rad.chunks(CHUNK * n).enumerate() {
        let (_, jac) = robot.jacobian_batch(chunk);
        for row in 0..jac.nrows() {
            let base = (3 * c * CHUNK + row) * p;
            for (k, (&col, &s)) in params.iter().zip(scale).enumerate() {
                out[base + k] = jac[(row, col)] * s;
            }
        }
    }
    out
}

impl InfoModel {
    /// Builds the model of the candidate pool `candidates_rad` (flat, stride N, radians).
    ///
    /// * `params`: the parameters to design for; `None`: the robot's minimal identifiable
    ///   set, decided by `identify`'s analysis on the generic pose set
    ///   ([`identify::generic_poses`], the one calibrate's free-parameter count uses too),
    ///   i.e. what the robot can show from poses in general position.
    /// * The pool must observe every one of them: if its information matrix (unit diagonal)
    ///   has λ_min/λ_max < 10⁻¹⁴, `identify::analyze` on the pool names the parameters the
    ///   pool cannot observe ([`DesignError::RankDeficientPool`]).
    /// * `workspace_rad`: the poses of the I criterion; `None`: the pool itself (the
    ///   candidates are the poses the robot can reach and the tracker see, so their mean is
    ///   the natural "where the robot will be used").
    pub fn new(
        robot: &Robot,
        candidates_rad: &[f64],
        workspace_rad: Option<&[f64]>,
        params: Option<&[usize]>,
        scale: &Scale,
    ) -> Result<InfoModel, DesignError> {
        let n = robot.n_joints();
        let k_count = check_candidates(robot, candidates_rad, workspace_rad)?;
        let id_opts = IdentifiabilityOptions::default();
        let params: Vec<usize> = match params {
            Some(p) => {
                let mut p = p.to_vec();
                p.sort_unstable();
                p.dedup();
                if p.is_empty() || p.iter().any(|&k| k >= robot.n_params()) {
                    return Err(DesignError::InvalidOption {
                        name: "params",
                        message: "empty or out of range".into(),
                    });
                }
                p
            }
            None => {
                let generic = generic_poses(robot)?;
                ParamSet::Minimal.resolve(robot, &generic, None, &id_opts)?
            }
        };
        let all_scale = scale.internal(robot)?;
        let scale: Vec<f64> = params.iter().map(|&k| all_scale[k]).collect();
        let p = params.len();
        let blocks = blocks_of(robot, candidates_rad, &params, &scale);
        let names: Vec<String> = params
            .iter()
            .map(|&k| robot.layout().get(k).name.to_string())
            .collect();
        let mut model = InfoModel {
            n_joints: n,
            params,
            names,
            scale,
            p,
            n_candidates: k_count,
            measure: Measure::Point,
            rows: 3,
            blocks,
            workspace: DMatrix::zeros(p, p),
        };
        let all: Vec<usize> = (0..k_count).collect();
        let pool = model.information(&all);
        if !pool_full_rank(&pool) {
            // Name what the pool cannot observe: the one rank decision, on the pool.
            let stride = k_count.div_ceil(POOL_ANALYSIS_MAX).max(1);
            let sub: Vec<f64> = candidates_rad
                .chunks_exact(n)
                .step_by(stride)
                .flatten()
                .copied()
                .collect();
            let report = analyze(robot, &sub, None, &model.params, &id_opts)?;
            if !report.redundant.is_empty() {
                let detail = report
                    .redundancies
                    .iter()
                    .map(|r| {
                        if r.confounded_with.is_empty() {
                            format!("{} moves no point", r.name)
                        } else {
                            let with: Vec<&str> =
                                r.confounded_with.iter().map(|t| t.name.as_str()).collect();
                            format!("{} with {}", r.name, with.join(", "))
                        }
                    })
                    .collect::<Vec<_>>()
                    .join("; ");
                return Err(DesignError::RankDeficientPool {
                    names: report.redundant,
                    detail,
                    candidates: k_count,
                });
            }
        }
        model.workspace = match workspace_rad {
            None => pool / k_count as f64,
            Some(w) => {
                let wb = blocks_of(robot, w, &model.params, &model.scale);
                let nw = w.len() / n;
                let mut acc = DMatrix::zeros(p, p);
                for blk in wb.chunks_exact(3 * p) {
                    add_outer(&mut acc, blk, 3, p, 1.0);
                }
                acc / nw as f64
            }
        };
        Ok(model)
    }

    /// The scaled block of candidate `i` (`rows` × p, row-major).
    pub fn block(&self, i: usize) -> &[f64] {
        let r = self.rows;
        &self.blocks[r * i * self.p..r * (i + 1) * self.p]
    }

    /// `M = Σ_{i∈set} B_iᵀ B_i`, summed densely in the order of `set`.
    pub fn information(&self, set: &[usize]) -> DMatrix<f64> {
        let mut m = DMatrix::zeros(self.p, self.p);
        for &i in set {
            add_outer(&mut m, self.block(i), self.rows, self.p, 1.0);
        }
        m
    }

    /// The criterion's value of a set of candidates, the dense way
    /// ([`crate::dense_value`]); `None` when its M is singular.
    pub fn value(&self, criterion: Criterion, set: &[usize]) -> Option<f64> {
        dense_value(
            criterion,
            &self.information(set),
            Some(&self.workspace),
            set.len(),
        )
    }
}

/// `m += sign · Bᵀ B` for a `rows` × p row-major block. Each entry adds one sum over the
/// rows in order, started at zero (for 3 rows the same bits as the unrolled form).
///
/// Three rows (a point), the hot loop of the E and O3 exchanges, work on the column-major
/// storage directly: the same operations in the same order as an element-wise loop over
/// `m[(i, j)]`.
pub(crate) fn add_outer(m: &mut DMatrix<f64>, b: &[f64], rows: usize, p: usize, sign: f64) {
    assert_eq!(m.shape(), (p, p), "a p × p matrix");
    if rows != 3 {
        for j in 0..p {
            for i in 0..p {
                let mut s = 0.0;
                for r in 0..rows {
                    s += sign * b[r * p + j] * b[r * p + i];
                }
                m[(i, j)] += s;
            }
        }
        return;
    }
    let (r0, r1, r2) = (&b[..p], &b[p..2 * p], &b[2 * p..3 * p]);
    for (j, col) in m.as_mut_slice().chunks_exact_mut(p).enumerate() {
        let (a0, a1, a2) = (sign * r0[j], sign * r1[j], sign * r2[j]);
        for (((v, x0), x1), x2) in col.iter_mut().zip(r0).zip(r1).zip(r2) {
            *v += a0 * x0 + a1 * x1 + a2 * x2;
        }
    }
}

/// Checks the candidate and workspace poses (finite, within the limits, whole poses; a
/// workspace given is not empty) and returns the number of candidates (at least one).
pub(crate) fn check_candidates(
    robot: &Robot,
    candidates_rad: &[f64],
    workspace_rad: Option<&[f64]>,
) -> Result<usize, DesignError> {
    check_poses(robot, candidates_rad, "candidate")?;
    if let Some(w) = workspace_rad {
        check_poses(robot, w, "workspace pose")?;
        if w.is_empty() {
            return Err(DesignError::InvalidOption {
                name: "workspace",
                message: "no workspace poses".into(),
            });
        }
    }
    let k_count = candidates_rad.len() / robot.n_joints();
    if k_count == 0 {
        return Err(DesignError::TooFewCandidates {
            candidates: 0,
            poses: 1,
        });
    }
    Ok(k_count)
}

/// The pool's unit-diagonal information matrix is comfortably non-singular.
pub(crate) fn pool_full_rank(m: &DMatrix<f64>) -> bool {
    match crate::criterion::unit_scaled_eigenvalues(m) {
        Some(ev) => {
            let (hi, lo) = (ev[0], ev[ev.len() - 1]);
            hi > 0.0 && lo > POOL_RANK_RTOL * hi
        }
        None => false,
    }
}
