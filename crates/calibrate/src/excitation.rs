//! What the poses determine, looked at before any check blames the units or the frame.
//!
//! Poses in which a joint barely moves leave the parameters near it undetermined: a humanoid
//! wrist spanning 2.6° gives standard errors of 63–400 mm, and a least-squares fit moves those
//! parameters far, by whatever the noise says. That is weak excitation, not a wrong unit or
//! frame. [`diagnose`] names the joints whose range in the data is small, the parameters whose
//! standard error (from the data alone) exceeds half their manufacturing tolerance, what to
//! measure, and which parameters the prior holds (`crate::prior`); [`parameters`] is the
//! parameters check with that evidence: when every parameter that moved too far is one the
//! poses leave undetermined, it says so instead of suspecting the units and frame.

use identify::Fit;
use identify::frames::{FrameData, FrameFit};
use kinematics::Robot;
use measurements::Measurement;

use crate::checks::{self, refuse_with, tolerance};
use crate::error::Refusal;
use crate::prior::PriorSpec;
use crate::request::{Check, Setting};

/// Range of motion in the data below which a joint is said to move little, degrees [10: the
/// parameters of a joint's axis are seen through the arc its motion draws; below 10° the
/// chord is under a fifth of the radius and their standard errors grow as 1/range].
pub const SMALL_RANGE_DEG: f64 = 10.0;

pub use crate::tolerance::{UNDETERMINED_FRACTION, leaves_undetermined};

/// The standard error sought when saying how far a joint should move: this fraction of the
/// tolerance [0.25: half the undetermined line, so that the parameter is clearly determined].
const TARGET_FRACTION: f64 = 0.25;

/// Least motion recommended for a small joint, degrees [30].
const MIN_RECOMMENDED_DEG: f64 = 30.0;

/// One parameter the poses leave undetermined.
#[derive(Clone, Debug, PartialEq)]
pub struct Undetermined {
    /// Its name.
    pub name: String,
    /// Its standard error from the data alone, display units.
    pub std_error: f64,
    /// Its manufacturing tolerance ([`crate::checks::tolerance`]), display units.
    pub tolerance: f64,
}

/// What the poses determine.
#[derive(Clone, Debug, PartialEq)]
pub struct Excitation {
    /// Range of motion of each joint in the data, degrees.
    pub ranges_deg: Vec<f64>,
    /// Joints (0-based) whose range is below [`SMALL_RANGE_DEG`].
    pub small_joints: Vec<usize>,
    /// Parameters whose standard error exceeds [`UNDETERMINED_FRACTION`] × their tolerance,
    /// layout order.
    pub undetermined: Vec<Undetermined>,
    /// Parameters the prior rather than the data determine (`identify::Posterior`).
    pub held_by_prior: Vec<String>,
    /// The motion to measure for the small joints, degrees: the range at which the worst
    /// standard error would be a quarter of its tolerance (standard errors ∝ 1/range),
    /// at least 30° and at most 180°; `None` when no joint is small or nothing undetermined.
    pub recommended_deg: Option<f64>,
}

/// What the poses `rows` determine for the fit `fit` (its covariance: the data's alone).
pub fn diagnose(robot: &Robot, rows: &[Measurement], fit: &Fit) -> Excitation {
    let poses: Vec<&[f64]> = rows.iter().map(|r| r.q_deg.as_slice()).collect();
    let std_errors = fit
        .covariance
        .as_ref()
        .map(|c| {
            c.indices
                .iter()
                .copied()
                .zip(c.std_errors.iter().copied())
                .collect()
        })
        .unwrap_or_default();
    let held = fit.posterior.as_ref();
    diagnose_with(robot, &poses, std_errors, held)
}

/// What the poses of `data` determine for the 6-DoF / multi-target fit `fit` (its standard
/// errors: the data's alone; the robot parameters only, the tool frame and targets have no
/// tolerance): the same diagnosis as [`diagnose`] for points.
pub fn diagnose_frames(robot: &Robot, data: &FrameData, fit: &FrameFit) -> Excitation {
    let q_deg: Vec<f64> = data.poses_rad.iter().map(|q| q.to_degrees()).collect();
    let poses: Vec<&[f64]> = q_deg.chunks(data.n_joints.max(1)).collect();
    let std_errors = fit
        .free
        .robot
        .iter()
        .zip(&fit.estimates)
        .map(|(&k, e)| (k, e.std_error))
        .collect();
    diagnose_with(robot, &poses, std_errors, fit.posterior.as_ref())
}

/// The diagnosis from each pose's joints (`poses`, degrees; millimetres for a prismatic
/// joint), the standard errors from the data alone (`(layout index, display units)`) and the
/// posterior of a prior fit.
fn diagnose_with(
    robot: &Robot,
    poses: &[&[f64]],
    std_errors: Vec<(usize, f64)>,
    posterior: Option<&identify::Posterior>,
) -> Excitation {
    let n = robot.n_joints();
    let ranges_deg: Vec<f64> = (0..n)
        .map(|j| {
            let (lo, hi) = poses
                .iter()
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), q| {
                    (lo.min(q[j]), hi.max(q[j]))
                });
            (hi - lo).max(0.0)
        })
        .collect();
    let small_joints: Vec<usize> = (0..n)
        .filter(|&j| ranges_deg[j] < SMALL_RANGE_DEG)
        .collect();
    let layout = robot.layout();
    let undetermined: Vec<Undetermined> = std_errors
        .into_iter()
        .filter_map(|(k, se)| {
            let p = layout.get(k);
            let tol = tolerance(p.kind)?;
            (se > UNDETERMINED_FRACTION * tol).then(|| Undetermined {
                name: p.name.to_string(),
                std_error: se,
                tolerance: tol,
            })
        })
        .collect();
    let held_by_prior = posterior.map_or_else(Vec::new, |p| {
        p.held_by_prior().into_iter().map(String::from).collect()
    });
    let worst = undetermined
        .iter()
        .map(|u| u.std_error / (TARGET_FRACTION * u.tolerance))
        .fold(0.0, f64::max);
    let recommended_deg = (!small_joints.is_empty() && !undetermined.is_empty()).then(|| {
        let widest = small_joints
            .iter()
            .map(|&j| ranges_deg[j])
            .fold(0.0, f64::max);
        (widest * worst).clamp(MIN_RECOMMENDED_DEG, 180.0)
    });
    Excitation {
        ranges_deg,
        small_joints,
        undetermined,
        held_by_prior,
        recommended_deg,
    }
}

impl Excitation {
    /// The small joints and their ranges: `q6 (2.6°)`.
    fn joints_text(&self) -> String {
        self.small_joints
            .iter()
            .map(|&j| format!("q{} ({:.1}°)", j + 1, self.ranges_deg[j]))
            .collect::<Vec<_>>()
            .join(", ")
    }

    fn undetermined_text(&self) -> String {
        self.undetermined
            .iter()
            .map(|u| {
                format!(
                    "{} (standard error {:.3}, tolerance {})",
                    u.name, u.std_error, u.tolerance
                )
            })
            .collect::<Vec<_>>()
            .join(", ")
    }

    /// What to measure, in words.
    fn what_to_measure(&self) -> String {
        match self.recommended_deg {
            Some(x) => format!(
                "measure poses moving {} by at least {x:.0}°",
                self.small_joints
                    .iter()
                    .map(|&j| format!("joint {}", j + 1))
                    .collect::<Vec<_>>()
                    .join(" and ")
            ),
            None => "measure more varied poses (`kincal design` chooses them)".into(),
        }
    }

    /// The warning of weak excitation (none when the poses determine every parameter):
    /// the small joints, the undetermined parameters, what to measure, and what the prior
    /// (`prior`) holds.
    pub fn warning(&self, prior: &PriorSpec) -> Option<String> {
        if self.undetermined.is_empty() && self.held_by_prior.is_empty() {
            return None;
        }
        let mut w = String::from("weak excitation: ");
        if !self.small_joints.is_empty() {
            w.push_str(&format!(
                "joint{} {} move{} less than {SMALL_RANGE_DEG}° in these data; ",
                if self.small_joints.len() > 1 { "s" } else { "" },
                self.joints_text(),
                if self.small_joints.len() > 1 { "" } else { "s" },
            ));
        }
        if !self.undetermined.is_empty() {
            w.push_str(&format!(
                "the poses leave {} undetermined (mm / °); {}",
                self.undetermined_text(),
                self.what_to_measure()
            ));
        }
        match prior {
            _ if !self.held_by_prior.is_empty() => w.push_str(&format!(
                "{}the prior holds {} at the robot file's values (posterior standard \
                 deviation above half the prior's)",
                if self.undetermined.is_empty() {
                    ""
                } else {
                    "; "
                },
                self.held_by_prior.join(", ")
            )),
            PriorSpec::None => w.push_str(
                "; without a prior (--prior none) they take whatever values the noise gives",
            ),
            PriorSpec::Tolerance { .. } | PriorSpec::Auto => {}
        }
        Some(w)
    }
}

/// The parameters check ([`checks::parameters`]) with the evidence of `excitation`: when
/// every parameter beyond its tolerance is one the poses leave undetermined, the refusal says
/// that the poses do not determine them, the joints that barely move and what to measure;
/// the units and frame are suspected only when a well-determined parameter moved too far.
///
/// # Errors
/// [`Refusal::Implausible`] of [`Check::Parameters`].
pub fn parameters(
    start: &Robot,
    identified: &Robot,
    identifiable: &[usize],
    excitation: &Excitation,
) -> Result<(), Refusal> {
    let far = checks::far_parameters(start, identified, identifiable);
    if far.is_empty() {
        return Ok(());
    }
    let weak = far
        .iter()
        .all(|(name, _, _)| excitation.undetermined.iter().any(|u| &u.name == name));
    if !weak {
        return checks::parameters(start, identified, identifiable);
    }
    let moved: Vec<String> = far
        .iter()
        .map(|(name, d, limit)| format!("{name} {d:+.3} (tolerance ±{limit})"))
        .collect();
    let mut evidence = format!(
        "parameters that these poses do not determine moved beyond their manufacturing \
         tolerance (mm / °): {}; the poses leave {} undetermined",
        moved.join(", "),
        excitation.undetermined_text()
    );
    if !excitation.small_joints.is_empty() {
        evidence.push_str(&format!(
            " (joints moving less than {SMALL_RANGE_DEG}°: {})",
            excitation.joints_text()
        ));
    }
    Err(refuse_with(
        Check::Parameters,
        evidence,
        &format!(
            "{}, or identify with the prior (auto, the default, or tolerance), which holds what \
             the data do not determine",
            excitation.what_to_measure()
        ),
        Some(Setting::Prior("auto")),
    ))
}
