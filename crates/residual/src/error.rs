//! The crate's typed errors.

/// What can go wrong fitting, reading or cross-validating a residual model. Every variant
/// names the input (the field of a model file, the row of the training data, the fold).
#[derive(Debug, thiserror::Error)]
pub enum ResidualError {
    /// The training inputs are unusable (too few poses, joint counts that differ, lengths
    /// that do not match).
    #[error("residual model training data: {0}")]
    Data(String),
    /// A value is NaN or infinite.
    #[error("residual model {what}: row {row} is not finite")]
    NonFinite {
        /// Which input (`joints_deg`, `residuals_mm`, a query).
        what: &'static str,
        /// Its index (0-based).
        row: usize,
    },
    /// A query has another number of joints than the model was trained on.
    #[error(
        "residual model: query row {row} has {got} joints, the model was trained on {expected}"
    )]
    Joints {
        /// The query row (0-based).
        row: usize,
        /// Joints in the query row.
        got: usize,
        /// Joints of the training poses.
        expected: usize,
    },
    /// The kernel matrix is not positive definite at these hyperparameters (the noise
    /// variance is bounded below so that this does not happen on real data; a model file
    /// edited by hand can still cause it).
    #[error("residual model: the kernel matrix is not positive definite ({context})")]
    NotPositiveDefinite {
        /// Where (fitting, reading a file).
        context: String,
    },
    /// A model file that cannot be read as one.
    #[error("residual model file {source_name}: {message}")]
    File {
        /// The file's name as given.
        source_name: String,
        /// What is wrong, naming the field.
        message: String,
    },
    /// The geometric refit of a cross-validation fold failed.
    #[error(
        "cross-validation fold {fold}: the geometric fit on its training poses failed: {source}"
    )]
    Geometry {
        /// The fold (1-based).
        fold: usize,
        /// Why.
        source: Box<dyn std::error::Error + Send + Sync>,
    },
    /// The cross-validation cannot run with these options.
    #[error("cross-validation: {0}")]
    CrossValidation(String),
}

/// The crate's result.
pub type Result<T, E = ResidualError> = std::result::Result<T, E>;
