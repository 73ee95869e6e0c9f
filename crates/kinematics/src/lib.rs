//! Kinematics of serial revolute robots in the Hayati-modified DH convention of
//! `docs/model.md` §2: robot model files, the identification parameter
//! vector with names and units, forward kinematics of the flange and of the measured point,
//! the analytic identification Jacobian, and damped-Newton inverse kinematics valid for any
//! parameter values.
//!
//! Random poses within the joint limits that are admissible for measuring (away from the
//! wrist and other singularities) come from [`sampling`], the one pose sampler, with a
//! generator the caller supplies: the crate draws nothing of its own and does no I/O but the
//! model file. Rotation maths (log/exp of SO(3), the inverse left Jacobian, projection on
//! SO(3), roll-pitch-yaw) live in [`rotation`], the one place of the workspace. Internally angles are radians and lengths
//! millimetres; interfaces (files, reports) use degrees and millimetres.

mod error;
mod extended;
mod frame;
mod ik;
mod model;
mod params;
mod robot;
pub mod rotation;
pub mod sampling;
pub mod simd;
pub mod trig;

pub use error::ModelError;
pub use extended::{ExtendedModel, Gravity, expand_family};
pub use frame::Frame;
pub use ik::{
    ArmSingularity, IkError, IkOptions, IkReport, IkSearch, IkTarget, IkUnreachable, Lower6,
    NearestIk, cholesky6,
};
pub use model::{
    AxisMapSpec, BaseSpec, ControllerKind, ControllerSpec, ExtendedParamSpec, FileRole, JointSpec,
    JointType, LinkMassSpec, MAX_ANGLE_DEG, MAX_JOINTS, MAX_LENGTH_MM, MassModelSpec, Provenance,
    ResidualModelRef, RobotSpec, TargetSpec,
};
pub use params::{
    BETA_ALPHA_TOL_DEG, ExtendedKind, ParamInfo, ParamKind, ParamLayout, ParamName, Unit,
};
pub use robot::{
    MAX_PARAMS, POSE_LANES, PRISMATIC_SLOT, PoseLanes, PoseTrig, Robot, gram_of_axes,
    prismatic_internal, prismatic_mm,
};
pub use sampling::PoseSampler;
pub use trig::joint_sin_cos;

/// The largest buffer (bytes) a thread keeps for reuse between solves and trials (issue 43:
/// no allocation per trial in the steady state): 256 KiB, a trial of about 2,700 poses of
/// six joints. Larger ones are freed as before: their allocation is negligible next to the work that
/// fills them, and keeping them would raise the peak memory of large identifications (a
/// 200,000-pose trial's sines and cosines are tens of MB). With about seventy buffers
/// kept (`identify`'s pools of 24 and 24, four `PoseTrig`s of four, a few more), a thread
/// holds at most about 18 MB this way. The normal equations' block buffers are the exception:
/// kept at any size, four a thread, as before (a large pose set's is reused by its next
/// solve rather than allocated again).
pub const KEPT_BUFFER_MAX_BYTES: usize = 1 << 18;

/// Whether a thread keeps a buffer of `capacity` elements of `T` ([`KEPT_BUFFER_MAX_BYTES`]).
pub fn keep_buffer<T>(capacity: usize) -> bool {
    capacity > 0 && capacity.saturating_mul(std::mem::size_of::<T>()) <= KEPT_BUFFER_MAX_BYTES
}
