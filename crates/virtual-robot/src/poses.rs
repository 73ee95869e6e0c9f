//! The `poses` section: which joint configurations are measured.
//!
//! Each set (`identification`, `validation`) is either a count — poses drawn uniformly
//! within the joint limits from the trial's own stream and kept if they pass every
//! constraint — or an explicit list of joint configurations in degrees, used as given.
//!
//! Constraints, checked in this order; a rejected draw is counted under the first it fails:
//! 1. `wrist`: `|q5| ≥ min_abs_q5_deg` (away from the wrist singularity; robots with fewer
//!    than 5 joints skip it);
//! 2. `floor`: the point's height `z ≥ min_point_z_mm` (robot base frame);
//! 3. `elevation` and 4. `range`: the tracker sees the point (its window shrunk by
//!    [`SAMPLING_MARGIN_DEG`] and its range by [`SAMPLING_MARGIN_MM`] at each end, so
//!    scatter and drift cannot push a sampled pose out of view);
//! 5. `condition`: [`Robot::singularity_condition`]`(q, condition_orientation_scale_mm)
//!    ≤ max_condition` on the nominal robot (`null` disables the check).
//!
//! The point is where the true robot puts it (true geometry, compliance and gears: the
//! operator checks poses on the real robot); for the error-scaling set, drawn before the
//! truth exists, it is the nominal robot's point. Sampling gives up after
//! `count · max_draws_per_pose` draws with an error naming the set and the rejection counts.
//! Joint values are drawn in degrees and converted once with `to_radians`, so the degrees
//! written to the measurement file convert back to exactly the radians simulated.
//!
//! ```json
//! "poses": { "identification": 50, "validation": [[0, 10, -20, 0, 45, 0], [30, 20, -10, 5, 60, 0]],
//!            "min_point_z_mm": 300, "min_abs_q5_deg": 10, "max_condition": 100,
//!            "condition_orientation_scale_mm": 1000, "max_draws_per_pose": 1000 }
//! ```

use std::fmt;

use kinematics::{Frame, MAX_JOINTS, Robot};
use nalgebra::{Cholesky, Matrix6, Vector3};
use rand::RngExt;
use rand::rngs::ChaCha8Rng;
use serde::de::{self, SeqAccess, Visitor};
use serde::{Deserialize, Deserializer, Serialize, Serializer};

use crate::error::{ConfigError, NotMeasurable, SimError};
use crate::tracker::Tracker;
use crate::unmodelled::{CmdTrig, Unmodelled};
use crate::validate::{finite, non_negative, positive};

/// Elevation margin kept from the tracker's window edge when sampling, degrees.
pub const SAMPLING_MARGIN_DEG: f64 = 0.1;
/// Range margin kept from the tracker's range ends when sampling, mm.
pub const SAMPLING_MARGIN_MM: f64 = 10.0;

/// A pose set: a count of random poses or an explicit list (JSON: a number or an array of
/// arrays of degrees).
#[derive(Clone, Debug, PartialEq)]
pub enum PoseSet {
    /// Draw this many poses.
    Count(usize),
    /// These joint configurations, degrees, one row per pose.
    ListDeg(Vec<Vec<f64>>),
}

impl PoseSet {
    /// Number of poses of the set.
    pub fn len(&self) -> usize {
        match self {
            PoseSet::Count(n) => *n,
            PoseSet::ListDeg(v) => v.len(),
        }
    }

    /// True if the set has no pose.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

impl Serialize for PoseSet {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        match self {
            PoseSet::Count(n) => s.serialize_u64(*n as u64),
            PoseSet::ListDeg(v) => v.serialize(s),
        }
    }
}

impl<'de> Deserialize<'de> for PoseSet {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl<'de> Visitor<'de> for V {
            type Value = PoseSet;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("a pose count or a list of joint configurations in degrees")
            }
            fn visit_u64<E: de::Error>(self, v: u64) -> Result<PoseSet, E> {
                usize::try_from(v)
                    .map(PoseSet::Count)
                    .map_err(|_| E::custom(format!("pose count {v} is too large")))
            }
            fn visit_i64<E: de::Error>(self, v: i64) -> Result<PoseSet, E> {
                u64::try_from(v)
                    .map_err(|_| E::custom(format!("pose count {v} is negative")))
                    .and_then(|u| self.visit_u64(u))
            }
            fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<PoseSet, A::Error> {
                let mut rows = Vec::new();
                while let Some(row) = seq.next_element::<Vec<f64>>()? {
                    rows.push(row);
                }
                Ok(PoseSet::ListDeg(rows))
            }
        }
        d.deserialize_any(V)
    }
}

/// The `poses` section (see the module docs).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct PoseSampling {
    /// Identification poses (default 50 random).
    pub identification: PoseSet,
    /// Validation poses (default 50 random).
    pub validation: PoseSet,
    /// Lowest allowed height of the point above the robot base, mm (default 300).
    pub min_point_z_mm: f64,
    /// Smallest allowed |q5|, degrees (default 10).
    pub min_abs_q5_deg: f64,
    /// Largest allowed condition number (default 100; `null`: no limit).
    pub max_condition: Option<f64>,
    /// Orientation scale of the condition number's Jacobian, mm (default 1000).
    pub condition_orientation_scale_mm: f64,
    /// Draws allowed per wanted pose before sampling fails (default 1000).
    pub max_draws_per_pose: u64,
}

impl Default for PoseSampling {
    fn default() -> Self {
        PoseSampling {
            identification: PoseSet::Count(50),
            validation: PoseSet::Count(50),
            min_point_z_mm: 300.0,
            min_abs_q5_deg: 10.0,
            max_condition: Some(100.0),
            condition_orientation_scale_mm: 1000.0,
            max_draws_per_pose: 1000,
        }
    }
}

impl PoseSampling {
    /// Checks counts (≥ 1), explicit rows (N finite values within the joint limits) and the
    /// constraint values.
    pub fn validate(&self, nominal: &Robot) -> Result<(), ConfigError> {
        validate_set("poses.identification", &self.identification, nominal)?;
        validate_set("poses.validation", &self.validation, nominal)?;
        finite("poses.min_point_z_mm", self.min_point_z_mm)?;
        non_negative("poses.min_abs_q5_deg", self.min_abs_q5_deg)?;
        if self.min_abs_q5_deg >= 180.0 {
            return Err(ConfigError::invalid(
                "poses.min_abs_q5_deg",
                format!("must be below 180°, got {:?}", self.min_abs_q5_deg),
            ));
        }
        if let Some(c) = self.max_condition {
            finite("poses.max_condition", c)?;
            if c < 1.0 {
                return Err(ConfigError::invalid(
                    "poses.max_condition",
                    format!("a condition number is at least 1, got {c:?}"),
                ));
            }
        }
        positive(
            "poses.condition_orientation_scale_mm",
            self.condition_orientation_scale_mm,
        )?;
        if self.max_draws_per_pose == 0 {
            return Err(ConfigError::invalid(
                "poses.max_draws_per_pose",
                "must be at least 1",
            ));
        }
        Ok(())
    }
}

fn validate_set(field: &str, set: &PoseSet, robot: &Robot) -> Result<(), ConfigError> {
    if set.is_empty() {
        return Err(ConfigError::invalid(
            field,
            "the set needs at least one pose, got 0",
        ));
    }
    let PoseSet::ListDeg(rows) = set else {
        return Ok(());
    };
    let n = robot.n_joints();
    for (r, row) in rows.iter().enumerate() {
        if row.len() != n {
            return Err(ConfigError::invalid(
                format!("{field}[{r}]"),
                format!("{} joint values for a robot with {n} joints", row.len()),
            ));
        }
        for (i, v) in row.iter().enumerate() {
            let f = format!("{field}[{r}][{i}]");
            finite(&f, *v)?;
            let [lo, hi] = robot.limits_rad(i);
            let q = v.to_radians();
            if !(q >= lo && q <= hi) {
                return Err(ConfigError::invalid(
                    f,
                    format!(
                        "q{} = {v}° is outside its limits [{}, {}]°",
                        i + 1,
                        lo.to_degrees(),
                        hi.to_degrees()
                    ),
                ));
            }
        }
    }
    Ok(())
}

/// What the sampler of one pose set saw.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SamplingStats {
    /// Poses wanted.
    pub wanted: usize,
    /// Poses accepted.
    pub accepted: usize,
    /// Candidate draws (0 for an explicit list).
    pub draws: u64,
    /// Rejected for |q5| below the limit.
    pub rejected_wrist: u64,
    /// Rejected for the point below the floor clearance.
    pub rejected_floor: u64,
    /// Rejected for being outside the tracker's elevation window.
    pub rejected_elevation: u64,
    /// Rejected for being outside the tracker's range.
    pub rejected_range: u64,
    /// Rejected for the condition number above the limit.
    pub rejected_condition: u64,
}

impl SamplingStats {
    /// Total rejected draws.
    pub fn rejected(&self) -> u64 {
        self.rejected_wrist
            + self.rejected_floor
            + self.rejected_elevation
            + self.rejected_range
            + self.rejected_condition
    }

    /// Rejected / drawn (0 when nothing was drawn).
    pub fn rejection_rate(&self) -> f64 {
        if self.draws == 0 {
            0.0
        } else {
            self.rejected() as f64 / self.draws as f64
        }
    }

    /// `"wrist 3, floor 0, elevation 12, range 0, condition 1"`.
    pub fn rejections_text(&self) -> String {
        format!(
            "wrist {}, floor {}, elevation {}, range {}, condition {}",
            self.rejected_wrist,
            self.rejected_floor,
            self.rejected_elevation,
            self.rejected_range,
            self.rejected_condition
        )
    }

    /// Sum of two reports.
    pub fn merged(&self, other: &SamplingStats) -> SamplingStats {
        SamplingStats {
            wanted: self.wanted + other.wanted,
            accepted: self.accepted + other.accepted,
            draws: self.draws + other.draws,
            rejected_wrist: self.rejected_wrist + other.rejected_wrist,
            rejected_floor: self.rejected_floor + other.rejected_floor,
            rejected_elevation: self.rejected_elevation + other.rejected_elevation,
            rejected_range: self.rejected_range + other.rejected_range,
            rejected_condition: self.rejected_condition + other.rejected_condition,
        }
    }
}

/// Sampling statistics of one trial.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SamplingReport {
    /// The identification set.
    pub identification: SamplingStats,
    /// The validation set.
    pub validation: SamplingStats,
    /// The error-scaling set (`None` without `truth.scale_to`).
    pub scale: Option<SamplingStats>,
}

impl SamplingReport {
    /// Identification and validation together.
    pub fn total(&self) -> SamplingStats {
        self.identification.merged(&self.validation)
    }

    /// Rejection rate of identification and validation together.
    pub fn rejection_rate(&self) -> f64 {
        self.total().rejection_rate()
    }
}

/// Which constraint a pose fails.
enum Reject {
    Wrist,
    Floor,
    Elevation,
    Range,
    Condition,
}

/// Checks the constraints for one pose whose point (robot base frame) is
/// `point(q_rad, trig)`, computed only once the wrist test has passed; `trig` holds the
/// sines and cosines of `q_rad` (and of `unmodelled`'s gear terms), computed once for the
/// point and the condition test. Returns the point of an accepted pose.
fn check(
    cfg: &PoseSampling,
    nominal: &Robot,
    tracker: &Tracker,
    q_rad: &[f64],
    unmodelled: Option<&Unmodelled>,
    point: &dyn Fn(&[f64], &CmdTrig) -> Vector3<f64>,
) -> Result<Vector3<f64>, Reject> {
    if q_rad.len() >= 5 && q_rad[4].abs() < cfg.min_abs_q5_deg.to_radians() {
        return Err(Reject::Wrist);
    }
    let mut trig = CmdTrig::default();
    trig.compute(unmodelled, q_rad);
    let point = point(q_rad, &trig);
    if point.z < cfg.min_point_z_mm {
        return Err(Reject::Floor);
    }
    match tracker.check_window(&point, SAMPLING_MARGIN_DEG, SAMPLING_MARGIN_MM) {
        Err(NotMeasurable::Elevation { .. }) => return Err(Reject::Elevation),
        Err(_) => return Err(Reject::Range),
        Ok(()) => {}
    }
    if let Some(limit) = cfg.max_condition
        && !condition_at_most_trig(
            nominal,
            q_rad,
            &trig.sc[..q_rad.len()],
            cfg.condition_orientation_scale_mm,
            limit,
        )
    {
        return Err(Reject::Condition);
    }
    Ok(point)
}

/// `robot.singularity_condition(q, scale) ≤ limit`, decided without an SVD in most cases.
///
/// With `M = J Jᵀ` (6×6; its eigenvalues are the squared singular values σ² of the 6×N
/// geometric Jacobian when N ≥ 6) and `c = 1/limit²`: every eigenvalue lies in
/// `[max_k M_kk, tr M] ∋ λ_max`, so a Cholesky factorisation of `M − c·tr(M)·I` proves
/// `λ_min ≥ λ_max/limit²` (accept) and the failure of one of `M − c·max_k M_kk·I` proves
/// the opposite (reject). Only the undecided remainder (and N < 6) pays for the SVD.
#[cfg(test)]
fn condition_at_most(robot: &Robot, q_rad: &[f64], scale_mm: f64, limit: f64) -> bool {
    let mut sc = [[0.0; 2]; MAX_JOINTS];
    kinematics::joint_sin_cos(q_rad, &mut sc);
    condition_at_most_trig(robot, q_rad, &sc[..q_rad.len()], scale_mm, limit)
}

/// [`Robot::geometric_gram`] of the flange origin at the joints whose `[sin q, cos q]` are
/// `sc`: the same operations on the same chain ([`Robot::frames_trig`] gives the axes and
/// origins `joint_axes` does), so the same bits.
fn geometric_gram_trig(robot: &Robot, sc: &[[f64; 2]], scale_mm: f64) -> Matrix6<f64> {
    let n = sc.len();
    let mut frames = [Frame::identity(); MAX_JOINTS + 1];
    robot.frames_trig(sc, &mut frames);
    let p = frames[n].transform_point(&Vector3::zeros());
    kinematics::gram_of_axes(
        frames[..n]
            .iter()
            .map(|f| (f.rot.column(2).into_owned(), f.pos_mm)),
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
    kinematics::cholesky6(&mut l)
}

/// `condition_at_most` at the joints whose `[sin q, cos q]` are `sc`.
fn condition_at_most_trig(
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

/// Draws `count` poses (degrees and radians, flat with stride N) passing every constraint.
#[allow(clippy::too_many_arguments)]
pub(crate) fn sample(
    field: &str,
    count: usize,
    cfg: &PoseSampling,
    nominal: &Robot,
    tracker: &Tracker,
    unmodelled: Option<&Unmodelled>,
    point: &dyn Fn(&[f64], &CmdTrig) -> Vector3<f64>,
    rng: &mut ChaCha8Rng,
) -> Result<Sampled, SimError> {
    let n = nominal.n_joints();
    let mut limits_deg = [[0.0; 2]; MAX_JOINTS];
    for (i, l) in limits_deg.iter_mut().enumerate().take(n) {
        let [lo, hi] = nominal.limits_rad(i);
        *l = [lo.to_degrees(), hi.to_degrees()];
    }
    let mut deg = Vec::with_capacity(count * n);
    let mut rad = Vec::with_capacity(count * n);
    let mut points = Vec::with_capacity(count);
    let mut stats = SamplingStats {
        wanted: count,
        ..SamplingStats::default()
    };
    let max_draws = (count as u64).saturating_mul(cfg.max_draws_per_pose);
    let mut qd = [0.0; MAX_JOINTS];
    let mut qr = [0.0; MAX_JOINTS];
    while stats.accepted < count {
        if stats.draws >= max_draws {
            return Err(SimError::Sampling {
                field: field.to_string(),
                stats,
            });
        }
        stats.draws += 1;
        for i in 0..n {
            let [lo, hi] = limits_deg[i];
            qd[i] = lo + (hi - lo) * rng.random::<f64>();
            qr[i] = qd[i].to_radians();
        }
        if !nominal.in_limits(&qr[..n]) {
            // Only possible through rounding at a limit; redraw (counted as a draw).
            continue;
        }
        match check(cfg, nominal, tracker, &qr[..n], unmodelled, point) {
            Ok(p) => {
                stats.accepted += 1;
                deg.extend_from_slice(&qd[..n]);
                rad.extend_from_slice(&qr[..n]);
                points.push(p);
            }
            Err(Reject::Wrist) => stats.rejected_wrist += 1,
            Err(Reject::Floor) => stats.rejected_floor += 1,
            Err(Reject::Elevation) => stats.rejected_elevation += 1,
            Err(Reject::Range) => stats.rejected_range += 1,
            Err(Reject::Condition) => stats.rejected_condition += 1,
        }
    }
    Ok(Sampled {
        deg,
        rad,
        points,
        stats,
    })
}

/// A sampled pose set.
#[derive(Debug, Default)]
pub(crate) struct Sampled {
    /// Joints, degrees, flat with stride N.
    pub(crate) deg: Vec<f64>,
    /// The same in radians.
    pub(crate) rad: Vec<f64>,
    /// The point checked for each pose (what `point` gave).
    pub(crate) points: Vec<Vector3<f64>>,
    /// The sampler's counts.
    pub(crate) stats: SamplingStats,
}

#[cfg(test)]
mod tests {
    use super::*;
    use kinematics::RobotSpec;
    use rand::SeedableRng;

    /// The fixed-size Gram and Cholesky decisions are nalgebra's, bit for bit.
    #[test]
    fn gram_and_cholesky_replicas_match_nalgebra() {
        let text = include_str!("../../../scenarios/robots/kr1000-titan.json");
        let robot = Robot::from_spec(&RobotSpec::from_json_str(text, "kr1000").unwrap()).unwrap();
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        let mut q = [0.0; 6];
        let mut outcomes = [0usize; 2];
        for _ in 0..3000 {
            for (i, v) in q.iter_mut().enumerate() {
                let [lo, hi] = robot.limits_rad(i);
                *v = lo + (hi - lo) * rng.random::<f64>();
            }
            let mut sc = [[0.0; 2]; MAX_JOINTS];
            kinematics::joint_sin_cos(&q, &mut sc);
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
        let text = include_str!("../../../scenarios/robots/kr1000-titan.json");
        let robot = Robot::from_spec(&RobotSpec::from_json_str(text, "kr1000").unwrap()).unwrap();
        let mut rng = ChaCha8Rng::seed_from_u64(1);
        let mut q = [0.0; 6];
        let mut decided_both_ways = [0usize; 2];
        for _ in 0..2000 {
            for (i, v) in q.iter_mut().enumerate() {
                let [lo, hi] = robot.limits_rad(i);
                *v = lo + (hi - lo) * rng.random::<f64>();
            }
            let exact = robot.singularity_condition(&q, 1000.0);
            for limit in [3.0, 8.0, 30.0, 100.0] {
                // Skip the rounding-level tie band around the limit.
                if ((exact - limit) / limit).abs() < 1e-9 {
                    continue;
                }
                let fast = condition_at_most(&robot, &q, 1000.0, limit);
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
}
