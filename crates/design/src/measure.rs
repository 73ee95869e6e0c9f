//! What one pose measures: a point, a full frame (6-DoF probe) or several targets.
//!
//! The rows of a pose's block come from `identify` — [`kinematics::Robot`]'s identification
//! Jacobian for a point, `identify::frames::residual_jacobian` (the rows the 6-DoF and
//! multi-target identification fits) for a frame or targets — so the information matrix
//! designed here is the `JᵀWJ` of the identification that will run:
//!
//! | measure | rows per pose | unknowns beside the robot's |
//! |---|---|---|
//! | `point` | 3 (position, mm) | — (the tool point is a robot parameter) |
//! | `frame` | 6: 3 position (mm) + 3 orientation (`log(R_modelᵀR_meas)`, rad, weighted) | tool orientation (3), tool point (3) |
//! | `targets` | 3·k: one point per target of the robot file | one point per target (3k) |
//!
//! Orientation rows carry the weight identify uses without per-row σ:
//! [`identify::frames::DEFAULT_MM_PER_DEG`] (1° of orientation weighs as 5 mm of position).

use std::fmt;
use std::str::FromStr;

use serde::{Deserialize, Serialize};

/// What one pose measures (see the module docs).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Measure {
    /// One point (a single reflector): 3 rows per pose. The default: what the paper and
    /// every committed result measure.
    #[default]
    Point,
    /// The full frame of a 6-DoF probe (position and orientation): 6 rows per pose.
    Frame,
    /// Every target (reflector) the robot file names in `targets`: 3 rows per target.
    Targets,
}

impl Measure {
    /// Every measure.
    pub const ALL: [Measure; 3] = [Measure::Point, Measure::Frame, Measure::Targets];

    /// Lower-case name (`point`, `frame`, `targets`).
    pub fn as_str(self) -> &'static str {
        match self {
            Measure::Point => "point",
            Measure::Frame => "frame",
            Measure::Targets => "targets",
        }
    }
}

impl fmt::Display for Measure {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

impl FromStr for Measure {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Measure::ALL
            .into_iter()
            .find(|m| m.as_str().eq_ignore_ascii_case(s.trim()))
            .ok_or_else(|| format!("unknown measurement {s:?} (point, frame, targets)"))
    }
}
