//! The layout of a panel before anything is drawn: its input validated (empty data,
//! non-finite values, mismatched lengths, non-positive values on a log axis) and its axes
//! chosen (ranges with padding and legend headroom, ticks, the x label area) from the pixel
//! sizes below.

use super::figure::{Figure, LegendAt, PlotError, Scale};
use super::style::CHAR_WIDTH_PX;
use super::ticks::{Coord, linear_ticks, log_ticks};

/// Height of one legend row, px.
pub(super) const LEGEND_ROW_PX: usize = 22;
/// The legend's frame, counted in the headroom above the data, px.
const LEGEND_FRAME_PX: usize = 16;
/// The largest share of the plotting area's height the legend's headroom takes.
const MAX_LEGEND_SHARE: f64 = 0.6;
/// Height of the panel's title, px (none without a title).
const TITLE_PX: f64 = 35.0;
/// The panel's margins above and below the plotting area, px.
const MARGINS_PX: f64 = 30.0;
/// The plotting area's height is taken as at least this, px.
const MIN_PLOT_HEIGHT_PX: f64 = 100.0;
/// Height of the x label area (tick labels and the axis title), px.
const X_LABEL_AREA_PX: u32 = 50;
/// Per character of the longest category label drawn vertically, px.
const CATEGORY_CHAR_PX: f64 = 8.5;
/// Below category labels drawn vertically: the tick, the gap and the axis title, px.
const CATEGORY_AXIS_PX: u32 = 40;
/// Space between category labels side by side, px.
const CATEGORY_GAP_PX: f64 = 6.0;
/// Padding below and beside the data, as a share of their span.
const PAD: f64 = 0.04;
/// Padding above the data (before the legend's headroom), as a share of their span.
const PAD_ABOVE: f64 = 0.06;
/// The plotting area's width, px (800 less the y label area and the margins: 683).
const PLOT_WIDTH_PX: f64 = 680.0;
/// A rounder estimate of the same width, px, where only a threshold depends on it (category
/// labels side by side or vertical; gaps between histogram bars).
pub(super) const ROUGH_PLOT_WIDTH_PX: f64 = 700.0;
/// The least distance between explicit x ticks whose labels are kept, px.
const TICK_LABEL_PX: f64 = 34.0;
/// About how many 1-2-5 ticks an axis gets: x, y, and y on a log axis of less than a decade.
const X_TICKS: usize = 8;
const Y_TICKS: usize = 6;
const Y_TICKS_SUB_DECADE: usize = 5;

/// Fraction of the data span to add for a legend of `rows` rows ([`LEGEND_ROW_PX`] per row
/// plus [`LEGEND_FRAME_PX`], in a plotting area of `plot_px` pixels).
fn legend_headroom(rows: usize, plot_px: f64) -> f64 {
    if rows == 0 {
        return 0.0;
    }
    let f = ((LEGEND_FRAME_PX + LEGEND_ROW_PX * rows) as f64 / plot_px).min(MAX_LEGEND_SHARE);
    f / (1.0 - f)
}

/// A validated panel with its axes chosen.
pub(super) struct Prepared {
    /// The x axis.
    pub x: Coord,
    /// The y axis.
    pub y: Coord,
    /// Pixel height of the x label area.
    pub x_area: u32,
    /// Category labels drawn vertically (they do not fit side by side).
    pub rotate_categories: bool,
}

pub(super) fn check_finite(
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

/// Histogram bins: finite edges, each bin's upper edge above its lower edge.
pub(super) fn check_bins(bins: &[(f64, f64, u64)]) -> Result<(), PlotError> {
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
    Ok(())
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
pub(super) fn prepare(fig: &Figure, panel_h: f64) -> Result<Prepared, PlotError> {
    if fig.series.is_empty() && fig.bins.is_empty() {
        return Err(PlotError::empty("the list of series"));
    }
    let (xlog, ylog) = (fig.x_scale == Scale::Log, fig.y_scale == Scale::Log);
    let mut xs = Vec::new();
    let mut ys = Vec::new();
    if !fig.bins.is_empty() {
        check_bins(&fig.bins)?;
        // The bars' extent: their edges, from zero to the highest count (at least 1).
        xs.extend(fig.bins.iter().flat_map(|b| [b.0, b.1]));
        ys.push(0.0);
        ys.push(fig.bins.iter().map(|b| b.2).max().unwrap_or(0).max(1) as f64);
    }
    for s in &fig.series {
        if s.points.is_empty() {
            return Err(PlotError::empty(&format!("series `{}`", s.name)));
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
        Some(c) => {
            c.iter().map(|l| l.chars().count()).max().unwrap_or(0) as f64 * CATEGORY_CHAR_PX
                + f64::from(CATEGORY_AXIS_PX)
        }
        None => f64::from(X_LABEL_AREA_PX),
    };
    let title_px = if fig.title.is_empty() { 0.0 } else { TITLE_PX };
    let plot_h = (panel_h - title_px - x_area_px - MARGINS_PX).max(MIN_PLOT_HEIGHT_PX);
    let headroom = legend_headroom(legend_rows(fig), plot_h);
    let (y_pad_lo, y_pad_hi) = match fig.legend {
        LegendAt::UpperRight => (PAD, PAD_ABOVE + headroom),
        // The caller puts the legend low only where the data leave that corner empty (a CDF).
        LegendAt::LowerRight => (PAD, PAD_ABOVE),
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
        (PAD, PAD)
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
        // Labels need about TICK_LABEL_PX each: drop a tick closer than that to the last one
        // kept.
        let px = |v: f64| (if xlog { v.log10() } else { v } - x_lo) / (x_hi - x_lo) * PLOT_WIDTH_PX;
        let mut kept: Vec<f64> = Vec::with_capacity(t.len());
        for v in t {
            if kept.last().is_none_or(|&k| px(v) - px(k) >= TICK_LABEL_PX) {
                kept.push(v);
            }
        }
        kept
    } else if xlog {
        log_ticks(x_lo, x_hi)
    } else {
        linear_ticks(x_lo, x_hi, X_TICKS)
    };
    let y_ticks = if ylog {
        let t = log_ticks(y_lo, y_hi);
        if t.len() < 3 {
            // Less than a decade: 1-2-5 steps in value space.
            let (a, b) = (10f64.powf(y_lo), 10f64.powf(y_hi));
            linear_ticks(a, b, Y_TICKS_SUB_DECADE)
                .into_iter()
                .filter(|&v| v > 0.0)
                .collect()
        } else {
            t
        }
    } else {
        linear_ticks(y_lo, y_hi, Y_TICKS)
    };

    let (x_area, rotate) = match &fig.x_categories {
        Some(c) => {
            let longest = c.iter().map(|l| l.chars().count()).max().unwrap_or(0) as f64;
            let rotate = longest * CHAR_WIDTH_PX + CATEGORY_GAP_PX
                > ROUGH_PLOT_WIDTH_PX / c.len().max(1) as f64;
            let area = if rotate {
                (longest * CATEGORY_CHAR_PX) as u32 + CATEGORY_AXIS_PX
            } else {
                X_LABEL_AREA_PX
            };
            (area, rotate)
        }
        None => (X_LABEL_AREA_PX, false),
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
