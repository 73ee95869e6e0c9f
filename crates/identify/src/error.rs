//! The error type of this crate.

use kinematics::ModelError;

/// Everything that can go wrong setting up or solving an identification problem.
///
/// Every variant is a refusal to produce a result: the crate never returns a fit, report or
/// covariance that holds a NaN or infinity.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum IdentifyError {
    /// The flat pose buffer is not a whole number of joint vectors.
    #[error(
        "pose buffer holds {len} values, which is not a multiple of the robot's {n_joints} joints"
    )]
    PoseLength {
        /// Length of the buffer.
        len: usize,
        /// Joints per pose.
        n_joints: usize,
    },
    /// There are no poses.
    #[error("no poses given")]
    NoPoses,
    /// Poses and measured points differ in number.
    #[error("{poses} poses but {points} measured points: one point per pose is required")]
    PointCount {
        /// Number of poses.
        poses: usize,
        /// Number of points.
        points: usize,
    },
    /// An input number is NaN or infinite.
    #[error("{what} {index} ({detail}) is not finite")]
    NonFinite {
        /// What kind of value (`"measured point"`, `"pose"`, `"start parameter"`, …).
        what: &'static str,
        /// 0-based index of the offending pose, point or parameter.
        index: usize,
        /// Which component and its value, e.g. `y = NaN`.
        detail: String,
    },
    /// The weight vector has the wrong length.
    #[error("{found} weights given; expected {expected} (one per residual row: 3 per pose)")]
    WeightCount {
        /// Expected length (3 × poses).
        expected: usize,
        /// Length given.
        found: usize,
    },
    /// A weight is not a finite positive number.
    #[error(
        "weight of residual row {row} is {value:?}; weights are 1/σ and must be finite and > 0"
    )]
    BadWeight {
        /// 0-based residual row.
        row: usize,
        /// The value.
        value: f64,
    },
    /// The free-parameter set is empty.
    #[error("no free parameters: nothing to identify")]
    NoFreeParameters,
    /// A free-parameter index is out of range.
    #[error("free parameter index {index} is out of range (the robot has {n_params} parameters)")]
    FreeIndex {
        /// The index.
        index: usize,
        /// Number of parameters of the robot.
        n_params: usize,
    },
    /// A free parameter is listed twice.
    #[error("free parameter `{name}` is listed twice")]
    DuplicateFree {
        /// Its name.
        name: String,
    },
    /// Fewer residual equations than free parameters.
    #[error(
        "{equations} equations (3 per pose × {poses} poses) for {free} free parameters: \
         at least as many equations as free parameters are needed ({needed_poses} poses)"
    )]
    TooFewEquations {
        /// 3 × poses.
        equations: usize,
        /// Number of poses.
        poses: usize,
        /// Number of free parameters.
        free: usize,
        /// Smallest number of poses that would do.
        needed_poses: usize,
    },
    /// Too few distinct poses (e.g. every pose identical): repeated poses add no equations.
    #[error(
        "only {distinct} distinct pose(s) among {poses} (poses closer than {tol_rad:e} rad in \
         every joint count as one): at most {equations} independent equations for {free} free \
         parameters; at least {needed_poses} distinct poses are needed"
    )]
    TooFewDistinctPoses {
        /// Number of distinct poses.
        distinct: usize,
        /// Number of poses.
        poses: usize,
        /// Tolerance used to call two poses identical, rad.
        tol_rad: f64,
        /// 3 × distinct.
        equations: usize,
        /// Number of free parameters.
        free: usize,
        /// Smallest number of distinct poses that would do.
        needed_poses: usize,
    },
    /// The robot model rejected something (unknown parameter name, vector length).
    #[error(transparent)]
    Model(#[from] ModelError),
    /// The damped normal matrix could not be factorised.
    #[error(
        "iteration {iteration}: the damped normal matrix (μ = {mu:e}) is not positive definite, \
         so no step can be computed; the free parameters are probably redundant and \
         column scaling is off — use the `minimal` parameter set or enable column scaling"
    )]
    Singular {
        /// 1-based iteration.
        iteration: usize,
        /// The damping in use.
        mu: f64,
    },
    /// A computed step, cost or Jacobian was NaN or infinite.
    #[error("iteration {iteration}: the {what} is not finite; the problem is numerically singular")]
    NonFiniteStep {
        /// 1-based iteration (0 = at the start point).
        iteration: usize,
        /// What was not finite.
        what: &'static str,
    },
    /// A singular value decomposition did not converge.
    #[error("the singular value decomposition of the {what} did not converge")]
    Svd {
        /// Which matrix.
        what: &'static str,
    },
    /// The point sets cannot define a rigid registration.
    #[error("registration: {reason}")]
    Registration {
        /// Why.
        reason: String,
    },
    /// An option is out of its valid range.
    #[error("option `{name}` = {value}: {reason}")]
    InvalidOption {
        /// Option name.
        name: &'static str,
        /// Its value, formatted.
        value: String,
        /// What is required.
        reason: &'static str,
    },
    /// Part of the tool frame (its orientation or a target point) is not determined by the
    /// data.
    #[error(
        "the data do not determine the tool frame: {} redundant (measure more poses, or \
         each target at several poses)",
        unknowns.join(", ")
    )]
    ToolFrameNotIdentifiable {
        /// The undetermined unknowns (`tool_rx`, `<target>_x`, …).
        unknowns: Vec<String>,
    },
    /// The pose sampler could not find enough admissible poses.
    #[error(transparent)]
    Sampling(#[from] kinematics::sampling::SamplingError),
}
