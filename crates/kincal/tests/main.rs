//! The integration tests of `kincal`, in one test binary (one link instead of one per file:
//! on a 2-core machine linking dominates a cold `cargo test`). Each file is a module.

mod calibrate_cli;
mod campaign_cli;
mod common;
mod controller_cli;
mod design_frames_cli;
mod docs_examples;
mod files_cli;
mod frames_cli;
mod full_device_cli;
mod messages_cli;
mod trust_cli;
mod urdf_cli;
