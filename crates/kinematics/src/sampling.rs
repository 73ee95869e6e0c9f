//! Admissible random poses: the one pose sampler of the workspace.
//!
//! A draw takes every joint uniformly within its limits, in degrees
//! (`lo + (hi − lo)·u`, `u` the generator's `f64` in [0, 1)), converted once with
//! `to_radians`, so that degrees written to a file convert back to exactly the radians used.
//! A draw that rounding puts outside a limit is drawn again (it counts as a draw). The
//! checks, in this order, a rejected draw counted under the first it fails:
//! 1. wrist: `|q5| ≥` [`PoseSampler::min_abs_wrist_deg`] (away from the wrist singularity of
//!    a spherical wrist; robots with fewer than 5 joints skip it);
//! 2. the caller's screen, if any ([`PoseSampler::sample_screened`]: the virtual robot's
//!    floor and tracker window, for instance), given the joints and their sines and cosines;
//! 3. condition: [`Robot::singularity_condition`]`(q, orientation_scale_mm) ≤ max_condition`
//!    (`None` disables it), decided by [`condition_at_most`] without an SVD in most cases.
//!
//! The caller supplies the random generator (the virtual robot its per-trial streams,
//! `identify::generic_poses` a fixed seed): this crate draws nothing of its own. Sampling
//! gives up after `count · max_draws_per_pose` draws ([`Exhausted`], [`SamplingError`]).

use nalgebra::{Cholesky, Matrix6, Vector3};
use rand::{Rng, RngExt};

use crate::ik::cholesky6;
use crate::model::MAX_JOINTS;
use crate::robot::{Robot, gram_of_axes};

/// The admissibility rule of [`PoseSampler::sample`]. Defaults in brackets.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PoseSampler {
    /// Smallest |q5|, degrees [10: a margin around the wrist singularity q5 = 0]; robots
    /// with fewer than 5 joints skip the test.
    pub min_abs_wrist_deg: f64,
    /// Largest condition number of the 6 × N geometric Jacobian of the flange origin
    /// [Some(100): away from shoulder and elbow singularities too; `None`: no limit].
    pub max_condition: Option<f64>,
    /// Length weighing rotation against translation in that Jacobian, mm [1000, the order of
    /// a large robot's reach].
    pub orientation_scale_mm: f64,
    /// Draws allowed per pose wanted before giving up \[1000\].
    pub max_draws_per_pose: u64,
}

impl Default for PoseSampler {
    fn default() -> Self {
        PoseSampler {
            min_abs_wrist_deg: 10.0,
            max_condition: Some(100.0),
            orientation_scale_mm: 1000.0,
            max_draws_per_pose: 1000,
        }
    }
}

/// Why a draw was rejected: the sampler's own tests or the caller's screen.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Rejection<E> {
    /// |q5| below [`PoseSampler::min_abs_wrist_deg`].
    Wrist,
    /// The caller's screen said no, for this reason.
    Screen(E),
    /// The condition number above [`PoseSampler::max_condition`].
    Condition,
}

/// The poses a sampler accepted, in order.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Sampled<T = ()> {
    /// Joints, degrees, flat with stride N (as drawn).
    pub deg: Vec<f64>,
    /// The same in radians (`to_radians` of each value).
    pub rad: Vec<f64>,
    /// What the screen returned for each accepted pose.
    pub kept: Vec<T>,
    /// Draws made (accepted, rejected and redrawn at a limit).
    pub draws: u64,
}

/// Sampling gave up: the constraints left too few poses within the draws allowed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Exhausted {
    /// Poses wanted.
    pub wanted: usize,
    /// Poses accepted before giving up.
    pub accepted: usize,
    /// Draws made (`wanted · max_draws_per_pose`).
    pub draws: u64,
}

/// [`PoseSampler::sample`] gave up; the counts name the constraint that rejected most.
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
#[error(
    "pose sampling: the constraints left only {} of {} poses after {} draws \
     (rejected: wrist {rejected_wrist}, condition {rejected_condition})",
    exhausted.accepted, exhausted.wanted, exhausted.draws
)]
pub struct SamplingError {
    /// Wanted, accepted and drawn.
    pub exhausted: Exhausted,
    /// Draws rejected by the wrist test.
    pub rejected_wrist: u64,
    /// Draws rejected by the condition test.
    pub rejected_condition: u64,
}

impl PoseSampler {
    /// `count` admissible poses of `robot` drawn from `rng`.
    pub fn sample<R: Rng + ?Sized>(
        &self,
        robot: &Robot,
        count: usize,
        rng: &mut R,
    ) -> Result<Sampled, SamplingError> {
        let (mut wrist, mut condition) = (0, 0);
        self.sample_screened(
            robot,
            count,
            rng,
            |_, _| Ok::<(), ()>(()),
            |r| match r {
                Rejection::Wrist => wrist += 1,
                Rejection::Condition => condition += 1,
                Rejection::Screen(()) => {}
            },
        )
        .map_err(|exhausted| SamplingError {
            exhausted,
            rejected_wrist: wrist,
            rejected_condition: condition,
        })
    }

    /// `count` poses of `robot` drawn from `rng` that pass the wrist test, then
    /// `screen(q_rad, sc)` (`sc[i] = [sin q_i, cos q_i]`, [`crate::trig::joint_sin_cos`]'s bits), then
    /// the condition test (see the module docs). Each rejection is reported to `rejected`;
    /// what `screen` returns for an accepted pose is kept in [`Sampled::kept`].
    pub fn sample_screened<R, T, E>(
        &self,
        robot: &Robot,
        count: usize,
        rng: &mut R,
        screen: impl FnMut(&[f64], &[[f64; 2]]) -> Result<T, E>,
        rejected: impl FnMut(Rejection<E>),
    ) -> Result<Sampled<T>, Exhausted>
    where
        R: Rng + ?Sized,
    {
        let mut out = Sampled {
            deg: Vec::new(),
            rad: Vec::new(),
            kept: Vec::new(),
            draws: 0,
        };
        self.sample_screened_into(robot, count, rng, screen, rejected, &mut out)?;
        Ok(out)
    }

    /// [`PoseSampler::sample_screened`] into `out` (cleared first; its vectors keep their
    /// room, so a sampler refilling the same `out` allocates nothing once it has the room:
    /// a campaign's kept virtual robot). The same draws and poses. On `Err`, `out` holds the
    /// poses accepted before giving up.
    pub fn sample_screened_into<R, T, E>(
        &self,
        robot: &Robot,
        count: usize,
        rng: &mut R,
        mut screen: impl FnMut(&[f64], &[[f64; 2]]) -> Result<T, E>,
        mut rejected: impl FnMut(Rejection<E>),
        out: &mut Sampled<T>,
    ) -> Result<(), Exhausted>
    where
        R: Rng + ?Sized,
    {
        let n = robot.n_joints();
        let mut limits_deg = [[0.0; 2]; MAX_JOINTS];
        for (i, l) in limits_deg.iter_mut().enumerate().take(n) {
            let [lo, hi] = robot.limits_rad(i);
            *l = [lo.to_degrees(), hi.to_degrees()];
        }
        let min_wrist_rad = self.min_abs_wrist_deg.to_radians();
        let wrist = robot.wrist_joint();
        out.deg.clear();
        out.rad.clear();
        out.kept.clear();
        out.draws = 0;
        out.deg.reserve_exact(count * n);
        out.rad.reserve_exact(count * n);
        out.kept.reserve_exact(count);
        let max_draws = (count as u64).saturating_mul(self.max_draws_per_pose);
        let mut qd = [0.0; MAX_JOINTS];
        let mut qr = [0.0; MAX_JOINTS];
        let mut sc = [[0.0; 2]; MAX_JOINTS];
        while out.kept.len() < count {
            if out.draws >= max_draws {
                return Err(Exhausted {
                    wanted: count,
                    accepted: out.kept.len(),
                    draws: out.draws,
                });
            }
            out.draws += 1;
            for i in 0..n {
                let [lo, hi] = limits_deg[i];
                qd[i] = lo + (hi - lo) * rng.random::<f64>();
                qr[i] = qd[i].to_radians();
            }
            let q = &qr[..n];
            if !robot.in_limits(q) {
                // Only possible through rounding at a limit; redraw (counted as a draw).
                continue;
            }
            if let Some(w) = wrist
                && q[w].abs() < min_wrist_rad
            {
                rejected(Rejection::Wrist);
                continue;
            }
            robot.joint_trig(q, &mut sc);
            let kept = match screen(q, &sc[..n]) {
                Ok(k) => k,
                Err(e) => {
                    rejected(Rejection::Screen(e));
                    continue;
                }
            };
            if let Some(limit) = self.max_condition
                && !condition_at_most(robot, q, &sc[..n], self.orientation_scale_mm, limit)
            {
                rejected(Rejection::Condition);
                continue;
            }
            out.deg.extend_from_slice(&qd[..n]);
            out.rad.extend_from_slice(q);
            out.kept.push(kept);
        }
        Ok(())
    }
}

/// `robot.singularity_condition(q_rad, scale_mm) ≤ limit`, decided without an SVD in most
/// cases; `sc` holds `[sin q_i, cos q_i]` of `q_rad` ([`crate::trig::joint_sin_cos`]'s bits).
///
/// With `M = J Jᵀ` (6×6; its eigenvalues are the squared singular values σ² of the 6×N
/// geometric Jacobian when N ≥ 6) and `c = 1/limit²`: every eigenvalue lies in
/// `[max_k M_kk, tr M] ∋ λ_max`, so a Cholesky factorisation of `M − c·tr(M)·I` proves
/// `λ_min ≥ λ_max/limit²` (accept) and the failure of one of `M − c·max_k M_kk·I` proves
/// the opposite (reject). Only the undecided remainder (and N < 6) pays for the SVD.
pub fn condition_at_most(
    robot: &Robot,
    q_rad: &[f64],
    sc: &[[f64; 2]],
    scale_mm: f64,
    limit: f64,
) -> bool {
    if q_rad.len() >= 6 {
        let m = geometric_gram_trig(robot, sc, scale_mm);
        let c = 1.0 / (limit * limit);
        if shifted_cholesky_ok(&m, c * m.trace()) {
            return true;
        }
        let max_diag = (0..6).map(|k| m[(k, k)]).fold(0.0, f64::max);
        if !shifted_cholesky_ok(&m, c * max_diag) {
            return false;
        }
    }
    robot.singularity_condition(q_rad, scale_mm) <= limit
}

/// [`Robot::geometric_gram`] of the flange origin at the joints whose `[sin q, cos q]` are
/// `sc`: the same chain and the same sum, so the same bits.
fn geometric_gram_trig(robot: &Robot, sc: &[[f64; 2]], scale_mm: f64) -> Matrix6<f64> {
    let mut axes = [(Vector3::zeros(), Vector3::zeros()); MAX_JOINTS];
    let f = robot.joint_axes_trig(sc, &mut axes);
    let p = f.transform_point(&Vector3::zeros());
    let axes = axes[..sc.len()].iter().enumerate();
    gram_of_axes(
        axes.map(|(i, (z, o))| (*z, *o, robot.prismatic_rate(i))),
        &p,
        scale_mm,
    )
}

/// Whether nalgebra's `Cholesky::new(m − I·t)` succeeds, decided by the same operations in
/// the same order (its left-looking column algorithm: `a_ij − a_jk·a_ik` over k, then
/// `a_jj > 0`, its square root, and the column divided by it) on a fixed-size array.
/// Non-finite `t` goes to nalgebra itself.
fn shifted_cholesky_ok(m: &Matrix6<f64>, t: f64) -> bool {
    if !t.is_finite() {
        return Cholesky::new(m - Matrix6::identity() * t).is_some();
    }
    // l[j][i]: column j, row i (lower triangle), as `m − I·t` elementwise.
    let mut l = [[0.0; 6]; 6];
    for (j, col) in l.iter_mut().enumerate() {
        for (i, v) in col.iter_mut().enumerate().skip(j) {
            let id = if i == j { 1.0 } else { 0.0 };
            *v = m[(i, j)] - id * t;
        }
    }
    cholesky6(&mut l)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::RobotSpec;
    use crate::trig::joint_sin_cos;
    use rand::SeedableRng;
    use rand::rngs::ChaCha8Rng;

    fn kr1000() -> Robot {
        let text = include_str!("../../../scenarios/robots/kr1000-titan.json");
        Robot::from_spec(&RobotSpec::from_json_str(text, "kr1000").unwrap()).unwrap()
    }

    /// The fixed-size Gram and Cholesky decisions are nalgebra's, bit for bit.
    #[test]
    fn gram_and_cholesky_replicas_match_nalgebra() {
        let robot = kr1000();
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        let mut q = [0.0; 6];
        let mut outcomes = [0usize; 2];
        for _ in 0..3000 {
            for (i, v) in q.iter_mut().enumerate() {
                let [lo, hi] = robot.limits_rad(i);
                *v = lo + (hi - lo) * rng.random::<f64>();
            }
            let mut sc = [[0.0; 2]; MAX_JOINTS];
            joint_sin_cos(&q, &mut sc);
            let m = geometric_gram_trig(&robot, &sc[..6], 1000.0);
            let reference = robot.geometric_gram(&q, &Vector3::zeros(), 1000.0);
            assert!(
                m.iter()
                    .zip(reference.iter())
                    .all(|(a, b)| a.to_bits() == b.to_bits())
            );
            // Shifts around λ_min, where the factorisation's outcome is decided by rounding.
            let lmin = m.symmetric_eigenvalues().min();
            for t in [
                0.0,
                lmin * (1.0 - 1e-12),
                lmin,
                lmin * (1.0 + 1e-12),
                lmin * 0.5,
                lmin * 2.0,
                1e-4 * m.trace(),
                f64::INFINITY,
                f64::NAN,
            ] {
                let ok = shifted_cholesky_ok(&m, t);
                assert_eq!(ok, Cholesky::new(m - Matrix6::identity() * t).is_some());
                outcomes[usize::from(ok)] += 1;
            }
        }
        assert!(outcomes.iter().all(|n| *n > 3000), "{outcomes:?}");
    }

    #[test]
    fn condition_bounds_agree_with_the_svd() {
        let robot = kr1000();
        let mut rng = ChaCha8Rng::seed_from_u64(1);
        let mut q = [0.0; 6];
        let mut decided_both_ways = [0usize; 2];
        for _ in 0..2000 {
            for (i, v) in q.iter_mut().enumerate() {
                let [lo, hi] = robot.limits_rad(i);
                *v = lo + (hi - lo) * rng.random::<f64>();
            }
            let exact = robot.singularity_condition(&q, 1000.0);
            let mut sc = [[0.0; 2]; MAX_JOINTS];
            joint_sin_cos(&q, &mut sc);
            for limit in [3.0, 8.0, 30.0, 100.0] {
                // Skip the rounding-level tie band around the limit.
                if ((exact - limit) / limit).abs() < 1e-9 {
                    continue;
                }
                let fast = condition_at_most(&robot, &q, &sc[..6], 1000.0, limit);
                assert_eq!(
                    fast,
                    exact <= limit,
                    "cond {exact} vs limit {limit} at {q:?}"
                );
                decided_both_ways[usize::from(fast)] += 1;
            }
        }
        assert!(
            decided_both_ways.iter().all(|n| *n > 500),
            "{decided_both_ways:?}"
        );
    }

    /// Every pose within the limits, away from the wrist singularity and well conditioned;
    /// the same generator state gives the same poses; the screen's rejections are counted.
    #[test]
    fn sampled_poses_are_admissible_and_reproducible() {
        let robot = kr1000();
        let sampler = PoseSampler::default();
        let a = sampler
            .sample(&robot, 40, &mut ChaCha8Rng::seed_from_u64(5))
            .unwrap();
        let b = sampler
            .sample(&robot, 40, &mut ChaCha8Rng::seed_from_u64(5))
            .unwrap();
        assert_eq!(a, b);
        assert_eq!((a.rad.len(), a.deg.len(), a.kept.len()), (240, 240, 40));
        for (q, d) in a.rad.chunks_exact(6).zip(a.deg.chunks_exact(6)) {
            assert!(robot.in_limits(q));
            assert!(q[4].abs() >= 10f64.to_radians());
            assert!(robot.singularity_condition(q, 1000.0) <= 100.0);
            assert!(q.iter().zip(d).all(|(r, d)| *r == d.to_radians()));
        }
        // A screen refusing every other pose: each refusal reported once, as the screen's.
        let (mut screened, mut other, mut calls) = (0, 0, 0);
        let s = sampler
            .sample_screened(
                &robot,
                10,
                &mut ChaCha8Rng::seed_from_u64(5),
                |_, _| {
                    calls += 1;
                    if calls % 2 == 0 { Err("no") } else { Ok(calls) }
                },
                |r| match r {
                    Rejection::Screen("no") => screened += 1,
                    _ => other += 1,
                },
            )
            .unwrap();
        assert_eq!(s.draws, 10 + screened + other);
        assert!(screened >= 9, "{screened}");
        // Nothing passes: the error says how many were wanted, found and drawn.
        let strict = PoseSampler {
            max_condition: Some(1.0),
            max_draws_per_pose: 3,
            ..sampler
        };
        let err = strict
            .sample(&robot, 4, &mut ChaCha8Rng::seed_from_u64(5))
            .unwrap_err();
        assert_eq!(
            (
                err.exhausted.wanted,
                err.exhausted.accepted,
                err.exhausted.draws
            ),
            (4, 0, 12)
        );
        assert_eq!(err.rejected_wrist + err.rejected_condition, 12);
        assert!(err.to_string().contains("only 0 of 4 poses after 12 draws"));
    }
}
