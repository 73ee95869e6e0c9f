//! The integration tests of `measurements`, in one test binary (one link instead of one per file:
//! on a 2-core machine linking dominates a cold `cargo test`). Each file is a module.

mod fuzz;
mod messages;
mod mutate;
mod read;
mod write;
