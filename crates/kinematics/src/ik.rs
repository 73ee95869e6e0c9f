//! Inverse kinematics by damped Newton (Levenberg–Marquardt) on the full model.
//!
//! Works for any parameter values — after calibration the closed-form IK of the nominal
//! robot no longer holds. The target is a point fixed in the flange frame (the flange origin,
//! or the measured point) with its position and the flange orientation. Each iteration:
//!
//! `e = [p* − p(q); L·log(R*·R(q)ᵀ)]`, `J = [z_i × (p − o_i); L·z_i]` (6×N),
//! `Δq = Jᵀ (J Jᵀ + λ I)⁻¹ e` (6×6 Cholesky, no heap allocation),
//!
//! with `L` = [`IkOptions::orientation_scale_mm`] to weigh radians against millimetres, and
//! λ = μ·max diag(J Jᵀ) adapted as in Levenberg's method (÷10 on success, ×10 on failure).
//! Steps are clamped to the joint limits.

use nalgebra::{Matrix3, Rotation3, Vector3, Vector6};

use crate::frame::Frame;
use crate::model::MAX_JOINTS;
use crate::robot::Robot;
use crate::rotation::log_so3;
use crate::trig::joint_sin_cos;

/// What the IK must reach: a point fixed in the flange frame at a position, with the flange at
/// an orientation (both in the measurement frame).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct IkTarget {
    /// The point, in the flange frame, mm (zero = flange origin).
    pub point_in_flange_mm: Vector3<f64>,
    /// Where that point must be, mm.
    pub position_mm: Vector3<f64>,
    /// The flange orientation required.
    pub rotation: Matrix3<f64>,
}

impl IkTarget {
    /// The full flange pose `frame` (position of the flange origin and its orientation).
    pub fn flange(frame: &Frame) -> Self {
        IkTarget {
            point_in_flange_mm: Vector3::zeros(),
            position_mm: frame.pos_mm,
            rotation: frame.rot,
        }
    }

    /// The measured point of `robot` at `q_rad`, with the flange orientation held: the target
    /// compensation uses (nominal model at the commanded joints).
    pub fn point_with_orientation(robot: &Robot, q_rad: &[f64]) -> Self {
        let f = robot.flange(q_rad);
        IkTarget {
            point_in_flange_mm: robot.tool_mm(),
            position_mm: f.transform_point(&robot.tool_mm()),
            rotation: f.rot,
        }
    }
}

/// Options of [`Robot::solve_ik`]. Defaults in brackets.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct IkOptions {
    /// Iteration cap, counting rejected steps \[100\].
    pub max_iterations: usize,
    /// Position error accepted as converged, mm [1e-6].
    pub tol_pos_mm: f64,
    /// Orientation error accepted as converged, rad [1e-9].
    pub tol_rot_rad: f64,
    /// Length that converts radians of orientation error into mm in the damped solve [1000 mm,
    /// the order of a large robot's reach, so that both parts of the error weigh alike].
    pub orientation_scale_mm: f64,
    /// Initial relative damping μ0 [1e-9: the start is usually close, so begin near Newton].
    pub mu0: f64,
    /// Largest change of any joint in one step, rad [0.2 ≈ 11°]. The whole step is scaled
    /// down to respect it, so that an ill-conditioned Jacobian near a singularity cannot
    /// throw the solve into another branch or against a limit.
    pub max_step_rad: f64,
    /// Stages of the path fallback when the direct solve fails \[8; < 2 disables it\].
    pub path_stages: usize,
}

impl Default for IkOptions {
    fn default() -> Self {
        IkOptions {
            max_iterations: 100,
            tol_pos_mm: 1e-6,
            tol_rot_rad: 1e-9,
            orientation_scale_mm: 1000.0,
            mu0: 1e-9,
            max_step_rad: 0.2,
            path_stages: 8,
        }
    }
}

/// A converged IK solve.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct IkReport {
    /// Iterations used (accepted and rejected steps).
    pub iterations: usize,
    /// Final position error, mm.
    pub pos_err_mm: f64,
    /// Final orientation error, rad.
    pub rot_err_rad: f64,
}

/// Why IK failed. The joint vector passed in holds the best configuration found.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum IkError {
    /// The joint vector has the wrong length.
    #[error("IK: expected {expected} joint values, got {found}")]
    Length {
        /// Joints of the robot.
        expected: usize,
        /// Values given.
        found: usize,
    },
    /// A start value or target is not finite.
    #[error("IK: non-finite start configuration or target")]
    NotFinite,
    /// The target was not reached within tolerance (unreachable, outside the joint limits,
    /// or too far from the start).
    #[error(
        "IK did not converge after {iterations} iterations: position error {pos_err_mm:.3e} mm, orientation error {rot_err_rad:.3e} rad"
    )]
    NotConverged {
        /// Iterations used.
        iterations: usize,
        /// Best position error reached, mm.
        pos_err_mm: f64,
        /// Best orientation error reached, rad.
        rot_err_rad: f64,
    },
}

/// Damping beyond which steps are too small to matter: the solve has stalled.
const MU_GIVE_UP: f64 = 1e8;

struct Residual {
    e: Vector6<f64>,
    pos_err_mm: f64,
    rot_err_rad: f64,
    cost: f64,
}

/// [`joint_sin_cos`] (the same bits) through one whole block of the sine kernel for up to
/// eight joints: the kernel's partial-block path costs more than the padding.
#[inline]
fn padded_sin_cos(q_rad: &[f64], sc: &mut [[f64; 2]; MAX_JOINTS]) {
    const BLOCK: usize = 8;
    let n = q_rad.len();
    if n > BLOCK {
        joint_sin_cos(q_rad, sc);
        return;
    }
    let mut x = [0.0; BLOCK];
    x[..n].copy_from_slice(q_rad);
    let mut s = [0.0; BLOCK];
    let mut c = [0.0; BLOCK];
    crate::trig::sin_cos_slice(&x, &mut s, &mut c);
    for i in 0..n {
        sc[i] = [s[i], c[i]];
    }
}

/// The lower triangle of a symmetric 6×6 matrix, column-major: `l[col][row]`, row ≥ col.
pub type Lower6 = [[f64; 6]; 6];

/// nalgebra's `Cholesky::new` on the lower triangle of `l`, in place, by the same
/// operations in the same order (left-looking columns: `a_ij − a_jk·a_ik` over k, the
/// pivot's square root if it is positive, the column divided by it): `false` where
/// nalgebra returns `None`. Fixed size and unrolled, so several times cheaper.
#[inline(always)]
#[allow(clippy::needless_range_loop, clippy::neg_cmp_op_on_partial_ord)]
pub fn cholesky6(l: &mut Lower6) -> bool {
    for j in 0..6 {
        for k in 0..j {
            let f = l[k][j];
            for i in j..6 {
                l[j][i] += -f * l[k][i];
            }
        }
        let d = l[j][j];
        if !(d > 0.0) {
            return false;
        }
        let r = d.sqrt();
        l[j][j] = r;
        for i in j + 1..6 {
            l[j][i] /= r;
        }
    }
    true
}

/// `Cholesky::solve` of nalgebra with the factor [`cholesky6`] left in `l`: forward
/// substitution (`b_r − (b_i/l_ii)·l_ri`), then backward with nalgebra's dot product (a
/// sum from +0 in row order), the same operations in the same order.
#[inline(always)]
#[allow(clippy::needless_range_loop)]
fn cholesky6_solve(l: &Lower6, b: &Vector6<f64>) -> Vector6<f64> {
    let mut y = [b[0], b[1], b[2], b[3], b[4], b[5]];
    for i in 0..6 {
        let coeff = y[i] / l[i][i];
        y[i] = coeff;
        for r in i + 1..6 {
            y[r] += -coeff * l[i][r];
        }
    }
    for i in (0..6).rev() {
        let mut dot = 0.0;
        for k in i + 1..6 {
            dot += l[i][k] * y[k];
        }
        y[i] = (y[i] - dot) / l[i][i];
    }
    Vector6::from(y)
}

/// Joint axes `(z_{i−1}, o_{i−1})` of one configuration and its target point `p`: what the
/// IK Jacobian needs, kept from the residual evaluation so an accepted point costs one chain.
#[derive(Clone, Copy)]
struct Axes {
    axes: [(Vector3<f64>, Vector3<f64>); MAX_JOINTS],
    point: Vector3<f64>,
}

impl Robot {
    /// Residual at `q_rad`; fills `axes` with the chain's joint axes and the point.
    fn ik_residual(
        &self,
        target: &IkTarget,
        q_rad: &[f64],
        scale: f64,
        axes: &mut Axes,
    ) -> Residual {
        let mut sc = [[0.0; 2]; MAX_JOINTS];
        padded_sin_cos(q_rad, &mut sc);
        self.mark_prismatic(q_rad, &mut sc);
        let f = self.joint_axes_trig(&sc[..q_rad.len()], &mut axes.axes);
        let p = f.transform_point(&target.point_in_flange_mm);
        axes.point = p;
        let ep = target.position_mm - p;
        let er = log_so3(&(target.rotation * f.rot.transpose()));
        let e = Vector6::new(ep.x, ep.y, ep.z, er.x * scale, er.y * scale, er.z * scale);
        Residual {
            e,
            pos_err_mm: ep.norm(),
            rot_err_rad: er.norm(),
            cost: e.norm_squared(),
        }
    }

    /// Solves IK for `target` starting from `q_rad` (radians), which is overwritten with the
    /// solution (or, on failure, the best configuration found). See the module docs.
    ///
    /// If the direct solve fails, the target is approached along a path instead: the pose of
    /// the start is moved to the target in [`IkOptions::path_stages`] equal steps (position
    /// linearly, orientation along the geodesic `exp(s·log(R*·R0ᵀ))·R0`), each solved from
    /// the previous solution. This keeps the solve on the start's branch where a single
    /// Newton step from far away would jump to another one (near shoulder or wrist
    /// singularities). Iterations of all stages are counted.
    pub fn solve_ik(
        &self,
        target: &IkTarget,
        q_rad: &mut [f64],
        opts: &IkOptions,
    ) -> Result<IkReport, IkError> {
        let start: [f64; MAX_JOINTS] = {
            let mut s = [0.0; MAX_JOINTS];
            if q_rad.len() <= MAX_JOINTS {
                s[..q_rad.len()].copy_from_slice(q_rad);
            }
            s
        };
        let direct = self.solve_ik_direct(target, q_rad, opts, true);
        let Err(IkError::NotConverged { iterations, .. }) = direct else {
            return direct;
        };
        if opts.path_stages < 2 {
            return direct;
        }
        let n = q_rad.len();
        q_rad.copy_from_slice(&start[..n]);
        let f0 = self.flange(q_rad);
        let p0 = f0.transform_point(&target.point_in_flange_mm);
        let w = log_so3(&(target.rotation * f0.rot.transpose()));
        let mut total = iterations;
        let mut last = direct;
        for k in 1..=opts.path_stages {
            let s = k as f64 / opts.path_stages as f64;
            let stage = IkTarget {
                point_in_flange_mm: target.point_in_flange_mm,
                position_mm: p0 + (target.position_mm - p0) * s,
                rotation: if k == opts.path_stages {
                    target.rotation
                } else {
                    Rotation3::new(w * s).matrix() * f0.rot
                },
            };
            last = self.solve_ik_direct(&stage, q_rad, opts, true);
            total += match &last {
                Ok(r) => r.iterations,
                Err(IkError::NotConverged { iterations, .. }) => *iterations,
                Err(_) => 0,
            };
        }
        match last {
            Ok(r) => Ok(IkReport {
                iterations: total,
                ..r
            }),
            Err(IkError::NotConverged {
                pos_err_mm,
                rot_err_rad,
                ..
            }) => Err(IkError::NotConverged {
                iterations: total,
                pos_err_mm,
                rot_err_rad,
            }),
            Err(e) => Err(e),
        }
    }

    /// One damped Newton solve from `q_rad`; `limited = false` ignores the joint limits
    /// (used to tell a target beyond a limit from one beyond reach).
    fn solve_ik_direct(
        &self,
        target: &IkTarget,
        q_rad: &mut [f64],
        opts: &IkOptions,
        limited: bool,
    ) -> Result<IkReport, IkError> {
        let limits = |i: usize| {
            if limited {
                self.limits_rad(i)
            } else {
                [f64::NEG_INFINITY, f64::INFINITY]
            }
        };
        let n = self.n_joints();
        if q_rad.len() != n {
            return Err(IkError::Length {
                expected: n,
                found: q_rad.len(),
            });
        }
        if q_rad.iter().any(|q| !q.is_finite())
            || !target.position_mm.iter().all(|v| v.is_finite())
            || !target.rotation.iter().all(|v| v.is_finite())
            || !target.point_in_flange_mm.iter().all(|v| v.is_finite())
        {
            return Err(IkError::NotFinite);
        }
        let scale = opts.orientation_scale_mm;
        let clamp = |q: &mut [f64]| {
            for (i, v) in q.iter_mut().enumerate() {
                let [lo, hi] = limits(i);
                *v = v.clamp(lo, hi);
            }
        };
        clamp(q_rad);
        // Stop refining once well inside the tolerance: Newton's last step then costs nothing.
        let tight_pos = opts.tol_pos_mm * 1e-3;
        let tight_rot = opts.tol_rot_rad * 1e-3;
        // The current configuration's chain and the trial's, swapped by index on acceptance.
        let mut bufs = [Axes {
            axes: [(Vector3::zeros(), Vector3::zeros()); MAX_JOINTS],
            point: Vector3::zeros(),
        }; 2];
        let mut cur = 0;
        let mut res = self.ik_residual(target, q_rad, scale, &mut bufs[cur]);
        let mut mu = opts.mu0;
        let mut trial = [0.0; MAX_JOINTS];
        let mut cols = [Vector6::zeros(); MAX_JOINTS];
        let mut iterations = 0;
        let mut need_jacobian = true;
        while iterations < opts.max_iterations {
            if res.pos_err_mm <= tight_pos && res.rot_err_rad <= tight_rot {
                break;
            }
            if need_jacobian {
                let axes = &bufs[cur];
                let p = axes.point;
                for (i, (c, (z, o))) in cols[..n].iter_mut().zip(&axes.axes).enumerate() {
                    *c = match self.prismatic_rate(i) {
                        None => {
                            let lin = z.cross(&(p - o));
                            Vector6::new(lin.x, lin.y, lin.z, z.x * scale, z.y * scale, z.z * scale)
                        }
                        Some(v) => Vector6::new(z.x * v, z.y * v, z.z * v, 0.0, 0.0, 0.0),
                    };
                }
                need_jacobian = false;
            }
            // Active set: a joint at a limit whose step points outward is frozen and the step
            // is solved again without it, so the remaining joints still make progress.
            let mut frozen = self.ik_held();
            let mut solved = false;
            iterations += 1;
            for _pass in 0..=n {
                // J Jᵀ over the free joints (lower triangle: all the factorisation reads;
                // each entry summed over the joints in order from +0, as `a += c·cᵀ` does).
                let mut a: Lower6 = [[0.0; 6]; 6];
                for (c, _) in cols[..n].iter().zip(&frozen).filter(|(_, f)| !**f) {
                    for (k, col) in a.iter_mut().enumerate() {
                        for (r, v) in col.iter_mut().enumerate().skip(k) {
                            *v += c[r] * c[k];
                        }
                    }
                }
                let diagonal = Vector6::new(a[0][0], a[1][1], a[2][2], a[3][3], a[4][4], a[5][5]);
                let lambda = mu * diagonal.max().max(1e-300);
                for (k, col) in a.iter_mut().enumerate() {
                    col[k] += lambda;
                }
                if !cholesky6(&mut a) {
                    break;
                }
                let y = cholesky6_solve(&a, &res.e);
                let mut steps = [0.0; MAX_JOINTS];
                for i in 0..n {
                    steps[i] = if frozen[i] { 0.0 } else { cols[i].dot(&y) };
                }
                let largest = steps[..n].iter().fold(0.0f64, |m, s| m.max(s.abs()));
                let shrink = if largest > opts.max_step_rad {
                    opts.max_step_rad / largest
                } else {
                    1.0
                };
                let mut newly_frozen = false;
                for i in 0..n {
                    let step = steps[i] * shrink;
                    let [lo, hi] = limits(i);
                    if (q_rad[i] <= lo && step < 0.0) || (q_rad[i] >= hi && step > 0.0) {
                        frozen[i] = true;
                        newly_frozen = true;
                    }
                    trial[i] = q_rad[i] + step;
                }
                if !newly_frozen {
                    solved = true;
                    break;
                }
            }
            if !solved {
                mu *= 10.0;
                if mu > MU_GIVE_UP {
                    break;
                }
                continue;
            }
            clamp(&mut trial[..n]);
            let new_res = self.ik_residual(target, &trial[..n], scale, &mut bufs[1 - cur]);
            if new_res.cost < res.cost {
                q_rad.copy_from_slice(&trial[..n]);
                res = new_res;
                cur = 1 - cur;
                mu = (mu * 0.1).max(1e-15);
                need_jacobian = true;
            } else {
                mu *= 10.0;
                if mu > MU_GIVE_UP {
                    break;
                }
            }
        }
        if res.pos_err_mm <= opts.tol_pos_mm && res.rot_err_rad <= opts.tol_rot_rad {
            Ok(IkReport {
                iterations,
                pos_err_mm: res.pos_err_mm,
                rot_err_rad: res.rot_err_rad,
            })
        } else {
            Err(IkError::NotConverged {
                iterations,
                pos_err_mm: res.pos_err_mm,
                rot_err_rad: res.rot_err_rad,
            })
        }
    }
}

/// How [`Robot::solve_ik_nearest`] searches for the exact solution nearest the start.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct IkSearch {
    /// A solution that moves no joint by more than this is taken without searching further,
    /// rad [2° = 0.0349: calibration corrections move joints by hundredths of a degree away
    /// from singularities, so a larger change means the start's own solution is far or gone].
    pub accept_change_rad: f64,
    /// Random starts after the start itself and its wrist flip (half around the start with a
    /// growing spread, half uniform within the limits) \[64: on the KR1000 and the UR10 every reachable target of 10,000 was found with
    /// fewer; each costs one damped Newton solve, spent only on rows the start did not solve
    /// nearby\].
    pub random_starts: usize,
    /// Seed of those starts [a fixed constant, so that the same target gives the same bytes].
    pub seed: u64,
}

impl Default for IkSearch {
    fn default() -> Self {
        IkSearch {
            accept_change_rad: 2.0_f64.to_radians(),
            random_starts: 64,
            seed: 0x6b69_6e63_616c_2d69,
        }
    }
}

/// The exact solution [`Robot::solve_ik_nearest`] returned.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NearestIk {
    /// The final solve's report (iterations of that solve only).
    pub report: IkReport,
    /// Largest change of a joint from the start, rad.
    pub max_change_rad: f64,
    /// The joint (0-based) with that change.
    pub joint: usize,
    /// Starts tried (1 when the start's own solve was near enough).
    pub starts: usize,
}

/// Why [`Robot::solve_ik_nearest`] found no exact solution within the joint limits.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum IkUnreachable {
    /// Exact solutions exist, but each puts a joint beyond its limits; the one shown is the
    /// nearest to the limits (after shifting joints by whole turns where they allow it).
    #[error(
        "beyond a joint limit: the nearest exact solution needs q{} = {:.2}° (limits {:.1}° … {:.1}°)",
        joint + 1,
        value_rad.to_degrees(),
        limits_rad[0].to_degrees(),
        limits_rad[1].to_degrees()
    )]
    BeyondLimit {
        /// The joint (0-based).
        joint: usize,
        /// The value it would need, rad.
        value_rad: f64,
        /// Its limits, rad.
        limits_rad: [f64; 2],
    },
    /// No configuration reaches the target even with the joint limits ignored, from any of
    /// the starts tried: the point (with the orientation held) is out of the arm's reach.
    #[error(
        "beyond reach: even without joint limits the closest configuration found misses by {pos_err_mm:.3} mm and {:.4}°",
        rot_err_rad.to_degrees()
    )]
    BeyondReach {
        /// Smallest position error found, mm.
        pos_err_mm: f64,
        /// The orientation error there, rad.
        rot_err_rad: f64,
    },
    /// Wrong joint count or non-finite input.
    #[error(transparent)]
    Input(IkError),
}

/// Small deterministic generator (xorshift64*) for the random starts.
struct Xorshift(u64);

impl Xorshift {
    fn unit(&mut self) -> f64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        (self.0.wrapping_mul(0x2545_f491_4f6c_dd1d) >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// Largest |a_i − b_i| and its index.
fn max_change(a: &[f64], b: &[f64]) -> (f64, usize) {
    a.iter()
        .zip(b)
        .enumerate()
        .fold((0.0, 0), |(m, k), (i, (x, y))| {
            let d = (x - y).abs();
            if d > m { (d, i) } else { (m, k) }
        })
}

/// Distance between joint vectors as [`Robot::solve_ik_nearest`] ranks them: the largest
/// joint change, then (to break ties) the sum of squared changes.
fn distance(a: &[f64], b: &[f64]) -> (f64, f64) {
    let sq = a.iter().zip(b).map(|(x, y)| (x - y) * (x - y)).sum::<f64>();
    (max_change(a, b).0, sq)
}

/// Geometric measures of how near a six-joint arm is to its three singularities (see
/// [`Robot::arm_singularity`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ArmSingularity {
    /// Angle between the axes of joints 4 and 6, degrees in [0, 90]: 0 at the wrist
    /// singularity (for a spherical wrist, |q5| or |180° − |q5||).
    pub wrist_deg: f64,
    /// Distance of the wrist point from the surface where joint 1 cannot move it out of the
    /// arm's plane, mm: `|(z₁ × (w − o₁)) · n|` with `n` normal to the plane of the joint-2
    /// and joint-3 motions. For an arm without shoulder offset it is the distance of the wrist
    /// point from the axis of joint 1; 0 at the shoulder singularity.
    pub shoulder_mm: f64,
    /// Angle between the directions in which joints 2 and 3 move the wrist point, degrees in
    /// [0, 90]: 0 with the elbow stretched (or folded back) — the elbow singularity.
    pub elbow_deg: f64,
    /// Distance of the wrist point from the origin of joint 2's axis, mm: the arm's length
    /// in this pose, the scale for [`ArmSingularity::shoulder_mm`].
    pub arm_mm: f64,
}

/// The angle between two lines (not directions) with the given direction vectors, in [0, 90]
/// degrees.
fn line_angle_deg(a: &Vector3<f64>, b: &Vector3<f64>) -> f64 {
    a.cross(b).norm().atan2(a.dot(b).abs()).to_degrees()
}

impl Robot {
    /// How near the configuration `q_rad` of a six-joint arm is to its wrist, shoulder and
    /// elbow singularities ([`ArmSingularity`]); `None` for other joint counts. The wrist
    /// point `w` is the origin of the frame before joint 6 (the wrist centre of a spherical
    /// wrist; the intersection of axes 5 and 6 of a UR arm); with `z_i`, `o_i` axis and origin
    /// of joint i and `c_i = z_i × (w − o_i)` how joint i moves `w`:
    /// wrist = ∠(z₄, z₆), elbow = ∠(c₂, c₃), shoulder = |c₁ · n|, `n` = z₂ when axes 2 and 3
    /// are parallel (as on most arms), else the unit normal of c₂ × c₃.
    pub fn arm_singularity(&self, q_rad: &[f64]) -> Option<ArmSingularity> {
        if self.n_joints() != 6 || q_rad.len() != 6 {
            return None;
        }
        let mut axes = [(Vector3::zeros(), Vector3::zeros()); MAX_JOINTS];
        self.joint_axes(q_rad, &mut axes);
        let w = axes[5].1;
        let c = |i: usize| axes[i].0.cross(&(w - axes[i].1));
        let (c1, c2, c3) = (c(0), c(1), c(2));
        let n = if axes[1].0.cross(&axes[2].0).norm() < 0.1 {
            axes[1].0
        } else {
            let m = c2.cross(&c3);
            if m.norm() > 0.0 {
                m.normalize()
            } else {
                axes[1].0
            }
        };
        Some(ArmSingularity {
            wrist_deg: line_angle_deg(&axes[3].0, &axes[5].0),
            shoulder_mm: c1.dot(&n).abs(),
            elbow_deg: line_angle_deg(&c2, &c3),
            arm_mm: (w - axes[1].1).norm(),
        })
    }

    /// One damped Newton solve ([`IkOptions`], no path fallback) from `q_rad` with the joint
    /// limits ignored: where the start's own branch leads.
    pub fn solve_ik_unlimited(
        &self,
        target: &IkTarget,
        q_rad: &mut [f64],
        opts: &IkOptions,
    ) -> Result<IkReport, IkError> {
        self.solve_ik_direct(target, q_rad, opts, false)
    }

    /// The exact IK solution nearest the start `q_rad` (overwritten with it), within the
    /// joint limits: [`Robot::solve_ik`] from the start; if that fails or moves a joint by
    /// more than [`IkSearch::accept_change_rad`], damped Newton from other starts too (the
    /// wrist flip `(q4 + π, −q5, q6 + π)`, then [`IkSearch::random_starts`] random starts:
    /// the first half around the start with a spread growing from 2° to 180°, the rest
    /// uniform within the limits), each solution also shifted by whole turns towards the start where the limits
    /// allow; the nearest (largest joint change, then sum of squares) is returned. The search
    /// stops at the first solution within `accept_change_rad`.
    ///
    /// Fails only when none of these starts reaches the target within the limits; the same
    /// search with the limits ignored then tells [`IkUnreachable::BeyondLimit`] from
    /// [`IkUnreachable::BeyondReach`]. On failure `q_rad` holds the start again.
    pub fn solve_ik_nearest(
        &self,
        target: &IkTarget,
        q_rad: &mut [f64],
        opts: &IkOptions,
        search: &IkSearch,
    ) -> Result<NearestIk, IkUnreachable> {
        let n = self.n_joints();
        if q_rad.len() != n {
            return Err(IkUnreachable::Input(IkError::Length {
                expected: n,
                found: q_rad.len(),
            }));
        }
        let mut q0 = [0.0; MAX_JOINTS];
        q0[..n].copy_from_slice(q_rad);
        let q0 = &q0[..n];
        let mut best: Option<([f64; MAX_JOINTS], IkReport, (f64, f64))> = None;
        let mut starts = 1;
        let mut worst = (f64::INFINITY, 0.0, 0.0);
        let mut note = |q: &[f64], r: Result<IkReport, IkError>, best: &mut Option<_>| match r {
            Ok(rep) => {
                let (q, rep) = self.nearest_turn(target, q, q0, opts, rep, true);
                let d = distance(&q[..n], q0);
                if best.as_ref().is_none_or(|(_, _, bd)| d < *bd) {
                    *best = Some((q, rep, d));
                }
            }
            Err(IkError::NotConverged {
                pos_err_mm,
                rot_err_rad,
                ..
            }) => {
                let cost = pos_err_mm.powi(2) + (rot_err_rad * opts.orientation_scale_mm).powi(2);
                if cost < worst.0 {
                    worst = (cost, pos_err_mm, rot_err_rad);
                }
            }
            Err(_) => {}
        };
        let first = self.solve_ik(target, q_rad, opts);
        if let Err(e @ (IkError::Length { .. } | IkError::NotFinite)) = first {
            q_rad.copy_from_slice(q0);
            return Err(IkUnreachable::Input(e));
        }
        note(q_rad, first, &mut best);
        let near = |best: &Option<([f64; MAX_JOINTS], IkReport, (f64, f64))>| {
            best.as_ref()
                .is_some_and(|(_, _, d)| d.0 <= search.accept_change_rad)
        };
        let mut rng = Xorshift(search.seed | 1);
        let mut k = 0;
        while !near(&best) && k < search.random_starts + 1 {
            let mut q = [0.0; MAX_JOINTS];
            if k == 0 {
                q[..n].copy_from_slice(q0);
                if n >= 6 {
                    q[3] += std::f64::consts::PI;
                    q[4] = -q[4];
                    q[5] += std::f64::consts::PI;
                }
            } else {
                self.random_start(q0, k, search.random_starts, &mut rng, &mut q[..n]);
            }
            k += 1;
            starts += 1;
            let r = self.solve_ik(target, &mut q[..n], opts);
            note(&q[..n], r, &mut best);
        }
        if let Some((q, report, d)) = best {
            q_rad.copy_from_slice(&q[..n]);
            let (_, joint) = max_change(&q[..n], q0);
            return Ok(NearestIk {
                report,
                max_change_rad: d.0,
                joint,
                starts,
            });
        }
        q_rad.copy_from_slice(q0);
        Err(self.why_unreachable(target, q0, opts, search, worst))
    }

    /// Random start `k` of `count` (1-based) around `q0`: each joint uniform within
    /// `q0 ± s`, the spread s growing geometrically from 2° (start 1) to 180° (start
    /// count/2), then uniform over the limits; clamped to the limits. Near starts find the
    /// solutions next to the start (the other elbow branch of a stretched arm with the wrist
    /// kept), far ones the other branches.
    fn random_start(&self, q0: &[f64], k: usize, count: usize, rng: &mut Xorshift, q: &mut [f64]) {
        let half = (count / 2).max(1);
        let pi = std::f64::consts::PI;
        for (i, v) in q.iter_mut().enumerate() {
            let [lo, hi] = self.limits_rad(i);
            let (lo, hi) = (lo.max(-4.0 * pi), hi.min(4.0 * pi));
            *v = if k <= half {
                let t = (k - 1) as f64 / (half.max(2) - 1) as f64;
                let spread = 2.0_f64.to_radians() * 90.0_f64.powf(t);
                (q0[i] + spread * (2.0 * rng.unit() - 1.0)).clamp(lo, hi)
            } else {
                lo + (hi - lo) * rng.unit()
            };
        }
    }

    /// `q` (a solution reached with report `rep`) with each joint shifted by whole turns
    /// towards `q0` where its limits allow (`limited`), solved again there (the same point
    /// of a periodic model: one Newton check).
    fn nearest_turn(
        &self,
        target: &IkTarget,
        q: &[f64],
        q0: &[f64],
        opts: &IkOptions,
        rep: IkReport,
        limited: bool,
    ) -> ([f64; MAX_JOINTS], IkReport) {
        let n = q.len();
        let mut out = [0.0; MAX_JOINTS];
        out[..n].copy_from_slice(q);
        let tau = std::f64::consts::TAU;
        let mut shifted = out;
        let mut moved = false;
        for i in 0..n {
            // Of q, q + ⌊d/τ⌋τ and q + ⌈d/τ⌉τ (d = q0 − q): the nearest q0 within the limits.
            let d = (q0[i] - q[i]) / tau;
            let [lo, hi] = self.limits_rad(i);
            let mut pick = q[i];
            for turns in [d.floor(), d.ceil()] {
                let v = q[i] + turns * tau;
                if (!limited || (lo..=hi).contains(&v)) && (v - q0[i]).abs() < (pick - q0[i]).abs()
                {
                    pick = v;
                }
            }
            if pick != q[i] {
                shifted[i] = pick;
                moved = true;
            }
        }
        if moved {
            let mut trial = shifted;
            if let Ok(r) = self.solve_ik_direct(target, &mut trial[..n], opts, limited) {
                return (trial, r);
            }
        }
        (out, rep)
    }

    /// The reason no exact solution was found within the limits: the same starts with the
    /// limits ignored ([`IkUnreachable::BeyondLimit`] if any converges, the one least beyond
    /// its limits) or [`IkUnreachable::BeyondReach`] with the smallest error seen.
    fn why_unreachable(
        &self,
        target: &IkTarget,
        q0: &[f64],
        opts: &IkOptions,
        search: &IkSearch,
        limited_worst: (f64, f64, f64),
    ) -> IkUnreachable {
        let n = q0.len();
        let mut rng = Xorshift(search.seed | 1);
        let mut closest = limited_worst;
        // (total violation, joint, value) of the solution least beyond its limits.
        let mut least: Option<(f64, usize, f64)> = None;
        for k in 0..search.random_starts + 2 {
            let mut q = [0.0; MAX_JOINTS];
            q[..n].copy_from_slice(q0);
            if k == 1 && n >= 6 {
                q[3] += std::f64::consts::PI;
                q[4] = -q[4];
                q[5] += std::f64::consts::PI;
            } else if k > 1 {
                self.random_start(q0, k - 1, search.random_starts, &mut rng, &mut q[..n]);
            }
            match self.solve_ik_direct(target, &mut q[..n], opts, false) {
                Ok(_) => {
                    // Each joint by whole turns into (or nearest to) its limits.
                    let mut total = 0.0;
                    let mut worst_joint = (0.0, 0, 0.0);
                    for (i, v) in q[..n].iter().enumerate() {
                        let [lo, hi] = self.limits_rad(i);
                        let mid = 0.5 * (lo + hi);
                        let t = std::f64::consts::TAU;
                        let w = v + ((mid - v) / t).round() * t;
                        let over = (lo - w).max(w - hi).max(0.0);
                        total += over;
                        if over > worst_joint.0 {
                            worst_joint = (over, i, w);
                        }
                    }
                    if least.is_none_or(|(t, _, _)| total < t) {
                        least = Some((total, worst_joint.1, worst_joint.2));
                    }
                }
                Err(IkError::NotConverged {
                    pos_err_mm,
                    rot_err_rad,
                    ..
                }) => {
                    let cost =
                        pos_err_mm.powi(2) + (rot_err_rad * opts.orientation_scale_mm).powi(2);
                    if cost < closest.0 {
                        closest = (cost, pos_err_mm, rot_err_rad);
                    }
                }
                Err(e) => return IkUnreachable::Input(e),
            }
        }
        match least {
            Some((_, joint, value_rad)) => IkUnreachable::BeyondLimit {
                joint,
                value_rad,
                limits_rad: self.limits_rad(joint),
            },
            None => IkUnreachable::BeyondReach {
                pos_err_mm: closest.1,
                rot_err_rad: closest.2,
            },
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Matrix6;

    /// The fixed-size factorisation and solve are nalgebra's, bit for bit (successes,
    /// failures and every value), on Gram matrices of rank 1 to 6 with damping from none to
    /// large.
    #[test]
    fn cholesky6_matches_nalgebra_bit_for_bit() {
        let mut state = 0x9e37_79b9_7f4a_7c15_u64;
        let mut next = || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
        };
        let mut outcomes = [0usize; 2];
        for case in 0..20_000 {
            let rank = 1 + case % 7;
            let mut cols = [Vector6::zeros(); 7];
            for c in cols.iter_mut().take(rank) {
                for v in c.iter_mut() {
                    *v = next() * 10f64.powi((next() * 4.0) as i32);
                }
            }
            let mu = [0.0, 1e-15, 1e-9, 1e-3, 1.0][case % 5];
            let mut reference = Matrix6::zeros();
            let mut l: Lower6 = [[0.0; 6]; 6];
            for c in &cols[..rank] {
                reference += c * c.transpose();
                for (k, col) in l.iter_mut().enumerate() {
                    for (r, v) in col.iter_mut().enumerate().skip(k) {
                        *v += c[r] * c[k];
                    }
                }
            }
            let lambda = mu * reference.diagonal().max();
            for k in 0..6 {
                reference[(k, k)] += lambda;
                l[k][k] += lambda;
            }
            let b = Vector6::from_fn(|_, _| next());
            let ok = cholesky6(&mut l);
            let chol = reference.cholesky();
            assert_eq!(ok, chol.is_some(), "case {case}");
            outcomes[usize::from(ok)] += 1;
            if let Some(chol) = chol {
                let factor = chol.l_dirty();
                for j in 0..6 {
                    for i in j..6 {
                        assert_eq!(l[j][i].to_bits(), factor[(i, j)].to_bits());
                    }
                }
                let y = cholesky6_solve(&l, &b);
                let y0 = chol.solve(&b);
                assert_eq!(y.map(f64::to_bits), y0.map(f64::to_bits), "case {case}");
            }
        }
        assert!(outcomes.iter().all(|n| *n > 1000), "{outcomes:?}");
    }
}
