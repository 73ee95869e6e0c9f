//! The Python package `kincal` (`docs/python.md`): a thin binding of the library crates.
//!
//! The binding converts types (paths, numpy arrays, option strings, parameter records),
//! releases the GIL around the library calls, and maps library errors to
//! `kincal.KincalError` (`kincal.Refused` when a plausibility check refuses). It computes
//! nothing itself: forward kinematics is `kinematics::Robot::point`, parameter values are
//! converted by `ParamInfo::to_display`, URDF goes through the `urdf` crate, a design is the
//! design crate's `design_selection`, and every file is written by
//! `measurements::write_atomically`, so Python and the CLI give the same numbers.
//!
//! By topic (the layout of pydantic-core and polars): [`errors`] (the exceptions and the one
//! conversion of library errors), [`arrays`] (numpy ⇄ rows), [`options`] (option strings
//! and lists, parsed by the library's `FromStr`), [`interrupt`] (long calls that answer
//! Ctrl-C), then one module per part of the API:
//! [`robot`], [`calibration`], [`frame_calibration`], [`design`], [`campaign`]. This file
//! only registers them.

mod arrays;
mod calibration;
mod campaign;
mod design;
mod errors;
mod frame_calibration;
mod interrupt;
mod options;
mod robot;

use pyo3::prelude::*;

/// kincal's compiled core; import `kincal`, which re-exports it.
#[pymodule]
fn _kincal(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    errors::register(m)?;
    robot::register(m)?;
    calibration::register(m)?;
    frame_calibration::register(m)?;
    design::register(m)?;
    campaign::register(m)?;
    Ok(())
}
