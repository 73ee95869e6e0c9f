//! The fast kernels behind [`Robot::point`], [`Robot::flange`], [`Robot::frames_into`] and
//! the batch Jacobian.
//!
//! The straightforward implementation composes one 4×4-like [`Frame`] per link
//! (`Rz(θ+q)·Rx(α)·Ry(β)` as a 3×3 product, with `sin_cos(θ+q)` every time). These kernels
//! compute the same quantities with less arithmetic:
//!
//! - **sin/cos once per pose**: `sin(θ+q)`, `cos(θ+q)` come from the sines and cosines of q
//!   (computed once per pose, [`PoseTrig`]) and of θ (cached per parameter vector) by the
//!   angle-addition formulas, so an identification that evaluates the same poses at ten
//!   parameter vectors computes them once per joint and pose instead of twenty times.
//!   The sines and cosines themselves come eight at a time from [`crate::trig`].
//! - **poses in lanes**: [`Robot::point_lanes`] and [`Robot::point_jacobian_lanes`] run
//!   [`POSE_LANES`] poses through the same code, one per vector lane; the one-pose methods
//!   are the same generic code with one lane, so both give the same bits.
//! - **the point backwards**: `p = T_base(T_1(…(T_N t)))` applied to a vector from the tool
//!   inwards is three plane rotations per link (12 multiplications) instead of a 3×3 matrix
//!   product (27).
//! - **frames forwards by column mixing**: `R·Rz(t)`, `·Rx(α)`, `·Ry(β)` each mix two
//!   columns of R; the mixed columns are exactly the axes the identification Jacobian needs
//!   (`x'_i`, `y'_i`), so the chain is walked once for the point, the frames and the
//!   Jacobian. `Ry(β)` is skipped where β is exactly zero (no rounding change: sin β = 0,
//!   cos β = 1).
//!
//! [`Robot::flange_reference`], [`Robot::point_reference`] and
//! [`Robot::point_jacobian_into`] keep the straightforward composition as the reference;
//! the tests hold these kernels to it within 1e-12 relative.

use nalgebra::Vector3;

use super::{Link, PRISMATIC_SLOT, Robot, prismatic_mm};
use crate::frame::Frame;
use crate::kept::{Kept, Pool, give_pooled, take_pooled, with_kept};
use crate::model::MAX_JOINTS;
use crate::trig::{sin_cos_slice, sin_cos_small_lanes};

/// Sines and cosines of the joint values of a pose set, `[sin q, cos q]` per joint, pose
/// after pose, and the same in blocks of [`POSE_LANES`] poses for the pose-parallel kernels.
/// Build it once for poses that are evaluated at many parameter vectors (an identification,
/// an error scaling) and pass [`PoseTrig::pose`] to the `*_trig` methods of [`Robot`] or
/// [`PoseTrig::lanes`] to the `*_lanes` ones.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PoseTrig {
    n_joints: usize,
    sc: Vec<[f64; 2]>,
    /// Block b, joint i at `b·n_joints + i`: sin q_i of the block's poses (the last block is
    /// padded with copies of the last pose).
    lane_sin: Vec<[f64; POSE_LANES]>,
    lane_cos: Vec<[f64; POSE_LANES]>,
    /// Weights per pose of the extended robot this was built for ([`PoseTrig::for_robot`]):
    /// none for a geometric one.
    n_ext: usize,
    /// Block b, parameter k at `b·n_ext + k`: the weights `w_k(q)` of the block's poses
    /// (padded as `lane_sin`).
    lane_w: Vec<[f64; POSE_LANES]>,
    /// The fingerprint of the extended model the weights belong to (0: none).
    weights_of: u64,
}

/// One block of [`POSE_LANES`] poses for the pose-parallel kernels ([`PoseTrig::lanes`]):
/// lane t holds pose `block·POSE_LANES + t`.
#[derive(Clone, Copy, Debug)]
pub struct PoseLanes<'a> {
    /// `sin q_i` per lane, one entry per joint.
    pub sin_q: &'a [[f64; POSE_LANES]],
    /// `cos q_i` per lane, one entry per joint.
    pub cos_q: &'a [[f64; POSE_LANES]],
    /// The weights `w_k(q)` of an extended robot's parameters per lane, one entry per
    /// parameter ([`crate::ExtendedModel::weights`]); empty for a geometric robot.
    pub weights: &'a [[f64; POSE_LANES]],
    /// Which weights these are: the fingerprint of the extended model (parameters, mass
    /// model, torque geometry) they were computed for; 0 without weights. The kernels refuse
    /// weights of another model.
    pub weights_of: u64,
}

impl PoseTrig {
    /// The sines and cosines of `poses_rad` (flat, `n_joints` values per pose).
    ///
    /// Panics if `n_joints` is zero or does not divide the buffer (a programming error).
    pub fn new(n_joints: usize, poses_rad: &[f64]) -> Self {
        assert!(
            n_joints > 0 && poses_rad.len().is_multiple_of(n_joints),
            "pose buffer is not a multiple of the joint count"
        );
        // The buffers of a dropped one on this thread, refilled (no allocation once a
        // thread has built pose sets of this size: issue 43).
        // (A pose set too large to keep takes fresh buffers, as `Drop` will not keep them:
        // growing a kept one would only add a copy. `sc` is the largest geometric buffer.)
        let bufs = if crate::keep_buffer::<[f64; 2]>(poses_rad.len()) {
            take_pooled(&TRIG_POOL).unwrap_or_default()
        } else {
            TrigBuffers::default()
        };
        let mut trig = PoseTrig {
            n_joints,
            sc: bufs.sc,
            lane_sin: bufs.lane_sin,
            lane_cos: bufs.lane_cos,
            n_ext: 0,
            lane_w: bufs.lane_w,
            weights_of: 0,
        };
        trig.lane_w.clear();
        let fill = |sin: &mut Vec<f64>, cos: &mut Vec<f64>, sc: &mut Vec<[f64; 2]>| {
            refill(sin, poses_rad.len(), 0.0);
            refill(cos, poses_rad.len(), 0.0);
            sin_cos_slice(poses_rad, sin, cos);
            sc.clear();
            sc.reserve_exact(poses_rad.len());
            sc.extend(sin.iter().zip(cos.iter()).map(|(s, c)| [*s, *c]));
        };
        with_kept(&SIN_COS, |(sin, cos)| {
            fill(sin, cos, &mut trig.sc);
            if !crate::keep_buffer::<f64>(sin.capacity()) {
                (*sin, *cos) = (Vec::new(), Vec::new());
            }
        });
        let sc = &trig.sc;
        let m = sc.len() / n_joints;
        let blocks = m.div_ceil(POSE_LANES);
        refill(&mut trig.lane_sin, blocks * n_joints, [0.0; POSE_LANES]);
        refill(&mut trig.lane_cos, blocks * n_joints, [0.0; POSE_LANES]);
        for b in 0..blocks {
            for t in 0..POSE_LANES {
                let j = (b * POSE_LANES + t).min(m - 1);
                for i in 0..n_joints {
                    let [s, c] = sc[j * n_joints + i];
                    trig.lane_sin[b * n_joints + i][t] = s;
                    trig.lane_cos[b * n_joints + i][t] = c;
                }
            }
        }
        trig
    }

    /// [`PoseTrig::new`] for `robot`: for an extended robot ([`Robot::with_extended`]) the
    /// weights `w_k(q)` of its non-geometric parameters at every pose are computed too
    /// (they depend on the pose and the robot's fixed torque geometry, not on the parameter
    /// values), so that the lane kernels evaluate it at any parameter vector of the same
    /// extended model. For a geometric robot this is [`PoseTrig::new`].
    pub fn for_robot(robot: &Robot, poses_rad: &[f64]) -> Self {
        let mut trig = PoseTrig::new(robot.n_joints(), poses_rad);
        if robot.has_prismatic() {
            // A prismatic joint's pair is its value and the marker (`Robot::joint_trig`).
            let n = robot.n_joints();
            let m = trig.n_poses();
            for (j, q) in poses_rad.chunks_exact(n).enumerate() {
                robot.mark_prismatic(q, &mut trig.sc[j * n..(j + 1) * n]);
            }
            for b in 0..trig.n_blocks() {
                for t in 0..POSE_LANES {
                    let j = (b * POSE_LANES + t).min(m - 1);
                    for i in (0..n).filter(|&i| robot.links[i].prismatic) {
                        trig.lane_sin[b * n + i][t] = poses_rad[j * n + i];
                        trig.lane_cos[b * n + i][t] = PRISMATIC_SLOT;
                    }
                }
            }
        }
        if let Some(ext) = &robot.extended {
            let ne = ext.model.len();
            let m = trig.n_poses();
            let blocks = trig.n_blocks();
            let mut w = vec![0.0; ne];
            let mut frames = [Frame::identity(); MAX_JOINTS + 1];
            refill(&mut trig.lane_w, blocks * ne, [0.0; POSE_LANES]);
            for j in 0..m {
                ext.model
                    .weights_trig_in(&ext.torque_robot, trig.pose(j), &mut frames, &mut w);
                // Pose j and, past the last pose, its copies in the padding lanes.
                let (b, t) = (j / POSE_LANES, j % POSE_LANES);
                let last = if j + 1 == m { POSE_LANES } else { t + 1 };
                for (k, wk) in w.iter().enumerate() {
                    trig.lane_w[b * ne + k][t..last].fill(*wk);
                }
            }
            trig.n_ext = ne;
            trig.weights_of = ext.fingerprint;
        }
        trig
    }

    /// Number of poses.
    pub fn n_poses(&self) -> usize {
        self.sc.len() / self.n_joints.max(1)
    }

    /// Joints per pose.
    pub fn n_joints(&self) -> usize {
        self.n_joints
    }

    /// `[sin q_i, cos q_i]` of pose `j`.
    #[inline]
    pub fn pose(&self, j: usize) -> &[[f64; 2]] {
        &self.sc[j * self.n_joints..(j + 1) * self.n_joints]
    }

    /// Number of blocks of [`POSE_LANES`] poses (the last one may be partial).
    pub fn n_blocks(&self) -> usize {
        self.n_poses().div_ceil(POSE_LANES)
    }

    /// `(sin q_i, cos q_i)` of the poses `b·POSE_LANES + t`, lane t, for every joint i, and
    /// the extended weights if built by [`PoseTrig::for_robot`]; lanes past the last pose
    /// repeat it.
    #[inline]
    pub fn lanes(&self, block: usize) -> PoseLanes<'_> {
        let r = block * self.n_joints..(block + 1) * self.n_joints;
        PoseLanes {
            sin_q: &self.lane_sin[r.clone()],
            cos_q: &self.lane_cos[r],
            weights: &self.lane_w[block * self.n_ext..(block + 1) * self.n_ext],
            weights_of: self.weights_of,
        }
    }
}

/// The buffers of a [`PoseTrig`], kept by a thread for the next one.
#[derive(Default)]
struct TrigBuffers {
    sc: Vec<[f64; 2]>,
    lane_sin: Vec<[f64; POSE_LANES]>,
    lane_cos: Vec<[f64; POSE_LANES]>,
    lane_w: Vec<[f64; POSE_LANES]>,
}

thread_local! {
    /// Buffers of dropped [`PoseTrig`]s, refilled by the next ones on the thread (a trial
    /// builds one per solve and per model evaluation on a pose set).
    static TRIG_POOL: Pool<TrigBuffers> = const { Pool::new() };
    /// The sines and cosines of [`PoseTrig::new`] before they are paired.
    static SIN_COS: Kept<(Vec<f64>, Vec<f64>)> = const { Kept::new() };
}

/// Buffers of [`PoseTrig`]s a thread keeps (a trial holds at most three at once: the
/// validation poses', a solve's and a model evaluation's).
const TRIG_POOL_SIZE: usize = 4;

/// `v` cleared and resized to `len` copies of `x`, grown to exactly `len` if too small (no
/// doubling past what a kept buffer may hold, `crate::KEPT_BUFFER_MAX_BYTES`).
fn refill<T: Clone>(v: &mut Vec<T>, len: usize, x: T) {
    v.clear();
    v.reserve_exact(len);
    v.resize(len, x);
}

impl Drop for PoseTrig {
    fn drop(&mut self) {
        // Kept only if every buffer may be (`crate::keep_buffer`; the extended weights may
        // be empty).
        let fits = |bytes: usize| bytes <= crate::KEPT_BUFFER_MAX_BYTES;
        let lanes = std::mem::size_of::<[f64; POSE_LANES]>();
        if !(crate::keep_buffer::<[f64; 2]>(self.sc.capacity())
            && fits(self.lane_sin.capacity() * lanes)
            && fits(self.lane_cos.capacity() * lanes)
            && fits(self.lane_w.capacity() * lanes))
        {
            return;
        }
        give_pooled(&TRIG_POOL, TRIG_POOL_SIZE, || TrigBuffers {
            sc: std::mem::take(&mut self.sc),
            lane_sin: std::mem::take(&mut self.lane_sin),
            lane_cos: std::mem::take(&mut self.lane_cos),
            lane_w: std::mem::take(&mut self.lane_w),
        });
    }
}

/// Poses evaluated together by the pose-parallel kernels ([`Robot::point_lanes`],
/// [`Robot::point_jacobian_lanes`]), one per vector lane.
pub const POSE_LANES: usize = 8;

/// One value per lane.
type Lanes<const L: usize> = [f64; L];

/// A 3-vector per lane (structure of arrays).
#[derive(Clone, Copy)]
struct V3<const L: usize> {
    x: Lanes<L>,
    y: Lanes<L>,
    z: Lanes<L>,
}

impl<const L: usize> V3<L> {
    #[inline(always)]
    fn splat(v: &Vector3<f64>) -> Self {
        V3 {
            x: [v.x; L],
            y: [v.y; L],
            z: [v.z; L],
        }
    }

    #[inline(always)]
    fn map(a: &Self, b: &Self, f: impl Fn(f64, f64) -> f64) -> Self {
        let mut r = *a;
        for t in 0..L {
            r.x[t] = f(a.x[t], b.x[t]);
            r.y[t] = f(a.y[t], b.y[t]);
            r.z[t] = f(a.z[t], b.z[t]);
        }
        r
    }

    /// `a·sa + b·sb` with per-lane factors.
    #[inline(always)]
    fn comb(a: &Self, sa: &Lanes<L>, b: &Self, sb: &Lanes<L>) -> Self {
        let mut r = *a;
        for t in 0..L {
            r.x[t] = a.x[t] * sa[t] + b.x[t] * sb[t];
            r.y[t] = a.y[t] * sa[t] + b.y[t] * sb[t];
            r.z[t] = a.z[t] * sa[t] + b.z[t] * sb[t];
        }
        r
    }

    /// `a·sa − b·sb` with per-lane factors.
    #[inline(always)]
    fn comb_minus(a: &Self, sa: &Lanes<L>, b: &Self, sb: &Lanes<L>) -> Self {
        let mut r = *a;
        for t in 0..L {
            r.x[t] = a.x[t] * sa[t] - b.x[t] * sb[t];
            r.y[t] = a.y[t] * sa[t] - b.y[t] * sb[t];
            r.z[t] = a.z[t] * sa[t] - b.z[t] * sb[t];
        }
        r
    }

    /// `a·sa + b·sb` with uniform factors.
    #[inline(always)]
    fn comb_u(a: &Self, sa: f64, b: &Self, sb: f64) -> Self {
        Self::comb(a, &[sa; L], b, &[sb; L])
    }

    /// `a·sa − b·sb` with uniform factors.
    #[inline(always)]
    fn comb_minus_u(a: &Self, sa: f64, b: &Self, sb: f64) -> Self {
        Self::comb_minus(a, &[sa; L], b, &[sb; L])
    }

    #[inline(always)]
    fn sub(a: &Self, b: &Self) -> Self {
        Self::map(a, b, |u, v| u - v)
    }

    #[inline(always)]
    fn add(a: &Self, b: &Self) -> Self {
        Self::map(a, b, |u, v| u + v)
    }

    /// `a × b`.
    #[inline(always)]
    fn cross(a: &Self, b: &Self) -> Self {
        let mut r = *a;
        for t in 0..L {
            r.x[t] = a.y[t] * b.z[t] - a.z[t] * b.y[t];
            r.y[t] = a.z[t] * b.x[t] - a.x[t] * b.z[t];
            r.z[t] = a.x[t] * b.y[t] - a.y[t] * b.x[t];
        }
        r
    }

    /// `r · v` for a rotation given by its columns `c` (uniform) and per-lane v.
    #[inline(always)]
    fn rotate(c: &[Vector3<f64>; 3], v: &Self) -> Self {
        let mut r = *v;
        for t in 0..L {
            r.x[t] = c[0].x * v.x[t] + c[1].x * v.y[t] + c[2].x * v.z[t];
            r.y[t] = c[0].y * v.x[t] + c[1].y * v.y[t] + c[2].y * v.z[t];
            r.z[t] = c[0].z * v.x[t] + c[1].z * v.y[t] + c[2].z * v.z[t];
        }
        r
    }

    #[inline(always)]
    fn lane(&self, t: usize) -> Vector3<f64> {
        Vector3::new(self.x[t], self.y[t], self.z[t])
    }
}

/// `(sin(θ+q), cos(θ+q))` per lane from sin q, cos q and the link's cached sin/cos of θ; a
/// prismatic link's `(sin θ, cos θ)` (its pair holds q and [`PRISMATIC_SLOT`]: pairs built
/// without the robot's joint types are refused).
#[inline(always)]
fn angle<const L: usize>(l: &Link, sq: &Lanes<L>, cq: &Lanes<L>) -> (Lanes<L>, Lanes<L>) {
    if l.prismatic {
        assert!(
            cq.iter().all(|c| *c == PRISMATIC_SLOT),
            "a prismatic joint's [sin, cos] pair must hold its value: build the pairs with \
             Robot::joint_trig or PoseTrig::for_robot"
        );
        return ([l.sin_theta; L], [l.cos_theta; L]);
    }
    let (mut st, mut ct) = (*sq, *cq);
    for t in 0..L {
        st[t] = l.sin_theta * cq[t] + l.cos_theta * sq[t];
        ct[t] = l.cos_theta * cq[t] - l.sin_theta * sq[t];
    }
    (st, ct)
}

/// The offset along z per lane: d, or for a prismatic link `d + scale · prismatic_mm(q)`
/// with q in the pair's sine slot.
#[inline(always)]
fn link_d<const L: usize>(l: &Link, sq: &Lanes<L>) -> Lanes<L> {
    let mut d = [l.d_mm; L];
    if l.prismatic {
        for t in 0..L {
            d[t] = l.d_mm + l.scale * prismatic_mm(sq[t]);
        }
    }
    d
}

/// One link forwards: the rotation columns `c` and origin `o` of frame i−1 become those of
/// frame i (`d` from [`link_d`]). Returns `(x'_i, y'_i)`, the x axis after `Rz(θ+q)` and the
/// y axis after `Rz(θ+q)·Rx(α)`.
#[inline(always)]
fn step<const L: usize>(
    l: &Link,
    st: &Lanes<L>,
    ct: &Lanes<L>,
    d: &Lanes<L>,
    c: &mut [V3<L>; 3],
    o: &mut V3<L>,
) -> (V3<L>, V3<L>) {
    // R·Rz(t): columns 0 and 1 mix; the origin moves by R·(a ct, a st, d).
    let x = V3::comb(&c[0], ct, &c[1], st);
    let c1 = V3::comb_minus(&c[1], ct, &c[0], st);
    *o = V3::add(o, &V3::comb(&x, &[l.a_mm; L], &c[2], d));
    // ·Rx(α): columns 1 and 2 mix.
    let y = V3::comb_u(&c1, l.cos_alpha, &c[2], l.sin_alpha);
    let c2 = V3::comb_minus_u(&c[2], l.cos_alpha, &c1, l.sin_alpha);
    // ·Ry(β): columns 0 and 2 mix.
    if l.sin_beta != 0.0 {
        c[0] = V3::comb_minus_u(&x, l.cos_beta, &c2, l.sin_beta);
        c[2] = V3::comb_u(&x, l.sin_beta, &c2, l.cos_beta);
    } else {
        c[0] = x;
        c[2] = c2;
    }
    c[1] = y;
    (x, y)
}

#[inline(always)]
fn columns(f: &Frame) -> [Vector3<f64>; 3] {
    [
        f.rot.column(0).into_owned(),
        f.rot.column(1).into_owned(),
        f.rot.column(2).into_owned(),
    ]
}

#[inline(always)]
fn frame(c: &[V3<1>; 3], o: &V3<1>) -> Frame {
    Frame {
        rot: nalgebra::Matrix3::from_columns(&[c[0].lane(0), c[1].lane(0), c[2].lane(0)]),
        pos_mm: o.lane(0),
    }
}

/// Splits `[sin, cos]` pairs of one pose into single-lane sine and cosine arrays.
#[inline(always)]
fn single(sc: &[[f64; 2]]) -> ([Lanes<1>; MAX_JOINTS], [Lanes<1>; MAX_JOINTS]) {
    let mut s = [[0.0]; MAX_JOINTS];
    let mut c = [[0.0]; MAX_JOINTS];
    for (i, [si, ci]) in sc.iter().enumerate() {
        s[i] = [*si];
        c[i] = [*ci];
    }
    (s, c)
}

impl Robot {
    /// The point per lane, backwards from the tool: three plane rotations per link.
    #[inline(always)]
    fn point_generic<const L: usize>(&self, s: &[Lanes<L>], c: &[Lanes<L>]) -> V3<L> {
        let t = self.tool_mm;
        let mut v = V3::splat(&t);
        for ((l, sq), cq) in self.links.iter().zip(s).zip(c).rev() {
            let (st, ct) = angle(l, sq, cq);
            let d = link_d(l, sq);
            // Per lane: Ry(β) in a loop of its own (the β test outside it), then Rx(α), the
            // offset a, Rz(θ+q) and the offset d: two branch-free loops, both vectorised.
            if l.sin_beta != 0.0 {
                for k in 0..L {
                    let (x, z) = (v.x[k], v.z[k]);
                    v.x[k] = l.cos_beta * x + l.sin_beta * z;
                    v.z[k] = l.cos_beta * z - l.sin_beta * x;
                }
            }
            for k in 0..L {
                let (x, y, z) = (v.x[k] + l.a_mm, v.y[k], v.z[k]);
                let ya = l.cos_alpha * y - l.sin_alpha * z;
                v.z[k] = l.sin_alpha * y + l.cos_alpha * z + d[k];
                v.x[k] = ct[k] * x - st[k] * ya;
                v.y[k] = st[k] * x + ct[k] * ya;
            }
        }
        let b = columns(&self.base_frame);
        V3::add(&V3::rotate(&b, &v), &V3::splat(&self.base_frame.pos_mm))
    }

    /// Point and Jacobian per lane; `jac[k]` = lanes of (∂p_x, ∂p_y, ∂p_z)/∂param_k.
    #[inline(always)]
    fn point_jacobian_generic<const L: usize>(
        &self,
        s: &[Lanes<L>],
        cq: &[Lanes<L>],
        jac: &mut [[Lanes<L>; 3]],
    ) -> V3<L> {
        let np = self.layout.len();
        assert!(jac.len() >= np, "Jacobian buffer length");
        self.point_jacobian_each(s, cq, |k, v| jac[k] = [v.x, v.y, v.z])
    }

    /// Point and Jacobian per lane, each column handed to `set(k, ∂p/∂param_k)` as it is
    /// computed (in no particular order of k).
    #[inline(always)]
    fn point_jacobian_each<const L: usize>(
        &self,
        s: &[Lanes<L>],
        cq: &[Lanes<L>],
        mut set: impl FnMut(usize, &V3<L>),
    ) -> V3<L> {
        let p = self.point_generic(s, cq);
        let bc = columns(&self.base_frame);
        let mut c = [V3::splat(&bc[0]), V3::splat(&bc[1]), V3::splat(&bc[2])];
        let mut o = V3::splat(&self.base_frame.pos_mm);
        for (i, ((l, sq), cqi)) in self.links.iter().zip(s).zip(cq).enumerate() {
            let z = c[2];
            let r_prev = V3::sub(&p, &o);
            let (st, ct) = angle(l, sq, cqi);
            let (x, y) = step(l, &st, &ct, &link_d(l, sq), &mut c, &mut o);
            let r_this = V3::sub(&p, &o);
            set(4 * i, &V3::cross(&z, &r_prev));
            set(4 * i + 1, &z);
            set(4 * i + 2, &x);
            set(4 * i + 3, &V3::cross(&x, &r_this));
            if let Some(k) = self.beta_index[i] {
                set(k, &V3::cross(&y, &r_this));
            }
            if let Some(k) = self.scale_index[i] {
                let mut v = z;
                for (t, q) in sq.iter().enumerate() {
                    let q_mm = prismatic_mm(*q);
                    (v.x[t], v.y[t], v.z[t]) = (z.x[t] * q_mm, z.y[t] * q_mm, z.z[t] * q_mm);
                }
                set(k, &v);
            }
        }
        let b = self.base_index;
        let r_base = V3::sub(&p, &V3::splat(&self.base_frame.pos_mm));
        let [ax_x, ax_y, ax_z] = self.base_axes;
        set(b, &V3::cross(&V3::splat(&ax_x), &r_base));
        set(b + 1, &V3::cross(&V3::splat(&ax_y), &r_base));
        set(b + 2, &V3::cross(&V3::splat(&ax_z), &r_base));
        set(b + 3, &V3::splat(&Vector3::x()));
        set(b + 4, &V3::splat(&Vector3::y()));
        set(b + 5, &V3::splat(&Vector3::z()));
        set(b + 6, &c[0]);
        set(b + 7, &c[1]);
        set(b + 8, &c[2]);
        p
    }

    /// [`Robot::point_trig`] for [`POSE_LANES`] poses at once: `lanes.sin_q[i][t]`,
    /// `lanes.cos_q[i][t]` are sin and cos of joint i of pose t ([`PoseTrig::lanes`]);
    /// returns the lanes of x, y, z. Each lane is bit for bit what the one-pose kernel gives
    /// for that pose (same operations in the same order), at any vector width. An extended
    /// robot is evaluated at its effective joints, from the weights in `lanes` (build the
    /// [`PoseTrig`] with [`PoseTrig::for_robot`]).
    ///
    /// Panics if the lanes do not fit the robot (joint count, weight count).
    #[inline(always)]
    pub fn point_lanes(&self, lanes: PoseLanes<'_>) -> [[f64; POSE_LANES]; 3] {
        self.check_lanes(&lanes);
        let p = match &self.extended {
            None => self.point_generic(lanes.sin_q, lanes.cos_q),
            Some(_) if self.links.len() <= 8 => self.point_lanes_extended::<8>(&lanes),
            Some(_) => self.point_lanes_extended::<MAX_JOINTS>(&lanes),
        };
        [p.x, p.y, p.z]
    }

    /// [`Robot::point_jacobian_trig`] for [`POSE_LANES`] poses at once: `jac[k][r][t]` is
    /// `∂p_r/∂param_k` (r = x, y, z) of pose t; `jac` holds at least `n_params()` entries.
    /// Returns the points' lanes. Bit for bit the one-pose kernel's values, lane by lane.
    #[inline(always)]
    pub fn point_jacobian_lanes(
        &self,
        lanes: PoseLanes<'_>,
        jac: &mut [[[f64; POSE_LANES]; 3]],
    ) -> [[f64; POSE_LANES]; 3] {
        let np = self.layout.len();
        assert!(jac.len() >= np, "Jacobian buffer length");
        let mut slot = [usize::MAX; crate::robot::MAX_PARAMS];
        for (k, s) in slot[..np].iter_mut().enumerate() {
            *s = k;
        }
        self.point_jacobian_lanes_to(lanes, &slot[..np], jac)
    }

    /// [`Robot::point_jacobian_lanes`] for the columns `slot` selects: the lanes of
    /// `∂p/∂param_k` go to `out[slot[k]]`, or nowhere when `slot[k]` is out of range (e.g.
    /// `usize::MAX`; `slot` holds `n_params()` entries). Each column's values are bit for
    /// bit those of [`Robot::point_jacobian_lanes`]. An extended robot's columns are
    /// `w_k · ∂p/∂θ_j` (see [`Robot::with_extended`]).
    #[inline(always)]
    pub fn point_jacobian_lanes_to(
        &self,
        lanes: PoseLanes<'_>,
        slot: &[usize],
        out: &mut [[[f64; POSE_LANES]; 3]],
    ) -> [[f64; POSE_LANES]; 3] {
        self.check_lanes(&lanes);
        assert_eq!(slot.len(), self.layout.len(), "one slot per parameter");
        let p = match &self.extended {
            None => self.point_jacobian_each(lanes.sin_q, lanes.cos_q, |k, v| {
                if let Some(dst) = out.get_mut(slot[k]) {
                    *dst = [v.x, v.y, v.z];
                }
            }),
            Some(_) if self.links.len() <= 8 => {
                self.point_jacobian_lanes_extended::<8>(&lanes, slot, out)
            }
            Some(_) => self.point_jacobian_lanes_extended::<MAX_JOINTS>(&lanes, slot, out),
        };
        [p.x, p.y, p.z]
    }

    /// Panics unless `lanes` fit this robot: one entry per joint, and the weights of its
    /// extended parameters (none for a geometric robot).
    #[inline(always)]
    fn check_lanes(&self, lanes: &PoseLanes<'_>) {
        let n = self.links.len();
        assert!(
            lanes.sin_q.len() == n && lanes.cos_q.len() == n,
            "joint vector length"
        );
        let (ne, of) = self
            .extended
            .as_ref()
            .map_or((0, 0), |e| (e.model.len(), e.fingerprint));
        assert!(
            lanes.weights.len() == ne && lanes.weights_of == of,
            "the lanes carry {} extended weights of model {:#x}, the robot has {ne} extended \
             parameters of model {of:#x}: build the PoseTrig with PoseTrig::for_robot for this \
             robot",
            lanes.weights.len(),
            lanes.weights_of
        );
    }

    /// [`Robot::point_lanes`] of an extended robot, with effective-joint buffers of `J` ≥ n
    /// joints (8 for the usual chains: they are written once per block of poses).
    #[inline(always)]
    fn point_lanes_extended<const J: usize>(&self, lanes: &PoseLanes<'_>) -> V3<POSE_LANES> {
        let n = self.links.len();
        let (s, c) = self.effective_lanes::<J>(lanes);
        self.point_generic(&s[..n], &c[..n])
    }

    /// [`Robot::point_jacobian_lanes_to`] of an extended robot: the geometric columns at the
    /// effective joints, then the extended columns `w_k · ∂p/∂θ_j`, with buffers of `J` ≥ n
    /// joints.
    #[inline(always)]
    fn point_jacobian_lanes_extended<const J: usize>(
        &self,
        lanes: &PoseLanes<'_>,
        slot: &[usize],
        out: &mut [[[f64; POSE_LANES]; 3]],
    ) -> V3<POSE_LANES> {
        let Some(ext) = &self.extended else {
            unreachable!("called for extended robots only");
        };
        let n = self.links.len();
        let (s, c) = self.effective_lanes::<J>(lanes);
        // The θ columns (layout index 4i) are kept for the extended ones.
        let mut theta = [[[0.0; POSE_LANES]; 3]; J];
        let p = self.point_jacobian_each(&s[..n], &c[..n], |k, v| {
            if k < 4 * n && k % 4 == 0 {
                theta[k / 4] = [v.x, v.y, v.z];
            }
            if let Some(dst) = out.get_mut(slot[k]) {
                *dst = [v.x, v.y, v.z];
            }
        });
        for (k, (kind, w)) in ext.model.kinds().iter().zip(lanes.weights).enumerate() {
            debug_assert_eq!(ext.theta_index[k], 4 * kind.joint());
            if let Some(dst) = out.get_mut(slot[ext.first + k]) {
                let th = &theta[kind.joint()];
                *dst = std::array::from_fn(|r| std::array::from_fn(|t| th[r][t] * w[t]));
            }
        }
        p
    }

    /// The effective joints' `sin q̃`, `cos q̃` per lane of an extended robot (entries
    /// `..n` of buffers of `J` ≥ n joints), from the commanded joints' and the weights in
    /// `lanes`: `δ_j = Σ_k w_k x_k`, then `sin(q + δ) = s·cos δ + c·sin δ`,
    /// `cos(q + δ) = c·cos δ − s·sin δ` on the joints that carry a parameter (sin δ, cos δ
    /// by [`crate::trig::sin_cos_small_lanes`]). Lane by lane the bits of
    /// `Robot::effective_trig_of`.
    #[inline(always)]
    fn effective_lanes<const J: usize>(
        &self,
        lanes: &PoseLanes<'_>,
    ) -> ([[f64; POSE_LANES]; J], [[f64; POSE_LANES]; J]) {
        let n = self.links.len();
        let mut s = [[0.0; POSE_LANES]; J];
        let mut c = [[0.0; POSE_LANES]; J];
        s[..n].copy_from_slice(lanes.sin_q);
        c[..n].copy_from_slice(lanes.cos_q);
        if let Some(ext) = &self.extended {
            let x = ext.model.values();
            for (i, params) in &ext.by_joint {
                let i = *i;
                // δ_i in a register, its parameters in layout order (as `offsets` adds them).
                let mut delta = [0.0; POSE_LANES];
                for &k in params {
                    let (w, xk) = (&lanes.weights[k], x[k]);
                    for t in 0..POSE_LANES {
                        delta[t] += w[t] * xk;
                    }
                }
                let (sd, cd) = sin_cos_small_lanes(&delta);
                let (sq, cq) = (s[i], c[i]);
                for t in 0..POSE_LANES {
                    s[i][t] = sq[t] * cd[t] + cq[t] * sd[t];
                    c[i][t] = cq[t] * cd[t] - sq[t] * sd[t];
                }
            }
        }
        (s, c)
    }

    /// The measured point at the pose whose `[sin q, cos q]` are `sc` (see [`PoseTrig`]):
    /// the same value as [`Robot::point`] of that pose, bit for bit.
    ///
    /// Panics if `sc.len() != n_joints()`.
    #[inline]
    pub fn point_trig(&self, sc: &[[f64; 2]]) -> Vector3<f64> {
        let n = self.links.len();
        assert_eq!(sc.len(), n, "joint vector length");
        if self.is_extended() {
            return self.point_trig_extended(sc);
        }
        let (s, c) = single(sc);
        self.point_generic(&s[..n], &c[..n]).lane(0)
    }

    /// The forward chain at one pose, calling `visit(i, z_{i−1}, o_{i−1})` before each link;
    /// returns the flange's columns and origin.
    #[inline(always)]
    fn chain_trig(
        &self,
        sc: &[[f64; 2]],
        visit: impl FnMut(usize, &[V3<1>; 3], &V3<1>),
    ) -> ([V3<1>; 3], V3<1>) {
        if self.is_extended() {
            let (eff, _) = self.effective_trig_of(sc);
            return self.chain_trig_geometric(&eff[..sc.len()], visit);
        }
        self.chain_trig_geometric(sc, visit)
    }

    /// [`Robot::chain_trig`] on the sines and cosines given (the effective joints).
    #[inline(always)]
    fn chain_trig_geometric(
        &self,
        sc: &[[f64; 2]],
        mut visit: impl FnMut(usize, &[V3<1>; 3], &V3<1>),
    ) -> ([V3<1>; 3], V3<1>) {
        let n = self.links.len();
        assert_eq!(sc.len(), n, "joint vector length");
        let (s, cq) = single(sc);
        let bc = columns(&self.base_frame);
        let mut c = [V3::splat(&bc[0]), V3::splat(&bc[1]), V3::splat(&bc[2])];
        let mut o = V3::splat(&self.base_frame.pos_mm);
        for (i, ((l, sq), cqi)) in self.links.iter().zip(&s[..n]).zip(&cq[..n]).enumerate() {
            visit(i, &c, &o);
            let (st, ct) = angle(l, sq, cqi);
            step(l, &st, &ct, &link_d(l, sq), &mut c, &mut o);
        }
        (c, o)
    }

    /// The flange frame at the pose whose `[sin q, cos q]` are `sc`.
    #[inline]
    pub fn flange_trig(&self, sc: &[[f64; 2]]) -> Frame {
        let (c, o) = self.chain_trig(sc, |_, _, _| {});
        frame(&c, &o)
    }

    /// Frames `T_base · T_1 ··· T_i`, i = 0..N, into `frames[0..=N]`, at the pose whose
    /// `[sin q, cos q]` are `sc`.
    #[inline]
    pub fn frames_trig(&self, sc: &[[f64; 2]], frames: &mut [Frame; MAX_JOINTS + 1]) {
        let (c, o) = self.chain_trig(sc, |i, c, o| frames[i] = frame(c, o));
        frames[self.links.len()] = frame(&c, &o);
    }

    /// For every joint the axis `z_{i−1}` and its origin `o_{i−1}`, and the flange frame, at
    /// the pose whose `[sin q, cos q]` are `sc`.
    #[inline]
    pub(crate) fn joint_axes_trig(
        &self,
        sc: &[[f64; 2]],
        axes: &mut [(Vector3<f64>, Vector3<f64>); MAX_JOINTS],
    ) -> Frame {
        let (c, o) = self.chain_trig(sc, |i, c, o| axes[i] = (c[2].lane(0), o.lane(0)));
        frame(&c, &o)
    }

    /// The measured point ([`Robot::point_trig`], bit for bit) and its derivative with
    /// respect to every parameter, as the three rows of the 3 × P block:
    /// `jx[k] = ∂p_x/∂param_k` etc. (formulas of [`Robot::point_jacobian_into`]). The rows
    /// must hold at least `n_params()` values; no allocation.
    pub fn point_jacobian_trig(
        &self,
        sc: &[[f64; 2]],
        jx: &mut [f64],
        jy: &mut [f64],
        jz: &mut [f64],
    ) -> Vector3<f64> {
        let n = self.links.len();
        let np = self.layout.len();
        assert_eq!(sc.len(), n, "joint vector length");
        assert!(
            jx.len() >= np && jy.len() >= np && jz.len() >= np,
            "Jacobian row length"
        );
        if self.is_extended() {
            return self.point_jacobian_trig_extended(sc, jx, jy, jz);
        }
        self.point_jacobian_rows(&sc[..n], jx, jy, jz)
    }

    /// The chain's point and Jacobian rows at the sines and cosines given, `np` columns.
    #[inline(always)]
    fn point_jacobian_rows(
        &self,
        sc: &[[f64; 2]],
        jx: &mut [f64],
        jy: &mut [f64],
        jz: &mut [f64],
    ) -> Vector3<f64> {
        let n = self.links.len();
        let np = self.layout.len();
        let (s, c) = single(sc);
        let mut jac = [[[0.0]; 3]; crate::robot::MAX_PARAMS];
        let p = self.point_jacobian_generic(&s[..n], &c[..n], &mut jac[..np]);
        for (k, [x, y, z]) in jac[..np].iter().enumerate() {
            jx[k] = x[0];
            jy[k] = y[0];
            jz[k] = z[0];
        }
        p.lane(0)
    }

    /// [`Robot::point_trig`] of an extended robot: the chain at the effective joints.
    #[inline(never)]
    fn point_trig_extended(&self, sc: &[[f64; 2]]) -> Vector3<f64> {
        let n = self.links.len();
        let (eff, _) = self.effective_trig_of(sc);
        let (s, c) = single(&eff[..n]);
        self.point_generic(&s[..n], &c[..n]).lane(0)
    }

    /// [`Robot::point_jacobian_trig`] of an extended robot: the geometric columns at the
    /// effective joints, then the extended columns `w_k · ∂p/∂θ_j`.
    #[inline(never)]
    fn point_jacobian_trig_extended(
        &self,
        sc: &[[f64; 2]],
        jx: &mut [f64],
        jy: &mut [f64],
        jz: &mut [f64],
    ) -> Vector3<f64> {
        let n = self.links.len();
        let np = self.layout.len();
        let (eff, w) = self.effective_trig_of(sc);
        let p = self.point_jacobian_rows(&eff[..n], jx, jy, jz);
        self.extended_columns(&w, &mut jx[..np]);
        self.extended_columns(&w, &mut jy[..np]);
        self.extended_columns(&w, &mut jz[..np]);
        p
    }
}
