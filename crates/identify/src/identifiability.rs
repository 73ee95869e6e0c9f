//! Identifiability of a parameter set on a pose set: singular values of the column-scaled
//! Jacobian, numerical rank, redundant parameters and what they are confounded with, a minimal
//! parameter set, condition number and the observability indices O1–O5 (`docs/model.md` §6).
//!
//! # Scaling
//!
//! Every column of the (weighted) stacked Jacobian `J` (3m × P) is divided by its Euclidean
//! norm: `J̃ = J·S`, `S = diag(1/‖J_k‖)`. Rank and singular values of J̃ do not depend on
//! units (rad vs mm) or on how far a parameter sits from the points; a scaled unit is "one mm
//! of RSS point motion". A column below [`ZERO_COLUMN_RTOL_SQ`] (squared,
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
//! The priority ([`keep_priority`]) follows the list of `docs/model.md` §6: first the ball
//! offset `tool_*`, then the base translations `base_dx, base_dy, base_dz`, then the joint
//! parameters in layout order (θ, d, a, α per joint, then β), then the base rotations `base_rx,
//! base_ry, base_rz`. For the KR1000 it drops exactly d1 (kept: base_dz), base_rz (kept: θ1),
//! d3 (kept: d2) and θ6, d6, a6, α6 (kept: tool_x, tool_y, tool_z).
//!
//! # Confounding
//!
//! For each dropped parameter r, the null vector `v = N·N_D⁻¹·e_r` has v_r = 1, zero on the
//! other dropped parameters, and `J̃_r = −Σ_{k kept} v_k J̃_k`: the kept parameters with
//! |v_k| > [`IdentifiabilityOptions::involvement_threshold`] are what r is confounded with.
//! Independently of the choice of D, the connected components of the null-space projector
//! `N Nᵀ` (entries above the same threshold) give the confounded groups.

use std::str::FromStr;

use kinematics::kept::{keep_with, take_kept};
use kinematics::{ParamKind, ParamLayout, PoseTrig, Robot};
use nalgebra::{DMatrix, DVector, linalg::SVD};
use serde::{Deserialize, Serialize};

use crate::error::IdentifyError;
use crate::problem::{
    NormalWork, check_free, check_poses, check_start, check_weights, weighted_jacobian,
};
use crate::scratch;

/// A column whose squared norm is below this fraction of the largest squared column norm is
/// treated as zero (the parameter does not move the measured point): the analysis here counts
/// it as a zero column and LM's column scaling leaves it unscaled (one threshold for both)
/// [1e-20, i.e. a column norm ratio of 1e-10, well above rounding (≈1e-16) in columns that
/// are exactly zero, e.g. θ6 with the ball on the flange axis].
pub const ZERO_COLUMN_RTOL_SQ: f64 = 1e-20;

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
                    value: format!("{v:?}"),
                    reason: "must lie in (0, 1)",
                });
            }
        }
        Ok(())
    }
}

/// The observability indices of `docs/model.md` §6 on the r identifiable singular values
/// σ_1 ≥ … ≥ σ_r of the column-scaled Jacobian (L = r, m = number of poses).
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

impl Observability {
    /// The indices of the identifiable singular values `sv` (σ_1 ≥ … ≥ σ_r > 0, L = r) of a
    /// Jacobian over `m` poses; `None` when `sv` is empty or not positive and descending.
    pub fn from_singular_values(sv: &[f64], m: usize) -> Option<Observability> {
        let r = sv.len();
        if r == 0 || m == 0 || !sv.iter().all(|s| s.is_finite() && *s > 0.0) {
            return None;
        }
        if sv.windows(2).any(|w| w[1] > w[0]) {
            return None;
        }
        let (s1, sr) = (sv[0], sv[r - 1]);
        let mean_ln = sv.iter().map(|s| s.ln()).sum::<f64>() / r as f64;
        Some(Observability {
            o1: mean_ln.exp() / (m as f64).sqrt(),
            o2: sr / s1,
            o3: sr,
            o4: sr * sr / s1,
            o5: 1.0 / sv.iter().map(|s| 1.0 / s).sum::<f64>(),
        })
    }
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
/// parameters in layout order, base rotations, then the non-geometric parameters of an
/// extended robot. See the module docs.
pub fn keep_priority(layout: &ParamLayout) -> Vec<usize> {
    let mut idx: Vec<usize> = (0..layout.len()).collect();
    idx.sort_by_key(|&k| (priority_rank(layout.get(k).kind), k));
    idx
}

/// The class of a parameter kind in [`keep_priority`] (lower: kept first).
fn priority_rank(kind: ParamKind) -> u8 {
    match kind {
        ParamKind::ToolX | ParamKind::ToolY | ParamKind::ToolZ => 0,
        ParamKind::BaseDx | ParamKind::BaseDy | ParamKind::BaseDz => 1,
        ParamKind::BaseRx | ParamKind::BaseRy | ParamKind::BaseRz => 3,
        // Non-geometric joint parameters last: where one is confounded with geometry, the
        // geometric parameter is kept.
        ParamKind::Extended(_) => 4,
        _ => 2,
    }
}

/// [`keep_priority`] restricted to `free` (distinct indices): positions into `free`, most
/// preferred first.
pub(crate) fn free_priority(layout: &ParamLayout, free: &[usize]) -> Vec<usize> {
    // (From the thread's pool: the solver's rank test gives it back.)
    let mut pos = scratch::indices(free.len());
    pos.extend(0..free.len());
    pos.sort_by_key(|&c| (priority_rank(layout.get(free[c]).kind), free[c]));
    pos
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
    let (dropped, _) = greedy_drop(&null, priority, opts.drop_row_min);
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

/// The dropped positions (ascending) chosen from a null-space basis `null` (P × d, orthonormal
/// columns): from the lowest priority up, a parameter is dropped when its row of `null`,
/// orthogonalised against the rows already dropped, keeps a norm ≥ `drop_row_min` (see the
/// module docs). Also returns the smallest distance `|norm − drop_row_min|` met by a
/// decision (0 when the fallback for an incomplete pass was needed): how far the choice is
/// from changing under a perturbation of the basis. The decisions depend only on the
/// subspace, not on which orthonormal basis of it is given.
pub(crate) fn greedy_drop(
    null: &DMatrix<f64>,
    priority: &[usize],
    drop_row_min: f64,
) -> (Vec<usize>, f64) {
    let (p, d) = null.shape();
    let mut basis: Vec<DVector<f64>> = Vec::with_capacity(d);
    let mut dropped = Vec::with_capacity(d);
    let mut margin = f64::INFINITY;
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
        margin = margin.min((n - drop_row_min).abs());
        if n >= drop_row_min {
            basis.push(r / n);
            dropped.push(k);
        }
    }
    // Cannot happen while P·drop_row_min² < 1; kept as a guarantee of exactly P − r drops.
    while basis.len() < d {
        margin = 0.0;
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
    (dropped, margin)
}

/// Kept relative squared distance `s_k` of a unit column from the span of the columns kept
/// before it: above this a column is kept by [`kept_by_cholesky`], below
/// [`CHOL_DROP_S`] dropped, in between the decision is left to the SVD.
const CHOL_KEEP_S: f64 = 1e-7;
/// See [`CHOL_KEEP_S`].
const CHOL_DROP_S: f64 = 1e-11;
/// Smallest σ_min of the kept scaled columns the Cholesky path accepts (a condition number of
/// about 6·10³ for 34 columns): enough margin for the rank decision and for the inverse of
/// J̃ᵀJ̃ to carry ~10 correct digits.
const CHOL_MIN_SIGMA: f64 = 1e-3;
/// Smallest margin of the greedy selection's decisions for the Cholesky path's null space to
/// stand in for the SVD's (the two agree to ~1e-12).
const CHOL_MIN_MARGIN: f64 = 1e-6;

/// The identifiable subset, chosen without an SVD (see [`kept_by_cholesky`]).
pub(crate) struct Kept {
    /// Column scaling 1/‖J_k‖ (1 for zero columns), by position.
    pub scale: Vec<f64>,
    /// Kept positions, ascending.
    pub kept: Vec<usize>,
    /// Dropped positions, ascending.
    pub dropped: Vec<usize>,
    /// `(J̃_Kᵀ J̃_K)⁻¹` of the scaled kept columns, in the order of `kept`.
    pub inv: DMatrix<f64>,
}

/// Step 1 of [`kept_by_cholesky`]: the greedy Cholesky factorisation in priority order of
/// the scaled normal matrix of `a` (see there).
#[derive(Default)]
struct Greedy {
    /// Column scaling 1/‖J_k‖ (1 for zero columns), by position.
    scale: Vec<f64>,
    /// Zero columns, by position.
    zero: Vec<bool>,
    /// The scaled normal matrix G̃ = S·A·S, dense column-major (P × P).
    gm: Vec<f64>,
    /// Kept positions in priority order.
    kp: Vec<usize>,
    /// The factor of the kept columns, row-major (row i at i·P).
    l: Vec<f64>,
    /// Reciprocals of its diagonal.
    inv_d: Vec<f64>,
    /// Dropped non-zero positions, in priority order.
    drops: Vec<usize>,
    /// Scratch: the non-zero positions in priority order, the factorisation's padded
    /// matrix and the kept pivots' places in it.
    order: Vec<usize>,
    m: Vec<f64>,
    pivots: Vec<usize>,
}

thread_local! {
    /// The buffers of the last [`Greedy`] dropped on this thread, refilled by the next
    /// ([`greedy_cholesky`] runs in every solve: no allocation per call, issue 43).
    static GREEDY: kinematics::kept::Kept<Greedy> = const { kinematics::kept::Kept::new() };
}

impl Drop for Greedy {
    fn drop(&mut self) {
        // (Moved out only when kept: `mem::take` leaves an empty value, dropped here without
        // coming back.)
        if self.gm.capacity() > 0 {
            keep_with(&GREEDY, || std::mem::take(self));
        }
    }
}

/// [`Greedy`] of `a`; `None` when a column's zero test or a keep/drop decision falls in the
/// band left to the SVD, or `a` is not finite. Compiled for the run-time SIMD level (the
/// same operations, hence the same bits, at every level: no FMA).
fn greedy_cholesky(a: &DMatrix<f64>, priority: &[usize]) -> Option<Greedy> {
    let mut gr = take_kept(&GREEDY).unwrap_or_default();
    kinematics::simd::vectorised(
        #[inline(always)]
        || greedy_impl(a, priority, &mut gr),
    )
    .then_some(gr)
}

/// Fills `gr` (its buffers cleared and resized, contents as if new); `false` for `None` of
/// [`greedy_cholesky`].
#[inline(always)]
fn greedy_impl(a: &DMatrix<f64>, priority: &[usize], gr: &mut Greedy) -> bool {
    let p = a.ncols();
    // (A fold, not `all`: no early exit, so it vectorises.)
    if p == 0 || !a.as_slice().iter().fold(true, |ok, v| ok & v.is_finite()) {
        return false;
    }
    // Column norms and the zero test of analyze_matrix, with a factor-2 margin.
    let max_sq = (0..p).fold(0.0_f64, |m, k| m.max(a[(k, k)]));
    let thr = ZERO_COLUMN_RTOL_SQ * max_sq;
    let Greedy {
        scale,
        zero,
        gm,
        kp,
        l,
        inv_d,
        drops,
        order,
        m,
        pivots,
    } = gr;
    let refill = |v: &mut Vec<f64>, len: usize, x: f64| {
        v.clear();
        v.resize(len, x);
    };
    refill(scale, p, 1.0);
    zero.clear();
    zero.resize(p, false);
    for k in 0..p {
        let d = a[(k, k)];
        if d > 2.0 * thr && d > 0.0 {
            scale[k] = 1.0 / d.sqrt();
        } else if d < 0.5 * thr || d <= 0.0 {
            zero[k] = true;
        } else {
            return false;
        }
    }
    // The scaled normal matrix G̃ = S·A·S, dense column-major.
    refill(gm, p * p, 0.0);
    for ((dst, src), sj) in gm
        .chunks_exact_mut(p)
        .zip(a.as_slice().chunks_exact(p))
        .zip(scale.iter())
    {
        for ((d, v), si) in dst.iter_mut().zip(src).zip(scale.iter()) {
            *d = si * v * sj;
        }
    }

    // Greedy Cholesky in priority order, right-looking: `m` holds the scaled matrix of the
    // non-zero columns in priority order (column-major with leading dimension `ld`, lower
    // triangle; entry (a, b), a ≥ b, is G̃'s entry in the column of the later one, as a
    // left-looking factorisation reads it). A kept pivot's column becomes its column of L
    // (multiplied by the reciprocal of the diagonal, not divided), and its outer product is
    // subtracted from the trailing columns; a dropped one is skipped. Every entry thus
    // receives the same operations in the same order as in the left-looking (row by row)
    // form, bit for bit, while the trailing updates run over contiguous columns, in whole
    // blocks of rows (the strict upper triangle and the padding rows then hold values that
    // are never read).
    order.clear();
    order.extend(priority.iter().copied().filter(|&k| !zero[k]));
    let n = order.len();
    let ld = crate::linalg::padded_ld(n);
    refill(m, ld * n, 0.0);
    for (b, &kb) in order.iter().enumerate() {
        for (a, &ka) in order.iter().enumerate().skip(b) {
            m[b * ld + a] = gm[ka * p + kb];
        }
    }
    kp.clear();
    pivots.clear();
    refill(inv_d, p, 0.0);
    drops.clear();
    // Panels of columns: a kept pivot updates the rest of its panel at once, and the
    // panel's kept pivots update the trailing columns together (the same operations in
    // the same order for every entry, see `linalg::downdate`).
    for b0 in (0..n).step_by(crate::linalg::PANEL_COLS) {
        let end = (b0 + crate::linalg::PANEL_COLS).min(n);
        let first = pivots.len();
        for (b, &k) in order.iter().enumerate().take(end).skip(b0) {
            let s = m[b * ld + b];
            if s > CHOL_KEEP_S {
                let d = s.sqrt();
                let inv = 1.0 / d;
                m[b * ld + b] = d;
                for v in &mut m[b * ld + b + 1..b * ld + n] {
                    *v *= inv;
                }
                inv_d[kp.len()] = inv;
                kp.push(k);
                pivots.push(b);
                crate::linalg::downdate(m, n, ld, &[b], b + 1..end);
            } else if s < CHOL_DROP_S {
                drops.push(k);
            } else {
                return false;
            }
        }
        crate::linalg::downdate(m, n, ld, &pivots[first..], end..n);
    }
    // `l` row-major (row i at i·p): row i holds L's entries of the i-th kept column.
    refill(l, p * p, 0.0);
    for (i, &a) in pivots.iter().enumerate() {
        for (j, &b) in pivots.iter().enumerate().take(i + 1) {
            l[i * p + j] = m[b * ld + a];
        }
    }
    true
}

/// The identifiable subset and `(J̃_KᵀJ̃_K)⁻¹` from the normal matrix `a = JᵀJ` (P × P) and
/// the stacked Jacobian (3m × P, asked of `jac` only when a column is dropped), *when it can
/// be certified* to be exactly what the SVD of [`analyze_matrix`] would choose; `None`
/// otherwise (the caller then runs the SVD).
///
/// 1. The columns are visited in priority order with a Cholesky factorisation of the
///    scaled J̃ᵀJ̃ that skips a column whose squared distance `s` from the span of the kept
///    ones is below [`CHOL_DROP_S`] (`s` above [`CHOL_KEEP_S`] keeps it; in between: `None`).
/// 2. Rank ≥ r: `σ_r(J̃) ≥ σ_min(J̃_K) ≥ 1/‖L⁻¹‖_F`, required ≥ [`CHOL_MIN_SIGMA`] (far above
///    `rank_rtol·σ_1`, σ_1 ≤ √P).
/// 3. Rank ≤ r: `σ_{r+1}(J̃) ≤ ‖J̃_D − J̃_K C‖_F` with `C = (J̃_KᵀJ̃_K)⁻¹J̃_KᵀJ̃_D`, computed in
///    the 3m-dimensional space (accurate to ~1e-13, where the normal matrix would only give
///    1e-7), required ≤ `rank_rtol/10` (σ_1 ≥ 1: the columns have unit norm).
/// 4. The null space spanned by `[−C; I]` and the zero columns replaces the SVD's: the
///    greedy selection ([`greedy_drop`]) must return the same dropped set with every decision
///    at least [`CHOL_MIN_MARGIN`] from its threshold.
///
/// With a clear gap (exact redundancies at rounding level, the rest well conditioned, the
/// usual case) this costs a few µs where the SVD costs a few hundred.
pub(crate) fn kept_by_cholesky(
    jac: &mut dyn FnMut() -> DMatrix<f64>,
    a: &DMatrix<f64>,
    priority: &[usize],
    opts: &IdentifiabilityOptions,
) -> Option<Kept> {
    let p = a.ncols();
    // 1. Greedy Cholesky in priority order.
    let gr = greedy_cholesky(a, priority)?;
    let (scale, zero, gm, kp) = (&gr.scale[..], &gr.zero[..], &gr.gm[..], &gr.kp[..]);
    let (l, inv_d, drops) = (&gr.l[..], &gr.inv_d[..], &gr.drops[..]);
    let r = kp.len();
    if r == 0 {
        return None;
    }

    // 2. L⁻¹ (`li` column-major: column c at c·r) and (J̃_KᵀJ̃_K)⁻¹ = L⁻ᵀL⁻¹ (priority
    //    order, symmetric, row i at i·r), by the documented sums of
    //    [`crate::linalg::lower_inverse_gram`]; the bound on σ_min.
    // (Buffers from the thread's pools, given back on the way out.)
    let (mut li, mut ginv) = (scratch::zeros(r * r), scratch::zeros(r * r));
    crate::linalg::lower_inverse_gram(l, p, inv_d, r, &mut li, &mut ginv);
    let frob = li.iter().map(|v| v * v).sum::<f64>().sqrt();
    scratch::give_back(li);
    let sigma_lower = 1.0 / frob;
    if !(sigma_lower >= CHOL_MIN_SIGMA && sigma_lower > 10.0 * opts.rank_rtol * (p as f64).sqrt()) {
        scratch::give_back(ginv);
        return None;
    }
    let sum0: f64 = std::iter::empty::<f64>().sum();

    // 3. Residual of the dropped (non-zero) columns in the 3m-space: J̃_d − J̃_K c with
    //    L Lᵀ c = J̃_KᵀJ̃_d (all kept columns: a redundancy may involve columns of lower
    //    priority than the dropped one, e.g. β2 in d3's).
    let jac = if drops.is_empty() {
        DMatrix::zeros(0, 0)
    } else {
        jac()
    };
    let rows = jac.nrows();
    let js = jac.as_slice();
    // (Only dropped columns need these: none allocated without.)
    let mut res = Vec::new();
    let mut terms: Vec<(usize, f64)> = Vec::new();
    let mut total = 0.0;
    let mut null_cols: Vec<DVector<f64>> = Vec::with_capacity(p - r);
    let mut c = if drops.is_empty() {
        Vec::new()
    } else {
        vec![0.0; r]
    };
    for dpos in drops {
        let gd = &gm[dpos * p..(dpos + 1) * p];
        // c_i = Σ_j ginv_ij·gd_kj in j order, for all i at once (ginv is exactly symmetric:
        // row i is column i).
        c.fill(sum0);
        for (row, &k) in ginv.chunks_exact(r).zip(kp) {
            let gk = gd[k];
            for (ci, v) in c.iter_mut().zip(row) {
                *ci += v * gk;
            }
        }
        // s_d·J_d − Σ_t c_t s_t·J_t (the first term is added, the others subtracted).
        terms.clear();
        terms.push((*dpos, scale[*dpos]));
        terms.extend(kp.iter().zip(&c).map(|(&k, ct)| (k, ct * scale[k])));
        total += crate::linalg::combination_norm_sq(js, rows, &terms, &mut res);
        let mut v = DVector::zeros(p);
        v[*dpos] = 1.0;
        for (t, &kpos) in kp.iter().enumerate() {
            v[kpos] = -c[t];
        }
        null_cols.push(v);
    }
    // (NaN fails too.)
    if total.sqrt().partial_cmp(&(0.1 * opts.rank_rtol)) != Some(std::cmp::Ordering::Less) {
        scratch::give_back(ginv);
        return None;
    }

    // 4. Orthonormal null space (twice-modified Gram–Schmidt) and the greedy selection.
    for (k, _) in zero.iter().enumerate().filter(|(_, z)| **z) {
        let mut v = DVector::zeros(p);
        v[k] = 1.0;
        null_cols.push(v);
    }
    let d = null_cols.len();
    let mut null = DMatrix::zeros(p, d);
    for (j, v0) in null_cols.iter().enumerate() {
        let mut v = v0.clone();
        for _ in 0..2 {
            for i in 0..j {
                let c = null.column(i).dot(&v);
                v.axpy(-c, &null.column(i), 1.0);
            }
        }
        let n = v.norm();
        null.set_column(j, &(v / n));
    }
    let (dropped, margin) = greedy_drop(&null, priority, opts.drop_row_min);
    let mut expected: Vec<usize> = (0..p).filter(|k| !kp.contains(k)).collect();
    expected.sort_unstable();
    if dropped != expected || margin.is_nan() || margin < CHOL_MIN_MARGIN {
        scratch::give_back(ginv);
        return None;
    }

    // The inverse in ascending order of the kept positions (`Kept`'s buffers from the
    // pools: the covariance gives them back).
    let mut order = scratch::indices(r);
    order.extend(0..r);
    order.sort_by_key(|&i| kp[i]);
    let mut kept = scratch::indices(r);
    kept.extend(order.iter().map(|&i| kp[i]));
    let mut inv = scratch::zero_matrix(r, r);
    for j in 0..r {
        for i in 0..r {
            inv[(i, j)] = ginv[order[i] * r + order[j]];
        }
    }
    scratch::give_back_indices(order);
    scratch::give_back(ginv);
    Some(Kept {
        scale: scratch::copy(scale),
        kept,
        dropped,
        inv,
    })
}

/// Whether [`crate::covariance`] can choose the identifiable subset of `free` at `robot`
/// without the SVD ([`kept_by_cholesky`] certifies it). For tests and benchmarks.
#[doc(hidden)]
pub fn cholesky_certifies(
    robot: &Robot,
    poses_rad: &[f64],
    weights: Option<&[f64]>,
    free: &[usize],
    opts: &IdentifiabilityOptions,
) -> bool {
    let m = poses_rad.len() / robot.n_joints();
    let pf = free.len();
    let trig = PoseTrig::for_robot(robot, poses_rad);
    let mut work = NormalWork::new(pf);
    let mut jac = DMatrix::zeros(3 * m, pf);
    let zeros = vec![nalgebra::Vector3::zeros(); m];
    work.assemble_stacked(robot, &trig, &zeros, weights, free, &mut jac);
    let mut a = DMatrix::zeros(pf, pf);
    let mut g = DVector::zeros(pf);
    work.copy_to(&mut a, &mut g);
    let priority = free_priority(robot.layout(), free);
    kept_by_cholesky(&mut || jac.clone(), &a, &priority, opts).is_some()
}

/// Positions (into `free`, ascending) of the parameters that are exactly redundant (or do
/// not move the points) at `robot` on these poses, dropped from the lowest priority up as
/// the minimal set drops them ([`keep_priority`]): by the greedy Cholesky of
/// [`kept_by_cholesky`]'s first step when every decision is clear, by the SVD of
/// [`analyze`] otherwise. Empty when `free` is identifiable. What
/// [`crate::lm::Redundant::Hold`] holds.
pub(crate) fn redundant_positions(
    robot: &Robot,
    poses_rad: &[f64],
    weights: Option<&[f64]>,
    free: &[usize],
    a: &DMatrix<f64>,
    opts: &IdentifiabilityOptions,
) -> Result<Vec<usize>, IdentifyError> {
    opts.validate()?;
    let m = poses_rad.len() / robot.n_joints();
    let pf = free.len();
    let priority = free_priority(robot.layout(), free);
    // A clear gap (the usual case) is decided by the greedy Cholesky alone: exactly
    // redundant columns (relative squared distance from the span of the columns of higher
    // priority < 1e-11) and zero ones are dropped. Anything closer to the thresholds goes to
    // the SVD on the stacked Jacobian.
    // (From the thread's pool: the caller gives it back.)
    let dropped = match greedy_cholesky(a, &priority) {
        Some(gr) => {
            let mut d = scratch::indices(pf);
            d.extend((0..pf).filter(|k| !gr.kp.contains(k)));
            d
        }
        None => {
            let trig = PoseTrig::for_robot(robot, poses_rad);
            let mut j = DMatrix::zeros(3 * m, pf);
            NormalWork::stacked_jacobian(robot, &trig, weights, free, &mut j);
            analyze_matrix(j, &priority, opts)?.dropped
        }
    };
    scratch::give_back_indices(priority);
    Ok(dropped)
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
    let priority = free_priority(layout, &free);
    let an = analyze_matrix(jac, &priority, opts)?;
    let name = |pos: usize| layout.get(free[pos]).name.to_string();
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
        (
            Some(ident[0] / ident[r - 1]),
            Observability::from_singular_values(ident, m),
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

impl std::fmt::Display for ParamSet {
    /// `paper`, `minimal` or the names joined by `,`: what [`ParamSet::from_str`] reads back.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            ParamSet::Paper => f.write_str("paper"),
            ParamSet::Minimal => f.write_str("minimal"),
            ParamSet::Names(names) => f.write_str(&names.join(",")),
        }
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
        let mut out = Vec::new();
        self.resolve_into(robot, poses_rad, weights, opts, &mut out)?;
        Ok(out)
    }

    /// [`ParamSet::resolve`] written into `out` (the paper's set without allocation once
    /// `out` has the room: what a campaign's trials resolve; the others replace `out`). On
    /// `Err`, `out` is unchanged.
    pub fn resolve_into(
        &self,
        robot: &Robot,
        poses_rad: &[f64],
        weights: Option<&[f64]>,
        opts: &IdentifiabilityOptions,
        out: &mut Vec<usize>,
    ) -> Result<(), IdentifyError> {
        *out = match self {
            ParamSet::Paper => {
                out.clear();
                out.extend(0..robot.n_params());
                return Ok(());
            }
            ParamSet::Minimal => {
                let all: Vec<usize> = (0..robot.n_params()).collect();
                analyze(robot, poses_rad, weights, &all, opts)?.identifiable_indices
            }
            ParamSet::Names(names) => {
                if names.is_empty() {
                    return Err(IdentifyError::NoFreeParameters);
                }
                robot.layout().select(names)?
            }
        };
        Ok(())
    }
}
