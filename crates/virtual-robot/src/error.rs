//! Typed errors of the virtual robot.

use std::path::PathBuf;

use crate::sampling::SamplingStats;

/// A scenario section has a value the virtual robot does not accept. Every variant names the
/// offending field by its path in the scenario file, e.g. `tracker.sigma_fraction` or
/// `truth.explicit.thetaX`.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum ConfigError {
    /// The JSON is malformed, a field is unknown, missing or has the wrong type.
    #[error("`{field}`: {message}")]
    Parse {
        /// Path of the field (`.` for the document root).
        field: String,
        /// What the parser said.
        message: String,
    },
    /// A value out of its domain (negative σ, window out of range, …).
    #[error("`{field}`: {message}")]
    Invalid {
        /// Path of the field.
        field: String,
        /// Why it is rejected.
        message: String,
    },
    /// A parameter name the robot's parameter vector does not have.
    #[error("`{field}`: unknown parameter `{name}` (this robot has: {known})")]
    UnknownParameter {
        /// Path of the field, e.g. `truth.explicit.thetaX`.
        field: String,
        /// The unknown name.
        name: String,
        /// The robot's parameter names, comma-separated.
        known: String,
    },
}

impl ConfigError {
    /// Path of the offending field.
    pub fn field(&self) -> &str {
        match self {
            ConfigError::Parse { field, .. }
            | ConfigError::Invalid { field, .. }
            | ConfigError::UnknownParameter { field, .. } => field,
        }
    }

    pub(crate) fn invalid(field: impl Into<String>, message: impl Into<String>) -> Self {
        ConfigError::Invalid {
            field: field.into(),
            message: message.into(),
        }
    }
}

/// Why a commanded pose gives no measurement.
#[derive(Clone, Copy, Debug, PartialEq, thiserror::Error)]
pub enum NotMeasurable {
    /// The joint vector has the wrong length.
    #[error("the joint vector has {found} values, the robot has {expected} joints")]
    JointCount {
        /// Number of joints of the robot.
        expected: usize,
        /// Length of the vector given.
        found: usize,
    },
    /// A joint value outside its limits (or not finite): the controller refuses to move.
    #[error("joint {joint} at {value_deg}° is outside its limits [{min_deg}, {max_deg}]°")]
    JointLimits {
        /// 1-based joint number.
        joint: usize,
        /// The commanded value, degrees.
        value_deg: f64,
        /// Lower limit, degrees.
        min_deg: f64,
        /// Upper limit, degrees.
        max_deg: f64,
    },
    /// The target is outside the tracker's elevation window.
    #[error(
        "the target is at {elevation_deg:.3}° elevation, outside the tracker's ±{limit_deg}° window"
    )]
    Elevation {
        /// Elevation of the target seen from the tracker head, degrees.
        elevation_deg: f64,
        /// The window's half-width, degrees.
        limit_deg: f64,
    },
    /// The target is outside the tracker's range.
    #[error("the target is {range_m:.4} m from the tracker, outside its range {min_m}–{max_m} m")]
    Range {
        /// Distance tracker head → target, m.
        range_m: f64,
        /// Shortest measurable distance, m.
        min_m: f64,
        /// Longest measurable distance, m.
        max_m: f64,
    },
}

/// Everything that can go wrong building a [`crate::World`] or running a simulation.
#[derive(Debug, thiserror::Error)]
pub enum SimError {
    /// The configuration is invalid.
    #[error(transparent)]
    Config(#[from] ConfigError),
    /// The trial number does not fit the stream id.
    #[error("trial {trial} is larger than the largest trial number {max}")]
    Trial {
        /// The trial asked for.
        trial: u64,
        /// [`crate::MAX_TRIAL`].
        max: u64,
    },
    /// The sampling constraints left too few poses.
    #[error(
        "`{field}`: the sampling constraints left only {} of {} poses after {} draws (rejected: {})",
        stats.accepted, stats.wanted, stats.draws, stats.rejections_text()
    )]
    Sampling {
        /// The pose set, e.g. `poses.identification`.
        field: String,
        /// What the sampler saw.
        stats: SamplingStats,
    },
    /// A pose of a set could not be measured.
    #[error("`{field}[{index}]`: {source}")]
    NotMeasurable {
        /// The pose set, e.g. `poses.validation`.
        field: String,
        /// 0-based index of the pose in the set.
        index: usize,
        /// Why.
        source: NotMeasurable,
    },
    /// Scaling the injected errors to the target failed.
    #[error("`truth.scale_to.mean_error_mm`: {message}")]
    Scale {
        /// Why.
        message: String,
    },
    /// Formatting a measurement file failed.
    #[error(transparent)]
    Measurement(#[from] measurements::MeasurementError),
    /// Writing an output file failed.
    #[error("{}: {source}", file.display())]
    Io {
        /// The file or directory.
        file: PathBuf,
        /// The underlying error.
        #[source]
        source: std::io::Error,
    },
}
