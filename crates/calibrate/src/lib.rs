//! The calibration workflow on real data, for any front end (the `kincal` CLI, scripts,
//! other programs): the steps an engineer runs on a robot file and tracker exports.
//!
//! ```text
//! robot.json + data.csv ─► register ─► identify ─► screen outliers ─► validate ─► Calibration
//!                                                                        (workflow)
//! identified.json + joints.csv ─► predict                                  (joints)
//! identified.json + registered-nominal.json + targets.csv ─► compensate   (joints)
//! ```
//!
//! Every function returns values; nothing is printed, rendered or written. A [`Calibration`]
//! is rendered by the `report` crate (`report::calibration::render`: `identified.json`,
//! `registered-nominal.json`, `parameters.json`, `report.md`, `report.html` and its plots),
//! and the front ends write the files. Errors are [`CalibrateError`]s naming the file, line,
//! column or request field at fault. The formats are those of `docs/model.md`.

mod error;
mod files;
pub mod frames;
mod joints;
mod request;
mod workflow;

pub use error::{CalibrateError, Refusal, Result};
pub use files::{LoadedRobot, file_name, points_mm, poses_rad, radians_notice, row_label};
pub use joints::{Compensation, Prediction, SAME_FRAME_MM, compensate_targets, predict};
pub use request::{IdentifyRequest, Split};
pub use workflow::{Calibration, Inputs, Validation, calibrate, mean_max, norms, residuals, run};
