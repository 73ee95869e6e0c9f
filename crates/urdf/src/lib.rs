//! URDF in and out: converts between a URDF robot description and a kincal robot file
//! (`docs/urdf.md`).
//!
//! - [`import_str`] / [`import_file`]: the serial chain between a base link and a tip link of
//!   a plain URDF (xacro expanded first) → a robot file whose measured point is the tip link's
//!   point for every joint vector, exactly (any joint axes and origins, not only DH-shaped
//!   ones).
//! - [`export`]: any robot file (e.g. an `identified.json`) → a URDF whose root link is the
//!   measurement frame and whose deepest link is a fixed link at the measured point, with
//!   joint origins that reproduce the robot file's kinematics; [`offsets_json`] writes the
//!   joint-angle offsets θ alone, for controllers that only take offsets.
//!
//! The XML is read by the `urdf-rs` crate; no I/O but reading the input file.

mod error;
mod export;
mod import;

pub use error::UrdfError;
pub use export::{
    BASE_LINK, ExportOptions, FLANGE_LINK, ROOT_LINK, TOOL_LINK, export, offsets_json,
};
pub use import::{
    ImportOptions, Imported, MAX_REACH_MM, MIN_REACH_MM, check_reach, import_file, import_str,
    reach_mm,
};
