//! The learned residual model of a calibration (`docs/residual-model.md`): a Gaussian
//! process on the 3-D position error the geometric model leaves (`measured − geometry`,
//! mm) as a function of the joints — gear errors, compliance, thermal and cable effects
//! vary smoothly with them — and the cross-validation that decides whether the hybrid
//! (geometry + the model's mean) predicts held-out poses better than the geometry alone.
//!
//! ```text
//! joints, residuals ─► ResidualModel::fit ─► predict (mean, sd) · to_json_string / from_json_str
//! joints + a geometric fit per fold ─► cross_validate ─► CrossValidation (folds, gains, coverage, helps)
//! ```
//!
//! The model ([`gp`]): an anisotropic squared-exponential kernel on the joint angles in
//! radians plus white noise, the three outputs normalised and sharing one kernel,
//! hyperparameters by maximum marginal likelihood (projected BFGS with analytic gradients,
//! one deterministic start) — the model of scikit-learn's example
//! (`crates/kincal-py/examples/hybrid_gp.py`). The gate and the coverage: [`cv`].
//!
//! 6-DoF data: a second GP of the same code on the orientation residual (the rotation
//! vector of `R_measured · R_geometryᵀ`, degrees), trained on the same poses
//! ([`ResidualModel::fit_orientation`], [`cross_validate_pose`]); its file is
//! [`FORMAT_ORIENTATION`] with an `orientation` object whose fields end in `_deg`.
//!
//! **Why written here, not taken from a crate.** The GP is ~300 lines on a Cholesky factor;
//! the crates looked at each failed one of the requirements (nalgebra 0.35, few
//! dependencies, the same bits on every run):
//! `friedrich` fits its hyperparameters by gradient steps under a wall-clock budget (a
//! `chrono::Duration`), so a fit depends on the machine's speed, and it pins an older
//! nalgebra; `egobox-gp` brings ndarray, linfa, linfa-pls, cobyla, rayon and egobox-doe, and its
//! multistart draws start points from entropy; `linfa` has no GP regression; `argmin` would
//! give the optimiser only (its L-BFGS is deterministic) for another dependency tree, while
//! the problem has 8 unknowns. The arithmetic here has one order (dot products in eight
//! fixed lanes, no FMA, no threads): a fit gives the same bytes on every run.
//!
//! Errors are [`ResidualError`]s naming the input at fault.

pub mod cv;
mod error;
pub mod gp;

pub use cv::{
    Coverage, CrossValidation, CvOptions, DEFAULT_FOLDS, FoldResult, Gain, GeometryResult, HeldOut,
    PoseCrossValidation, PoseGeometryResult, cross_validate, cross_validate_pose, folds, held_out,
    held_out_predicted,
};
pub use error::{ResidualError, Result};
pub use gp::{
    FORMAT, FORMAT_ORIENTATION, GpOptions, Hyperparameters, MIN_TRAIN_POSES, OptimiserReport,
    OrientationPrediction, Prediction, ResidualModel, evenly_spaced,
};

/// The residual model's file name beside `identified.json` (`docs/residual-model.md`).
pub const MODEL_FILE: &str = "residual-model.json";
