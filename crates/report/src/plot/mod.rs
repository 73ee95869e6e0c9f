//! The plotting layer: one [`Figure`] description, drawn to SVG by plotters.
//!
//! Conventions every plot follows (so that a reader needs no legend to the legend):
//! - axis titles in words with the unit, e.g. "μ0 (Levenberg damping, log scale)" or
//!   "validation error after compensation (mm)";
//! - labelled ticks on both axes (1-2-5 steps; on a log axis 1-2-5 per decade or whole
//!   decades; explicit ticks at the sweep values when given);
//! - [`Scale::auto`] picks a log axis for positive values spanning two decades or more;
//! - legends in words, drawn inside the plot in a box that data never sits under (headroom
//!   is added above the data);
//! - each series has its own colour (Okabe–Ito, colour-blind safe), marker shape and dash
//!   pattern, so curves that coincide stay visible; with [`Figure::dodge`] their markers are
//!   also shifted sideways by a few pixels;
//! - error bars (e.g. ± 1 sd over trials) with caps;
//! - independent poses are points ([`Style::Markers`]), not lines;
//! - reference values (the paper's, a mean, a threshold) are labelled dashed lines.
//!
//! Every function is pure (data in, SVG text out) and deterministic: the same input gives the
//! same bytes. Inputs are validated before anything is drawn: empty data, non-finite values
//! (reported with the series name and index), mismatched lengths and non-positive values on a
//! log axis are errors, never silently dropped.
//!
//! Text: plotters' SVG backend (without its `ttf` feature) writes every string as an escaped
//! `<text>` element with `font-family="sans-serif"`, so the viewer's own sans-serif font draws
//! it; plotters only estimates text extents, so labels are kept short and placed with margins
//! (the legend's box is sized from a conservative character width).
//!
//! The parts: what a figure is (`figure.rs`), the charts built on it (`charts.rs`: CDF,
//! histogram), the axes and their ticks (`ticks.rs`), the validation and the pixel layout of
//! a panel (`layout.rs`), the colours, markers and dashes (`style.rs`) and the drawing with
//! plotters (`draw.rs`).

mod charts;
mod draw;
mod figure;
mod layout;
mod style;
mod ticks;

pub use charts::{MAX_CDF_STEPS, cdf_figure, histogram_svg, rebin};
pub use draw::{figure_svg, panels_svg};
pub use figure::{Figure, HEIGHT, LegendAt, PlotError, RefLine, Scale, Series, Style, WIDTH};
pub use style::PALETTE;

#[cfg(test)]
mod tests;
