//! Pictures and reports people look at: one plotting layer ([`plot`]), the number formatting
//! rules of every table and console line ([`fmt`]), self-contained HTML pages ([`html`]) and
//! everything a real-data calibration shows ([`calibration`]: `report.md`, `report.html` and
//! its plots, `parameters.json`, the console summary).
//!
//! The campaign and sweep reports (`crates/campaign`) and the real-data calibration
//! (`crates/calibrate`, rendered here) both draw through this crate, so every figure follows
//! the same conventions (see `docs/reports.md`).

pub mod calibration;
pub mod fmt;
pub mod html;
pub mod identifiability;
pub mod plot;

pub use plot::{Figure, LegendAt, PlotError, RefLine, Scale, Series, Style};
