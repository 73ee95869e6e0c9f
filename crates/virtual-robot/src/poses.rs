//! The `poses` section: which joint configurations are measured.
//!
//! Each set (`identification`, `validation`) is either a count — poses drawn uniformly
//! within the joint limits from the trial's own stream and kept if they pass every
//! constraint — or an explicit list of joint configurations in degrees, used as given.
//!
//! The draws and the wrist and condition tests are [`kinematics::sampling`]'s (the one pose
//! sampler); the floor and the tracker window are this crate's screen between them.
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

use kinematics::Robot;
use kinematics::sampling::{PoseSampler, Rejection};
use nalgebra::Vector3;
use rand::rngs::ChaCha8Rng;
use serde::de::{self, SeqAccess, Visitor};
use serde::{Deserialize, Deserializer, Serialize, Serializer};

use crate::error::{ConfigError, NotMeasurable, SimError};
use crate::sampling::SamplingStats;
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
    /// The length of track the random identification poses cover, mm: each prismatic
    /// joint is drawn within this span about the middle of its limits (default: absent, the
    /// whole limits; validation poses always use the whole limits).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub identification_track_span_mm: Option<f64>,
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
            identification_track_span_mm: None,
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
        if let Some(span) = self.identification_track_span_mm {
            positive("poses.identification_track_span_mm", span)?;
        }
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

/// Which of the virtual robot's own constraints a pose fails.
enum Reject {
    Floor,
    Elevation,
    Range,
}

impl PoseSampling {
    /// The robot the random identification poses are drawn for: `nominal` with each
    /// prismatic joint's limits narrowed to [`PoseSampling::identification_track_span_mm`]
    /// about their middle (`None` without a span or a prismatic joint: `nominal` itself).
    pub fn identification_robot(&self, nominal: &Robot) -> Option<Robot> {
        let span = self.identification_track_span_mm?;
        if !nominal.has_prismatic() {
            return None;
        }
        let mut r = nominal.clone();
        for i in 0..r.n_joints() {
            if r.joint_type(i) == kinematics::JointType::Prismatic {
                let [lo, hi] = r.limits_rad(i);
                let mid = 0.5 * (lo + hi);
                let half = 0.5 * kinematics::prismatic_internal(span);
                r.set_limits_rad(i, [(mid - half).max(lo), (mid + half).min(hi)]);
            }
        }
        Some(r)
    }

    /// The admissibility rule of [`kinematics::sampling`] these settings give: the wrist
    /// margin, the condition limit and its orientation scale, the draws allowed per pose.
    pub fn sampler(&self) -> PoseSampler {
        PoseSampler {
            min_abs_wrist_deg: self.min_abs_q5_deg,
            max_condition: self.max_condition,
            orientation_scale_mm: self.condition_orientation_scale_mm,
            max_draws_per_pose: self.max_draws_per_pose,
        }
    }
}

/// Draws `count` poses (degrees and radians, flat with stride N) passing every constraint:
/// [`PoseSampling::sampler`]'s rule on `nominal`, with the floor and the tracker window as
/// its screen, checked on `point(q_rad, trig)` (robot base frame; `trig` holds the sines
/// and cosines of `q_rad` and of `unmodelled`'s gear terms).
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
    let mut out = Sampled::default();
    sample_into(
        field, count, cfg, nominal, tracker, unmodelled, point, rng, &mut out,
    )?;
    Ok(out)
}

/// [`sample`] into `out` (its vectors refilled in place: no allocation once they have the
/// room). On `Err`, `out` is left partly filled.
#[allow(clippy::too_many_arguments)]
pub(crate) fn sample_into(
    field: &str,
    count: usize,
    cfg: &PoseSampling,
    nominal: &Robot,
    tracker: &Tracker,
    unmodelled: Option<&Unmodelled>,
    point: &dyn Fn(&[f64], &CmdTrig) -> Vector3<f64>,
    rng: &mut ChaCha8Rng,
    out: &mut Sampled,
) -> Result<(), SimError> {
    let mut stats = SamplingStats {
        wanted: count,
        ..SamplingStats::default()
    };
    let screen = |q_rad: &[f64], sc: &[[f64; 2]]| {
        let mut trig = CmdTrig::default();
        trig.compute_with_joints(unmodelled, q_rad, sc);
        let point = point(q_rad, &trig);
        if point.z < cfg.min_point_z_mm {
            return Err(Reject::Floor);
        }
        match tracker.check_window(&point, SAMPLING_MARGIN_DEG, SAMPLING_MARGIN_MM) {
            Err(NotMeasurable::Elevation { .. }) => Err(Reject::Elevation),
            Err(_) => Err(Reject::Range),
            Ok(()) => Ok(point),
        }
    };
    let tally = |r: Rejection<Reject>| match r {
        Rejection::Wrist => stats.rejected_wrist += 1,
        Rejection::Screen(Reject::Floor) => stats.rejected_floor += 1,
        Rejection::Screen(Reject::Elevation) => stats.rejected_elevation += 1,
        Rejection::Screen(Reject::Range) => stats.rejected_range += 1,
        Rejection::Condition => stats.rejected_condition += 1,
    };
    // The sampler fills `out`'s own vectors (moved in and back: no copy).
    let mut s = kinematics::sampling::Sampled {
        deg: std::mem::take(&mut out.deg),
        rad: std::mem::take(&mut out.rad),
        kept: std::mem::take(&mut out.points),
        draws: 0,
    };
    let result = cfg
        .sampler()
        .sample_screened_into(nominal, count, rng, screen, tally, &mut s);
    (out.deg, out.rad, out.points) = (s.deg, s.rad, s.kept);
    match result {
        Ok(()) => {
            stats.accepted = out.points.len();
            stats.draws = s.draws;
            out.stats = stats;
            Ok(())
        }
        Err(e) => {
            stats.accepted = e.accepted;
            stats.draws = e.draws;
            Err(SimError::Sampling {
                field: field.to_string(),
                stats,
            })
        }
    }
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
