//! The integration tests of `campaign`, in one test binary (one link instead of one per file:
//! on a 2-core machine linking dominates a cold `cargo test`). Each file is a module.

mod budget;
mod campaign;
mod cartesian;
mod common;
mod extended;
mod files;
mod fuzz;
#[path = "../../measurements/tests/mutate/mod.rs"]
mod mutate;
mod residual;
