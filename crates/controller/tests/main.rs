//! The integration tests of `controller`, in one test binary.

#![allow(clippy::needless_range_loop)] // index loops over fixed-size arrays read best here

mod golden;
mod rotation;
mod round_trip;
