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
pub mod kept;
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

pub use kept::{KEPT_BUFFER_MAX_BYTES, keep_buffer};
