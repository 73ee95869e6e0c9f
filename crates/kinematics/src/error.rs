//! Typed errors of the kinematics crate.

use std::path::PathBuf;

/// Everything that can go wrong loading or validating a robot model.
#[derive(Debug, thiserror::Error)]
pub enum ModelError {
    /// The model file could not be read.
    #[error("{file}: cannot read robot file: {source}")]
    Io {
        /// The file.
        file: PathBuf,
        /// The underlying error.
        #[source]
        source: std::io::Error,
    },
    /// The JSON is malformed, a field is missing, unknown, or has the wrong type.
    #[error("{source_name}: field `{field}`: {message}")]
    Parse {
        /// File path or label of the text.
        source_name: String,
        /// Path of the offending field, e.g. `joints[2].d_mm` (`.` for the document root).
        field: String,
        /// What serde said.
        message: String,
    },
    /// A field has a value the model does not accept (NaN, limits reversed, …).
    #[error("{source_name}: field `{field}`: {message}")]
    Invalid {
        /// File path or label of the model.
        source_name: String,
        /// Path of the offending field.
        field: String,
        /// Why it is rejected.
        message: String,
    },
    /// A parameter name that the robot's parameter vector does not have.
    #[error("unknown parameter `{name}` (this robot has: {known})")]
    UnknownParameter {
        /// The name asked for.
        name: String,
        /// The names the robot does have, comma-separated.
        known: String,
    },
    /// A parameter or joint vector of the wrong length.
    #[error("{what}: expected {expected} values, got {found}")]
    Length {
        /// What vector.
        what: &'static str,
        /// Expected length.
        expected: usize,
        /// Length found.
        found: usize,
    },
}
