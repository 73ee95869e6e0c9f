//! Kinematic parameter identification (`docs/model.md` §6 and §7).
//!
//! * [`Problem`]: a start model, poses, measured points, optional per-row weights, the free
//!   parameters; residual `e = p^meas − p(x; q)`.
//! * [`LeastSquares`] / [`least_squares`]: the one damped least-squares solver (Levenberg–
//!   Marquardt): a problem gives its normal equations, cost and step; the solver owns the
//!   damping, the stopping tests and the covariance. Points ([`solve`]) and frames or several
//!   targets per pose ([`frames::fit_frames`]) are its two problems.
//! * [`solve`]: damped least squares on points with the schedules of `docs/model.md` §7 ([`Damping`]: the
//!   paper's Levenberg, Marquardt, Nielsen), optional column scaling, five stopping tests with
//!   the reason reported ([`StopReason`]) and a per-iteration trace. Normal equations are
//!   accumulated per pose from [`kinematics::Robot::point_jacobian_into`] on the free
//!   parameters only and solved by Cholesky.
//! * [`identify`]: registration (when the data are far from the start model), [`solve`], and
//!   the covariance of the identifiable free parameters ([`Covariance`]) in a [`Fit`].
//! * [`analyze`]: identifiability — singular values of the column-scaled Jacobian, rank,
//!   redundant parameters and what they are confounded with, the minimal set, condition
//!   number, O1–O5. [`ParamSet`] resolves `paper`, `minimal` or a list of names;
//!   [`ParamSpec`] adds the non-geometric parameters after `+` (`paper+compliance+gears`).
//! * [`register_base`] / [`kabsch`]: closed-form rigid registration re-expressed in the base
//!   parameters.
//! * [`register_base_and_tool`]: the same with the tool offset estimated with the frame (a
//!   probe far from where the robot file says does not bend the registration).
//! * [`generic_poses`]: the generic pose set, on which the structural questions (minimal
//!   set, free-parameter count) are answered; random poses come from
//!   [`kinematics::sampling`].
//! * [`outliers::screen`]: points whose 3-D residual exceeds k·σ̂₃ after a fit.
//!
//! Units: internally radians and millimetres (the kinematics crate's parameter vector);
//! every report converts to degrees and millimetres. Kinematics is never re-implemented here.
//!
//! ```
//! use identify::{IdentifyOptions, ParamSet, Problem, identify};
//! use kinematics::{PoseSampler, Robot, RobotSpec};
//! use rand::{SeedableRng, rngs::ChaCha8Rng};
//!
//! let text = std::fs::read_to_string(concat!(
//!     env!("CARGO_MANIFEST_DIR"),
//!     "/../../scenarios/robots/kr1000-titan.json"
//! ))?;
//! let nominal = Robot::from_spec(&RobotSpec::from_json_str(&text, "kr1000")?)?;
//! // A "true" robot 0.3 mm longer in a2, measured noise-free at 40 poses.
//! let mut x = nominal.params();
//! x[nominal.layout().index_of("a2")?] += 0.3;
//! let truth = nominal.with_params(&x)?;
//! let poses = PoseSampler::default()
//!     .sample(&nominal, 40, &mut ChaCha8Rng::seed_from_u64(7))?
//!     .rad;
//! let points = truth.points(&poses);
//!
//! let free = ParamSet::Minimal.resolve(&nominal, &poses, None, &Default::default())?;
//! let problem = Problem::new(&nominal, &poses, &points, free)?;
//! let fit = identify(&problem, &IdentifyOptions::default())?;
//! assert!(fit.stop.converged());
//! assert!((fit.estimate("a2").unwrap().value - 1400.3).abs() < 1e-6);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

#![warn(missing_docs)]

pub mod compensation;
pub mod covariance;
mod error;
mod fit;
pub mod frames;
mod generic;
pub mod identifiability;
mod linalg;
pub mod lm;
mod options_str;
pub mod outliers;
pub mod params;
pub mod prior;
mod problem;
pub mod registration;
mod scratch;
pub mod simd;
pub mod tool_registration;

pub use compensation::{
    Compensated, CompensationOptions, DEFAULT_FLAG_CHANGE_DEG, FlagReason, assess_solution,
    compensate, compensate_nearest, compensate_nearest_to, compensation_target,
    compensation_target_trig, singularity_reasons,
};
pub use covariance::{
    CorrelatedPair, Covariance, NormalCovariance, covariance, covariance_at_solution,
};
pub use error::IdentifyError;
pub use fit::posterior;
pub use fit::{Fit, IdentifyOptions, ParamEstimate, identify};
pub use generic::{GENERIC_POSE_COUNT, GENERIC_POSE_SEED, generic_poses};
pub use identifiability::{
    ConfoundTerm, IdentifiabilityOptions, IdentifiabilityReport, Observability, ParamSet,
    Redundancy, analyze, keep_priority,
};
pub use lm::{
    Damping, LeastSquares, LmOptions, LmSolution, LsSolution, Redundant, StopReason, TraceEntry,
    least_squares, solve,
};
pub use options_str::{UnknownName, parse_name};
pub use outliers::{BlockOutlier, BlockScreen, Outlier, OutlierScreen};
pub use params::ParamSpec;
pub use prior::{HELD_BY_PRIOR, Posterior, PosteriorParam, Prior, PriorTerm};
pub use problem::{Problem, SAME_POSE_TOL_RAD};
pub use registration::{
    ROBUST_INLIER_FACTOR, RegistrationPolicy, RegistrationReport, RigidTransform,
    RobustRegistration, base_parameter_indices, kabsch, kabsch_robust, mean_point_error,
    proper_and_improper_rms, register_base, register_base_robust,
};
pub use simd::{SimdLevel, set_simd_level, simd_level};
pub use tool_registration::{ToolRegistration, register_base_and_tool};
