//! The identification problem: start model, poses, measured points, weights, free parameters;
//! and the allocation-free assembly of its residual, cost and normal equations.

use kinematics::kept::{Pool, give_pooled, take_pooled};
use kinematics::{MAX_PARAMS, POSE_LANES, ParamName, PoseTrig, Robot};
use nalgebra::{DMatrix, DVector, Vector3};

use crate::error::IdentifyError;
use crate::scratch;
use crate::simd::{SimdLevel, simd_level};

/// Two poses whose joint values all differ by less than this (rad) count as the same pose when
/// [`Problem::new`] checks that enough distinct poses exist [1e-9 rad ≈ 6e-8°, far below any
/// controller's resolution, far above rounding].
pub const SAME_POSE_TOL_RAD: f64 = 1e-9;

/// One identification problem.
///
/// Residual of pose j: `e_j = w_j ∘ (p_j^meas − p(x; q_j))` (mm, or dimensionless when
/// weighted), with `p(x; q)` the measured point predicted by the robot with parameter vector
/// `x` ([`Robot::point`]) and `w_j` the optional weights of its three rows (1/σ). The cost is
/// the (weighted) residual sum of squares `F(x) = Σ_j ‖e_j‖²`; only the free parameters move.
///
/// Everything is checked on construction: shapes, finiteness, positive weights, free indices,
/// and that there are at least as many equations — counting repeated poses once — as free
/// parameters.
#[derive(Clone, Debug)]
pub struct Problem<'a> {
    robot: &'a Robot,
    poses_rad: &'a [f64],
    points_mm: &'a [Vector3<f64>],
    weights: Option<&'a [f64]>,
    free: Vec<usize>,
    prior: Option<&'a crate::prior::PriorTerm>,
}

impl<'a> Problem<'a> {
    /// A problem with the start model `robot` (usually the nominal one), the poses (flat, row
    /// after row, `n_joints()` values each, radians), one measured point per pose (mm,
    /// measurement frame) and the free parameter indices (layout order is restored; duplicates
    /// are an error).
    pub fn new(
        robot: &'a Robot,
        poses_rad: &'a [f64],
        points_mm: &'a [Vector3<f64>],
        free: Vec<usize>,
    ) -> Result<Self, IdentifyError> {
        check_poses_and_points(robot, poses_rad, points_mm)?;
        for (j, p) in points_mm.iter().enumerate() {
            for (c, name) in ["x", "y", "z"].iter().enumerate() {
                if !p[c].is_finite() {
                    return Err(IdentifyError::NonFinite {
                        what: "measured point",
                        index: j,
                        detail: format!("{name} = {}", p[c]),
                    });
                }
            }
        }
        check_start(robot)?;
        let free = check_free(robot, free)?;
        check_counts(robot, poses_rad, free.len())?;
        Ok(Problem {
            robot,
            poses_rad,
            points_mm,
            weights: None,
            free,
            prior: None,
        })
    }

    /// [`Problem::new`] with the free set copied from a slice into a buffer of the thread's
    /// (given back when the problem is dropped: no allocation in the steady state, what a
    /// campaign's trial builds its problems with).
    pub fn from_slices(
        robot: &'a Robot,
        poses_rad: &'a [f64],
        points_mm: &'a [Vector3<f64>],
        free: &[usize],
    ) -> Result<Self, IdentifyError> {
        Problem::new(robot, poses_rad, points_mm, scratch::copy_indices(free))
    }

    /// The same problem with a Gaussian prior on the parameters (`crate::prior`: the cost
    /// gains `Σ λ_k (x_k − x0_k)²` over the free parameters; maximum a posteriori).
    ///
    /// # Errors
    /// [`IdentifyError::InvalidOption`] when the term is not one weight per parameter, or a
    /// weight or mean is not finite.
    pub fn with_prior(mut self, prior: &'a crate::prior::PriorTerm) -> Result<Self, IdentifyError> {
        let n = self.robot.n_params();
        if prior.mean.len() != n
            || prior.weight.len() != n
            || !prior.mean.iter().all(|v| v.is_finite())
            || !prior.weight.iter().all(|w| w.is_finite() && *w >= 0.0)
        {
            return Err(IdentifyError::InvalidOption {
                name: "prior",
                value: format!("{} means, {} weights", prior.mean.len(), prior.weight.len()),
                reason: "one finite mean and one finite non-negative weight per parameter",
            });
        }
        self.prior = Some(prior);
        Ok(self)
    }

    /// The prior, if any.
    pub fn prior(&self) -> Option<&'a crate::prior::PriorTerm> {
        self.prior
    }

    /// The same problem with per-row weights `w` (1/σ of each residual row; `3 × poses`
    /// values, rows x, y, z of pose 0 first). Weighting by 1/σ makes the cost a χ² and the
    /// estimate the maximum-likelihood one for independent Gaussian errors.
    pub fn with_weights(mut self, weights: &'a [f64]) -> Result<Self, IdentifyError> {
        check_weights(weights, 3 * self.n_poses())?;
        self.weights = Some(weights);
        Ok(self)
    }

    /// The start model.
    pub fn robot(&self) -> &'a Robot {
        self.robot
    }

    /// The poses, radians, flat.
    pub fn poses_rad(&self) -> &'a [f64] {
        self.poses_rad
    }

    /// The measured points, mm.
    pub fn points_mm(&self) -> &'a [Vector3<f64>] {
        self.points_mm
    }

    /// The per-row weights, if any.
    pub fn weights(&self) -> Option<&'a [f64]> {
        self.weights
    }

    /// Free parameter indices, in layout order.
    pub fn free(&self) -> &[usize] {
        &self.free
    }

    /// Names of the free parameters, in layout order.
    pub fn free_names(&self) -> Vec<ParamName> {
        let layout = self.robot.layout();
        self.free.iter().map(|&k| layout.get(k).name).collect()
    }

    /// Number of poses m.
    pub fn n_poses(&self) -> usize {
        self.points_mm.len()
    }

    /// Number of residual equations, 3m.
    pub fn n_equations(&self) -> usize {
        3 * self.n_poses()
    }

    /// The normal equations of the problem at its start model on the free parameters:
    /// `a = Jᵀ J` (P × P, resized if needed), `g = Jᵀ e`, with `J` the weighted Jacobian
    /// (3m × P) and `e` the weighted residual; returns the cost `‖e‖²`. This is what every
    /// accepted LM iteration assembles (exposed for benchmarks and tests).
    pub fn normal_equations(&self, a: &mut DMatrix<f64>, g: &mut DVector<f64>) -> f64 {
        let pf = self.free.len();
        if a.shape() != (pf, pf) {
            *a = DMatrix::zeros(pf, pf);
        }
        if g.len() != pf {
            *g = DVector::zeros(pf);
        }
        let trig = PoseTrig::for_robot(self.robot, self.poses_rad);
        let mut work = NormalWork::new(pf);
        let cost = work.assemble(self.robot, &trig, self.points_mm, self.weights, &self.free);
        work.copy_to(a, g);
        cost
    }

    /// [`Problem::normal_equations`] by the straightforward path (reference Jacobian
    /// [`Robot::point_jacobian_into`], unvectorised accumulation): what the fast path is
    /// tested against.
    pub fn normal_equations_reference(&self, a: &mut DMatrix<f64>, g: &mut DVector<f64>) -> f64 {
        let pf = self.free.len();
        if a.shape() != (pf, pf) {
            *a = DMatrix::zeros(pf, pf);
        }
        if g.len() != pf {
            *g = DVector::zeros(pf);
        }
        assemble_normal(
            self.robot,
            self.poses_rad,
            self.points_mm,
            self.weights,
            &self.free,
            a,
            g,
        )
    }

    /// The same data with a subset of the free parameters (validated indices, ascending).
    pub(crate) fn with_free(&self, free: Vec<usize>) -> Problem<'a> {
        debug_assert!(free.iter().all(|k| self.free.contains(k)));
        Problem {
            robot: self.robot,
            poses_rad: self.poses_rad,
            points_mm: self.points_mm,
            weights: self.weights,
            free,
            prior: self.prior,
        }
    }

    /// The same data with another start model (same layout, e.g. after registration).
    pub(crate) fn with_robot<'b>(&self, robot: &'b Robot) -> Problem<'b>
    where
        'a: 'b,
    {
        Problem {
            robot,
            poses_rad: self.poses_rad,
            points_mm: self.points_mm,
            weights: self.weights,
            free: scratch::copy_indices(&self.free),
            prior: self.prior,
        }
    }
}

impl Drop for Problem<'_> {
    /// The free set back to the thread's buffers (`crate::scratch`) for the next problem.
    fn drop(&mut self) {
        scratch::give_back_indices(std::mem::take(&mut self.free));
    }
}

/// Checks the pose buffer (shape, finiteness) and returns the number of poses.
pub(crate) fn check_poses(robot: &Robot, poses_rad: &[f64]) -> Result<usize, IdentifyError> {
    let n = robot.n_joints();
    if !poses_rad.len().is_multiple_of(n) {
        return Err(IdentifyError::PoseLength {
            len: poses_rad.len(),
            n_joints: n,
        });
    }
    let m = poses_rad.len() / n;
    if m == 0 {
        return Err(IdentifyError::NoPoses);
    }
    for (j, q) in poses_rad.chunks_exact(n).enumerate() {
        if let Some(i) = q.iter().position(|v| !v.is_finite()) {
            return Err(IdentifyError::NonFinite {
                what: "pose",
                index: j,
                detail: format!("q{} = {}", i + 1, q[i]),
            });
        }
    }
    Ok(m)
}

/// [`check_poses`], and one measured point per pose; returns the number of poses.
pub(crate) fn check_poses_and_points(
    robot: &Robot,
    poses_rad: &[f64],
    points_mm: &[Vector3<f64>],
) -> Result<usize, IdentifyError> {
    let m = check_poses(robot, poses_rad)?;
    if points_mm.len() != m {
        return Err(IdentifyError::PointCount {
            poses: m,
            points: points_mm.len(),
        });
    }
    Ok(m)
}

/// Checks that the start model's parameters are finite.
pub(crate) fn check_start(robot: &Robot) -> Result<(), IdentifyError> {
    if let Some(k) = (0..robot.n_params()).find(|&k| !robot.param(k).is_finite()) {
        return Err(IdentifyError::NonFinite {
            what: "start parameter",
            index: k,
            detail: format!("{} = {}", robot.layout().get(k).name, robot.param(k)),
        });
    }
    Ok(())
}

/// Validates free indices and returns them sorted.
pub(crate) fn check_free(robot: &Robot, mut free: Vec<usize>) -> Result<Vec<usize>, IdentifyError> {
    if free.is_empty() {
        return Err(IdentifyError::NoFreeParameters);
    }
    let np = robot.n_params();
    if let Some(&k) = free.iter().find(|&&k| k >= np) {
        return Err(IdentifyError::FreeIndex {
            index: k,
            n_params: np,
        });
    }
    free.sort_unstable();
    if let Some(w) = free.windows(2).find(|w| w[0] == w[1]) {
        return Err(IdentifyError::DuplicateFree {
            name: robot.layout().get(w[0]).name.to_string(),
        });
    }
    Ok(free)
}

/// Checks that the poses give at least as many equations as free parameters, counting
/// repeated poses once.
pub(crate) fn check_counts(
    robot: &Robot,
    poses_rad: &[f64],
    n_free: usize,
) -> Result<(), IdentifyError> {
    let n = robot.n_joints();
    let m = poses_rad.len() / n;
    let needed_poses = n_free.div_ceil(3);
    if 3 * m < n_free {
        return Err(IdentifyError::TooFewEquations {
            equations: 3 * m,
            poses: m,
            free: n_free,
            needed_poses,
        });
    }
    let distinct = count_distinct(poses_rad, n, SAME_POSE_TOL_RAD);
    if 3 * distinct < n_free {
        return Err(IdentifyError::TooFewDistinctPoses {
            distinct,
            poses: m,
            tol_rad: SAME_POSE_TOL_RAD,
            equations: 3 * distinct,
            free: n_free,
            needed_poses,
        });
    }
    Ok(())
}

/// Number of distinct poses (lexicographic sort, then neighbours closer than `tol` in every
/// joint are merged). O(m log m).
fn count_distinct(poses_rad: &[f64], n: usize, tol: f64) -> usize {
    let row = |j: usize| &poses_rad[j * n..(j + 1) * n];
    // The rows sorted lexicographically, by index (a buffer of the thread's pool).
    let mut order = crate::scratch::indices(poses_rad.len() / n);
    order.extend(0..poses_rad.len() / n);
    order.sort_by(|&a, &b| {
        row(a)
            .iter()
            .zip(row(b))
            .map(|(x, y)| x.total_cmp(y))
            .find(|o| o.is_ne())
            .unwrap_or(std::cmp::Ordering::Equal)
    });
    let mut distinct = usize::from(!order.is_empty());
    for w in order.windows(2) {
        if row(w[0])
            .iter()
            .zip(row(w[1]))
            .any(|(a, b)| (a - b).abs() > tol)
        {
            distinct += 1;
        }
    }
    crate::scratch::give_back_indices(order);
    distinct
}

/// Checks a weight vector.
pub(crate) fn check_weights(weights: &[f64], expected: usize) -> Result<(), IdentifyError> {
    if weights.len() != expected {
        return Err(IdentifyError::WeightCount {
            expected,
            found: weights.len(),
        });
    }
    if let Some(row) = weights.iter().position(|w| !(w.is_finite() && *w > 0.0)) {
        return Err(IdentifyError::BadWeight {
            row,
            value: weights[row],
        });
    }
    Ok(())
}

/// The three weights of pose `j` (ones when unweighted).
#[inline]
pub(crate) fn pose_weights(weights: Option<&[f64]>, j: usize) -> Vector3<f64> {
    match weights {
        Some(w) => Vector3::new(w[3 * j], w[3 * j + 1], w[3 * j + 2]),
        None => Vector3::new(1.0, 1.0, 1.0),
    }
}

/// Weighted residual sum of squares `Σ_j ‖w_j ∘ (p_j^meas − p(q_j))‖²` of `robot`.
pub(crate) fn weighted_rss(
    robot: &Robot,
    poses_rad: &[f64],
    points_mm: &[Vector3<f64>],
    weights: Option<&[f64]>,
) -> f64 {
    let n = robot.n_joints();
    poses_rad
        .chunks_exact(n)
        .zip(points_mm)
        .enumerate()
        .map(|(j, (q, meas))| {
            let e = (meas - robot.point(q)).component_mul(&pose_weights(weights, j));
            e.norm_squared()
        })
        .sum()
}

/// Weighted residual sum of squares from precomputed sines and cosines of the poses: the
/// same value as [`weighted_rss`], bit for bit ([`Robot::point_trig`] is [`Robot::point`]).
pub(crate) fn weighted_rss_trig(
    robot: &Robot,
    trig: &PoseTrig,
    points_mm: &[Vector3<f64>],
    weights: Option<&[f64]>,
) -> f64 {
    kinematics::simd::vectorised(
        #[inline(always)]
        || rss_impl(robot, trig, points_mm, weights),
    )
}

/// The points [`POSE_LANES`] at a time, the sum in pose order.
#[inline(always)]
fn rss_impl(
    robot: &Robot,
    trig: &PoseTrig,
    points_mm: &[Vector3<f64>],
    weights: Option<&[f64]>,
) -> f64 {
    let mut sum = 0.0;
    for block in 0..trig.n_blocks() {
        let p = robot.point_lanes(trig.lanes(block));
        group_residuals(&p, points_mm, weights, block, &mut sum);
    }
    sum
}

/// The weighted residuals `w ∘ (p_meas − p)` of pose group `grp` from its points' lanes `p`
/// (lane t: pose `8·grp + t`; zero in the lanes past the last pose), each pose's squared
/// norm added to `cost` in pose order. The one computation of the cost, for
/// [`weighted_rss_trig`] and [`NormalWork::assemble`], which must agree bit for bit.
#[inline(always)]
fn group_residuals(
    p: &[[f64; L]; 3],
    points_mm: &[Vector3<f64>],
    weights: Option<&[f64]>,
    grp: usize,
    cost: &mut f64,
) -> [[f64; L]; 3] {
    let first = grp * L;
    let mut e = [[0.0; L]; 3];
    for (t, meas) in points_mm[first..points_mm.len().min(first + L)]
        .iter()
        .enumerate()
    {
        let pt = Vector3::new(p[0][t], p[1][t], p[2][t]);
        let et = (meas - pt).component_mul(&pose_weights(weights, first + t));
        *cost += et.norm_squared();
        for r in 0..3 {
            e[r][t] = et[r];
        }
    }
    e
}

/// Poses whose blocks are computed together ([`Robot::point_jacobian_lanes`]), one per lane.
const L: usize = POSE_LANES;

/// `((v₀ + v₁) + (v₂ + v₃)) + ((v₄ + v₅) + (v₆ + v₇))`: the one fixed order in which the
/// lanes' partial sums are added (the same bits at any vector width).
#[inline(always)]
fn lane_sum(v: &[f64; L]) -> f64 {
    const { assert!(L == 8) };
    ((v[0] + v[1]) + (v[2] + v[3])) + ((v[4] + v[5]) + (v[6] + v[7]))
}

/// Buffers of [`NormalWork::assemble`]: the weighted Jacobian blocks and residuals of every
/// group of [`POSE_LANES`] poses, and the assembled system.
///
/// The blocks stay in the layout the kinematics kernel writes them in (pose t of a group in
/// lane t), so nothing is transposed. Every entry of `A = JᵀJ` and `g = Jᵀe` is summed lane
/// by lane over the groups (lane t adds the poses t, t + 8, t + 16, … in pose order, each
/// term `(x·x' + y·y') + z·z'`), then the eight lanes are added by [`lane_sum`]: element-wise
/// operations in one fixed order (no FMA), hence the same bits at every vector width.
pub(crate) struct NormalWork {
    pf: usize,
    /// `pf + 1` rounded up to a multiple of [`TILE`]: columns per group in `b`.
    pp: usize,
    /// Entry (k, l), k ≤ l, of `A` at `l(l+1)/2 + k` (packed upper triangle, column by
    /// column).
    a: Vec<f64>,
    g: Vec<f64>,
    /// Weighted blocks: `b[grp·pp + c][r][t]` = row r (x, y, z) of free column c at pose
    /// `8·grp + t`, and in column `pf` the weighted residuals; zero in the lanes past the
    /// last pose (zero weight: their terms are exact zeros, which leave every sum
    /// unchanged). `g` is thus column `pf` of the same product. Grows to the number of poses
    /// on first use. Columns 0..=pf are written by every assembly before they are read; the
    /// padding columns past `pf` hold whatever the buffer held (it is reused unzeroed), which
    /// reaches only tile entries that are never stored (each lane and entry is its own sum).
    b: Vec<[[f64; L]; 3]>,
}

/// Columns (and rows) of the tiles of `A` computed together by [`tile`] (in register blocks
/// whose shape depends on the vector width); `b` is padded to whole tiles.
const TILE: usize = 4;

thread_local! {
    /// Block buffers of dropped [`NormalWork`]s, reused by the next ones on the thread: a
    /// solve makes several, and a campaign thread runs thousands of solves, so this saves
    /// an allocation and the zeroing of some 40 KB per buffer (a large pose set's, tens of
    /// MB, is reused by its next solve). What they held never reaches a result (see the `b`
    /// field of [`NormalWork`]). The packed `A` and `g` go to [`crate::scratch`]'s pools.
    static BLOCK_POOL: Pool<Vec<[[f64; L]; 3]>> = const { Pool::new() };
}

/// Buffers kept in [`BLOCK_POOL`] per thread (a solve holds at most four at once: a normal
/// and a spare system on all free columns, and on the solved ones when some are held).
const POOL_SIZE: usize = 4;

impl Drop for NormalWork {
    fn drop(&mut self) {
        crate::scratch::give_back(std::mem::take(&mut self.a));
        crate::scratch::give_back(std::mem::take(&mut self.g));
        if self.b.capacity() > 0 {
            give_pooled(&BLOCK_POOL, POOL_SIZE, || std::mem::take(&mut self.b));
        }
    }
}

/// Index of entry (k, l), k ≤ l, in the packed upper triangle.
#[inline(always)]
fn tri(k: usize, l: usize) -> usize {
    debug_assert!(k <= l);
    l * (l + 1) / 2 + k
}

impl NormalWork {
    /// Buffers for `pf` free parameters (the block buffer from this thread's pool).
    pub(crate) fn new(pf: usize) -> Self {
        NormalWork {
            pf,
            pp: (pf + 1).div_ceil(TILE) * TILE,
            a: crate::scratch::zeros(pf * (pf + 1) / 2),
            g: crate::scratch::zeros(pf),
            b: take_pooled(&BLOCK_POOL).unwrap_or_default(),
        }
    }

    /// [`assemble_normal`] from precomputed sines and cosines of the poses, vectorised at
    /// the run-time [`simd_level`] (all levels give identical bits). Returns the cost; the
    /// system stays in `self` ([`NormalWork::copy_to`]).
    pub(crate) fn assemble(
        &mut self,
        robot: &Robot,
        trig: &PoseTrig,
        points_mm: &[Vector3<f64>],
        weights: Option<&[f64]>,
        free: &[usize],
    ) -> f64 {
        self.dispatch(robot, trig, points_mm, weights, free, None)
    }

    /// [`NormalWork::assemble`] that also writes the stacked weighted Jacobian
    /// `diag(w)·∂p/∂x_free` (3m × P) into `jac`.
    pub(crate) fn assemble_stacked(
        &mut self,
        robot: &Robot,
        trig: &PoseTrig,
        points_mm: &[Vector3<f64>],
        weights: Option<&[f64]>,
        free: &[usize],
        jac: &mut DMatrix<f64>,
    ) -> f64 {
        assert_eq!(
            jac.shape(),
            (3 * points_mm.len(), free.len()),
            "Jacobian shape"
        );
        self.dispatch(
            robot,
            trig,
            points_mm,
            weights,
            free,
            Some(jac.as_mut_slice()),
        )
    }

    fn dispatch(
        &mut self,
        robot: &Robot,
        trig: &PoseTrig,
        points_mm: &[Vector3<f64>],
        weights: Option<&[f64]>,
        free: &[usize],
        stack: Option<&mut [f64]>,
    ) -> f64 {
        debug_assert_eq!(free.len(), self.pf);
        let groups = trig.n_blocks();
        if self.b.len() < groups * self.pp {
            self.b.resize(groups * self.pp, [[0.0; L]; 3]);
        }
        kinematics::simd::vectorised(
            #[inline(always)]
            || self.assemble_impl(robot, trig, points_mm, weights, free, stack),
        )
    }

    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    fn assemble_impl(
        &mut self,
        robot: &Robot,
        trig: &PoseTrig,
        points_mm: &[Vector3<f64>],
        weights: Option<&[f64]>,
        free: &[usize],
        mut stack: Option<&mut [f64]>,
    ) -> f64 {
        let (pf, pp) = (self.pf, self.pp);
        let mut cost = 0.0;
        let m = points_mm.len();
        let groups = trig.n_blocks();
        let slot = free_slots(robot, free);
        for grp in 0..groups {
            let first = grp * L;
            let count = L.min(m - first);
            let blocks = &mut self.b[grp * pp..(grp + 1) * pp];
            let p = weighted_blocks(robot, trig, grp, &slot, weights, &mut blocks[..pf]);
            // The weighted residuals go into the block after the last free column.
            blocks[pf] = group_residuals(&p, points_mm, weights, grp, &mut cost);
            if let Some(st) = stack.as_deref_mut() {
                scatter_stacked(&blocks[..pf], first, count, 3 * m, st);
            }
        }
        products(&self.b[..groups * pp], pp, pf, &mut self.a, &mut self.g);
        cost
    }

    /// The stacked weighted Jacobian `diag(w)·∂p/∂x_free` (3m × P) alone, into `jac`, from
    /// the pose-parallel kernel (the values [`NormalWork::assemble_stacked`] writes).
    pub(crate) fn stacked_jacobian(
        robot: &Robot,
        trig: &PoseTrig,
        weights: Option<&[f64]>,
        free: &[usize],
        jac: &mut DMatrix<f64>,
    ) {
        let m = trig.n_poses();
        assert_eq!(jac.shape(), (3 * m, free.len()), "Jacobian shape");
        let slot = free_slots(robot, free);
        let mut blocks = vec![[[0.0; L]; 3]; free.len()];
        for grp in 0..trig.n_blocks() {
            let first = grp * L;
            weighted_blocks(robot, trig, grp, &slot, weights, &mut blocks);
            scatter_stacked(&blocks, first, L.min(m - first), 3 * m, jac.as_mut_slice());
        }
    }

    /// The assembled system column-scaled, as [`NormalWork::copy_to`] followed by
    /// `a_kl·s_k·s_l` would give it, bit for bit (`(s_k·a_kl)·s_l` in both triangles, so the
    /// result may differ from symmetric in the last bit, exactly as the two-step way):
    /// `sa` column-major P × P, `sg_l = s_l·g_l`.
    pub(crate) fn scaled_to(&self, s: &[f64], sa: &mut [f64], sg: &mut [f64]) {
        let pf = self.pf;
        debug_assert!(s.len() == pf && sa.len() == pf * pf && sg.len() == pf);
        // Packed column l (contiguous) gives column l of the upper triangle and, mirrored,
        // row l of the lower one.
        for l in 0..pf {
            let sl = s[l];
            let packed = &self.a[tri(0, l)..tri(0, l) + l + 1];
            for ((d, v), sk) in sa[l * pf..l * pf + l + 1].iter_mut().zip(packed).zip(s) {
                *d = sk * v * sl;
            }
            for (k, (v, sk)) in packed[..l].iter().zip(s).enumerate() {
                sa[k * pf + l] = sl * v * sk;
            }
            sg[l] = sl * self.g[l];
        }
    }

    /// The assembled system as a full symmetric `a` (P × P) and `g`.
    pub(crate) fn copy_to(&self, a: &mut DMatrix<f64>, g: &mut DVector<f64>) {
        let pf = self.pf;
        debug_assert_eq!(a.shape(), (pf, pf));
        for l in 0..pf {
            for k in 0..=l {
                let v = self.a[tri(k, l)];
                a[(k, l)] = v;
                a[(l, k)] = v;
            }
            g[l] = self.g[l];
        }
    }
}

/// Where [`weighted_blocks`] puts each parameter's column: its position among the free
/// ones, or nowhere (`usize::MAX`).
///
/// Panics unless the free indices are distinct and below `n_params()`: every free column
/// must be written, since the block buffers are reused unzeroed.
fn free_slots(robot: &Robot, free: &[usize]) -> [usize; MAX_PARAMS] {
    let np = robot.n_params();
    let mut slot = [usize::MAX; MAX_PARAMS];
    for (c, &k) in free.iter().enumerate() {
        assert!(
            k < np && slot[k] == usize::MAX,
            "free parameter indices must be distinct and below n_params"
        );
        slot[k] = c;
    }
    slot
}

/// The weighted blocks of the free columns of pose group `grp` into `blocks` (one per free
/// column, `slot` from [`free_slots`]): `blocks[c][r][t] = w[r][t]·∂p_r/∂x_c` of pose
/// `8·grp + t`, zero in the lanes past the last pose. Returns the points' lanes.
/// Unweighted, the factors would be 1 (exact), so only the lanes past the last pose are
/// cleared.
#[inline(always)]
fn weighted_blocks(
    robot: &Robot,
    trig: &PoseTrig,
    grp: usize,
    slot: &[usize; MAX_PARAMS],
    weights: Option<&[f64]>,
    blocks: &mut [[[f64; L]; 3]],
) -> [[f64; L]; 3] {
    let first = grp * L;
    let count = L.min(trig.n_poses() - first);
    let p = robot.point_jacobian_lanes_to(trig.lanes(grp), &slot[..robot.n_params()], blocks);
    if weights.is_some() {
        // w[r][t]: the weight of row r of pose t (zero past the last pose).
        let mut w = [[0.0; L]; 3];
        for (r, wr) in w.iter_mut().enumerate() {
            for (t, v) in wr[..count].iter_mut().enumerate() {
                *v = pose_weights(weights, first + t)[r];
            }
        }
        for bc in blocks.iter_mut() {
            let v = *bc;
            *bc = std::array::from_fn(|r| std::array::from_fn(|t| v[r][t] * w[r][t]));
        }
    } else if count < L {
        for bc in blocks.iter_mut() {
            for row in bc.iter_mut() {
                row[count..].fill(0.0);
            }
        }
    }
    p
}

/// The `count` live poses of a group's blocks (first pose `first`) into the stacked
/// column-major Jacobian `st` (`rows` = 3m rows, one column per block).
#[inline(always)]
fn scatter_stacked(
    blocks: &[[[f64; L]; 3]],
    first: usize,
    count: usize,
    rows: usize,
    st: &mut [f64],
) {
    for (col, bc) in st.chunks_exact_mut(rows).zip(blocks) {
        for t in 0..count {
            for r in 0..3 {
                col[3 * (first + t) + r] = bc[r][t];
            }
        }
    }
}

/// Every entry of `A` (packed upper triangle) and `g` from the blocks `b` (`pp` per group),
/// at the run-time SIMD level (all levels give identical bits). Each level's function is
/// kept out of line, apart from the kinematics of [`NormalWork::assemble`], so that its code
/// does not depend on how that was inlined and vectorised.
#[inline(always)]
fn products(b: &[[[f64; L]; 3]], pp: usize, pf: usize, a: &mut [f64], g: &mut [f64]) {
    match simd_level() {
        #[cfg(target_arch = "x86_64")]
        // SAFETY: simd_level() never returns a level the CPU does not support.
        SimdLevel::Avx512 => unsafe { products_avx512(b, pp, pf, a, g) },
        #[cfg(target_arch = "x86_64")]
        // SAFETY: as above.
        SimdLevel::Avx2 => unsafe { products_avx2(b, pp, pf, a, g) },
        _ => products_portable(b, pp, pf, a, g),
    }
}

/// [`products`] with AVX-512: the [`tile`]s computed in one register block of 4 × 4
/// entries of 8 lanes (16 of the 32 registers), the lane sums of each tile's 16 entries
/// added as vectors ([`lane_sums8_avx512`]), column by column, so that a tile wholly inside
/// the triangle is stored as four runs of the packed columns; diagonal tiles compute only
/// their upper 10 entries ([`diagonal_tile_avx512`]). The same operations in the same order
/// as [`tile`] and [`lane_sum`], written with intrinsics: left to the compiler, a
/// `-C target-cpu=native` build on Zen 5 turned the loop into gathers and ran the LM solve
/// 2.3× slower. (Storing entry by entry and computing whole diagonal tiles made the
/// benchmark's LM solve 2.7 µs slower, 42.2 µs against 39.6 µs.)
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
#[inline(never)]
fn products_avx512(b: &[[[f64; L]; 3]], pp: usize, pf: usize, a: &mut [f64], g: &mut [f64]) {
    use std::arch::x86_64::{
        _mm256_storeu_pd, _mm512_add_pd, _mm512_castpd512_pd256, _mm512_extractf64x4_pd,
        _mm512_setzero_pd, _mm512_storeu_pd,
    };
    let groups = b.len() / pp;
    for l0 in (0..=pf).step_by(TILE) {
        for k0 in (0..=l0).step_by(TILE) {
            if k0 == l0 && l0 + TILE <= pf {
                diagonal_tile_avx512(b, pp, k0, a);
                continue;
            }
            let mut acc = [[_mm512_setzero_pd(); TILE]; TILE];
            for grp in 0..groups {
                let blocks = &b[grp * pp..(grp + 1) * pp];
                let vk = columns_avx512(blocks, k0);
                let vl = columns_avx512(blocks, l0);
                for (ai, ki) in acc.iter_mut().zip(&vk) {
                    for (aij, lj) in ai.iter_mut().zip(&vl) {
                        *aij = _mm512_add_pd(*aij, term_avx512(ki, lj));
                    }
                }
            }
            // The sums column by column: lane 4j + i of `left` is entry (i, j), of `right`
            // entry (i, 2 + j).
            let left = lane_sums8_avx512([
                acc[0][0], acc[1][0], acc[2][0], acc[3][0], acc[0][1], acc[1][1], acc[2][1],
                acc[3][1],
            ]);
            let right = lane_sums8_avx512([
                acc[0][2], acc[1][2], acc[2][2], acc[3][2], acc[0][3], acc[1][3], acc[2][3],
                acc[3][3],
            ]);
            if k0 + TILE <= l0 && l0 + TILE <= pf {
                // Wholly above the diagonal and left of `g`: the tile's four columns are
                // contiguous runs of the packed triangle.
                let columns = [
                    _mm512_castpd512_pd256(left),
                    _mm512_extractf64x4_pd::<1>(left),
                    _mm512_castpd512_pd256(right),
                    _mm512_extractf64x4_pd::<1>(right),
                ];
                for (j, column) in columns.into_iter().enumerate() {
                    let at = tri(k0, l0 + j);
                    let dst = &mut a[at..at + TILE];
                    // SAFETY: `dst` holds TILE = 4 doubles.
                    unsafe { _mm256_storeu_pd(dst.as_mut_ptr(), column) };
                }
            } else {
                let mut by_column = [0.0; TILE * TILE];
                // SAFETY: `by_column` holds 16 doubles.
                unsafe {
                    _mm512_storeu_pd(by_column.as_mut_ptr(), left);
                    _mm512_storeu_pd(by_column.as_mut_ptr().add(8), right);
                }
                let sums = std::array::from_fn(|e| by_column[(e % TILE) * TILE + e / TILE]);
                store_tile(a, g, pf, k0, l0, &sums);
            }
        }
    }
}

/// A diagonal tile of [`products_avx512`] left of `g`: only its 10 entries on or above the
/// diagonal, from the 4 columns loaded once, each by the same operations in the same order
/// as there. In column order they are the packed triangle's runs of 1, 2, 3 and 4 entries
/// from `tri(k0, k0 + j)`.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
#[inline]
fn diagonal_tile_avx512(b: &[[[f64; L]; 3]], pp: usize, k0: usize, a: &mut [f64]) {
    use std::arch::x86_64::{_mm512_add_pd, _mm512_setzero_pd, _mm512_storeu_pd};
    /// (row, column) of the entries on or above the diagonal, column by column.
    const UPPER: [(usize, usize); 10] = [
        (0, 0),
        (0, 1),
        (1, 1),
        (0, 2),
        (1, 2),
        (2, 2),
        (0, 3),
        (1, 3),
        (2, 3),
        (3, 3),
    ];
    let mut acc = [_mm512_setzero_pd(); 16];
    for blocks in b.chunks_exact(pp) {
        let v = columns_avx512(blocks, k0);
        for (s, &(i, j)) in acc.iter_mut().zip(&UPPER) {
            *s = _mm512_add_pd(*s, term_avx512(&v[i], &v[j]));
        }
    }
    let mut sums = [0.0; 16];
    let (lo, hi) = acc.split_at(8);
    // SAFETY: `sums` holds 16 doubles.
    unsafe {
        _mm512_storeu_pd(
            sums.as_mut_ptr(),
            lane_sums8_avx512(lo.try_into().expect("8")),
        );
        _mm512_storeu_pd(
            sums.as_mut_ptr().add(8),
            lane_sums8_avx512(hi.try_into().expect("8")),
        );
    }
    for j in 0..TILE {
        let (at, from) = (tri(k0, k0 + j), j * (j + 1) / 2);
        a[at..at + j + 1].copy_from_slice(&sums[from..from + j + 1]);
    }
}

/// Rows x, y, z of the [`TILE`] columns `c0..c0 + TILE` of one group's `blocks`, as
/// vectors of the group's 8 poses.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
#[inline]
fn columns_avx512(blocks: &[[[f64; L]; 3]], c0: usize) -> [[std::arch::x86_64::__m512d; 3]; TILE] {
    use std::arch::x86_64::{_mm512_loadu_pd, _mm512_setzero_pd};
    let columns: &[[[f64; L]; 3]; TILE] = blocks[c0..c0 + TILE].try_into().expect("columns");
    // (Loops, not `array::map`: the closures were not inlined and ran the solve 4× slower.)
    let mut v = [[_mm512_setzero_pd(); 3]; TILE];
    for (vc, column) in v.iter_mut().zip(columns) {
        for (vr, row) in vc.iter_mut().zip(column) {
            // SAFETY: each row holds L = 8 doubles.
            *vr = unsafe { _mm512_loadu_pd(row.as_ptr()) };
        }
    }
    v
}

/// One pose's term of an entry, lane by lane, in the documented order:
/// `(x_k·x_l + y_k·y_l) + z_k·z_l`.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
#[inline]
fn term_avx512(
    k: &[std::arch::x86_64::__m512d; 3],
    l: &[std::arch::x86_64::__m512d; 3],
) -> std::arch::x86_64::__m512d {
    use std::arch::x86_64::{_mm512_add_pd, _mm512_mul_pd};
    let xy = _mm512_add_pd(_mm512_mul_pd(k[0], l[0]), _mm512_mul_pd(k[1], l[1]));
    _mm512_add_pd(xy, _mm512_mul_pd(k[2], l[2]))
}

/// The [`lane_sum`]s of eight vectors at once (lane t of the result is vector t's): the
/// same additions in the same tree, as three levels of pairwise sums of neighbouring lanes
/// (two shuffles and one vector addition each), 7 vector additions instead of 56 scalar
/// ones.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
#[inline]
fn lane_sums8_avx512(x: [std::arch::x86_64::__m512d; 8]) -> std::arch::x86_64::__m512d {
    let s01 = pair_sums_avx512(x[0], x[1]);
    let s23 = pair_sums_avx512(x[2], x[3]);
    let s45 = pair_sums_avx512(x[4], x[5]);
    let s67 = pair_sums_avx512(x[6], x[7]);
    pair_sums_avx512(pair_sums_avx512(s01, s23), pair_sums_avx512(s45, s67))
}

/// `[a₀+a₁, a₂+a₃, a₄+a₅, a₆+a₇, b₀+b₁, b₂+b₃, b₄+b₅, b₆+b₇]`.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
#[inline]
fn pair_sums_avx512(
    a: std::arch::x86_64::__m512d,
    b: std::arch::x86_64::__m512d,
) -> std::arch::x86_64::__m512d {
    use std::arch::x86_64::{_mm512_add_pd, _mm512_permutex2var_pd, _mm512_setr_epi64};
    let even = _mm512_setr_epi64(0, 2, 4, 6, 8, 10, 12, 14);
    let odd = _mm512_setr_epi64(1, 3, 5, 7, 9, 11, 13, 15);
    _mm512_add_pd(
        _mm512_permutex2var_pd(a, even, b),
        _mm512_permutex2var_pd(a, odd, b),
    )
}

/// [`products`] with AVX2: register blocks of 2 × 2 entries of 4 lanes (16 registers).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline(never)]
fn products_avx2(b: &[[[f64; L]; 3]], pp: usize, pf: usize, a: &mut [f64], g: &mut [f64]) {
    products_tiled::<2, 2, 4>(b, pp, pf, a, g)
}

/// [`products`] on the baseline build: register blocks of 2 × 2 entries of 2 lanes (SSE2's
/// 16 registers).
#[inline(never)]
fn products_portable(b: &[[[f64; L]; 3]], pp: usize, pf: usize, a: &mut [f64], g: &mut [f64]) {
    products_tiled::<2, 2, 2>(b, pp, pf, a, g)
}

/// The tiles of `A` and `g` on or above the diagonal, by [`tile`] in register blocks
/// K × C × W (the fastest shapes tried at each width; the shape changes no bit) and
/// [`lane_sum`] per entry. (Storing the tiles inside the triangle as runs of the packed
/// columns, as [`products_avx512`] does, made the AVX2 build slower.)
#[inline(always)]
fn products_tiled<const K: usize, const C: usize, const W: usize>(
    b: &[[[f64; L]; 3]],
    pp: usize,
    pf: usize,
    a: &mut [f64],
    g: &mut [f64],
) {
    for l0 in (0..=pf).step_by(TILE) {
        for k0 in (0..=l0).step_by(TILE) {
            let tile = tile::<K, C, W>(b, pp, k0, l0);
            let sums = std::array::from_fn(|e| lane_sum(&tile[e / TILE][e % TILE]));
            store_tile(a, g, pf, k0, l0, &sums);
        }
    }
}

/// The lane sums of the [`TILE`] × [`TILE`] entries (k0 + i, l0 + j) of `A` (column `pf`:
/// of `g`): over the groups of `b` (`pp` blocks each), lane by lane,
/// `(x_k·x_l + y_k·y_l) + z_k·z_l` added in group order to a sum starting at zero. Computed
/// in register blocks of K × C entries and W lanes (each block loaded serves C or K entries,
/// and the K·C·W sums are independent accumulation chains); the lanes are independent, so
/// the shape changes no bit. On a diagonal tile (k0 = l0) the register blocks wholly below
/// the diagonal are skipped (their entries stay zero).
#[inline(always)]
fn tile<const K: usize, const C: usize, const W: usize>(
    b: &[[[f64; L]; 3]],
    pp: usize,
    k0: usize,
    l0: usize,
) -> Tile {
    let mut out = [[[0.0; L]; TILE]; TILE];
    for kk in (0..TILE).step_by(K) {
        for jj in (0..TILE).step_by(C) {
            if k0 == l0 && kk >= jj + C {
                // Wholly below the diagonal of a diagonal tile: never stored.
                continue;
            }
            for lane0 in (0..L).step_by(W) {
                let mut acc = [[[0.0; W]; C]; K];
                for blocks in b.chunks_exact(pp) {
                    let bk: &[[[f64; L]; 3]; K] =
                        blocks[k0 + kk..k0 + kk + K].try_into().expect("rows");
                    let bl: &[[[f64; L]; 3]; C] =
                        blocks[l0 + jj..l0 + jj + C].try_into().expect("columns");
                    for (ai, bki) in acc.iter_mut().zip(bk) {
                        for (aij, blj) in ai.iter_mut().zip(bl) {
                            for (t, v) in aij.iter_mut().enumerate() {
                                let u = lane0 + t;
                                *v += bki[0][u] * blj[0][u]
                                    + bki[1][u] * blj[1][u]
                                    + bki[2][u] * blj[2][u];
                            }
                        }
                    }
                }
                for (i, ai) in acc.iter().enumerate() {
                    for (j, aij) in ai.iter().enumerate() {
                        out[kk + i][jj + j][lane0..lane0 + W].copy_from_slice(aij);
                    }
                }
            }
        }
    }
    out
}

/// A [`tile`]'s per-lane sums: [`TILE`] × [`TILE`] entries of [`L`] lanes.
type Tile = [[[f64; L]; TILE]; TILE];

/// Stores the lane `sums` of a [`tile`] at (k0, l0) of a `pf`-column system (row by row):
/// the entries on or above the diagonal into the packed triangle `a`, those of column `pf`
/// (the residuals' column) into `g`.
#[inline(always)]
fn store_tile(
    a: &mut [f64],
    g: &mut [f64],
    pf: usize,
    k0: usize,
    l0: usize,
    sums: &[f64; TILE * TILE],
) {
    for (e, &sum) in sums.iter().enumerate() {
        let (k, l) = (k0 + e / TILE, l0 + e % TILE);
        if k <= l && l < pf {
            a[tri(k, l)] = sum;
        } else if l == pf && k < pf {
            g[k] = sum;
        }
    }
}

/// Assembles the normal equations on the free parameters at `robot`:
/// `A = Σ_j B_jᵀ B_j`, `g = Σ_j B_jᵀ e_j`, with `B_j = diag(w_j) · ∂p(q_j)/∂x_free` (3 × P)
/// and `e_j = w_j ∘ (p_j^meas − p(q_j))`; returns the cost `Σ_j ‖e_j‖²`.
///
/// `a` must be P × P and `g` of length P. Accumulates per pose from
/// [`Robot::point_jacobian_into`] into the upper triangle, then mirrors it; no heap
/// allocation.
pub(crate) fn assemble_normal(
    robot: &Robot,
    poses_rad: &[f64],
    points_mm: &[Vector3<f64>],
    weights: Option<&[f64]>,
    free: &[usize],
    a: &mut DMatrix<f64>,
    g: &mut DVector<f64>,
) -> f64 {
    let n = robot.n_joints();
    let np = robot.n_params();
    let pf = free.len();
    debug_assert_eq!(a.shape(), (pf, pf));
    debug_assert_eq!(g.len(), pf);
    a.fill(0.0);
    g.fill(0.0);
    let mut cols = [Vector3::zeros(); MAX_PARAMS];
    // The pose's 3 × P block, one row per array (contiguous, so the rank-3 update below
    // vectorises).
    let (mut bx, mut by, mut bz) = ([0.0; MAX_PARAMS], [0.0; MAX_PARAMS], [0.0; MAX_PARAMS]);
    let mut cost = 0.0;
    let a_data = a.as_mut_slice();
    let g_data = g.as_mut_slice();
    for (j, (q, meas)) in poses_rad.chunks_exact(n).zip(points_mm).enumerate() {
        let p = robot.point_jacobian_into(q, &mut cols[..np]);
        let w = pose_weights(weights, j);
        let e = (meas - p).component_mul(&w);
        cost += e.norm_squared();
        for (c, &k) in free.iter().enumerate() {
            bx[c] = cols[k].x * w.x;
            by[c] = cols[k].y * w.y;
            bz[c] = cols[k].z * w.z;
        }
        let (bx, by, bz) = (&bx[..pf], &by[..pf], &bz[..pf]);
        for (gk, ((x, y), z)) in g_data.iter_mut().zip(bx.iter().zip(by).zip(bz)) {
            *gk += x * e.x + y * e.y + z * e.z;
        }
        // Upper triangle, column-major: entry (k, l), k ≤ l, lives at l·P + k.
        for l in 0..pf {
            let (xl, yl, zl) = (bx[l], by[l], bz[l]);
            let col = &mut a_data[l * pf..l * pf + l + 1];
            for (akl, ((x, y), z)) in col.iter_mut().zip(bx.iter().zip(by).zip(bz)) {
                *akl += x * xl + y * yl + z * zl;
            }
        }
    }
    for l in 0..pf {
        for k in 0..l {
            a[(l, k)] = a[(k, l)];
        }
    }
    cost
}

/// The stacked weighted Jacobian `diag(w) · ∂p/∂x_free` (3m × P) at `robot`.
pub(crate) fn weighted_jacobian(
    robot: &Robot,
    poses_rad: &[f64],
    weights: Option<&[f64]>,
    free: &[usize],
) -> DMatrix<f64> {
    let n = robot.n_joints();
    let np = robot.n_params();
    let m = poses_rad.len() / n;
    let mut jac = DMatrix::zeros(3 * m, free.len());
    let mut cols = [Vector3::zeros(); MAX_PARAMS];
    for (j, q) in poses_rad.chunks_exact(n).enumerate() {
        robot.point_jacobian_into(q, &mut cols[..np]);
        let w = pose_weights(weights, j);
        for (c, &k) in free.iter().enumerate() {
            let v = cols[k].component_mul(&w);
            jac[(3 * j, c)] = v.x;
            jac[(3 * j + 1, c)] = v.y;
            jac[(3 * j + 2, c)] = v.z;
        }
    }
    jac
}

#[cfg(test)]
mod tests {
    use super::*;

    type Products = fn(&[[[f64; L]; 3]], usize, usize, &mut [f64], &mut [f64]);

    /// The products by intrinsics (AVX-512) and by the compiler (AVX2, portable) give the
    /// same bits, and each entry is the scalar sum in the documented order: lane by lane
    /// over the groups, `(x·x' + y·y') + z·z'`, then [`lane_sum`].
    #[test]
    fn products_are_the_documented_sums_at_every_width() {
        // (pf = 8 and 12: off-diagonal tiles ending right at the residuals' column.)
        for pf in [1usize, 3, 4, 7, 8, 12, 27, 34] {
            let pp = (pf + 1).div_ceil(TILE) * TILE;
            let groups = 3;
            // Values of mixed magnitude and sign, so that any other order of the additions
            // changes some bits; NaN in the padding columns past `pf`, which hold whatever
            // the reused buffer held and must reach no stored entry.
            let b: Vec<[[f64; L]; 3]> = (0..groups * pp)
                .map(|c| {
                    std::array::from_fn(|r| {
                        std::array::from_fn(|t| {
                            let x = ((c * 24 + r * 8 + t) as f64 * 0.618).sin();
                            if c % pp > pf {
                                f64::NAN
                            } else {
                                x * 10f64.powi(((c + 2 * t) % 7) as i32 - 3)
                            }
                        })
                    })
                })
                .collect();
            let expect = |k: usize, l: usize| {
                let lanes: [f64; L] = std::array::from_fn(|t| {
                    let mut v = 0.0;
                    for grp in 0..groups {
                        let (x, y) = (&b[grp * pp + k], &b[grp * pp + l]);
                        v += x[0][t] * y[0][t] + x[1][t] * y[1][t] + x[2][t] * y[2][t];
                    }
                    v
                });
                lane_sum(&lanes)
            };
            let mut runs: Vec<(&str, Products)> = vec![("portable", products_portable)];
            #[cfg(target_arch = "x86_64")]
            {
                use kinematics::simd::SimdLevel;
                let level = SimdLevel::detect();
                if level >= SimdLevel::Avx2 {
                    // SAFETY: the CPU has AVX2.
                    runs.push(("avx2", |b, pp, pf, a, g| unsafe {
                        products_avx2(b, pp, pf, a, g)
                    }));
                }
                if level >= SimdLevel::Avx512 {
                    // SAFETY: the CPU has AVX-512.
                    runs.push(("avx512", |b, pp, pf, a, g| unsafe {
                        products_avx512(b, pp, pf, a, g)
                    }));
                }
            }
            for (name, run) in runs {
                let mut a = vec![f64::NAN; pf * (pf + 1) / 2];
                let mut g = vec![f64::NAN; pf];
                run(&b, pp, pf, &mut a, &mut g);
                for l in 0..pf {
                    for k in 0..=l {
                        assert_eq!(
                            a[tri(k, l)].to_bits(),
                            expect(k, l).to_bits(),
                            "{name} {pf} ({k}, {l})"
                        );
                    }
                    assert_eq!(g[l].to_bits(), expect(l, pf).to_bits(), "{name} {pf} g {l}");
                }
            }
        }
    }
}
