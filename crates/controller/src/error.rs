//! The crate's one error type.

use thiserror::Error;

/// What went wrong writing or reading controller text; every variant names the target,
/// line or field.
#[derive(Debug, Error)]
pub enum ControllerError {
    /// A format name that is none of [`crate::Format::ALL`].
    #[error("unknown output format {0:?}: one of csv, kuka-krl, abb-rapid, urscript")]
    UnknownFormat(String),
    /// The robot is not one the writers declare targets for (six revolute joints).
    #[error("{0}")]
    UnsupportedRobot(String),
    /// A target that cannot be written: wrong joint count, a non-finite value, a name that
    /// is not one line.
    #[error("target {index} ({name:?}): {message}")]
    Target {
        /// 0-based position in the list given.
        index: usize,
        /// The target's name.
        name: String,
        /// What is wrong.
        message: String,
    },
    /// A program name that is not an identifier of the format.
    #[error("program name {name:?}: {message}")]
    ProgramName {
        /// The name given.
        name: String,
        /// What the format needs.
        message: String,
    },
    /// A declaration that does not parse.
    #[error("{source_name}:{line}: {message}")]
    Parse {
        /// The text's label (a file name).
        source_name: String,
        /// 1-based line.
        line: usize,
        /// What is wrong, naming the field.
        message: String,
    },
}
