//! What the pose sampler saw: the draws and the rejections per constraint of one pose set
//! ([`SamplingStats`]) and of one trial's sets ([`SamplingReport`]). Shared by the sampler
//! (`poses`), its error ([`crate::SimError::Sampling`]) and the truth file; it imports
//! neither.

use serde::{Deserialize, Serialize};

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
