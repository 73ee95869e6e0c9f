//! Identifiability of a parameter set on a pose set: singular values of the column-scaled
//! Jacobian, numerical rank, redundant parameters and what they are confounded with, a minimal
//! parameter set, condition number and the observability indices O1–O5 (spec §3).
//!
//! # Scaling
//!
//! Every column of the (weighted) stacked Jacobian `J` (3m × P) is divided by its Euclidean
//! norm: `J̃ = J·S`, `S = diag(1/‖J_k‖)`. Rank and singular values of J̃ do not depend on
//! units (rad vs mm) or on how far a parameter sits from the points; a scaled unit is "one mm
//! of RSS point motion". A column below [`crate::lm::ZERO_COLUMN_RTOL_SQ`] (squared,
//! relative to the largest) is set to exactly zero: that parameter does not move the point.
//!
//! # Rank and null space
//!
//! SVD `J̃ = U Σ Vᵀ` (singular values descending). Rank r = #{σ_i > rtol·σ_1}
//! ([`IdentifiabilityOptions::rank_rtol`]). The last P − r columns of V span the null space N:
//! parameter changes that leave every predicted point unchanged to first order.
//!
//! # Which parameters are kept (the minimal set)
//!
//! A set D of P − r parameters can be dropped (fixed) with the rest still spanning the column
//! space exactly when the rows of N belonging to D form an invertible matrix N_D. D is built
//! greedily from the *lowest*-priority parameter up: a parameter joins D when its row of N,
//! orthogonalised against the rows already in D, keeps a norm ≥
//! [`IdentifiabilityOptions::drop_row_min`]. Because N has orthonormal columns, its rows'
//! squared norms sum to P − r, so one pass always completes with exactly P − r parameters
//! (while P·drop_row_min² < 1). For exactly confounded groups this is QR with a fixed pivot
//! order on the column space: within each group the highest-priority parameters are kept.
//!
//! The priority ([`keep_priority`]) follows spec §3's list: first the ball offset `tool_*`,
//! then the base translations `base_dx, base_dy, base_dz`, then the joint parameters in
//! layout order (θ, d, a, α per joint, then β), then the base rotations `base_rx, base_ry,
//! base_rz`. For the KR1000 it drops exactly d1 (kept: base_dz), base_rz (kept: θ1), d3 (kept:
//! d2) and θ6, d6, a6, α6 (kept: tool_x, tool_y, tool_z).
//!
//! # Confounding
//!
//! For each dropped parameter r, the null vector `v = N·N_D⁻¹·e_r` has v_r = 1, zero on the
//! other dropped parameters, and `J̃_r = −Σ_{k kept} v_k J̃_k`: the kept parameters with
//! |v_k| > [`IdentifiabilityOptions::involvement_threshold`] are what r is confounded with.
//! Independently of the choice of D, the connected components of the null-space projector
//! `N Nᵀ` (entries above the same threshold) give the confounded groups.

use std::str::FromStr;

use kinematics::{ParamKind, ParamLayout, Robot};
use nalgebra::{DMatrix, DVector, linalg::SVD};
use serde::{Deserialize, Serialize};

use crate::error::IdentifyError;
use crate::lm::ZERO_COLUMN_RTOL_SQ;
use crate::problem::{check_free, check_poses, check_start, check_weights, weighted_jacobian};

/// Iteration cap of the SVDs (nalgebra's `try_new`); far beyond what 34 columns need.
const SVD_MAX_ITER: usize = 10_000;

/// Options of [`analyze`]. Defaults in brackets, with the reason.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct IdentifiabilityOptions {
    /// Relative rank tolerance: σ_i counts when σ_i > rank_rtol·σ_1 [1e-9]. Exact
    /// redundancies leave σ ≈ 1e-15·σ_1 (rounding), so this is far above them; a direction
    /// with σ = 1e-9·σ_1 would need point noise ~10⁻⁹ mm to be determined to 1 mm of point
    /// motion, i.e. it is not identifiable from any tracker.
    pub rank_rtol: f64,
    /// A null-space component (scaled, per unit of the redundant parameter) or projector entry
    /// above this counts as involvement in a redundancy [1e-6: exact dependence leaves
    /// rounding ≈ 1e-12; real shares are O(0.1)].
    pub involvement_threshold: f64,
    /// Minimum norm of a parameter's null-space row (orthogonalised against those already
    /// dropped) for it to be dropped [1e-2: smaller would drop a parameter that is barely
    /// involved and leave an ill-conditioned kept set; must satisfy P·drop_row_min² < 1 so one
    /// pass always finds P − r parameters].
    pub drop_row_min: f64,
}

impl Default for IdentifiabilityOptions {
    fn default() -> Self {
        IdentifiabilityOptions {
            rank_rtol: 1e-9,
            involvement_threshold: 1e-6,
            drop_row_min: 1e-2,
        }
    }
}

impl IdentifiabilityOptions {
    fn validate(&self) -> Result<(), IdentifyError> {
        for (name, v) in [
            ("rank_rtol", self.rank_rtol),
            ("involvement_threshold", self.involvement_threshold),
            ("drop_row_min", self.drop_row_min),
        ] {
            if !(v.is_finite() && v > 0.0 && v < 1.0) {
                return Err(IdentifyError::InvalidOption {
                    name,
                    value: v.to_string(),
                    reason: "must lie in (0, 1)",
                });
            }
        }
        Ok(())
    }
}

/// The observability indices of spec §3 on the r identifiable singular values σ_1 ≥ … ≥ σ_r
/// of the column-scaled Jacobian (L = r, m = number of poses).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Observability {
    /// O1 = (∏σ_i)^(1/L) / √m (Borm–Menq).
    pub o1: f64,
    /// O2 = σ_r / σ_1, the inverse condition number (Driels–Pathre).
    pub o2: f64,
    /// O3 = σ_r, the minimum singular value (Nahvi–Hollerbach).
    pub o3: f64,
    /// O4 = σ_r² / σ_1, the noise amplification index (Nahvi–Hollerbach).
    pub o4: f64,
    /// O5 = (Σ 1/σ_i)⁻¹ (Sun–Hollerbach).
    pub o5: f64,
}

/// One term of a redundancy: a kept parameter and its null-vector weight.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ConfoundTerm {
    /// The kept parameter.
    pub name: String,
    /// v_k of the scaled null vector with v_redundant = 1: the scaled column of the
    /// redundant parameter equals −Σ v_k × (scaled column k).
    pub weight: f64,
}

/// A redundant (dropped) parameter and what it is confounded with.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Redundancy {
    /// The redundant parameter.
    pub name: String,
    /// Kept parameters that absorb it (empty if the parameter does not move the point at all).
    pub confounded_with: Vec<ConfoundTerm>,
}

/// What [`analyze`] finds.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct IdentifiabilityReport {
    /// Robot name.
    pub robot: String,
    /// Number of poses m.
    pub n_poses: usize,
    /// Number of equations 3m.
    pub n_equations: usize,
    /// Number of parameters analysed P.
    pub parameter_count: usize,
    /// Their names, layout order.
    pub parameters: Vec<String>,
    /// The scaling applied before the SVD (words).
    pub scaling: String,
    /// Parameters whose Jacobian column is zero (they do not move the measured point).
    pub zero_columns: Vec<String>,
    /// Singular values of the scaled Jacobian, descending (P values; zeros when 3m < P).
    pub singular_values: Vec<f64>,
    /// Numerical rank r.
    pub rank: usize,
    /// The relative tolerance used.
    pub rank_rtol: f64,
    /// The absolute tolerance used: rank_rtol·σ_1.
    pub rank_tolerance: f64,
    /// The P − r redundant parameters (dropped from the minimal set), layout order.
    pub redundant: Vec<String>,
    /// For each redundant parameter, what it is confounded with.
    pub redundancies: Vec<Redundancy>,
    /// Groups of parameters sharing null-space directions (components of the null-space
    /// projector), each in layout order.
    pub confounded_groups: Vec<Vec<String>>,
    /// The minimal (identifiable) set: the r kept parameters, layout order.
    pub identifiable: Vec<String>,
    /// Their indices in the robot's parameter vector.
    pub identifiable_indices: Vec<usize>,
    /// σ_1 / σ_r of the identifiable part (`None` when r = 0).
    pub condition_number: Option<f64>,
    /// O1–O5 on σ_1..σ_r (`None` when r = 0).
    pub observability: Option<Observability>,
}

/// Keep-priority of the parameters (most preferred first): tool, base translations, joint
/// parameters in layout order, base rotations. See the module docs.
pub fn keep_priority(layout: &ParamLayout) -> Vec<usize> {
    let rank = |kind: ParamKind| match kind {
        ParamKind::ToolX | ParamKind::ToolY | ParamKind::ToolZ => 0,
        ParamKind::BaseDx | ParamKind::BaseDy | ParamKind::BaseDz => 1,
        ParamKind::BaseRx | ParamKind::BaseRy | ParamKind::BaseRz => 3,
        _ => 2,
    };
    let mut idx: Vec<usize> = (0..layout.len()).collect();
    idx.sort_by_key(|&k| (rank(layout.get(k).kind), k));
    idx
}

/// The outcome of the matrix part of the analysis, in positions 0..P of the analysed set.
pub(crate) struct Analysis {
    pub scale: Vec<f64>,
    pub zero: Vec<bool>,
    pub singular_values: Vec<f64>,
    pub rank: usize,
    pub tol: f64,
    /// Null-space basis, P × (P − r).
    pub null: DMatrix<f64>,
    /// Kept positions, ascending.
    pub kept: Vec<usize>,
    /// Dropped positions, ascending.
    pub dropped: Vec<usize>,
}

/// Scales, decomposes and selects on a weighted Jacobian whose columns are the analysed
/// parameters; `priority` lists positions most preferred first.
pub(crate) fn analyze_matrix(
    mut jac: DMatrix<f64>,
    priority: &[usize],
    opts: &IdentifiabilityOptions,
) -> Result<Analysis, IdentifyError> {
    let p = jac.ncols();
    let norms: Vec<f64> = jac.column_iter().map(|c| c.norm()).collect();
    let max_norm = norms.iter().fold(0.0_f64, |m, &v| m.max(v));
    if !norms.iter().all(|v| v.is_finite()) {
        return Err(IdentifyError::NonFiniteStep {
            iteration: 0,
            what: "Jacobian",
        });
    }
    let mut scale = vec![1.0; p];
    let mut zero = vec![false; p];
    for k in 0..p {
        if norms[k] * norms[k] > ZERO_COLUMN_RTOL_SQ * max_norm * max_norm && norms[k] > 0.0 {
            scale[k] = 1.0 / norms[k];
            jac.column_mut(k).scale_mut(scale[k]);
        } else {
            zero[k] = true;
            jac.column_mut(k).fill(0.0);
        }
    }
    if jac.nrows() < p {
        jac = jac.resize_vertically(p, 0.0);
    }
    let svd =
        SVD::try_new(jac, false, true, f64::EPSILON, SVD_MAX_ITER).ok_or(IdentifyError::Svd {
            what: "scaled Jacobian",
        })?;
    let v_t = svd.v_t.as_ref().ok_or(IdentifyError::Svd {
        what: "scaled Jacobian",
    })?;
    let singular_values: Vec<f64> = svd.singular_values.iter().copied().collect();
    let s1 = singular_values.first().copied().unwrap_or(0.0);
    let tol = opts.rank_rtol * s1;
    let rank = singular_values.iter().filter(|&&s| s > tol).count();
    let d = p - rank;
    let null = DMatrix::from_fn(p, d, |i, j| v_t[(rank + j, i)]);

    // Drop from the lowest priority up (see module docs).
    let mut basis: Vec<DVector<f64>> = Vec::with_capacity(d);
    let mut dropped = Vec::with_capacity(d);
    let residual = |row: usize, basis: &[DVector<f64>]| {
        let mut r: DVector<f64> = null.row(row).transpose();
        for _ in 0..2 {
            for b in basis {
                let c = b.dot(&r);
                r.axpy(-c, b, 1.0);
            }
        }
        r
    };
    for &k in priority.iter().rev() {
        if basis.len() == d {
            break;
        }
        let r = residual(k, &basis);
        let n = r.norm();
        if n >= opts.drop_row_min {
            basis.push(r / n);
            dropped.push(k);
        }
    }
    // Cannot happen while P·drop_row_min² < 1; kept as a guarantee of exactly P − r drops.
    while basis.len() < d {
        let (k, r) = (0..p)
            .filter(|k| !dropped.contains(k))
            .map(|k| (k, residual(k, &basis)))
            .max_by(|a, b| a.1.norm().total_cmp(&b.1.norm()))
            .expect("fewer parameters than null-space dimensions");
        let n = r.norm();
        basis.push(r / n);
        dropped.push(k);
    }
    dropped.sort_unstable();
    let kept = (0..p).filter(|k| !dropped.contains(k)).collect();
    Ok(Analysis {
        scale,
        zero,
        singular_values,
        rank,
        tol,
        null,
        kept,
        dropped,
    })
}

/// Analyses the identifiability of the parameters `free` (indices into the robot's parameter
/// vector) at `robot` on the given poses (flat, radians), with optional per-row weights
/// (1/σ, 3 per pose). Measured points are not needed.
pub fn analyze(
    robot: &Robot,
    poses_rad: &[f64],
    weights: Option<&[f64]>,
    free: &[usize],
    opts: &IdentifiabilityOptions,
) -> Result<IdentifiabilityReport, IdentifyError> {
    opts.validate()?;
    let m = check_poses(robot, poses_rad)?;
    check_start(robot)?;
    let free = check_free(robot, free.to_vec())?;
    if let Some(w) = weights {
        check_weights(w, 3 * m)?;
    }
    let layout = robot.layout();
    let jac = weighted_jacobian(robot, poses_rad, weights, &free);
    let pos_of = |k: usize| free.iter().position(|&f| f == k);
    let priority: Vec<usize> = keep_priority(layout)
        .into_iter()
        .filter_map(pos_of)
        .collect();
    let an = analyze_matrix(jac, &priority, opts)?;
    let name = |pos: usize| layout.get(free[pos]).name.clone();
    let p = free.len();
    let d = an.dropped.len();

    // Null vectors normalised on each dropped parameter: v = N · N_D⁻¹ · e_r.
    let mut redundancies = Vec::with_capacity(d);
    if d > 0 {
        let nd = DMatrix::from_fn(d, d, |i, j| an.null[(an.dropped[i], j)]);
        let inv = nd.try_inverse().ok_or(IdentifyError::Svd {
            what: "null-space rows of the redundant parameters",
        })?;
        let v_all = &an.null * inv; // P × d, column i = null vector of dropped[i]
        for (i, &r) in an.dropped.iter().enumerate() {
            let confounded_with = an
                .kept
                .iter()
                .filter(|&&k| v_all[(k, i)].abs() > opts.involvement_threshold)
                .map(|&k| ConfoundTerm {
                    name: name(k),
                    weight: v_all[(k, i)],
                })
                .collect();
            redundancies.push(Redundancy {
                name: name(r),
                confounded_with,
            });
        }
    }

    // Groups: connected components of the projector N Nᵀ.
    let proj = &an.null * an.null.transpose();
    let thr = opts.involvement_threshold;
    let mut group_of: Vec<Option<usize>> = vec![None; p];
    let mut groups: Vec<Vec<usize>> = Vec::new();
    for start in 0..p {
        if group_of[start].is_some() || proj[(start, start)] <= thr {
            continue;
        }
        let gid = groups.len();
        let mut members = vec![start];
        group_of[start] = Some(gid);
        let mut head = 0;
        while head < members.len() {
            let i = members[head];
            head += 1;
            for j in 0..p {
                if group_of[j].is_none() && proj[(i, j)].abs() > thr {
                    group_of[j] = Some(gid);
                    members.push(j);
                }
            }
        }
        members.sort_unstable();
        groups.push(members);
    }

    let sv = &an.singular_values;
    let r = an.rank;
    let (condition_number, observability) = if r == 0 {
        (None, None)
    } else {
        let ident = &sv[..r];
        let (s1, sr) = (ident[0], ident[r - 1]);
        let mean_ln = ident.iter().map(|s| s.ln()).sum::<f64>() / r as f64;
        (
            Some(s1 / sr),
            Some(Observability {
                o1: mean_ln.exp() / (m as f64).sqrt(),
                o2: sr / s1,
                o3: sr,
                o4: sr * sr / s1,
                o5: 1.0 / ident.iter().map(|s| 1.0 / s).sum::<f64>(),
            }),
        )
    };

    Ok(IdentifiabilityReport {
        robot: robot.name().to_string(),
        n_poses: m,
        n_equations: 3 * m,
        parameter_count: p,
        parameters: (0..p).map(name).collect(),
        scaling: "columns of the (weighted) stacked 3m × P Jacobian divided by their Euclidean \
                  norms (zero columns left at zero)"
            .into(),
        zero_columns: (0..p).filter(|&k| an.zero[k]).map(name).collect(),
        singular_values: sv.clone(),
        rank: r,
        rank_rtol: opts.rank_rtol,
        rank_tolerance: an.tol,
        redundant: an.dropped.iter().map(|&k| name(k)).collect(),
        redundancies,
        confounded_groups: groups
            .iter()
            .map(|g| g.iter().map(|&k| name(k)).collect())
            .collect(),
        identifiable: an.kept.iter().map(|&k| name(k)).collect(),
        identifiable_indices: an.kept.iter().map(|&k| free[k]).collect(),
        condition_number,
        observability,
    })
}

/// Which parameters to identify.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ParamSet {
    /// All of them (the paper's 34 for the KR1000); redundant ones included.
    Paper,
    /// The minimal identifiable set at the start model and the given poses (see the module
    /// docs for which parameter of a confounded group is kept).
    Minimal,
    /// An explicit list of names.
    Names(Vec<String>),
}

impl FromStr for ParamSet {
    type Err = std::convert::Infallible;

    /// `paper`, `minimal`, or comma-separated names (checked against a robot by
    /// [`ParamSet::resolve`]).
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Ok(match s.trim() {
            "paper" => ParamSet::Paper,
            "minimal" => ParamSet::Minimal,
            other => ParamSet::Names(
                other
                    .split(',')
                    .map(|n| n.trim().to_string())
                    .filter(|n| !n.is_empty())
                    .collect(),
            ),
        })
    }
}

impl ParamSet {
    /// The free parameter indices for `robot` (layout order). `Minimal` analyses the
    /// Jacobian at `robot` on `poses_rad` (with the optional weights); `Names` fails on an
    /// unknown name, naming the robot's parameters.
    pub fn resolve(
        &self,
        robot: &Robot,
        poses_rad: &[f64],
        weights: Option<&[f64]>,
        opts: &IdentifiabilityOptions,
    ) -> Result<Vec<usize>, IdentifyError> {
        match self {
            ParamSet::Paper => Ok((0..robot.n_params()).collect()),
            ParamSet::Minimal => {
                let all: Vec<usize> = (0..robot.n_params()).collect();
                Ok(analyze(robot, poses_rad, weights, &all, opts)?.identifiable_indices)
            }
            ParamSet::Names(names) => {
                if names.is_empty() {
                    return Err(IdentifyError::NoFreeParameters);
                }
                Ok(robot.layout().select(names)?)
            }
        }
    }
}
