//! The calibration workflow on real data, for any front end (the `kincal` CLI, scripts,
//! other programs): the steps an engineer runs on a robot file and tracker exports.
//!
//! ```text
//! robot.json + data.csv ─► check ─► split ─► register ─► identify ─► screen outliers
//!     ─► check the result ─► validate ─► Calibration          (workflow, pipeline: one
//!        pipeline for points, 6-DoF and multi-target data, MeasurementKind)
//! identified.json + joints.csv ─► predict                                  (joints)
//! identified.json + registered-nominal.json + targets.csv ─► compensate   (joints)
//! identified.json + registered-nominal.json + poses.csv ─► compensate     (cartesian:
//!     the nominal controller's IK, then the calibrated model's; CorrectedTarget)
//! ```
//!
//! Every function returns values; nothing is printed, rendered or written. A [`Calibration`]
//! is rendered by the `report` crate (`report::calibration::render`: `identified.json`,
//! `registered-nominal.json`, `parameters.json`, `report.md`, `report.html` and its plots),
//! and the front ends write the files. Errors are [`CalibrateError`]s naming the file, line,
//! column or request field at fault. The formats are those of `docs/model.md`.

mod cartesian;
pub mod checks;
pub mod contamination;
mod error;
pub mod excitation;
mod files;
mod joints;
mod memory;
mod pipeline;
pub mod prior;
pub mod provenance;
mod request;
pub mod residual;
pub mod scale;
mod tolerance;
pub mod tool_frame;
mod tool_offset;
mod workflow;

pub use cartesian::{
    CartesianOptions, CorrectedTarget, METRES_FRACTION, OrientationColumns, OrientationSource,
    TargetFrame, Tcp, compensate_cartesian, compensate_file, compensate_poses,
    compensate_poses_with, has_joint_columns, read_cartesian,
};
pub use error::{CalibrateError, Refusal, Result};
pub use files::{
    LoadedRobot, file_name, points_mm, poses_rad, radians_evidence, radians_notice, row_label,
};
pub use joints::{
    Compensation, Prediction, SAME_FRAME_DEG, SAME_FRAME_FRACTION, SAME_FRAME_MM, compensate_rows,
    compensate_rows_with, compensate_targets, orientation_wxyz, orientation_wxyz_with, predict,
    predict_with,
};
pub use memory::{compensate_set, compensate_set_with};
pub use pipeline::{MAX_CONCENTRATION_STEPS, MAX_REJECTION_PASSES, MeasurementKind, RobustScreen};
pub use prior::PriorSpec;
pub use request::{
    Check, Front, IdentifyRequest, JointUnits, LengthUnits, OutlierMode, Setting, Split, Weighting,
};
pub use tool_frame::ToolFrameCalibration;
pub use tool_offset::TOOL_REGISTRATION_MM;
pub use workflow::{
    Calibration, Inputs, PointCalibration, STILL_JOINT_DEG, Validation, calibrate, mean_max, norms,
    residuals, run,
};
