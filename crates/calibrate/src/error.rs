//! The error type of this crate.

use std::path::PathBuf;

use identify::IdentifyError;
use kinematics::ModelError;
use measurements::MeasurementError;

/// Everything that stops a calibration, prediction or compensation.
///
/// Leaves name the file, line, column or option at fault; [`CalibrateError::Context`] adds
/// what was being done, outermost first, as a front end prints the chain (`{:#}` of an
/// `anyhow::Error`, or the [`std::error::Error::source`] chain).
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum CalibrateError {
    /// A robot model file could not be loaded.
    #[error("loading the {what} {}", path.display())]
    Robot {
        /// Which robot (`"robot"`, `"calibrated robot"`, …).
        what: &'static str,
        /// The file.
        path: PathBuf,
        /// Why.
        #[source]
        source: ModelError,
    },
    /// A measurement or joint file could not be read (its error names file, line, column).
    #[error("{context}")]
    Read {
        /// What was read, for which robot.
        context: String,
        /// Why.
        #[source]
        source: MeasurementError,
    },
    /// The identification library refused.
    #[error("{context}")]
    Identify {
        /// What was being done.
        context: String,
        /// Why.
        #[source]
        source: IdentifyError,
    },
    /// Statistics could not be computed (no finite errors).
    #[error("{context}")]
    Evaluate {
        /// What was being computed.
        context: String,
        /// Why.
        #[source]
        source: evaluate::EvalError,
    },
    /// The design of `--select` failed (too few rows, a rank-deficient pool, bad joints).
    #[error("{context}")]
    Design {
        /// What was being chosen.
        context: String,
        /// Why.
        #[source]
        source: design::DesignError,
    },
    /// A plot of the report could not be drawn (non-finite errors).
    #[error("drawing {what}")]
    Plot {
        /// Which plot.
        what: String,
        /// Why.
        #[source]
        source: report::PlotError,
    },
    /// An option or input is unusable; the message names the option or the file.
    #[error("{0}")]
    Refused(String),
    /// An output could not be written (nothing half-written is left).
    #[error("writing {}", path.display())]
    Write {
        /// The file or directory.
        path: PathBuf,
        /// Why.
        #[source]
        source: std::io::Error,
    },
    /// `source` happened while doing `context`.
    #[error("{context}")]
    Context {
        /// What was being done.
        context: String,
        /// What went wrong.
        #[source]
        source: Box<CalibrateError>,
    },
}

impl CalibrateError {
    /// Wraps `self` with what was being done.
    pub fn context(self, context: impl Into<String>) -> Self {
        CalibrateError::Context {
            context: context.into(),
            source: Box::new(self),
        }
    }
}

/// `Result` with [`CalibrateError`].
pub type Result<T, E = CalibrateError> = std::result::Result<T, E>;

/// Turns an identification error into a [`CalibrateError`] with context.
pub(crate) fn id_err(context: impl Into<String>) -> impl FnOnce(IdentifyError) -> CalibrateError {
    let context = context.into();
    move |source| CalibrateError::Identify { context, source }
}
