//! The calibration workflow on real data, for any front end (the `kincal` CLI, scripts,
//! other programs): the steps an engineer runs on a robot file and tracker exports.
//!
//! ```text
//! robot.json + data.csv ─► register ─► identify ─► screen outliers ─► validate ─► report
//!                                                                        (workflow)
//! identified.json + joints.csv ─► predict                                  (joints)
//! identified.json + registered-nominal.json + targets.csv ─► compensate   (joints)
//! ```
//!
//! Every function returns values and rendered text; nothing is printed and nothing is
//! written except by [`Rendered::write_to`], which writes each file atomically. Errors are
//! [`CalibrateError`]s naming the file, line, column or option at fault. The formats are
//! those of `docs/model.md`.

mod error;
mod files;
mod joints;
mod workflow;

pub use error::{CalibrateError, Result};
pub use files::{LoadedRobot, file_name, points_mm, poses_rad, radians_notice, row_label};
pub use joints::{Compensation, Prediction, SAME_FRAME_MM, compensate_targets, predict};
pub use workflow::{
    Calibration, IdentifyRequest, PARAMETERS_FILE, REGISTERED_FILE, REPORT_FILE, REPORT_HTML_FILE,
    ROBOT_FILE, RedundantArg, Registration, Rendered, Schedule, Split, Validation, norms,
    residuals, run, split_params,
};
