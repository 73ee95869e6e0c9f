//! The integration tests of `identify`, in one test binary (one link instead of one per file:
//! on a 2-core machine linking dominates a cold `cargo test`). Each file is a module.

mod common;
mod compensation;
mod covariance;
mod degenerate;
mod fast_path;
mod frames;
mod identifiability;
mod noise;
mod noise_free;
mod oracle;
mod registration;
mod reuse;
mod serde;
