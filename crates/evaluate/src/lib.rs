//! Evaluation formulas for kinematic calibration.
//!
//! Everything here is independent of where the data come from (simulation or real
//! measurement files): no kinematics, no randomness. All lengths are millimetres
//! (`_mm`), all angles degrees (`_deg`), all relative changes percent (`_pct`).
//!
//! * [`stats`] — error statistics in the form of the paper's Table 4 (per axis and
//!   3-D: mean, max, RMS, 95th percentile) and the before/after comparison [`Table4`].
//! * [`iso9283`] — ISO 9283 (= GB/T 12642-2013) test cube geometry, the search for the
//!   largest admissible cube, and per-point pose accuracy `AP` / repeatability `RP_l`.
//! * [`recovery`] — parameter-recovery scoring (`error = estimate − truth`,
//!   `z = error / std_error`) and a summary of z-scores.
//!
//! Every fallible function returns [`EvalError`]; none of them produces NaN from
//! valid input.
//!
//! ```
//! use evaluate::{Table4, improvement_pct};
//!
//! // Error vectors e = measured − target (mm) on the validation poses.
//! let before = [[0.6, -0.8, 0.0], [0.0, 0.0, 1.2]];
//! let after = [[0.2, 0.0, 0.0], [0.0, 0.3, 0.0]];
//! let t = Table4::from_errors(&before, &after)?;
//! assert_eq!(t.before.norm.mean_mm, 1.1); // (1.0 + 1.2) / 2
//! assert_eq!(t.after.norm.max_mm, 0.3);
//! let pct = t.improvement().norm.mean_pct.unwrap(); // 100·(1.1 − 0.25)/1.1
//! assert!((pct - improvement_pct(1.1, 0.25).unwrap()).abs() < 1e-12);
//! # Ok::<(), evaluate::EvalError>(())
//! ```

#![deny(missing_docs)]

pub mod error;
pub mod iso9283;
pub mod recovery;
pub mod stats;

pub use error::EvalError;
pub use iso9283::{
    CUBE_EDGE_TOLERANCE_MM, ISO_CYCLE_ORDER, IsoCube, IsoPointRow, IsoReport, PointStats,
    TEST_POINT_DIAGONAL_FRACTION, largest_cube, point_stats,
};
pub use recovery::{ParameterRecovery, ZSummary, score_recovery, summarize_z};
pub use stats::{
    AxisImprovement, AxisStats, ErrorStats, StatsImprovement, Table4, error_stats, error_stats_in,
    error_stats_vectors, error_vectors_mm, improvement_pct, mean, norms, percentile_linear,
};

/// Result alias used throughout the crate.
pub type Result<T> = std::result::Result<T, EvalError>;
