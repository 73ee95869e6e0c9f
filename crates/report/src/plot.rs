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

use std::ops::Range;

use plotters::coord::Shift;
use plotters::coord::ranged1d::{KeyPointHint, NoDefaultFormatting, ValueFormatter};
use plotters::coord::types::RangedCoordf64;
use plotters::element::DashedPathElement;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use crate::fmt::number;

/// Width of every figure, in pixels.
pub const WIDTH: u32 = 800;
/// Height of a single-panel figure, in pixels.
pub const HEIGHT: u32 = 500;

/// The 3-D norms ‖e‖ = √(x² + y² + z²) of error vectors, in their order (what the error plots
/// draw).
pub fn norms(v: &[[f64; 3]]) -> Vec<f64> {
    v.iter()
        .map(|e| (e[0] * e[0] + e[1] * e[1] + e[2] * e[2]).sqrt())
        .collect()
}

/// The mean of `v`, summed in order (0 for an empty slice): the reference lines of the plots.
pub fn mean(v: &[f64]) -> f64 {
    v.iter().sum::<f64>() / v.len().max(1) as f64
}

/// Why a plot could not be drawn.
#[derive(Debug, Clone, thiserror::Error)]
pub enum PlotError {
    /// There is nothing to plot.
    #[error("nothing to plot: {what} is empty")]
    Empty {
        /// Which input was empty.
        what: String,
    },
    /// A value is NaN or infinite.
    #[error("non-finite value {value:?} in series `{series}` at index {index}")]
    NonFinite {
        /// The series (or input) holding the value.
        series: String,
        /// Position of the value in its series (0-based).
        index: usize,
        /// The offending value.
        value: f64,
    },
    /// Two inputs that must pair up element by element have different lengths.
    #[error("length mismatch: {what} has {got} entries, expected {expected}")]
    LengthMismatch {
        /// Which input has the wrong length.
        what: String,
        /// The length it must have.
        expected: usize,
        /// The length it has.
        got: usize,
    },
    /// A finite value that the plot still cannot represent (a negative standard deviation,
    /// a non-positive value on a log axis, a bin whose upper edge is not above its lower
    /// edge).
    #[error("invalid value {value:?} in series `{series}` at index {index}: {reason}")]
    InvalidValue {
        /// The series (or input) holding the value.
        series: String,
        /// Position of the value in its series (0-based).
        index: usize,
        /// The offending value.
        value: f64,
        /// What is wrong with it.
        reason: &'static str,
    },
    /// The plotting backend failed.
    #[error("plot backend failed: {0}")]
    Backend(String),
}

/// Linear or logarithmic axis.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Scale {
    /// Linear.
    Linear,
    /// Base-10 logarithmic; every value on it must be positive.
    Log,
}

impl Scale {
    /// [`Scale::Log`] when every value is positive and the largest is at least 100 times the
    /// smallest (log-spaced values such as a damping sweep), else [`Scale::Linear`].
    pub fn auto(values: impl IntoIterator<Item = f64>) -> Scale {
        let (mut lo, mut hi, mut any) = (f64::INFINITY, 0.0f64, false);
        for v in values {
            if v <= 0.0 || !v.is_finite() {
                return Scale::Linear;
            }
            lo = lo.min(v);
            hi = hi.max(v);
            any = true;
        }
        if any && hi >= 100.0 * lo {
            Scale::Log
        } else {
            Scale::Linear
        }
    }
}

/// How a series is drawn.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Style {
    /// Line through the points, with a marker at each (sweep curves).
    LineMarkers,
    /// Markers only (independent poses).
    Markers,
    /// Line only (an empirical CDF, drawn as steps by its caller).
    Line,
}

/// One named series of points.
#[derive(Clone, Debug, PartialEq)]
pub struct Series {
    /// Legend text, in words.
    pub name: String,
    /// `(x, y)` points, drawn in the order given.
    pub points: Vec<(f64, f64)>,
    /// Empty, or one `(low, high)` error bar per point.
    pub bars: Vec<(f64, f64)>,
    /// How it is drawn.
    pub style: Style,
}

impl Series {
    /// A series without error bars.
    pub fn new(name: impl Into<String>, points: Vec<(f64, f64)>, style: Style) -> Self {
        Series {
            name: name.into(),
            points,
            bars: Vec::new(),
            style,
        }
    }
}

/// A labelled reference line.
#[derive(Clone, Debug, PartialEq)]
pub struct RefLine {
    /// Legend text, e.g. "paper: 0.340 mm".
    pub label: String,
    /// Where it is (y for a horizontal line, x for a vertical one).
    pub at: f64,
    /// Vertical (at an x value) or horizontal (at a y value).
    pub vertical: bool,
    /// `Some(i)`: the colour of series `i`; `None`: dark grey.
    pub color_of: Option<usize>,
}

impl RefLine {
    /// A horizontal grey line at `y`.
    pub fn horizontal(label: impl Into<String>, y: f64) -> Self {
        RefLine {
            label: label.into(),
            at: y,
            vertical: false,
            color_of: None,
        }
    }

    /// A vertical grey line at `x`.
    pub fn vertical(label: impl Into<String>, x: f64) -> Self {
        RefLine {
            label: label.into(),
            at: x,
            vertical: true,
            color_of: None,
        }
    }

    /// The same line in the colour of series `i`.
    pub fn colored(mut self, i: usize) -> Self {
        self.color_of = Some(i);
        self
    }
}

/// Where the legend goes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LegendAt {
    /// Upper right corner (headroom is added above the data).
    UpperRight,
    /// Lower right corner, for data that leave it empty (a CDF); no headroom is added.
    LowerRight,
}

/// Everything one panel shows.
#[derive(Clone, Debug, PartialEq)]
pub struct Figure {
    /// Title above the plot (may be empty for the lower panels of a multi-panel figure).
    pub title: String,
    /// x axis title, in words with unit.
    pub x_title: String,
    /// y axis title, in words with unit.
    pub y_title: String,
    /// x scale.
    pub x_scale: Scale,
    /// y scale.
    pub y_scale: Scale,
    /// Explicit x ticks (e.g. the sweep's values); `None`: 1-2-5 ticks.
    pub x_ticks: Option<Vec<f64>>,
    /// Category labels at x = 0, 1, …, n − 1 (parameter names); replaces the x ticks.
    pub x_categories: Option<Vec<String>>,
    /// Start a linear y axis at zero (counts, errors).
    pub y_from_zero: bool,
    /// Shift the markers of series `i` sideways so that coinciding points stay distinct.
    pub dodge: bool,
    /// The series.
    pub series: Vec<Series>,
    /// Reference lines (drawn dashed, listed in the legend).
    pub refs: Vec<RefLine>,
    /// Legend corner.
    pub legend: LegendAt,
}

impl Figure {
    /// An empty linear figure with the given titles.
    pub fn new(
        title: impl Into<String>,
        x_title: impl Into<String>,
        y_title: impl Into<String>,
    ) -> Self {
        Figure {
            title: title.into(),
            x_title: x_title.into(),
            y_title: y_title.into(),
            x_scale: Scale::Linear,
            y_scale: Scale::Linear,
            x_ticks: None,
            x_categories: None,
            y_from_zero: false,
            dodge: false,
            series: Vec::new(),
            refs: Vec::new(),
            legend: LegendAt::UpperRight,
        }
    }
}

/// A single-panel figure as SVG ([`WIDTH`]×[`HEIGHT`]).
///
/// # Errors
/// [`PlotError::Empty`] if there is no series or a series has no points,
/// [`PlotError::NonFinite`] / [`PlotError::InvalidValue`] naming the series and index,
/// [`PlotError::LengthMismatch`] if a series' bars do not match its points.
pub fn figure_svg(fig: &Figure) -> Result<String, PlotError> {
    panels_svg(std::slice::from_ref(fig), HEIGHT)
}

/// Panels stacked vertically in one SVG of [`WIDTH`]×`height`, each with its own axes.
///
/// # Errors
/// As [`figure_svg`], for any panel; [`PlotError::Empty`] if there are no panels.
pub fn panels_svg(panels: &[Figure], height: u32) -> Result<String, PlotError> {
    if panels.is_empty() {
        return Err(empty("the list of panels"));
    }
    let panel_h = height as f64 / panels.len() as f64;
    let prepared: Vec<Prepared> = panels
        .iter()
        .map(|f| prepare(f, panel_h))
        .collect::<Result<_, _>>()?;
    render(height, |root| {
        let areas = root.split_evenly((panels.len(), 1));
        for ((area, fig), p) in areas.iter().zip(panels).zip(&prepared) {
            draw_panel(root, area, fig, p)?;
        }
        Ok(())
    })
}

/// Most steps a CDF draws per sample (see [`cdf_figure`]).
pub const MAX_CDF_STEPS: usize = 2000;

/// Empirical cumulative distribution: for each named sample, the share of values ≤ x (%),
/// drawn as steps (above [`MAX_CDF_STEPS`] values, the steps of every k-th value and of the
/// largest).
///
/// # Errors
/// [`PlotError::Empty`] if a sample is empty, [`PlotError::NonFinite`] for NaN or infinity.
pub fn cdf_figure(
    title: &str,
    x_title: &str,
    samples: &[(String, Vec<f64>)],
    refs: Vec<RefLine>,
) -> Result<Figure, PlotError> {
    let mut fig = Figure::new(title, x_title, "share of poses with a smaller error (%)");
    fig.legend = LegendAt::LowerRight;
    for (name, values) in samples {
        if values.is_empty() {
            return Err(empty(&format!("sample `{name}`")));
        }
        check_finite(name, values)?;
        let mut v = values.clone();
        v.sort_by(f64::total_cmp);
        let n = v.len() as f64;
        // Every step up to MAX_CDF_STEPS values; above, the steps of every k-th value and
        // the last (the curve is the same to the pixel, the file stays small).
        let k = v.len().div_ceil(MAX_CDF_STEPS).max(1);
        let mut steps: Vec<usize> = (0..v.len()).step_by(k).collect();
        if steps.last() != Some(&(v.len() - 1)) {
            steps.push(v.len() - 1);
        }
        let mut points = Vec::with_capacity(2 * steps.len() + 1);
        points.push((v[0], 0.0));
        for &i in &steps {
            points.push((v[i], 100.0 * i as f64 / n));
            points.push((v[i], 100.0 * (i + 1) as f64 / n));
        }
        fig.series
            .push(Series::new(name.clone(), points, Style::Line));
    }
    fig.refs = refs;
    fig.y_from_zero = true;
    Ok(fig)
}

/// A histogram of pre-binned data: one bar per `(lo, hi, count)` bin, with reference lines
/// (e.g. the mean and the paper's value) drawn vertically.
///
/// The campaign aggregates values in streaming histograms, so it passes bins, not raw values;
/// [`rebin`] turns `(value, count)` pairs into equal-width bins. `x_title` should carry the
/// unit; the y axis is the count of trials.
///
/// # Errors
/// [`PlotError::Empty`] if there are no bins, [`PlotError::NonFinite`] if an edge is NaN or
/// infinite, [`PlotError::InvalidValue`] if a bin's upper edge is not above its lower edge.
pub fn histogram_svg(
    title: &str,
    x_title: &str,
    y_title: &str,
    bins: &[(f64, f64, u64)],
    refs: &[RefLine],
) -> Result<String, PlotError> {
    if bins.is_empty() {
        return Err(empty("histogram bins"));
    }
    check_finite("bin lower edges", bins.iter().map(|b| b.0))?;
    check_finite("bin upper edges", bins.iter().map(|b| b.1))?;
    if let Some((index, &(_, hi, _))) = bins.iter().enumerate().find(|(_, b)| b.1 <= b.0) {
        return Err(PlotError::InvalidValue {
            series: "bin upper edges".into(),
            index,
            value: hi,
            reason: "a bin's upper edge must be above its lower edge",
        });
    }
    check_finite("reference lines", refs.iter().map(|r| r.at))?;
    let lo = bins.iter().map(|b| b.0).fold(f64::INFINITY, f64::min);
    let hi = bins.iter().map(|b| b.1).fold(f64::NEG_INFINITY, f64::max);
    let lo = refs.iter().map(|r| r.at).fold(lo, f64::min);
    let hi = refs.iter().map(|r| r.at).fold(hi, f64::max);
    let max_count = bins.iter().map(|b| b.2).max().unwrap_or(0).max(1) as f64;
    let mut fig = Figure::new(title, x_title, y_title);
    fig.y_from_zero = true;
    fig.refs = refs.to_vec();
    // The frame of the axes: an invisible series at the corners.
    fig.series.push(Series::new(
        "",
        vec![(lo, 0.0), (hi, max_count)],
        Style::Line,
    ));
    let p = prepare(&fig, HEIGHT as f64)?;
    render(HEIGHT, |root| {
        let mut chart = build(root, root, &fig, &p)?;
        let gap =
            u32::from((hi - lo) / (p.x.hi - p.x.lo) * 700.0 / bins.len() as f64 >= 6.0 && !p.x.log);
        chart
            .draw_series(bins.iter().map(|&(lo, hi, count)| {
                let mut bar = Rectangle::new([(lo, 0.0), (hi, count as f64)], BAR.filled());
                bar.set_margin(0, 0, gap, gap);
                bar
            }))
            .map_err(backend)?;
        draw_refs(&mut chart, &fig)?;
        draw_legend(root, &chart, &fig)
    })
}

/// Turns `(value, count)` pairs into `n_bins` equal-width `(lo, hi, count)` bins spanning the
/// range of the values.
///
/// Each value falls in the bin `[lo, hi)`, except that the largest value goes in the last
/// bin. Counts of equal values add up (saturating). If all values are equal, the bins span
/// `v ± 5 %` of `|v|` (`± 0.5` for `v = 0`). The result depends only on the multiset of
/// pairs, not their order. Returns an empty vector if `n_bins` is 0 or there are no finite
/// values; non-finite values are skipped.
pub fn rebin(values: &[(f64, u64)], n_bins: usize) -> Vec<(f64, f64, u64)> {
    let finite = || values.iter().filter(|(v, _)| v.is_finite());
    let Some(first) = finite().next() else {
        return Vec::new();
    };
    if n_bins == 0 {
        return Vec::new();
    }
    let (mut lo, mut hi) = (first.0, first.0);
    for &(v, _) in finite() {
        lo = lo.min(v);
        hi = hi.max(v);
    }
    if lo == hi {
        let half = if lo == 0.0 { 0.5 } else { lo.abs() * 0.05 };
        (lo, hi) = (lo - half, hi + half);
    }
    let span = hi - lo;
    let n = n_bins as f64;
    let edge = |i: usize| {
        if i == n_bins {
            hi
        } else {
            lo + span * (i as f64 / n)
        }
    };
    let mut bins: Vec<(f64, f64, u64)> = (0..n_bins).map(|i| (edge(i), edge(i + 1), 0)).collect();
    for &(v, count) in finite() {
        let i = (((v - lo) / span) * n).floor() as usize;
        let bin = &mut bins[i.min(n_bins - 1)];
        bin.2 = bin.2.saturating_add(count);
    }
    bins
}

// ---------------------------------------------------------------------------------------------
// Styles
// ---------------------------------------------------------------------------------------------

/// Okabe–Ito colours (colour-blind safe), without yellow and black.
pub const PALETTE: [RGBColor; 6] = [
    RGBColor(0, 114, 178),   // blue
    RGBColor(213, 94, 0),    // vermillion
    RGBColor(0, 158, 115),   // bluish green
    RGBColor(204, 121, 167), // reddish purple
    RGBColor(230, 159, 0),   // orange
    RGBColor(86, 180, 233),  // sky blue
];
/// Histogram bars.
const BAR: RGBColor = RGBColor(86, 150, 200);
/// Reference lines without a series colour.
const REF: RGBColor = RGBColor(90, 90, 90);
/// Approximate width of one legend character in pixels (15 px sans-serif, generous).
const CHAR_WIDTH_PX: f64 = 8.0;

/// Marker shapes, in the order series get them.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Marker {
    Circle,
    Triangle,
    Square,
    Diamond,
    OpenCircle,
    OpenTriangle,
    OpenSquare,
    OpenDiamond,
}

const MARKERS: [Marker; 8] = [
    Marker::Circle,
    Marker::Triangle,
    Marker::Square,
    Marker::Diamond,
    Marker::OpenCircle,
    Marker::OpenTriangle,
    Marker::OpenSquare,
    Marker::OpenDiamond,
];

/// Dash patterns `(dash, gap)` in pixels, in the order series get them; `(0, 0)` is solid.
const DASHES: [(u32, u32); 4] = [(0, 0), (9, 5), (3, 4), (16, 5)];

fn color_of(i: usize) -> RGBColor {
    PALETTE[i % PALETTE.len()]
}

fn marker_of(i: usize) -> Marker {
    MARKERS[i % MARKERS.len()]
}

fn dash_of(i: usize) -> (u32, u32) {
    DASHES[i % DASHES.len()]
}

// ---------------------------------------------------------------------------------------------
// Axes
// ---------------------------------------------------------------------------------------------

/// A linear or log axis over `[lo, hi]` (in log10 units for a log axis) with explicit ticks.
#[derive(Clone, Debug)]
struct Coord {
    log: bool,
    lo: f64,
    hi: f64,
    ticks: Vec<f64>,
}

impl Coord {
    fn t(&self, v: f64) -> f64 {
        if self.log { v.log10() } else { v }
    }
}

impl Ranged for Coord {
    type FormatOption = NoDefaultFormatting;
    type ValueType = f64;

    fn map(&self, value: &f64, limit: (i32, i32)) -> i32 {
        RangedCoordf64::from(self.lo..self.hi).map(&self.t(*value), limit)
    }

    fn key_points<H: KeyPointHint>(&self, hint: H) -> Vec<f64> {
        if hint.weight().allow_light_points() {
            Vec::new()
        } else {
            self.ticks.clone()
        }
    }

    fn range(&self) -> Range<f64> {
        if self.log {
            10f64.powf(self.lo)..10f64.powf(self.hi)
        } else {
            self.lo..self.hi
        }
    }
}

impl ValueFormatter<f64> for Coord {
    fn format(value: &f64) -> String {
        number(*value)
    }
}

/// `m · 10^k` as the f64 nearest to its decimal value (so that it prints as e.g. `0.2`).
fn decimal(m: i64, k: i32) -> f64 {
    format!("{m}e{k}").parse().unwrap_or(f64::NAN)
}

/// 1-2-5 ticks inside `[lo, hi]`, at most about `max` of them.
fn linear_ticks(lo: f64, hi: f64, max: usize) -> Vec<f64> {
    let span = hi - lo;
    if span <= 0.0 || !span.is_finite() {
        return vec![lo];
    }
    let raw = span / max as f64;
    let e = raw.log10().floor() as i32;
    let (m, e) = [1, 2, 5, 10]
        .iter()
        .map(|&m| (m, e))
        .find(|&(m, e)| decimal(m, e) >= raw)
        .unwrap_or((10, e));
    let step = decimal(m, e);
    let (k0, k1) = ((lo / step).ceil() as i64, (hi / step).floor() as i64);
    (k0..=k1).map(|k| decimal(k * m, e)).collect()
}

/// Ticks for a log axis spanning `[10^lo, 10^hi]`: the densest of the mantissa sets 1–9,
/// {1, 2, 5}, {1} that gives at most 10 ticks, or every n-th power of ten over many decades;
/// the two ends if no such tick falls inside.
fn log_ticks(lo: f64, hi: f64) -> Vec<f64> {
    const MAX_TICKS: usize = 10;
    let (k0, k1) = (lo.floor() as i32, hi.ceil() as i32);
    let inside = |v: &f64| (lo..=hi).contains(&v.log10());
    let all: [&[i64]; 3] = [&[1, 2, 3, 4, 5, 6, 7, 8, 9], &[1, 2, 5], &[1]];
    for mantissas in all {
        let ticks: Vec<f64> = (k0..=k1)
            .flat_map(|k| mantissas.iter().map(move |&m| decimal(m, k)))
            .filter(inside)
            .collect();
        if ticks.len() <= MAX_TICKS {
            return if ticks.len() < 2 {
                let r = |v: f64| format!("{v:.2e}").parse().unwrap_or(v);
                vec![r(10f64.powf(lo)), r(10f64.powf(hi))]
            } else {
                ticks
            };
        }
    }
    let step = ((k1 - k0) as usize).div_ceil(MAX_TICKS) as i32;
    (k0..=k1)
        .filter(|k| k.rem_euclid(step) == 0)
        .map(|k| decimal(1, k))
        .filter(inside)
        .collect()
}

/// Fraction of the data span to add for a legend of `rows` rows (about 22 px per row plus
/// 16 px of frame, in a plotting area of `plot_px` pixels).
fn legend_headroom(rows: usize, plot_px: f64) -> f64 {
    if rows == 0 {
        return 0.0;
    }
    let f = ((16 + 22 * rows) as f64 / plot_px).min(0.6);
    f / (1.0 - f)
}

// ---------------------------------------------------------------------------------------------
// Preparation: validation and ranges
// ---------------------------------------------------------------------------------------------

struct Prepared {
    x: Coord,
    y: Coord,
    /// Pixel height of the x label area.
    x_area: u32,
    rotate_categories: bool,
}

fn check_finite(
    series: &str,
    values: impl IntoIterator<Item = impl std::borrow::Borrow<f64>>,
) -> Result<(), PlotError> {
    match values
        .into_iter()
        .map(|v| *v.borrow())
        .enumerate()
        .find(|(_, v)| !v.is_finite())
    {
        Some((index, value)) => Err(PlotError::NonFinite {
            series: series.into(),
            index,
            value,
        }),
        None => Ok(()),
    }
}

fn check_positive(series: &str, index: usize, value: f64, log: bool) -> Result<(), PlotError> {
    if log && value <= 0.0 {
        return Err(PlotError::InvalidValue {
            series: series.into(),
            index,
            value,
            reason: "a logarithmic axis needs positive values",
        });
    }
    Ok(())
}

fn legend_rows(fig: &Figure) -> usize {
    fig.series.iter().filter(|s| !s.name.is_empty()).count()
        + fig.refs.iter().filter(|r| !r.label.is_empty()).count()
}

/// Validates `fig` and chooses its axes, for a panel `panel_h` pixels high.
fn prepare(fig: &Figure, panel_h: f64) -> Result<Prepared, PlotError> {
    if fig.series.is_empty() {
        return Err(empty("the list of series"));
    }
    let (xlog, ylog) = (fig.x_scale == Scale::Log, fig.y_scale == Scale::Log);
    let mut xs = Vec::new();
    let mut ys = Vec::new();
    for s in &fig.series {
        if s.points.is_empty() {
            return Err(empty(&format!("series `{}`", s.name)));
        }
        if !s.bars.is_empty() && s.bars.len() != s.points.len() {
            return Err(PlotError::LengthMismatch {
                what: format!("error bars of `{}`", s.name),
                expected: s.points.len(),
                got: s.bars.len(),
            });
        }
        for (i, &(x, y)) in s.points.iter().enumerate() {
            check_finite(&s.name, [x, y]).map_err(|_| PlotError::NonFinite {
                series: s.name.clone(),
                index: i,
                value: if x.is_finite() { y } else { x },
            })?;
            check_positive(&s.name, i, x, xlog)?;
            check_positive(&s.name, i, y, ylog)?;
            xs.push(x);
            ys.push(y);
        }
        for (i, &(lo, hi)) in s.bars.iter().enumerate() {
            let what = format!("error bars of `{}`", s.name);
            check_finite(&what, [lo, hi]).map_err(|_| PlotError::NonFinite {
                series: what.clone(),
                index: i,
                value: if lo.is_finite() { hi } else { lo },
            })?;
            if hi < lo {
                return Err(PlotError::InvalidValue {
                    series: what,
                    index: i,
                    value: hi,
                    reason: "an error bar's upper end is below its lower end",
                });
            }
            // On a log axis a bar reaching zero or below is cut at the axis' bottom.
            if !ylog || lo > 0.0 {
                ys.push(lo);
            }
            ys.push(hi);
        }
    }
    for (i, r) in fig.refs.iter().enumerate() {
        check_finite("reference lines", [r.at]).map_err(|_| PlotError::NonFinite {
            series: format!("reference line `{}`", r.label),
            index: i,
            value: r.at,
        })?;
        check_positive(&r.label, i, r.at, if r.vertical { xlog } else { ylog })?;
        if r.vertical { &mut xs } else { &mut ys }.push(r.at);
    }
    if let Some(t) = &fig.x_ticks {
        check_finite("x ticks", t)?;
        for (i, &v) in t.iter().enumerate() {
            check_positive("x ticks", i, v, xlog)?;
        }
        xs.extend(t);
    }

    // The plotting area's height: the panel less the title, the margins and the x labels.
    let x_area_px = match &fig.x_categories {
        Some(c) => c.iter().map(|l| l.chars().count()).max().unwrap_or(0) as f64 * 8.5 + 40.0,
        None => 50.0,
    };
    let title_px = if fig.title.is_empty() { 0.0 } else { 35.0 };
    let plot_h = (panel_h - title_px - x_area_px - 30.0).max(100.0);
    let headroom = legend_headroom(legend_rows(fig), plot_h);
    let (y_pad_lo, y_pad_hi) = match fig.legend {
        LegendAt::UpperRight => (0.04, 0.06 + headroom),
        // The caller puts the legend low only where the data leave that corner empty (a CDF).
        LegendAt::LowerRight => (0.04, 0.06),
    };
    let t = |v: f64, log: bool| if log { v.log10() } else { v };
    let (mut x0, mut x1) = min_max(xs.iter().map(|&v| t(v, xlog)));
    let (mut y0, mut y1) = min_max(ys.iter().map(|&v| t(v, ylog)));
    if fig.y_from_zero && !ylog {
        y0 = y0.min(0.0);
        y1 = y1.max(0.0);
    }
    (x0, x1) = widen(x0, x1);
    (y0, y1) = widen(y0, y1);
    let (xs_span, ys_span) = (x1 - x0, y1 - y0);
    let (x_pad_lo, x_pad_hi) = if let Some(c) = &fig.x_categories {
        (x0, x1) = (-0.5, c.len() as f64 - 0.5);
        (0.0, 0.0)
    } else {
        (0.04, 0.04)
    };
    let x_lo = x0 - x_pad_lo * xs_span;
    let x_hi = x1 + x_pad_hi * xs_span;
    let y_lo = if fig.y_from_zero && !ylog && y0 >= 0.0 && fig.legend == LegendAt::UpperRight {
        0.0
    } else {
        y0 - y_pad_lo * ys_span
    };
    let y_hi = y1 + y_pad_hi * ys_span;

    let x_ticks = if fig.x_categories.is_some() {
        Vec::new()
    } else if let Some(t) = &fig.x_ticks {
        let mut t = t.clone();
        t.sort_by(f64::total_cmp);
        t.dedup();
        // Labels need about 34 px each: drop a tick closer than that to the last one kept
        // (the plot is about 680 px wide).
        let px = |v: f64| (if xlog { v.log10() } else { v } - x_lo) / (x_hi - x_lo) * 680.0;
        let mut kept: Vec<f64> = Vec::with_capacity(t.len());
        for v in t {
            if kept.last().is_none_or(|&k| px(v) - px(k) >= 34.0) {
                kept.push(v);
            }
        }
        kept
    } else if xlog {
        log_ticks(x_lo, x_hi)
    } else {
        linear_ticks(x_lo, x_hi, 8)
    };
    let y_ticks = if ylog {
        let t = log_ticks(y_lo, y_hi);
        if t.len() < 3 {
            // Less than a decade: 1-2-5 steps in value space.
            let (a, b) = (10f64.powf(y_lo), 10f64.powf(y_hi));
            linear_ticks(a, b, 5)
                .into_iter()
                .filter(|&v| v > 0.0)
                .collect()
        } else {
            t
        }
    } else {
        linear_ticks(y_lo, y_hi, 6)
    };

    let (x_area, rotate) = match &fig.x_categories {
        Some(c) => {
            let longest = c.iter().map(|l| l.chars().count()).max().unwrap_or(0) as f64;
            let rotate = longest * 8.0 + 6.0 > 700.0 / c.len().max(1) as f64;
            let area = if rotate {
                (longest * 8.5) as u32 + 40
            } else {
                50
            };
            (area, rotate)
        }
        None => (50, false),
    };
    Ok(Prepared {
        x: Coord {
            log: xlog,
            lo: x_lo,
            hi: x_hi,
            ticks: x_ticks,
        },
        y: Coord {
            log: ylog,
            lo: y_lo,
            hi: y_hi,
            ticks: y_ticks,
        },
        x_area,
        rotate_categories: rotate,
    })
}

fn min_max(values: impl Iterator<Item = f64>) -> (f64, f64) {
    values.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
        (a.min(v), b.max(v))
    })
}

/// A zero span widened to `± 5 %` of the value (`± 0.5` at zero).
fn widen(lo: f64, hi: f64) -> (f64, f64) {
    if hi > lo {
        (lo, hi)
    } else {
        let half = if lo == 0.0 { 0.5 } else { lo.abs() * 0.05 };
        (lo - half, hi + half)
    }
}

// ---------------------------------------------------------------------------------------------
// Drawing
// ---------------------------------------------------------------------------------------------

type Area<'a> = DrawingArea<SVGBackend<'a>, Shift>;
type Chart<'a, 'b> = ChartContext<'a, SVGBackend<'b>, Cartesian2d<Coord, Coord>>;

fn empty(what: &str) -> PlotError {
    PlotError::Empty { what: what.into() }
}

fn backend<E: std::fmt::Display>(e: E) -> PlotError {
    PlotError::Backend(e.to_string())
}

/// Draws into a fresh white [`WIDTH`]×`height` SVG and returns its text.
fn render(
    height: u32,
    draw: impl FnOnce(&Area<'_>) -> Result<(), PlotError>,
) -> Result<String, PlotError> {
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (WIDTH, height)).into_drawing_area();
        root.fill(&WHITE).map_err(backend)?;
        draw(&root)?;
        root.present().map_err(backend)?;
    }
    Ok(svg)
}

// plotters' SVG backend writes font sizes divided by 1.24 (its pixel-to-point factor): these
// give 17, 15 and 13.3 px in the SVG.
fn title_font() -> TextStyle<'static> {
    ("sans-serif", 21.08).into_font().into()
}

fn axis_font() -> TextStyle<'static> {
    ("sans-serif", 18.6).into_font().into()
}

fn tick_font() -> TextStyle<'static> {
    ("sans-serif", 16.49).into_font().into()
}

fn build<'a, 'b>(
    _root: &Area<'b>,
    area: &'a Area<'b>,
    fig: &Figure,
    p: &Prepared,
) -> Result<Chart<'a, 'b>, PlotError> {
    let mut builder = ChartBuilder::on(area);
    if !fig.title.is_empty() {
        builder.caption(&fig.title, title_font());
    }
    let mut chart = builder
        .margin(12)
        .margin_right(25)
        .x_label_area_size(p.x_area)
        .y_label_area_size(80)
        .build_cartesian_2d(p.x.clone(), p.y.clone())
        .map_err(backend)?;
    let mut mesh = chart.configure_mesh();
    mesh.x_desc(fig.x_title.as_str())
        .y_desc(fig.y_title.as_str())
        .axis_desc_style(axis_font())
        .label_style(tick_font())
        .light_line_style(TRANSPARENT)
        .bold_line_style(RGBColor(225, 225, 225).stroke_width(1));
    if fig.x_categories.is_some() {
        mesh.disable_x_mesh();
    }
    mesh.draw().map_err(backend)?;
    Ok(chart)
}

fn draw_panel<'b>(
    root: &Area<'b>,
    area: &Area<'b>,
    fig: &Figure,
    p: &Prepared,
) -> Result<(), PlotError> {
    let mut chart = build(root, area, fig, p)?;
    draw_refs(&mut chart, fig)?;
    let n = fig.series.len();
    for (i, s) in fig.series.iter().enumerate() {
        let color = color_of(i);
        // Sideways shift of this series' markers, in pixels.
        let dx = if fig.dodge && n > 1 {
            (i as f64 - (n - 1) as f64 / 2.0) * 6.0
        } else {
            0.0
        };
        let px: Vec<(i32, i32)> = s
            .points
            .iter()
            .map(|pt| {
                let (x, y) = chart.backend_coord(pt);
                ((x as f64 + dx).round() as i32, y)
            })
            .collect();
        if matches!(s.style, Style::LineMarkers | Style::Line) {
            // In pixels, through the dodged markers (every point is inside the axes).
            let style = color.stroke_width(2);
            let d = dash_of(i);
            if d.0 == 0 {
                root.draw(&PathElement::new(px.clone(), style))
                    .map_err(backend)?;
            } else {
                root.draw(&DashedPathElement::new(px.clone(), d.0, d.1, style))
                    .map_err(backend)?;
            }
        }
        if !s.bars.is_empty() {
            let ylo = 10f64.powf(p.y.lo);
            for (k, &(lo, hi)) in s.bars.iter().enumerate() {
                let lo = if p.y.log { lo.max(ylo) } else { lo };
                let (_, plo) = chart.backend_coord(&(s.points[k].0, lo));
                let (_, phi) = chart.backend_coord(&(s.points[k].0, hi));
                let x = px[k].0;
                let style = color.stroke_width(1);
                root.draw(&PathElement::new(
                    vec![
                        (x - 4, plo),
                        (x + 4, plo),
                        (x, plo),
                        (x, phi),
                        (x - 4, phi),
                        (x + 4, phi),
                    ],
                    style,
                ))
                .map_err(backend)?;
            }
        }
        if s.style != Style::Line {
            let r = if s.points.len() > 300 { 2 } else { 4 };
            for &q in &px {
                draw_marker(root, q, marker_of(i), color, r)?;
            }
        }
    }
    if let Some(c) = &fig.x_categories {
        let style = tick_font();
        let label_style = if p.rotate_categories {
            style
                .transform(FontTransform::Rotate270)
                .pos(Pos::new(HPos::Right, VPos::Center))
        } else {
            style.pos(Pos::new(HPos::Center, VPos::Top))
        };
        let y0 = 10f64.powf(p.y.lo);
        let y_at = if p.y.log { y0 } else { p.y.lo };
        for (i, label) in c.iter().enumerate() {
            let (px, py) = chart.backend_coord(&(i as f64, y_at));
            root.draw(&PathElement::new(vec![(px, py), (px, py + 5)], BLACK))
                .map_err(backend)?;
            root.draw(&Text::new(
                label.as_str(),
                (px, py + 8),
                label_style.clone(),
            ))
            .map_err(backend)?;
        }
    }
    draw_legend(root, &chart, fig)
}

fn draw_line(
    chart: &mut Chart<'_, '_>,
    points: &[(f64, f64)],
    color: RGBColor,
    dash: (u32, u32),
    width: u32,
) -> Result<(), PlotError> {
    let style = color.stroke_width(width);
    if dash.0 == 0 {
        chart
            .draw_series(LineSeries::new(points.iter().copied(), style))
            .map_err(backend)?;
    } else {
        chart
            .draw_series(DashedLineSeries::new(
                points.iter().copied(),
                dash.0,
                dash.1,
                style,
            ))
            .map_err(backend)?;
    }
    Ok(())
}

fn draw_refs(chart: &mut Chart<'_, '_>, fig: &Figure) -> Result<(), PlotError> {
    let (xr, yr) = (chart.x_range(), chart.y_range());
    for r in &fig.refs {
        let color = r.color_of.map_or(REF, color_of);
        let pts = if r.vertical {
            vec![(r.at, yr.start), (r.at, yr.end)]
        } else {
            vec![(xr.start, r.at), (xr.end, r.at)]
        };
        draw_line(chart, &pts, color, (7, 5), 2)?;
    }
    Ok(())
}

fn draw_marker(
    root: &Area<'_>,
    (x, y): (i32, i32),
    m: Marker,
    color: RGBColor,
    r: i32,
) -> Result<(), PlotError> {
    let fill = color.filled();
    let stroke = color.stroke_width(2);
    let tri = |r: i32| vec![(x, y - r - 1), (x - r - 1, y + r), (x + r + 1, y + r)];
    let sq = |r: i32| {
        vec![
            (x - r, y - r),
            (x + r, y - r),
            (x + r, y + r),
            (x - r, y + r),
        ]
    };
    let dia = |r: i32| {
        vec![
            (x, y - r - 1),
            (x + r + 1, y),
            (x, y + r + 1),
            (x - r - 1, y),
        ]
    };
    let closed = |mut v: Vec<(i32, i32)>| {
        v.push(v[0]);
        v
    };
    match m {
        Marker::Circle => root.draw(&Circle::new((x, y), r, fill)),
        Marker::OpenCircle => root.draw(&Circle::new((x, y), r, stroke)),
        Marker::Triangle => root.draw(&Polygon::new(tri(r), fill)),
        Marker::OpenTriangle => root.draw(&PathElement::new(closed(tri(r)), stroke)),
        Marker::Square => root.draw(&Polygon::new(sq(r), fill)),
        Marker::OpenSquare => root.draw(&PathElement::new(closed(sq(r)), stroke)),
        Marker::Diamond => root.draw(&Polygon::new(dia(r), fill)),
        Marker::OpenDiamond => root.draw(&PathElement::new(closed(dia(r)), stroke)),
    }
    .map_err(backend)
}

/// The legend: a white box in the chosen corner, one row per named series (line sample in
/// its dash pattern, marker) and per reference line.
fn draw_legend(root: &Area<'_>, chart: &Chart<'_, '_>, fig: &Figure) -> Result<(), PlotError> {
    /// Label, colour, marker, dash pattern.
    type Row = (String, RGBColor, Option<Marker>, Option<(u32, u32)>);
    let mut rows: Vec<Row> = Vec::new();
    for (i, s) in fig.series.iter().enumerate() {
        if s.name.is_empty() {
            continue;
        }
        let marker = (s.style != Style::Line).then(|| marker_of(i));
        let dash = (s.style != Style::Markers).then(|| dash_of(i));
        rows.push((s.name.clone(), color_of(i), marker, dash));
    }
    for r in fig.refs.iter().filter(|r| !r.label.is_empty()) {
        rows.push((
            r.label.clone(),
            r.color_of.map_or(REF, color_of),
            None,
            Some((7, 5)),
        ));
    }
    if rows.is_empty() {
        return Ok(());
    }
    let (xr, yr) = chart.plotting_area().get_pixel_range();
    let longest = rows.iter().map(|r| r.0.chars().count()).max().unwrap_or(0) as f64;
    let w = (longest * CHAR_WIDTH_PX) as i32 + 56;
    let h = 22 * rows.len() as i32 + 12;
    let x1 = xr.end - 8;
    let x0 = (x1 - w).max(xr.start + 4);
    let (y0, _y1) = match fig.legend {
        LegendAt::UpperRight => (yr.start + 8, yr.start + 8 + h),
        LegendAt::LowerRight => (yr.end - 8 - h, yr.end - 8),
    };
    root.draw(&Rectangle::new(
        [(x0, y0), (x1, y0 + h)],
        WHITE.mix(0.9).filled(),
    ))
    .map_err(backend)?;
    root.draw(&Rectangle::new(
        [(x0, y0), (x1, y0 + h)],
        RGBColor(160, 160, 160).stroke_width(1),
    ))
    .map_err(backend)?;
    for (k, (label, color, marker, dash)) in rows.iter().enumerate() {
        let y = y0 + 17 + 22 * k as i32;
        let (sx0, sx1) = (x0 + 8, x0 + 40);
        if let Some(d) = dash {
            let style = color.stroke_width(2);
            if d.0 == 0 {
                root.draw(&PathElement::new(vec![(sx0, y), (sx1, y)], style))
                    .map_err(backend)?;
            } else {
                root.draw(&DashedPathElement::new(
                    vec![(sx0, y), (sx1, y)],
                    d.0,
                    d.1,
                    style,
                ))
                .map_err(backend)?;
            }
        }
        if let Some(m) = marker {
            draw_marker(root, ((sx0 + sx1) / 2, y), *m, *color, 4)?;
        }
        root.draw(&Text::new(
            label.as_str(),
            (x0 + 48, y),
            tick_font().pos(Pos::new(HPos::Left, VPos::Center)),
        ))
        .map_err(backend)?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Checks the document frame and returns the contents of every `<text>` element.
    fn texts(svg: &str) -> Vec<String> {
        assert!(svg.starts_with("<svg"));
        assert!(svg.trim_end().ends_with("</svg>"));
        assert_eq!(svg.matches("<text").count(), svg.matches("</text>").count());
        svg.split("<text")
            .skip(1)
            .map(|t| {
                t[t.find('>').unwrap() + 1..t.find("</text>").unwrap()]
                    .trim()
                    .to_string()
            })
            .collect()
    }

    fn has(texts: &[String], want: &str) -> bool {
        texts.iter().any(|t| t == want)
    }

    fn sweep_like(log_x: bool) -> Figure {
        let xs = [1e-9, 1e-6, 1e-3, 1.0, 1e3, 1e6];
        let mut f = Figure::new("T", "μ0 (damping, log scale)", "iterations");
        f.x_scale = if log_x { Scale::Log } else { Scale::Linear };
        f.x_ticks = Some(xs.to_vec());
        f.dodge = true;
        for name in ["Levenberg", "Marquardt"] {
            let mut s = Series::new(
                name,
                xs.iter().map(|&x| (x, 3.0)).collect(),
                Style::LineMarkers,
            );
            s.bars = vec![(2.5, 3.5); xs.len()];
            f.series.push(s);
        }
        f.refs.push(RefLine::horizontal("paper: 3", 3.0));
        f
    }

    /// Centres of the filled circles (the first series' markers) in the SVG.
    fn circles(svg: &str) -> Vec<(f64, f64)> {
        svg.lines()
            .filter(|l| l.starts_with("<circle"))
            .map(|l| {
                let attr = |a: &str| -> f64 {
                    let i = l.find(&format!(" {a}=\"")).unwrap() + a.len() + 3;
                    l[i..i + l[i..].find('"').unwrap()].parse().unwrap()
                };
                (attr("cx"), attr("cy"))
            })
            .collect()
    }

    #[test]
    fn log_x_axis_spreads_log_spaced_values_and_labels_every_tick() {
        let svg = figure_svg(&sweep_like(true)).unwrap();
        let t = texts(&svg);
        for label in [
            "1e-9",
            "1e-6",
            "0.001",
            "1",
            "1000",
            "1e6",
            "μ0 (damping, log scale)",
            "iterations",
            "Levenberg",
            "Marquardt",
            "paper: 3",
            "T",
        ] {
            assert!(has(&t, label), "missing {label:?}");
        }
        // y ticks are labelled too.
        assert!(has(&t, "3"), "{t:?}");
        // The six points of a series sit at equal spacing (a linear axis would put five of
        // them at the same pixel).
        let c = circles(&svg);
        let xs: Vec<f64> = c.iter().take(6).map(|p| p.0).collect();
        let d: Vec<f64> = xs.windows(2).map(|w| w[1] - w[0]).collect();
        assert!(d.iter().all(|&x| x > 80.0), "{xs:?}");
        assert!(d.iter().all(|&x| (x - d[0]).abs() <= 2.0), "{d:?}");
        let lin = circles(&figure_svg(&sweep_like(false)).unwrap());
        assert!(
            (lin[0].0 - lin[3].0).abs() <= 1.0,
            "a linear axis squashes them: {lin:?}"
        );
    }

    #[test]
    fn equal_curves_stay_distinct() {
        let svg = figure_svg(&sweep_like(true)).unwrap();
        // Series 0 has filled circles, series 1 filled triangles, dodged sideways.
        let circles = circles(&svg);
        assert_eq!(circles.len(), 6 + 1, "six markers and one legend sample");
        let triangles: Vec<&str> = svg.lines().filter(|l| l.starts_with("<polygon")).collect();
        assert!(triangles.len() > 6);
        // Different dash patterns: the second series is drawn in dashes (many short lines).
        let orange = format!(
            "#{:02X}{:02X}{:02X}",
            PALETTE[1].0, PALETTE[1].1, PALETTE[1].2
        );
        assert!(
            svg.lines()
                .filter(|l| l.starts_with("<polyline") && l.contains(&orange))
                .count()
                > 20
        );
        // Dodged: the first marker of series 0 is 6 px left of where no dodge puts it.
        let mut plain = sweep_like(true);
        plain.dodge = false;
        let undodged = super::tests::circles(&figure_svg(&plain).unwrap());
        assert!(
            (undodged[0].0 - circles[0].0 - 3.0).abs() <= 1.0,
            "{undodged:?} {circles:?}"
        );
    }

    #[test]
    fn error_bars_are_drawn() {
        let svg = figure_svg(&sweep_like(true)).unwrap();
        let blue = format!(
            "#{:02X}{:02X}{:02X}",
            PALETTE[0].0, PALETTE[0].1, PALETTE[0].2
        );
        // One polyline per bar (caps and stem), 1 px wide, per series.
        let bars = svg
            .lines()
            .filter(|l| {
                l.starts_with("<polyline") && l.contains(&blue) && l.contains("stroke-width=\"1\"")
            })
            .count();
        assert_eq!(bars, 6);
    }

    #[test]
    fn scale_auto() {
        assert_eq!(Scale::auto([1e-9, 1.0, 1e6]), Scale::Log);
        assert_eq!(Scale::auto([8.0, 150.0]), Scale::Linear);
        assert_eq!(Scale::auto([1.0, 100.0]), Scale::Log);
        assert_eq!(Scale::auto([0.0, 100.0]), Scale::Linear);
        assert_eq!(Scale::auto([]), Scale::Linear);
    }

    #[test]
    fn ticks() {
        assert_eq!(
            log_ticks(-3.0, 3.0),
            vec![0.001, 0.01, 0.1, 1.0, 10.0, 100.0, 1000.0]
        );
        assert_eq!(
            log_ticks(-1.0, 1.0),
            vec![0.1, 0.2, 0.5, 1.0, 2.0, 5.0, 10.0]
        );
        let wide = log_ticks(-9.5, 6.5);
        assert!(wide.len() <= 10 && wide.contains(&1.0), "{wide:?}");
        assert_eq!(
            linear_ticks(0.0, 1.0, 5),
            vec![0.0, 0.2, 0.4, 0.6, 0.8, 1.0]
        );
        assert_eq!(linear_ticks(0.31, 0.46, 5), vec![0.35, 0.4, 0.45]);
        assert_eq!(linear_ticks(-7.0, 13.0, 6), vec![-5.0, 0.0, 5.0, 10.0]);
    }

    #[test]
    fn a_sub_decade_log_axis_still_has_labelled_ticks() {
        let mut f = Figure::new("t", "x", "error (mm)");
        f.y_scale = Scale::Log;
        f.series.push(Series::new(
            "a",
            vec![(1.0, 0.34), (2.0, 0.45)],
            Style::LineMarkers,
        ));
        let t = texts(&figure_svg(&f).unwrap());
        let numeric = t
            .iter()
            .filter(|s| s.parse::<f64>().is_ok_and(|v| (0.3..0.5).contains(&v)))
            .count();
        assert!(numeric >= 2, "{t:?}");
    }

    #[test]
    fn crowded_explicit_ticks_are_thinned() {
        let mut f = Figure::new("t", "poses", "e");
        let xs = [8.0, 11.0, 12.0, 13.0, 15.0, 20.0, 30.0, 50.0, 100.0, 150.0];
        f.x_ticks = Some(xs.to_vec());
        f.series.push(Series::new(
            "a",
            xs.iter().map(|&x| (x, 1.0)).collect(),
            Style::Markers,
        ));
        let t = texts(&figure_svg(&f).unwrap());
        assert!(has(&t, "8") && has(&t, "150") && has(&t, "50"));
        assert!(!has(&t, "11") || !has(&t, "12"), "{t:?}");
    }

    #[test]
    fn cdf_steps_reach_one_hundred_percent() {
        let f = cdf_figure(
            "c",
            "e (mm)",
            &[("a".into(), vec![0.3, 0.1, 0.2])],
            Vec::new(),
        )
        .unwrap();
        let p = &f.series[0].points;
        assert_eq!(p.first(), Some(&(0.1, 0.0)));
        assert_eq!(p.last(), Some(&(0.3, 100.0)));
        assert!(p.windows(2).all(|w| w[1].0 >= w[0].0 && w[1].1 >= w[0].1));
        assert!(cdf_figure("c", "e", &[("a".into(), vec![])], Vec::new()).is_err());
    }

    #[test]
    fn bad_input_is_an_error_naming_the_series() {
        let mut f = sweep_like(true);
        f.series[1].points[2].1 = f64::NAN;
        assert!(
            matches!(figure_svg(&f), Err(PlotError::NonFinite { series, index: 2, .. }) if series == "Marquardt")
        );
        let mut f = sweep_like(true);
        f.series[0].points[0].0 = -1.0;
        assert!(matches!(
            figure_svg(&f),
            Err(PlotError::InvalidValue { index: 0, .. })
        ));
        let mut f = sweep_like(true);
        f.series[0].bars.pop();
        assert!(matches!(
            figure_svg(&f),
            Err(PlotError::LengthMismatch {
                expected: 6,
                got: 5,
                ..
            })
        ));
        let mut f = sweep_like(true);
        f.series[0].points.clear();
        assert!(matches!(figure_svg(&f), Err(PlotError::Empty { .. })));
        assert!(matches!(panels_svg(&[], 500), Err(PlotError::Empty { .. })));
        assert!(matches!(
            histogram_svg("t", "x", "n", &[], &[]),
            Err(PlotError::Empty { .. })
        ));
        assert!(matches!(
            histogram_svg("t", "x", "n", &[(0.0, 1.0, 1), (2.0, 2.0, 2)], &[]),
            Err(PlotError::InvalidValue { index: 1, .. })
        ));
    }

    #[test]
    fn text_is_escaped_and_output_deterministic() {
        let mut f = sweep_like(true);
        f.title = "a < b & c".into();
        let svg = figure_svg(&f).unwrap();
        assert!(texts(&svg).contains(&"a &lt; b &amp; c".to_string()));
        assert_eq!(svg, figure_svg(&f).unwrap());
    }

    #[test]
    fn rebin_equal_width_and_conserves_counts() {
        let bins = rebin(&[(0.0, 2), (1.0, 1), (2.5, 4), (4.0, 3), (10.0, 5)], 5);
        assert_eq!(
            bins.iter().map(|b| b.2).collect::<Vec<_>>(),
            vec![3, 4, 3, 0, 5]
        );
        assert_eq!((bins[0].0, bins[4].1), (0.0, 10.0));
        let one = rebin(&[(2.0, 3), (2.0, 4)], 5);
        assert_eq!(
            one.iter().map(|b| b.2).collect::<Vec<_>>(),
            vec![0, 0, 7, 0, 0]
        );
        assert!(rebin(&[], 4).is_empty() && rebin(&[(1.0, 1)], 0).is_empty());
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(64))]
        #[test]
        fn rebin_properties(
            values in proptest::collection::vec((-1e3f64..1e3, 0u64..100), 1..40),
            n in 1usize..30,
        ) {
            let bins = rebin(&values, n);
            proptest::prop_assert_eq!(bins.len(), n);
            let total: u64 = values.iter().map(|v| v.1).sum();
            proptest::prop_assert_eq!(bins.iter().map(|b| b.2).sum::<u64>(), total);
            let mut reversed = values.clone();
            reversed.reverse();
            proptest::prop_assert_eq!(rebin(&reversed, n), bins);
        }
    }
}
