//! Pictures and reports people look at: one plotting layer ([`plot`]), the number formatting
//! rules of every table and console line ([`fmt`]), self-contained HTML pages ([`html`]) and
//! the plots of a real-data identification ([`identify`]).
//!
//! The campaign and sweep reports (`crates/campaign`) and the real-data `identify` workflow
//! both draw through this crate, so every figure follows the same conventions (see
//! `docs/reports.md`).

pub mod fmt;
pub mod html;
pub mod identify;
pub mod plot;

pub use plot::{Figure, LegendAt, PlotError, RefLine, Scale, Series, Style};
