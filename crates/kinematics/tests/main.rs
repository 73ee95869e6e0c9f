//! The integration tests of `kinematics`, in one test binary (one link instead of one per file:
//! on a 2-core machine linking dominates a cold `cargo test`). Each file is a module.

mod controller;
mod extended;
mod frame_jacobian;
mod fuzz;
mod kinematics;
mod mass_model;
#[path = "../../measurements/tests/mutate/mod.rs"]
mod mutate;
mod plausible;
mod prismatic;
