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
//!   parameter vectors calls `sin_cos` once per joint and pose instead of twenty times.
//!   With θ = 0 the result is exactly `sin_cos(q)`; otherwise it differs by rounding
//!   (≤ 2 ulp).
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

use super::{Frame, Link, Robot};
use crate::model::MAX_JOINTS;

/// Sines and cosines of the joint values of a pose set, `[sin q, cos q]` per joint, pose
/// after pose. Build it once for poses that are evaluated at many parameter vectors (an
/// identification, an error scaling) and pass [`PoseTrig::pose`] to the `*_trig` methods of
/// [`Robot`].
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PoseTrig {
    n_joints: usize,
    sc: Vec<[f64; 2]>,
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
        PoseTrig {
            n_joints,
            sc: poses_rad
                .iter()
                .map(|q| {
                    let (s, c) = q.sin_cos();
                    [s, c]
                })
                .collect(),
        }
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
}

/// `[sin q_i, cos q_i]` of one joint vector, into `out[..q_rad.len()]`.
#[inline]
pub fn joint_sin_cos(q_rad: &[f64], out: &mut [[f64; 2]]) {
    for (o, q) in out.iter_mut().zip(q_rad) {
        let (s, c) = q.sin_cos();
        *o = [s, c];
    }
}

/// `(sin(θ+q), cos(θ+q))` from `[sin q, cos q]` and the link's cached sin/cos of θ.
#[inline(always)]
fn angle(l: &Link, [sq, cq]: [f64; 2]) -> (f64, f64) {
    (
        l.sin_theta * cq + l.cos_theta * sq,
        l.cos_theta * cq - l.sin_theta * sq,
    )
}

/// One link forwards: the rotation columns `c` and origin `o` of frame i−1 become those of
/// frame i. Returns `(x'_i, y'_i)`, the x axis after `Rz(θ+q)` and the y axis after
/// `Rz(θ+q)·Rx(α)`.
#[inline(always)]
fn step(
    l: &Link,
    st: f64,
    ct: f64,
    c: &mut [Vector3<f64>; 3],
    o: &mut Vector3<f64>,
) -> (Vector3<f64>, Vector3<f64>) {
    // R·Rz(t): columns 0 and 1 mix; the origin moves by R·(a ct, a st, d).
    let x = c[0] * ct + c[1] * st;
    let c1 = c[1] * ct - c[0] * st;
    *o += x * l.a_mm + c[2] * l.d_mm;
    // ·Rx(α): columns 1 and 2 mix.
    let y = c1 * l.cos_alpha + c[2] * l.sin_alpha;
    let c2 = c[2] * l.cos_alpha - c1 * l.sin_alpha;
    // ·Ry(β): columns 0 and 2 mix.
    if l.sin_beta != 0.0 {
        c[0] = x * l.cos_beta - c2 * l.sin_beta;
        c[2] = x * l.sin_beta + c2 * l.cos_beta;
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
fn frame(c: &[Vector3<f64>; 3], o: Vector3<f64>) -> Frame {
    Frame {
        rot: nalgebra::Matrix3::from_columns(c),
        pos_mm: o,
    }
}

impl Robot {
    /// The measured point at the pose whose `[sin q, cos q]` are `sc` (see [`PoseTrig`]):
    /// the same value as [`Robot::point`] of that pose, bit for bit.
    ///
    /// Panics if `sc.len() != n_joints()`.
    #[inline]
    pub fn point_trig(&self, sc: &[[f64; 2]]) -> Vector3<f64> {
        assert_eq!(sc.len(), self.links.len(), "joint vector length");
        let t = self.tool_mm;
        let (mut x, mut y, mut z) = (t.x, t.y, t.z);
        for (l, &tq) in self.links.iter().zip(sc).rev() {
            let (st, ct) = angle(l, tq);
            if l.sin_beta != 0.0 {
                let xb = l.cos_beta * x + l.sin_beta * z;
                z = l.cos_beta * z - l.sin_beta * x;
                x = xb;
            }
            let ya = l.cos_alpha * y - l.sin_alpha * z;
            z = l.sin_alpha * y + l.cos_alpha * z;
            y = ya;
            x += l.a_mm;
            let xz = ct * x - st * y;
            y = st * x + ct * y;
            x = xz;
            z += l.d_mm;
        }
        self.base_frame.transform_point(&Vector3::new(x, y, z))
    }

    /// The flange frame at the pose whose `[sin q, cos q]` are `sc`.
    #[inline]
    pub fn flange_trig(&self, sc: &[[f64; 2]]) -> Frame {
        assert_eq!(sc.len(), self.links.len(), "joint vector length");
        let mut c = columns(&self.base_frame);
        let mut o = self.base_frame.pos_mm;
        for (l, &tq) in self.links.iter().zip(sc) {
            let (st, ct) = angle(l, tq);
            step(l, st, ct, &mut c, &mut o);
        }
        frame(&c, o)
    }

    /// Frames `T_base · T_1 ··· T_i`, i = 0..N, into `frames[0..=N]`, at the pose whose
    /// `[sin q, cos q]` are `sc`.
    #[inline]
    pub fn frames_trig(&self, sc: &[[f64; 2]], frames: &mut [Frame; MAX_JOINTS + 1]) {
        assert_eq!(sc.len(), self.links.len(), "joint vector length");
        let mut c = columns(&self.base_frame);
        let mut o = self.base_frame.pos_mm;
        frames[0] = self.base_frame;
        for (i, (l, &tq)) in self.links.iter().zip(sc).enumerate() {
            let (st, ct) = angle(l, tq);
            step(l, st, ct, &mut c, &mut o);
            frames[i + 1] = frame(&c, o);
        }
    }

    /// For every joint the axis `z_{i−1}` and its origin `o_{i−1}`, and the flange frame, at
    /// the pose whose `[sin q, cos q]` are `sc`.
    #[inline]
    pub(crate) fn joint_axes_trig(
        &self,
        sc: &[[f64; 2]],
        axes: &mut [(Vector3<f64>, Vector3<f64>); MAX_JOINTS],
    ) -> Frame {
        let mut c = columns(&self.base_frame);
        let mut o = self.base_frame.pos_mm;
        for (i, (l, &tq)) in self.links.iter().zip(sc).enumerate() {
            axes[i] = (c[2], o);
            let (st, ct) = angle(l, tq);
            step(l, st, ct, &mut c, &mut o);
        }
        frame(&c, o)
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
        let p = self.point_trig(sc);
        let mut set = |k: usize, v: Vector3<f64>| {
            jx[k] = v.x;
            jy[k] = v.y;
            jz[k] = v.z;
        };
        let mut c = columns(&self.base_frame);
        let mut o = self.base_frame.pos_mm;
        for (i, (l, &tq)) in self.links.iter().zip(sc).enumerate() {
            let z = c[2];
            let r_prev = p - o;
            let (st, ct) = angle(l, tq);
            let (x, y) = step(l, st, ct, &mut c, &mut o);
            let r_this = p - o;
            set(4 * i, z.cross(&r_prev));
            set(4 * i + 1, z);
            set(4 * i + 2, x);
            set(4 * i + 3, x.cross(&r_this));
            if let Some(k) = self.beta_index[i] {
                set(k, y.cross(&r_this));
            }
        }
        let b = self.base_index;
        let r_base = p - self.base_frame.pos_mm;
        let [ax_x, ax_y, ax_z] = self.base_axes;
        set(b, ax_x.cross(&r_base));
        set(b + 1, ax_y.cross(&r_base));
        set(b + 2, ax_z.cross(&r_base));
        set(b + 3, Vector3::x());
        set(b + 4, Vector3::y());
        set(b + 5, Vector3::z());
        set(b + 6, c[0]);
        set(b + 7, c[1]);
        set(b + 8, c[2]);
        p
    }
}
