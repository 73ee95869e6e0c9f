//! The crate's error type.

use thiserror::Error;

/// Everything that can go wrong when evaluating data.
///
/// `what` fields name the input that was rejected (e.g. `"error vectors"`), so the
/// message can be shown to a user as is.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum EvalError {
    /// An input that must hold at least one value is empty.
    #[error("{what}: input is empty")]
    Empty {
        /// Which input.
        what: &'static str,
    },
    /// An input holds fewer values than the formula needs (e.g. a sample standard
    /// deviation with `n − 1` in the denominator needs `n ≥ 2`).
    #[error("{what}: need at least {needed} values, got {got}")]
    TooFew {
        /// Which input.
        what: &'static str,
        /// Minimum number of values.
        needed: usize,
        /// Number of values supplied.
        got: usize,
    },
    /// An input value is NaN or infinite.
    #[error("{what}: value {value:?} at index {index} is not finite")]
    NonFinite {
        /// Which input.
        what: &'static str,
        /// Index of the offending entry (row for vectors).
        index: usize,
        /// The offending value.
        value: f64,
    },
    /// Parallel inputs have different lengths.
    #[error("length mismatch: {what} has {got} entries, expected {expected}")]
    LengthMismatch {
        /// Which input.
        what: &'static str,
        /// Expected length.
        expected: usize,
        /// Supplied length.
        got: usize,
    },
    /// A reported standard error is not a finite positive number, so no z-score exists.
    #[error("parameter `{name}`: standard error must be finite and > 0, got {value:?}")]
    InvalidStdError {
        /// Parameter name.
        name: String,
        /// The offending standard error.
        value: f64,
    },
    /// A scalar argument is outside its admissible range.
    #[error("invalid argument `{name}` = {value:?}: {reason}")]
    InvalidArgument {
        /// Argument name.
        name: &'static str,
        /// Its value.
        value: f64,
        /// What the admissible range is.
        reason: &'static str,
    },
    /// No candidate centre admits a cube of at least the minimum edge.
    #[error(
        "no cube with edge >= {min_edge_mm} mm satisfies the predicate at any of the \
         {candidates} candidate centres"
    )]
    NoFeasibleCube {
        /// Minimum edge that was required (mm).
        min_edge_mm: f64,
        /// Number of candidate centres tried.
        candidates: usize,
    },
}
