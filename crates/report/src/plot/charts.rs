//! Charts built on a [`Figure`]: an empirical CDF and a histogram of pre-binned data.

use super::draw::figure_svg;
use super::figure::{Figure, LegendAt, PlotError, RefLine, Series, Style};
use super::layout::{check_bins, check_finite};

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
            return Err(PlotError::empty(&format!("sample `{name}`")));
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
        return Err(PlotError::empty("histogram bins"));
    }
    check_bins(bins)?;
    check_finite("reference lines", refs.iter().map(|r| r.at))?;
    let mut fig = Figure::new(title, x_title, y_title);
    fig.y_from_zero = true;
    fig.refs = refs.to_vec();
    fig.bins = bins.to_vec();
    figure_svg(&fig)
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
