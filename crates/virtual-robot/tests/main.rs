//! The integration tests of `virtual-robot`, in one test binary (one link instead of one per file:
//! on a 2-core machine linking dominates a cold `cargo test`). Each file is a module.

mod common;
mod compliance;
mod config;
mod mass_model;
mod repeatability;
mod sampling;
mod tracker;
mod world;
