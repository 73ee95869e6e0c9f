//! Sweeps: the sweep file, its points each run as a full campaign and the result
//! ([`spec`]), and its output files and figures ([`plots`]).

pub(crate) mod plots;
pub(crate) mod spec;
