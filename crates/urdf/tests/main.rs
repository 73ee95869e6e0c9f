//! The integration tests of `urdf`, in one test binary (one link instead of one per file:
//! on a 2-core machine linking dominates a cold `cargo test`). Each file is a module.

mod common;
mod errors;
mod fuzz;
mod import;
#[path = "../../measurements/tests/mutate/mod.rs"]
mod mutate;
mod prismatic;
mod reference;
mod round_trip;
