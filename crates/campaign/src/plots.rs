//! Dependency-free SVG plots for campaign reports, returned as `String`.
//!
//! Every function is pure (data in, SVG text out) and deterministic: the same input gives the
//! same bytes. Each figure is [`WIDTH`]×[`HEIGHT`] px with a title, axis labels that carry
//! units, and a legend when more than one series is drawn.
//!
//! Rendering uses plotters' SVG backend without the `ttf` feature. In that configuration
//! plotters estimates text extents with a crude built-in metric (no font files, no system
//! libraries) and the SVG backend writes every string as an escaped `<text>` element, so the
//! viewer's own sans-serif font draws it. The one thing plotters cannot do well here is
//! rotated tick labels (it centres them on the tick), so [`recovery_svg`] places its
//! parameter labels itself.
//!
//! Inputs are validated before anything is drawn: empty data, non-finite values (reported
//! with the series name and index) and mismatched lengths are errors, never silently dropped.

use std::ops::Range;

use plotters::coord::Shift;
use plotters::coord::ranged1d::{
    DefaultFormatting, KeyPointHint, NoDefaultFormatting, ValueFormatter,
};
use plotters::coord::types::RangedCoordf64;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

/// Width of every figure, in pixels.
pub const WIDTH: u32 = 800;
/// Height of every figure, in pixels.
pub const HEIGHT: u32 = 500;

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
    #[error("non-finite value {value} in series `{series}` at index {index}")]
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
    /// A finite value that the plot still cannot represent (e.g. a negative standard
    /// deviation, a non-positive value on a log axis, a bin whose upper edge is not above
    /// its lower edge).
    #[error("invalid value {value} in series `{series}` at index {index}: {reason}")]
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

// ---------------------------------------------------------------------------------------------
// Public plots
// ---------------------------------------------------------------------------------------------

/// The paper's Fig. 7: 3-D position error at each validation pose, before and after
/// calibration.
///
/// x is the validation pose index (1-based), y the position error in mm. Both series are drawn
/// as lines with markers (circles before, triangles after); the legend gives each series'
/// mean. `before_mm[i]` and `after_mm[i]` must refer to the same pose.
///
/// # Errors
/// [`PlotError::Empty`] if there are no poses, [`PlotError::LengthMismatch`] if the two
/// slices differ in length, [`PlotError::NonFinite`] naming the series if a value is NaN or
/// infinite.
pub fn per_pose_errors_svg(
    title: &str,
    before_mm: &[f64],
    after_mm: &[f64],
) -> Result<String, PlotError> {
    const BEFORE: &str = "before calibration";
    const AFTER: &str = "after calibration";
    if before_mm.is_empty() {
        return Err(empty("per-pose errors before calibration"));
    }
    if after_mm.len() != before_mm.len() {
        return Err(PlotError::LengthMismatch {
            what: "per-pose errors after calibration".into(),
            expected: before_mm.len(),
            got: after_mm.len(),
        });
    }
    check_finite(BEFORE, before_mm)?;
    check_finite(AFTER, after_mm)?;

    let n = before_mm.len();
    let (y0, y1) = zero_based_range(before_mm.iter().chain(after_mm).copied(), 2);
    let x_coord = TickedAxis::new(0.5, n as f64 + 0.5, index_ticks(n));
    let series = [
        (BEFORE, before_mm, PALETTE[1], Marker::Circle),
        (AFTER, after_mm, PALETTE[0], Marker::Triangle),
    ];

    render(|root| {
        let mut chart = chart_builder(root, title, 50, 70)
            .build_cartesian_2d(x_coord, y0..y1)
            .map_err(backend)?;
        chart
            .configure_mesh()
            .disable_x_mesh()
            .x_desc("validation pose index")
            .y_desc("3-D position error (mm)")
            .x_label_formatter(&|x| format!("{x:.0}"))
            .axis_desc_style(axis_font())
            .label_style(tick_font())
            .max_light_lines(0)
            .draw()
            .map_err(backend)?;
        for (name, values, color, marker) in series {
            let points: Vec<(f64, f64)> = values
                .iter()
                .enumerate()
                .map(|(i, &v)| ((i + 1) as f64, v))
                .collect();
            let mean = values.iter().sum::<f64>() / n as f64;
            draw_line_with_markers(
                &mut chart,
                &points,
                color,
                marker,
                format!("{name} (mean {mean:.3} mm)"),
            )?;
        }
        draw_legend(&mut chart)
    })
}

/// A histogram of pre-binned data: one bar per `(lo, hi, count)` bin.
///
/// The campaign aggregates values in streaming histograms, so it passes bins, not raw values;
/// [`rebin`] turns `(value, count)` pairs into equal-width bins. `x_label` should carry the
/// unit, e.g. `"mean position error after calibration (mm)"`; the y axis is the count. Bins
/// need not be sorted or contiguous; zero-count bins are drawn as zero-height bars.
///
/// # Errors
/// [`PlotError::Empty`] if there are no bins, [`PlotError::NonFinite`] if an edge is NaN or
/// infinite, [`PlotError::InvalidValue`] if a bin's upper edge is not above its lower edge.
pub fn histogram_svg(
    title: &str,
    x_label: &str,
    bins: &[(f64, f64, u64)],
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

    let lo = bins.iter().map(|b| b.0).fold(f64::INFINITY, f64::min);
    let hi = bins.iter().map(|b| b.1).fold(f64::NEG_INFINITY, f64::max);
    let (x0, x1) = padded_range(lo, hi, 0.02, 0.02);
    let max_count = bins.iter().map(|b| b.2).max().unwrap_or(0);
    let y1 = if max_count == 0 {
        1.0
    } else {
        max_count as f64 * 1.08
    };
    // A one-pixel gap between bars when they are wide enough to afford it.
    let gap = u32::from((hi - lo) / (x1 - x0) * 700.0 / bins.len() as f64 >= 6.0);

    render(|root| {
        let mut chart = chart_builder(root, title, 50, 70)
            .build_cartesian_2d(x0..x1, 0.0..y1)
            .map_err(backend)?;
        chart
            .configure_mesh()
            .disable_x_mesh()
            .x_desc(x_label)
            .y_desc("count")
            .y_label_formatter(&|y| format_count(*y))
            .axis_desc_style(axis_font())
            .label_style(tick_font())
            .max_light_lines(0)
            .draw()
            .map_err(backend)?;
        chart
            .draw_series(bins.iter().map(|&(lo, hi, count)| {
                let mut bar = Rectangle::new([(lo, 0.0), (hi, count as f64)], BAR.filled());
                bar.set_margin(0, 0, gap, gap);
                bar
            }))
            .map_err(backend)?;
        Ok(())
    })
}

/// Turns `(value, count)` pairs into `n_bins` equal-width `(lo, hi, count)` bins spanning the
/// range of the values.
///
/// Each value falls in the bin `[lo, hi)`, except that the largest value goes in the last
/// bin. Counts of equal values add up (saturating). Every finite value, including those with
/// a zero count, widens the range. If all values are equal, the bins span `v ± 5 %` of `|v|`
/// (`± 0.5` for `v = 0`), so the value sits in the middle bin (the upper middle one for an
/// even `n_bins`). The result depends only on
/// the multiset of pairs, not their order.
///
/// Returns an empty vector if `n_bins` is 0 or there are no finite values. Non-finite values
/// are skipped (the campaign's streaming statistics already count them separately).
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
        // `as usize` saturates (and maps NaN from an overflowing span to 0).
        let i = (((v - lo) / span) * n).floor() as usize;
        let bin = &mut bins[i.min(n_bins - 1)];
        bin.2 = bin.2.saturating_add(count);
    }
    bins
}

/// Parameter recovery: one bar per identified parameter showing its mean absolute recovery
/// error (identified − true), with ± 1 standard deviation drawn as a whisker.
///
/// `names`, `mean_abs_error`, `sd` and `unit_labels` are parallel: entry `i` describes
/// parameter `names[i]` in display unit `unit_labels[i]` (e.g. `"mm"`, `"mdeg"`). If all
/// units agree the y label is `"recovery error (<unit>)"`; otherwise it is
/// `"recovery error (display unit)"` and each parameter label carries its unit in brackets.
/// Parameter labels are rotated when they would not fit side by side.
///
/// # Errors
/// [`PlotError::Empty`] if there are no parameters, [`PlotError::LengthMismatch`] if the
/// slices differ in length, [`PlotError::NonFinite`] naming the parameter if a value is NaN
/// or infinite, [`PlotError::InvalidValue`] for a negative standard deviation.
pub fn recovery_svg(
    title: &str,
    names: &[String],
    mean_abs_error: &[f64],
    sd: &[f64],
    unit_labels: &[String],
) -> Result<String, PlotError> {
    let n = names.len();
    if n == 0 {
        return Err(empty("parameter names"));
    }
    for (what, len) in [
        ("mean absolute errors", mean_abs_error.len()),
        ("standard deviations", sd.len()),
        ("unit labels", unit_labels.len()),
    ] {
        if len != n {
            return Err(PlotError::LengthMismatch {
                what: what.into(),
                expected: n,
                got: len,
            });
        }
    }
    for (i, name) in names.iter().enumerate() {
        for (what, value) in [("mean absolute error", mean_abs_error[i]), ("sd", sd[i])] {
            if !value.is_finite() {
                return Err(PlotError::NonFinite {
                    series: format!("{what} of {name}"),
                    index: i,
                    value,
                });
            }
        }
        if sd[i] < 0.0 {
            return Err(PlotError::InvalidValue {
                series: format!("sd of {name}"),
                index: i,
                value: sd[i],
                reason: "a standard deviation cannot be negative",
            });
        }
    }

    let same_unit = unit_labels.iter().all(|u| *u == unit_labels[0]);
    let (y_desc, labels): (String, Vec<String>) = if same_unit {
        (
            format!("recovery error ({})", unit_labels[0]),
            names.to_vec(),
        )
    } else {
        (
            "recovery error (display unit)".into(),
            names
                .iter()
                .zip(unit_labels)
                .map(|(name, unit)| format!("{name} [{unit}]"))
                .collect(),
        )
    };

    let lows = mean_abs_error.iter().zip(sd).map(|(m, s)| m - s);
    let highs = mean_abs_error.iter().zip(sd).map(|(m, s)| m + s);
    let (y0, y1) = zero_based_range(lows.chain(highs), 2);

    // Rotate the parameter labels when they would not fit side by side.
    const PLOT_WIDTH_PX: f64 = 700.0;
    let longest = labels.iter().map(|l| l.chars().count()).max().unwrap_or(0);
    let rotate = longest as f64 * CHAR_WIDTH_PX + 6.0 > PLOT_WIDTH_PX / n as f64;
    let x_area = if rotate {
        (longest as f64 * CHAR_WIDTH_PX) as u32 + 45
    } else {
        50
    }
    .min(HEIGHT / 3);

    render(|root| {
        let mut chart = chart_builder(root, title, x_area, 70)
            // No automatic x ticks: the parameter labels are placed below.
            .build_cartesian_2d(TickedAxis::new(-0.5, n as f64 - 0.5, Vec::new()), y0..y1)
            .map_err(backend)?;
        chart
            .configure_mesh()
            .disable_x_mesh()
            .x_desc("parameter")
            .y_desc(y_desc.as_str())
            .axis_desc_style(axis_font())
            .label_style(tick_font())
            .max_light_lines(0)
            .draw()
            .map_err(backend)?;

        let bar = BAR.filled();
        chart
            .draw_series(mean_abs_error.iter().enumerate().map(|(i, &m)| {
                let x = i as f64;
                Rectangle::new([(x - 0.35, 0.0), (x + 0.35, m)], bar)
            }))
            .map_err(backend)?
            .label("mean |error|")
            .legend(move |(x, y)| Rectangle::new([(x, y - 5), (x + 20, y + 5)], bar));

        let whisker = WHISKER.stroke_width(1);
        chart
            .draw_series(
                mean_abs_error
                    .iter()
                    .zip(sd)
                    .enumerate()
                    .map(|(i, (&m, &s))| {
                        let (x, cap) = (i as f64, 0.15);
                        let (lo, hi) = (m - s, m + s);
                        // One polyline per whisker: lower cap, stem, upper cap.
                        PathElement::new(
                            vec![
                                (x - cap, lo),
                                (x + cap, lo),
                                (x, lo),
                                (x, hi),
                                (x - cap, hi),
                                (x + cap, hi),
                            ],
                            whisker,
                        )
                    }),
            )
            .map_err(backend)?
            .label("± 1 sd")
            .legend(move |(x, y)| {
                PathElement::new(
                    vec![
                        (x + 6, y - 6),
                        (x + 14, y - 6),
                        (x + 10, y - 6),
                        (x + 10, y + 6),
                    ]
                    .into_iter()
                    .chain([(x + 6, y + 6), (x + 14, y + 6)])
                    .collect::<Vec<_>>(),
                    whisker,
                )
            });

        // Parameter labels and ticks below the plotting area.
        let style = tick_font();
        let label_style = if rotate {
            // Reads bottom to top, ending just below the tick.
            style
                .transform(FontTransform::Rotate270)
                .pos(Pos::new(HPos::Right, VPos::Center))
        } else {
            style.pos(Pos::new(HPos::Center, VPos::Top))
        };
        for (i, label) in labels.iter().enumerate() {
            let (px, py) = chart.backend_coord(&(i as f64, y0));
            root.draw(&PathElement::new(vec![(px, py), (px, py + 5)], BLACK))
                .map_err(backend)?;
            root.draw(&Text::new(
                label.as_str(),
                (px, py + 8),
                label_style.clone(),
            ))
            .map_err(backend)?;
        }
        draw_legend(&mut chart)
    })
}

/// Sweep curves: one line with markers per named series of `(x, y)` points, e.g. validation
/// error versus pose count for each pose-selection schedule.
///
/// `x_label` and `y_label` should carry units. With `log_y` the y axis is logarithmic and
/// every y must be positive. Points are drawn in the order given. A legend is drawn when there
/// is more than one series.
///
/// # Errors
/// [`PlotError::Empty`] if there are no series or a series has no points (naming it),
/// [`PlotError::NonFinite`] naming the series if a coordinate is NaN or infinite,
/// [`PlotError::InvalidValue`] for a non-positive y on a log axis.
pub fn curves_svg(
    title: &str,
    x_label: &str,
    y_label: &str,
    series: &[(String, Vec<(f64, f64)>)],
    log_y: bool,
) -> Result<String, PlotError> {
    if series.is_empty() {
        return Err(empty("the list of series"));
    }
    for (name, points) in series {
        if points.is_empty() {
            return Err(empty(&format!("series `{name}`")));
        }
        for (index, &(x, y)) in points.iter().enumerate() {
            for value in [x, y] {
                if !value.is_finite() {
                    return Err(PlotError::NonFinite {
                        series: name.clone(),
                        index,
                        value,
                    });
                }
            }
            if log_y && y <= 0.0 {
                return Err(PlotError::InvalidValue {
                    series: name.clone(),
                    index,
                    value: y,
                    reason: "a logarithmic y axis needs positive values",
                });
            }
        }
    }

    let all = || series.iter().flat_map(|(_, p)| p.iter());
    let (xs, ys) = (all().map(|p| p.0), all().map(|p| p.1));
    let x_lo = xs.clone().fold(f64::INFINITY, f64::min);
    let x_hi = xs.fold(f64::NEG_INFINITY, f64::max);
    let (x0, x1) = padded_range(x_lo, x_hi, 0.03, 0.03);
    let legend_rows = if series.len() > 1 { series.len() } else { 0 };
    let top = 0.05 + legend_headroom(legend_rows);
    let y_lo = ys.clone().fold(f64::INFINITY, f64::min);
    let y_hi = ys.fold(f64::NEG_INFINITY, f64::max);

    if log_y {
        let (l0, l1) = padded_range(y_lo.log10(), y_hi.log10(), 0.05, top);
        let y_coord = LogAxis { lo: l0, hi: l1 };
        render(|root| {
            let chart = chart_builder(root, title, 50, 70)
                .build_cartesian_2d(x0..x1, y_coord)
                .map_err(backend)?;
            draw_curves(chart, x_label, y_label, series)
        })
    } else {
        let (y0, y1) = padded_range(y_lo, y_hi, 0.05, top);
        render(|root| {
            let chart = chart_builder(root, title, 50, 70)
                .build_cartesian_2d(x0..x1, y0..y1)
                .map_err(backend)?;
            draw_curves(chart, x_label, y_label, series)
        })
    }
}

// ---------------------------------------------------------------------------------------------
// Helpers
// ---------------------------------------------------------------------------------------------

/// Okabe–Ito colours (colour-blind safe), without yellow and black.
const PALETTE: [RGBColor; 6] = [
    RGBColor(0, 114, 178),   // blue
    RGBColor(213, 94, 0),    // vermillion
    RGBColor(0, 158, 115),   // bluish green
    RGBColor(204, 121, 167), // reddish purple
    RGBColor(230, 159, 0),   // orange
    RGBColor(86, 180, 233),  // sky blue
];
/// Histogram and recovery bars.
const BAR: RGBColor = RGBColor(86, 150, 200);
/// Recovery whiskers.
const WHISKER: RGBColor = RGBColor(40, 40, 40);
/// Marker radius / size in pixels.
const MARKER_PX: i32 = 4;
/// Rough width of one tick-label character in pixels (13 px sans-serif).
const CHAR_WIDTH_PX: f64 = 6.5;

type Area<'a> = DrawingArea<SVGBackend<'a>, Shift>;

/// A linear `f64` axis with explicitly chosen tick positions (plotters' `WithKeyPoints`
/// cannot have its labels formatted).
struct TickedAxis {
    inner: RangedCoordf64,
    ticks: Vec<f64>,
}

impl TickedAxis {
    fn new(lo: f64, hi: f64, ticks: Vec<f64>) -> Self {
        Self {
            inner: (lo..hi).into(),
            ticks,
        }
    }
}

impl Ranged for TickedAxis {
    type FormatOption = DefaultFormatting;
    type ValueType = f64;

    fn map(&self, value: &f64, limit: (i32, i32)) -> i32 {
        self.inner.map(value, limit)
    }

    fn key_points<H: KeyPointHint>(&self, hint: H) -> Vec<f64> {
        if hint.weight().allow_light_points() {
            Vec::new()
        } else {
            self.ticks.clone()
        }
    }

    fn range(&self) -> Range<f64> {
        self.inner.range()
    }
}

/// A logarithmic `f64` axis over `[10^lo, 10^hi]` with 1-2-5 ticks (plotters' own log axis
/// labels only whole decades, so less than a decade would show one tick or none).
struct LogAxis {
    lo: f64,
    hi: f64,
}

impl Ranged for LogAxis {
    type FormatOption = NoDefaultFormatting;
    type ValueType = f64;

    fn map(&self, value: &f64, limit: (i32, i32)) -> i32 {
        RangedCoordf64::from(self.lo..self.hi).map(&value.log10(), limit)
    }

    fn key_points<H: KeyPointHint>(&self, hint: H) -> Vec<f64> {
        if hint.weight().allow_light_points() {
            Vec::new()
        } else {
            log_ticks(self.lo, self.hi)
        }
    }

    fn range(&self) -> Range<f64> {
        10f64.powf(self.lo)..10f64.powf(self.hi)
    }
}

impl ValueFormatter<f64> for LogAxis {
    fn format(value: &f64) -> String {
        format_number(*value)
    }
}

/// Marker shapes for line series.
#[derive(Clone, Copy)]
enum Marker {
    Circle,
    Triangle,
}

fn empty(what: &str) -> PlotError {
    PlotError::Empty { what: what.into() }
}

fn backend<E: std::fmt::Display>(e: E) -> PlotError {
    PlotError::Backend(e.to_string())
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

/// Draws into a fresh white [`WIDTH`]×[`HEIGHT`] SVG and returns its text.
fn render(draw: impl FnOnce(&Area<'_>) -> Result<(), PlotError>) -> Result<String, PlotError> {
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (WIDTH, HEIGHT)).into_drawing_area();
        root.fill(&WHITE).map_err(backend)?;
        draw(&root)?;
        root.present().map_err(backend)?;
    }
    Ok(svg)
}

fn title_font() -> TextStyle<'static> {
    ("sans-serif", 24.8).into_font().into()
}

fn axis_font() -> TextStyle<'static> {
    ("sans-serif", 18.6).into_font().into()
}

fn tick_font() -> TextStyle<'static> {
    ("sans-serif", 16.12).into_font().into()
}

fn chart_builder<'a, 'b>(
    root: &'a Area<'b>,
    title: &str,
    x_area: u32,
    y_area: u32,
) -> ChartBuilder<'a, 'b, SVGBackend<'b>> {
    let mut builder = ChartBuilder::on(root);
    builder
        .caption(title, title_font())
        .margin(15)
        .margin_right(25)
        .x_label_area_size(x_area)
        .y_label_area_size(y_area);
    builder
}

/// A range `[lo, hi]` widened by `pad_lo` / `pad_hi` of its span below / above; a zero span
/// is first widened to `± 5 %` of the value (`± 0.5` at zero).
fn padded_range(lo: f64, hi: f64, pad_lo: f64, pad_hi: f64) -> (f64, f64) {
    let (lo, hi) = if hi > lo {
        (lo, hi)
    } else {
        let half = if lo == 0.0 { 0.5 } else { lo.abs() * 0.05 };
        (lo - half, hi + half)
    };
    let span = hi - lo;
    (lo - pad_lo * span, hi + pad_hi * span)
}

/// A y range that starts at zero (or below it, if a value is negative), with 8 % headroom plus
/// room for a legend of `legend_rows` rows.
fn zero_based_range(values: impl Iterator<Item = f64>, legend_rows: usize) -> (f64, f64) {
    let (lo, hi) = values.fold((0.0f64, 0.0f64), |(lo, hi), v| (lo.min(v), hi.max(v)));
    let pad_lo = if lo < 0.0 { 0.05 } else { 0.0 };
    if hi > lo {
        padded_range(lo, hi, pad_lo, 0.08 + legend_headroom(legend_rows))
    } else {
        (0.0, 1.0)
    }
}

/// Fraction of the data span to add above the data so that a legend of `rows` rows in the
/// upper-right corner (about 20 px per row plus 20 px of frame, in a plotting area about
/// 390 px high) does not cover it.
fn legend_headroom(rows: usize) -> f64 {
    if rows == 0 {
        return 0.0;
    }
    let f = ((20 + 20 * rows) as f64 / 390.0).min(0.6);
    f / (1.0 - f)
}

/// 1-based index ticks: every index if there are at most 20, else the multiples of the
/// smallest 1-2-5 step that leaves at most 20 ticks (plus index 1 for steps of 5 and more).
fn index_ticks(n: usize) -> Vec<f64> {
    let mut step = 1;
    let mut k = 0;
    while n / step > 20 {
        step = [2, 5, 10][k % 3] * 10usize.pow(k as u32 / 3);
        k += 1;
    }
    let first = (step >= 5).then_some(1.0);
    first
        .into_iter()
        .chain((1..=n / step).map(|j| (j * step) as f64))
        .collect()
}

/// A number for a tick label: rounded to 10 significant digits (hiding float noise such as
/// `0.30000000000000004`), plain between 1e-4 and 1e6, scientific outside.
fn format_number(v: f64) -> String {
    let r: f64 = format!("{v:.9e}").parse().unwrap_or(v);
    if r == 0.0 {
        "0".into()
    } else if (1e-4..1e6).contains(&r.abs()) {
        format!("{r}")
    } else {
        format!("{r:e}")
    }
}

/// `m · 10^k` as the f64 nearest to its decimal value (so that it prints as e.g. `0.2`).
fn decimal(m: u32, k: i32) -> f64 {
    format!("{m}e{k}").parse().unwrap_or(f64::NAN)
}

/// Ticks for a log axis spanning `[10^lo, 10^hi]`: the densest of the mantissa sets 1–9,
/// {1, 2, 5}, {1} that gives at most 10 ticks, or every n-th power of ten over many decades;
/// the two ends if no such tick falls inside.
fn log_ticks(lo: f64, hi: f64) -> Vec<f64> {
    const MAX_TICKS: usize = 10;
    let (k0, k1) = (lo.floor() as i32, hi.ceil() as i32);
    let inside = |v: &f64| (lo..=hi).contains(&v.log10());
    let all: [&[u32]; 3] = [&[1, 2, 3, 4, 5, 6, 7, 8, 9], &[1, 2, 5], &[1]];
    for mantissas in all {
        let ticks: Vec<f64> = (k0..=k1)
            .flat_map(|k| mantissas.iter().map(move |&m| decimal(m, k)))
            .filter(inside)
            .collect();
        if ticks.len() <= MAX_TICKS {
            return if ticks.is_empty() {
                vec![decimal_round(10f64.powf(lo)), decimal_round(10f64.powf(hi))]
            } else {
                ticks
            };
        }
    }
    let decades = (k1 - k0) as usize;
    let step = decades.div_ceil(MAX_TICKS) as i32;
    (k0..=k1)
        .filter(|k| k.rem_euclid(step) == 0)
        .map(|k| decimal(1, k))
        .filter(inside)
        .collect()
}

/// `v` rounded to 3 significant digits.
fn decimal_round(v: f64) -> f64 {
    format!("{v:.2e}").parse().unwrap_or(v)
}

/// Integer counts print without decimals; the y axis of a histogram may still put ticks at
/// fractions, which print with one decimal.
fn format_count(y: f64) -> String {
    if y.fract() == 0.0 {
        format!("{y:.0}")
    } else {
        format!("{y:.1}")
    }
}

/// One series as a polyline plus one marker per point, registered in the legend.
fn draw_line_with_markers<'a, X, Y>(
    chart: &mut ChartContext<'a, SVGBackend<'a>, Cartesian2d<X, Y>>,
    points: &[(f64, f64)],
    color: RGBColor,
    marker: Marker,
    label: String,
) -> Result<(), PlotError>
where
    X: Ranged<ValueType = f64>,
    Y: Ranged<ValueType = f64>,
{
    let line = color.stroke_width(2);
    let fill = color.filled();
    chart
        .draw_series(LineSeries::new(points.iter().copied(), line))
        .map_err(backend)?;
    let r = MARKER_PX;
    let sample = move |x: i32, y: i32| PathElement::new(vec![(x, y), (x + 24, y)], line);
    match marker {
        Marker::Circle => {
            chart
                .draw_series(points.iter().map(|&p| Circle::new(p, r, fill)))
                .map_err(backend)?
                .label(label)
                .legend(move |(x, y)| {
                    EmptyElement::at((0, 0)) + sample(x, y) + Circle::new((x + 12, y), r, fill)
                });
        }
        Marker::Triangle => {
            chart
                .draw_series(points.iter().map(|&p| TriangleMarker::new(p, r + 1, fill)))
                .map_err(backend)?
                .label(label)
                .legend(move |(x, y)| {
                    EmptyElement::at((0, 0))
                        + sample(x, y)
                        + TriangleMarker::new((x + 12, y), r + 1, fill)
                });
        }
    }
    Ok(())
}

fn draw_legend<'a, X, Y>(
    chart: &mut ChartContext<'a, SVGBackend<'a>, Cartesian2d<X, Y>>,
) -> Result<(), PlotError>
where
    X: Ranged,
    Y: Ranged,
{
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperRight)
        .background_style(WHITE.mix(0.85))
        .border_style(RGBColor(160, 160, 160))
        .label_font(tick_font())
        .draw()
        .map_err(backend)
}

fn draw_curves<'a, Y>(
    mut chart: ChartContext<'a, SVGBackend<'a>, Cartesian2d<RangedCoordf64, Y>>,
    x_label: &str,
    y_label: &str,
    series: &[(String, Vec<(f64, f64)>)],
) -> Result<(), PlotError>
where
    Y: Ranged<ValueType = f64> + ValueFormatter<f64>,
{
    chart
        .configure_mesh()
        .x_desc(x_label)
        .y_desc(y_label)
        .x_label_formatter(&|x| format_number(*x))
        .axis_desc_style(axis_font())
        .label_style(tick_font())
        .max_light_lines(0)
        .draw()
        .map_err(backend)?;
    for (i, (name, points)) in series.iter().enumerate() {
        let color = PALETTE[i % PALETTE.len()];
        let marker = if (i / PALETTE.len()).is_multiple_of(2) {
            Marker::Circle
        } else {
            Marker::Triangle
        };
        draw_line_with_markers(&mut chart, points, color, marker, name.clone())?;
    }
    if series.len() > 1 {
        draw_legend(&mut chart)?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The colour as plotters' SVG backend writes it.
    fn hex(c: RGBColor) -> String {
        format!("#{:02X}{:02X}{:02X}", c.0, c.1, c.2)
    }

    /// Checks the document frame and returns the contents of every `<text>` element.
    fn well_formed(svg: &str) -> Vec<String> {
        assert!(
            svg.starts_with("<svg"),
            "does not start with <svg: {}",
            &svg[..40]
        );
        assert!(
            svg.trim_end().ends_with("</svg>"),
            "does not end with </svg>"
        );
        assert!(svg.contains(&format!(r#"width="{WIDTH}" height="{HEIGHT}""#)));
        assert_eq!(svg.matches("<svg").count(), 1);
        assert_eq!(
            svg.matches("<text").count(),
            svg.matches("</text>").count(),
            "unbalanced <text>"
        );
        svg.split("<text")
            .skip(1)
            .map(|t| {
                let body = &t[t.find('>').unwrap() + 1..t.find("</text>").unwrap()];
                body.trim().to_string()
            })
            .collect()
    }

    /// Number of `tag` elements whose attributes contain `attr`.
    fn count(svg: &str, tag: &str, attr: &str) -> usize {
        svg.lines()
            .filter(|l| l.starts_with(&format!("<{tag} ")) && l.contains(attr))
            .count()
    }

    fn has_text(texts: &[String], want: &str) -> bool {
        texts.iter().any(|t| t == want)
    }

    fn strings(v: &[&str]) -> Vec<String> {
        v.iter().map(|s| s.to_string()).collect()
    }

    // --- Fig. 7 -------------------------------------------------------------------------

    const BEFORE: [f64; 7] = [1.3, 0.9, 1.1, 1.4, 0.8, 1.2, 1.15];
    const AFTER: [f64; 7] = [0.35, 0.3, 0.4, 0.33, 0.29, 0.38, 0.31];

    #[test]
    fn plots_per_pose_errors_elements() {
        let svg = per_pose_errors_svg("KR1000 validation", &BEFORE, &AFTER).unwrap();
        let texts = well_formed(&svg);
        assert!(has_text(&texts, "KR1000 validation"));
        assert!(has_text(&texts, "validation pose index"));
        assert!(has_text(&texts, "3-D position error (mm)"));
        assert!(has_text(&texts, "before calibration (mean 1.121 mm)"));
        assert!(has_text(&texts, "after calibration (mean 0.337 mm)"));
        for i in 1..=7 {
            assert!(has_text(&texts, &i.to_string()), "missing x tick {i}");
        }
        // One marker per pose and series, plus one in each legend entry.
        assert_eq!(svg.matches("<circle").count(), 7 + 1);
        assert_eq!(svg.matches("<polygon").count(), 7 + 1);
        // One line per series plus its legend sample.
        assert_eq!(count(&svg, "polyline", &hex(PALETTE[1])), 2);
        assert_eq!(count(&svg, "polyline", &hex(PALETTE[0])), 2);
        // The before-series line passes through all 7 poses.
        let line = svg
            .lines()
            .find(|l| l.starts_with("<polyline") && l.contains(&hex(PALETTE[1])))
            .unwrap();
        let points = line
            .split("points=\"")
            .nth(1)
            .unwrap()
            .split('"')
            .next()
            .unwrap();
        assert_eq!(points.split_whitespace().count(), 7);
    }

    #[test]
    fn plots_per_pose_errors_escapes_title() {
        let svg = per_pose_errors_svg("a < b & c", &[1.0], &[0.5]).unwrap();
        assert!(well_formed(&svg).contains(&"a &lt; b &amp; c".to_string()));
    }

    #[test]
    fn plots_per_pose_errors_rejects_bad_input() {
        assert!(matches!(
            per_pose_errors_svg("t", &[], &[]),
            Err(PlotError::Empty { .. })
        ));
        assert!(matches!(
            per_pose_errors_svg("t", &[1.0, 2.0], &[1.0]),
            Err(PlotError::LengthMismatch {
                expected: 2,
                got: 1,
                ..
            })
        ));
        let mut after = AFTER;
        after[2] = f64::NAN;
        let err = per_pose_errors_svg("t", &BEFORE, &after).unwrap_err();
        match &err {
            PlotError::NonFinite { series, index, .. } => {
                assert_eq!(series, "after calibration");
                assert_eq!(*index, 2);
            }
            other => panic!("wrong error {other:?}"),
        }
        assert!(err.to_string().contains("after calibration"));
        let mut before = BEFORE;
        before[0] = f64::INFINITY;
        assert!(matches!(
            per_pose_errors_svg("t", &before, &AFTER),
            Err(PlotError::NonFinite { series, index: 0, .. }) if series == "before calibration"
        ));
    }

    #[test]
    fn plots_index_ticks() {
        assert_eq!(index_ticks(3), vec![1.0, 2.0, 3.0]);
        assert_eq!(index_ticks(20).len(), 20);
        let t = index_ticks(30);
        assert_eq!(t[..3], [2.0, 4.0, 6.0]);
        assert_eq!(*t.last().unwrap(), 30.0);
        let t = index_ticks(1000);
        assert_eq!(t[..3], [1.0, 50.0, 100.0]);
        assert!(t.len() <= 21);
    }

    // --- histogram ----------------------------------------------------------------------

    #[test]
    fn plots_histogram_elements() {
        let bins = [
            (0.0, 0.1, 3),
            (0.1, 0.2, 0),
            (0.2, 0.3, 12),
            (0.3, 0.4, 7),
            (0.4, 0.5, 1),
        ];
        let svg = histogram_svg("Residuals", "mean position error (mm)", &bins).unwrap();
        let texts = well_formed(&svg);
        assert!(has_text(&texts, "Residuals"));
        assert!(has_text(&texts, "mean position error (mm)"));
        assert!(has_text(&texts, "count"));
        assert_eq!(count(&svg, "rect", &format!(r#"fill="{}""#, hex(BAR))), 5);
    }

    #[test]
    fn plots_histogram_rejects_bad_input() {
        assert!(matches!(
            histogram_svg("t", "x (mm)", &[]),
            Err(PlotError::Empty { .. })
        ));
        assert!(matches!(
            histogram_svg("t", "x (mm)", &[(0.0, 1.0, 1), (1.0, f64::NAN, 2)]),
            Err(PlotError::NonFinite { index: 1, .. })
        ));
        assert!(matches!(
            histogram_svg("t", "x (mm)", &[(0.0, 1.0, 1), (2.0, 2.0, 2)]),
            Err(PlotError::InvalidValue { index: 1, .. })
        ));
    }

    #[test]
    fn plots_rebin_equal_width_and_conserves_counts() {
        let values = [(0.0, 2), (1.0, 1), (2.5, 4), (4.0, 3), (10.0, 5)];
        let bins = rebin(&values, 5);
        assert_eq!(bins.len(), 5);
        assert_eq!(bins[0].0, 0.0);
        assert_eq!(bins[4].1, 10.0);
        for w in bins.windows(2) {
            assert_eq!(w[0].1, w[1].0, "bins must be contiguous");
        }
        for b in &bins {
            assert!((b.1 - b.0 - 2.0).abs() < 1e-12);
        }
        // 0 and 1 in [0, 2); 2.5 in [2, 4); 4 on the edge goes up; the maximum goes in the last bin.
        let counts: Vec<u64> = bins.iter().map(|b| b.2).collect();
        assert_eq!(counts, vec![3, 4, 3, 0, 5]);
    }

    #[test]
    fn plots_rebin_single_value_and_degenerate_input() {
        let bins = rebin(&[(2.0, 3), (2.0, 4)], 5);
        assert_eq!(bins.len(), 5);
        assert!((bins[0].0 - 1.9).abs() < 1e-12 && (bins[4].1 - 2.1).abs() < 1e-12);
        assert_eq!(
            bins.iter().map(|b| b.2).collect::<Vec<_>>(),
            vec![0, 0, 7, 0, 0]
        );
        let bins = rebin(&[(0.0, 1)], 1);
        assert_eq!(bins, vec![(-0.5, 0.5, 1)]);
        assert!(rebin(&[], 4).is_empty());
        assert!(rebin(&[(1.0, 1)], 0).is_empty());
        assert!(rebin(&[(f64::NAN, 1)], 3).is_empty());
        // Non-finite values are skipped, finite ones kept.
        let bins = rebin(&[(f64::INFINITY, 9), (1.0, 1), (3.0, 1)], 2);
        assert_eq!(bins.iter().map(|b| b.2).sum::<u64>(), 2);
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(64))]
        #[test]
        fn plots_rebin_properties(
            values in proptest::collection::vec((-1e3f64..1e3, 0u64..100), 1..40),
            n in 1usize..30,
        ) {
            let bins = rebin(&values, n);
            proptest::prop_assert_eq!(bins.len(), n);
            let total: u64 = values.iter().map(|v| v.1).sum();
            proptest::prop_assert_eq!(bins.iter().map(|b| b.2).sum::<u64>(), total);
            for &(v, _) in &values {
                proptest::prop_assert!(bins[0].0 <= v && v <= bins[n - 1].1);
            }
            let mut reversed = values.clone();
            reversed.reverse();
            proptest::prop_assert_eq!(rebin(&reversed, n), bins);
        }
    }

    // --- recovery -----------------------------------------------------------------------

    #[test]
    fn plots_recovery_elements_same_unit() {
        let names = strings(&["a_1", "d_2", "alpha_3", "theta_4"]);
        let units = strings(&["mm"; 4]);
        let svg = recovery_svg(
            "Recovery",
            &names,
            &[0.1, 0.2, 0.05, 0.3],
            &[0.02, 0.1, 0.0, 0.05],
            &units,
        )
        .unwrap();
        let texts = well_formed(&svg);
        assert!(has_text(&texts, "Recovery"));
        assert!(has_text(&texts, "parameter"));
        assert!(has_text(&texts, "recovery error (mm)"));
        for name in &names {
            assert!(has_text(&texts, name), "missing label {name}");
        }
        assert!(has_text(&texts, "mean |error|"));
        assert!(has_text(&texts, "± 1 sd"));
        // One bar and one whisker per parameter, plus one legend sample each.
        assert_eq!(
            count(&svg, "rect", &format!(r#"fill="{}""#, hex(BAR))),
            4 + 1
        );
        assert_eq!(count(&svg, "polyline", &hex(WHISKER)), 4 + 1);
        // Short labels stay horizontal; only the y-axis title is rotated.
        assert_eq!(svg.matches("rotate(270").count(), 1);
    }

    #[test]
    fn plots_recovery_mixed_units_and_rotated_labels() {
        let n = 30;
        let names: Vec<String> = (0..n).map(|i| format!("theta_{i}")).collect();
        let units: Vec<String> = (0..n)
            .map(|i| if i % 2 == 0 { "mm" } else { "mdeg" }.to_string())
            .collect();
        let m: Vec<f64> = (0..n).map(|i| 0.01 * i as f64).collect();
        let sd = vec![0.01; n];
        let svg = recovery_svg("Recovery", &names, &m, &sd, &units).unwrap();
        let texts = well_formed(&svg);
        assert!(has_text(&texts, "recovery error (display unit)"));
        assert!(has_text(&texts, "theta_0 [mm]"));
        assert!(has_text(&texts, "theta_29 [mdeg]"));
        assert_eq!(svg.matches("rotate(270").count(), n + 1);
        assert_eq!(
            count(&svg, "rect", &format!(r#"fill="{}""#, hex(BAR))),
            n + 1
        );
    }

    #[test]
    fn plots_recovery_rejects_bad_input() {
        let names = strings(&["a_1", "d_3"]);
        let units = strings(&["mm", "mm"]);
        assert!(matches!(
            recovery_svg("t", &[], &[], &[], &[]),
            Err(PlotError::Empty { .. })
        ));
        assert!(matches!(
            recovery_svg("t", &names, &[0.1, 0.2], &[0.1], &units),
            Err(PlotError::LengthMismatch {
                expected: 2,
                got: 1,
                ..
            })
        ));
        assert!(matches!(
            recovery_svg("t", &names, &[0.1, 0.2], &[0.1, 0.1], &units[..1]),
            Err(PlotError::LengthMismatch {
                expected: 2,
                got: 1,
                ..
            })
        ));
        let err = recovery_svg("t", &names, &[0.1, f64::NAN], &[0.1, 0.1], &units).unwrap_err();
        assert!(
            matches!(&err, PlotError::NonFinite { series, index: 1, .. } if series.contains("d_3")),
            "{err:?}"
        );
        assert!(matches!(
            recovery_svg("t", &names, &[0.1, 0.2], &[-0.1, 0.1], &units),
            Err(PlotError::InvalidValue { index: 0, .. })
        ));
    }

    // --- curves -------------------------------------------------------------------------

    fn sweep() -> Vec<(String, Vec<(f64, f64)>)> {
        let curve = |a: f64, n: usize| (1..=n).map(|k| (10.0 * k as f64, a / k as f64)).collect();
        vec![
            ("random".to_string(), curve(2.0, 4)),
            ("D-optimal".to_string(), curve(1.0, 5)),
            ("O-optimal".to_string(), curve(0.8, 6)),
        ]
    }

    #[test]
    fn plots_curves_elements() {
        for log_y in [false, true] {
            let svg = curves_svg(
                "Sweep",
                "pose count",
                "validation error (mm)",
                &sweep(),
                log_y,
            )
            .unwrap();
            let texts = well_formed(&svg);
            for t in [
                "Sweep",
                "pose count",
                "validation error (mm)",
                "random",
                "D-optimal",
                "O-optimal",
            ] {
                assert!(has_text(&texts, t), "missing {t:?} (log_y = {log_y})");
            }
            assert_eq!(svg.matches("<circle").count(), 4 + 5 + 6 + 3);
            for c in &PALETTE[..3] {
                assert_eq!(count(&svg, "polyline", &hex(*c)), 2, "log_y = {log_y}");
            }
            // Integer x ticks print without a trailing ".0".
            assert!(has_text(&texts, "20"));
            if log_y {
                assert!(has_text(&texts, "1") && has_text(&texts, "0.5"));
            }
        }
    }

    #[test]
    fn plots_curves_single_series_has_no_legend() {
        let series = vec![("only".to_string(), vec![(1.0, 2.0), (2.0, 3.0), (3.0, 2.5)])];
        let svg = curves_svg("One", "x (mm)", "y (mm)", &series, false).unwrap();
        let texts = well_formed(&svg);
        assert!(!has_text(&texts, "only"));
        assert_eq!(svg.matches("<circle").count(), 3);
        assert_eq!(count(&svg, "polyline", &hex(PALETTE[0])), 1);
    }

    #[test]
    fn plots_curves_rejects_bad_input() {
        assert!(matches!(
            curves_svg("t", "x", "y", &[], false),
            Err(PlotError::Empty { .. })
        ));
        let empty_series = vec![("ghost".to_string(), vec![])];
        assert!(matches!(
            curves_svg("t", "x", "y", &empty_series, false),
            Err(PlotError::Empty { what }) if what.contains("ghost")
        ));
        let mut s = sweep();
        s[1].1[3].1 = f64::NAN;
        let err = curves_svg("t", "x", "y", &s, false).unwrap_err();
        assert!(
            matches!(&err, PlotError::NonFinite { series, index: 3, .. } if series == "D-optimal"),
            "{err:?}"
        );
        assert!(err.to_string().contains("D-optimal"));
        let mut s = sweep();
        s[2].1[0].0 = f64::NEG_INFINITY;
        assert!(matches!(
            curves_svg("t", "x", "y", &s, false),
            Err(PlotError::NonFinite { series, index: 0, .. }) if series == "O-optimal"
        ));
        let mut s = sweep();
        s[0].1[1].1 = 0.0;
        assert!(curves_svg("t", "x", "y", &s, false).is_ok());
        assert!(matches!(
            curves_svg("t", "x", "y", &s, true),
            Err(PlotError::InvalidValue { series, index: 1, .. }) if series == "random"
        ));
    }

    #[test]
    fn plots_log_ticks_and_number_format() {
        assert_eq!(
            log_ticks(-3.0, 3.0),
            vec![0.001, 0.01, 0.1, 1.0, 10.0, 100.0, 1000.0]
        );
        assert_eq!(
            log_ticks(-1.0, 1.0),
            vec![0.1, 0.2, 0.5, 1.0, 2.0, 5.0, 10.0]
        );
        assert_eq!(
            log_ticks(-0.5, 0.0),
            vec![0.4, 0.5, 0.6, 0.7, 0.8, 0.9, 1.0]
        );
        let wide = log_ticks(-12.0, 12.0);
        assert!(wide.len() <= 13 && wide.contains(&1.0), "{wide:?}");
        assert_eq!(log_ticks(0.01, 0.02).len(), 2);
        assert_eq!(format_number(0.1 + 0.2), "0.3");
        assert_eq!(format_number(10.0), "10");
        assert_eq!(format_number(-0.0), "0");
        assert_eq!(format_number(1e-5), "1e-5");
        assert_eq!(format_number(2.5e6), "2.5e6");
    }

    // --- all ----------------------------------------------------------------------------

    #[test]
    fn plots_are_deterministic() {
        let names = strings(&["a_1", "d_2"]);
        let units = strings(&["mm", "mdeg"]);
        let bins = rebin(&[(0.3, 2), (0.35, 5), (0.5, 1)], 8);
        let render = || {
            [
                per_pose_errors_svg("F7", &BEFORE, &AFTER).unwrap(),
                histogram_svg("H", "error (mm)", &bins).unwrap(),
                recovery_svg("R", &names, &[0.1, 0.2], &[0.01, 0.02], &units).unwrap(),
                curves_svg("C", "n", "e (mm)", &sweep(), false).unwrap(),
                curves_svg("C", "n", "e (mm)", &sweep(), true).unwrap(),
            ]
        };
        assert_eq!(render(), render());
    }
}
