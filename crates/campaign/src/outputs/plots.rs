//! The campaign's and the sweep's figures, drawn through the `report` crate's plotting layer,
//! and their `report.html` pages.
//!
//! Every function is pure and deterministic (data in, SVG or HTML text out). Axis titles,
//! legends and captions are in words with units; parameter lists are in kinematic order
//! ([`kinematic_order`]).

use report::fmt::{self, number};
use report::html::{self, Picture};
use report::plot::{self, cdf_figure, figure_svg, histogram_svg, panels_svg, rebin};
use report::plot::{mean, norms};
use report::{Figure, PlotError, RefLine, Scale, Series, Style};

use crate::aggregate::Summary;
use crate::budget::{ResidualBudget, RunFigures};
use crate::error::{CampaignError, SweepPlotError};
use crate::summary::{CampaignSummary, PAPER, RecoverySummary};
use crate::summary::{is_paper, kinematic_order};
use crate::sweep::{PlotSpec, SweepPoint, SweepResult};

/// 3-D error per validation pose before and after calibration (the paper's Fig. 7), as points
/// (the poses are independent), with each series' mean and, for the paper's scenarios, the
/// paper's mean after calibration as dashed lines.
pub fn per_pose_error_svg(
    name: &str,
    trial: u64,
    before_mm: &[[f64; 3]],
    after_mm: &[[f64; 3]],
    paper: bool,
) -> Result<String, PlotError> {
    let (b, a) = (norms(before_mm), norms(after_mm));
    let idx = |v: &[f64]| -> Vec<(f64, f64)> {
        v.iter()
            .enumerate()
            .map(|(i, &e)| ((i + 1) as f64, e))
            .collect()
    };
    let mut f = Figure::new(
        format!("{name}: 3-D error per validation pose (trial {trial})"),
        "validation pose",
        "3-D position error (mm)",
    );
    f.y_from_zero = true;
    f.series
        .push(Series::new("before calibration", idx(&b), Style::Markers));
    f.series
        .push(Series::new("after compensation", idx(&a), Style::Markers));
    f.refs.push(
        RefLine::horizontal(format!("mean before: {} mm", fmt::mm(mean(&b))), mean(&b)).colored(0),
    );
    f.refs.push(
        RefLine::horizontal(format!("mean after: {} mm", fmt::mm(mean(&a))), mean(&a)).colored(1),
    );
    if paper {
        f.refs.push(RefLine::horizontal(
            format!("paper, mean after: {} mm", fmt::mm(PAPER.after_mean_mm)),
            PAPER.after_mean_mm,
        ));
    }
    figure_svg(&f)
}

/// Share of validation poses whose 3-D error is below x, before and after calibration, for
/// one trial; for the paper's scenarios with the paper's means as vertical lines.
pub fn error_cdf_svg(
    name: &str,
    trial: u64,
    before_mm: &[[f64; 3]],
    after_mm: &[[f64; 3]],
    paper: bool,
) -> Result<String, PlotError> {
    let refs = if paper {
        vec![
            RefLine::vertical(
                format!("paper, mean before: {} mm", fmt::mm(PAPER.before_mean_mm)),
                PAPER.before_mean_mm,
            )
            .colored(0),
            RefLine::vertical(
                format!("paper, mean after: {} mm", fmt::mm(PAPER.after_mean_mm)),
                PAPER.after_mean_mm,
            )
            .colored(1),
        ]
    } else {
        Vec::new()
    };
    let f = cdf_figure(
        &format!("{name}: distribution of the 3-D error (trial {trial})"),
        "3-D position error on the validation poses (mm)",
        &[
            ("before calibration".to_string(), norms(before_mm)),
            ("after compensation".to_string(), norms(after_mm)),
        ],
        refs,
    )?;
    figure_svg(&f)
}

/// Distribution over trials of the improvement of the mean error, with its mean and (for the
/// paper's scenarios) the paper's 69.7 % as vertical lines.
pub fn improvement_histogram_svg(
    name: &str,
    values: &[(f64, u64)],
    summary: &Summary,
    paper: bool,
) -> Result<String, PlotError> {
    let mut refs = vec![
        RefLine::vertical(
            format!("mean over trials: {} %", fmt::pct(summary.mean)),
            summary.mean,
        )
        .colored(1),
    ];
    // The paper's value as a line when it falls near the data; far from them (Table 3 as
    // the truth improves by 97 %) it would squeeze the bars into a pixel, so the axis title
    // names it instead.
    let span = (summary.max - summary.min).max(1.0);
    let near = (summary.min - span..=summary.max + span).contains(&PAPER.improvement_pct);
    let mut x_title = "improvement of the mean 3-D validation error (%)".to_string();
    if paper && near {
        refs.push(RefLine::vertical(
            format!("paper: {} %", fmt::pct(PAPER.improvement_pct)),
            PAPER.improvement_pct,
        ));
    } else if paper {
        x_title = format!(
            "improvement of the mean 3-D validation error (%); paper: {} %",
            fmt::pct(PAPER.improvement_pct)
        );
    }
    histogram_svg(
        &format!(
            "{name}: improvement of the mean error over {} trials",
            summary.n
        ),
        &x_title,
        "trials",
        &rebin(values, 20),
        &refs,
    )
}

/// One parameter's recovery, for the recovery figures.
struct RecoveryRow<'a> {
    name: &'a str,
    panel: RecoveryPanel,
    error: &'a Summary,
    z: Option<&'a Summary>,
}

/// The panels of the recovery plot, one per display unit.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum RecoveryPanel {
    /// Lengths, mm.
    Lengths,
    /// Angles in arcseconds: the geometric ones (summarised in degrees) and the gear terms.
    Angles,
    /// Joint compliances, µrad/(N·m).
    Compliance,
}

impl RecoveryPanel {
    /// The panel of a parameter summarised in `unit` ([`kinematics::Unit::as_str`]), and the
    /// factor to its display unit.
    fn of(unit: &str) -> (RecoveryPanel, f64) {
        match unit {
            "deg" => (RecoveryPanel::Angles, fmt::ARCSEC_PER_DEG),
            "arcsec" => (RecoveryPanel::Angles, 1.0),
            "urad/Nm" => (RecoveryPanel::Compliance, 1.0),
            _ => (RecoveryPanel::Lengths, 1.0),
        }
    }

    /// What the panel holds, and its unit.
    fn words(self) -> (&'static str, &'static str) {
        match self {
            RecoveryPanel::Lengths => ("lengths", "mm"),
            RecoveryPanel::Angles => ("angles", "arcsec"),
            RecoveryPanel::Compliance => ("joint compliances", "µrad/(N·m)"),
        }
    }
}

fn recovery_rows(
    recovery: &std::collections::BTreeMap<String, RecoverySummary>,
) -> Vec<RecoveryRow<'_>> {
    kinematic_order(recovery.keys().map(String::as_str))
        .into_iter()
        .filter_map(|n| {
            let r = &recovery[n];
            r.error.as_ref().map(|e| RecoveryRow {
                name: n,
                panel: RecoveryPanel::of(&r.unit).0,
                error: e,
                z: r.z.as_ref(),
            })
        })
        .collect()
}

/// Recovery error (estimate − truth) per parameter, mean ± 1 sd over trials, in kinematic
/// order: lengths in mm in the upper panel, angles (and the gear terms of an extended
/// model) in arcseconds below, joint compliances in µrad/(N·m) at the bottom.
pub fn recovery_svg(
    name: &str,
    recovery: &std::collections::BTreeMap<String, RecoverySummary>,
) -> Result<Option<String>, PlotError> {
    let rows = recovery_rows(recovery);
    let mut panels = Vec::new();
    for panel in [
        RecoveryPanel::Lengths,
        RecoveryPanel::Angles,
        RecoveryPanel::Compliance,
    ] {
        let sel: Vec<&RecoveryRow> = rows.iter().filter(|r| r.panel == panel).collect();
        if sel.is_empty() {
            continue;
        }
        let title = if panels.is_empty() {
            format!("{name}: parameter recovery over trials (minimal set)")
        } else {
            String::new()
        };
        let (what, unit) = panel.words();
        let what = if sel.iter().any(|r| recovery[r.name].unit == "arcsec") {
            "angles and gear terms"
        } else {
            what
        };
        let scale = |r: &RecoveryRow| RecoveryPanel::of(&recovery[r.name].unit).1;
        let mut f = Figure::new(
            title,
            format!("parameter ({what})"),
            format!("estimate − truth ({unit})"),
        );
        f.x_categories = Some(sel.iter().map(|r| r.name.to_string()).collect());
        let mut s = Series::new(
            "mean over trials ± 1 sd",
            sel.iter()
                .enumerate()
                .map(|(i, r)| (i as f64, r.error.mean * scale(r)))
                .collect(),
            Style::Markers,
        );
        s.bars = sel
            .iter()
            .map(|r| {
                (
                    (r.error.mean - r.error.sd) * scale(r),
                    (r.error.mean + r.error.sd) * scale(r),
                )
            })
            .collect();
        f.series.push(s);
        f.refs.push(RefLine::horizontal("zero: unbiased", 0.0));
        panels.push(f);
    }
    if panels.is_empty() {
        return Ok(None);
    }
    let h = match panels.len() {
        1 => 500,
        2 => 860,
        _ => 1220,
    };
    panels_svg(&panels, h).map(Some)
}

/// z-score per parameter (estimate − truth over the reported standard error), mean ± 1 sd
/// over trials, in kinematic order, with the band an honest standard error gives (mean 0,
/// sd 1: ± 1 and ± 3).
pub fn z_scores_svg(
    name: &str,
    recovery: &std::collections::BTreeMap<String, RecoverySummary>,
) -> Result<Option<String>, PlotError> {
    let rows: Vec<RecoveryRow> = recovery_rows(recovery)
        .into_iter()
        .filter(|r| r.z.is_some())
        .collect();
    if rows.is_empty() {
        return Ok(None);
    }
    let mut f = Figure::new(
        format!("{name}: z-scores of the recovered parameters"),
        "parameter",
        "z = (estimate − truth) / standard error",
    );
    f.x_categories = Some(rows.iter().map(|r| r.name.to_string()).collect());
    let z = |r: &RecoveryRow| *r.z.expect("filtered");
    let mut s = Series::new(
        "mean over trials ± 1 sd",
        rows.iter()
            .enumerate()
            .map(|(i, r)| (i as f64, z(r).mean))
            .collect(),
        Style::Markers,
    );
    s.bars = rows
        .iter()
        .map(|r| (z(r).mean - z(r).sd, z(r).mean + z(r).sd))
        .collect();
    f.series.push(s);
    f.refs.push(RefLine::horizontal(
        "z = ± 3 (honest errors: 99.7 % inside)",
        3.0,
    ));
    f.refs.push(RefLine::horizontal("", -3.0));
    f.refs.push(RefLine::horizontal("zero", 0.0).colored(1));
    figure_svg(&f).map(Some)
}

// ---------------------------------------------------------------------------------------------
// Sweeps
// ---------------------------------------------------------------------------------------------

/// A scenario path in words, for axis titles (the path itself if unknown).
pub fn path_in_words(path: &str) -> String {
    match path {
        "identification.lm.damping.mu0" => "μ0 (initial Levenberg–Marquardt damping)".into(),
        "identification.lm.damping.tau" => "τ (Nielsen's initial damping factor)".into(),
        "identification.lm.damping" | "identification.lm.damping.kind" => "damping schedule".into(),
        "identification.lm.column_scaling" => "Jacobian columns".into(),
        "poses.identification" => "identification poses".into(),
        "poses.validation" => "validation poses".into(),
        "tracker.noise_scale" => "tracker noise (× AT960)".into(),
        "unmodelled.compliance.scale" => "injected joint compliance (× the paper budget)".into(),
        "unmodelled.gears.scale" => "injected gear errors (× the paper budget)".into(),
        "identification.extended" => "identified model".into(),
        "trials" => "trials".into(),
        other => other.into(),
    }
}

/// A metric in words with its unit, for axis titles.
pub fn metric_in_words(metric: &str) -> String {
    match metric {
        "after_mean_mm" => "validation error after compensation (mm)".into(),
        "after_max_mm" => "max validation error after compensation (mm)".into(),
        "before_mean_mm" => "validation error before calibration (mm)".into(),
        "improvement_pct" => "improvement of the mean error (%)".into(),
        "predicted_error_mm" => "geometry error of the identified model (mm)".into(),
        "fit_rms_mm" => "RMS residual of the fit (mm)".into(),
        "lm_iterations" => "Levenberg–Marquardt iterations".into(),
        "compensation_failures" => "unreachable validation targets per trial".into(),
        other => other.into(),
    }
}

/// One sweep value in words, for legends (`{"kind": "nielsen"}` → `Nielsen`, `false` on the
/// column-scaling axis → `unscaled (JᵀJ + μI)`).
pub fn value_in_words(path: &str, v: &serde_json::Value) -> String {
    use serde_json::Value;
    let schedule = |s: &str| match s {
        "levenberg" => "Levenberg".to_string(),
        "marquardt" => "Marquardt".to_string(),
        "nielsen" => "Nielsen".to_string(),
        o => o.to_string(),
    };
    match (path, v) {
        ("identification.lm.column_scaling", Value::Bool(true)) => "column-scaled".into(),
        ("identification.lm.column_scaling", Value::Bool(false)) => "unscaled (JᵀJ + μI)".into(),
        ("identification.extended", Value::Array(a)) if a.is_empty() => "geometric model".into(),
        ("identification.extended", Value::Array(a)) => format!(
            "geometric + {}",
            a.iter()
                .map(|x| x.as_str().map_or_else(|| x.to_string(), String::from))
                .collect::<Vec<_>>()
                .join(" + ")
        ),
        (_, Value::String(s)) => schedule(s),
        (_, Value::Object(m)) => {
            let mut parts: Vec<String> = Vec::new();
            if let Some(Value::String(k)) = m.get("kind") {
                parts.push(schedule(k));
            }
            for (k, x) in m {
                if k != "kind" {
                    parts.push(format!("{k} {}", value_in_words(k, x)));
                }
            }
            parts.join(", ")
        }
        (_, Value::Number(n)) => n.as_f64().map_or_else(|| n.to_string(), number),
        (p, Value::Bool(b)) => format!("{}: {}", path_in_words(p), if *b { "yes" } else { "no" }),
        (_, other) => other.to_string(),
    }
}

fn summary_of<'a>(p: &'a SweepPoint, metric: &str) -> Option<&'a Summary> {
    p.metrics.get(metric).and_then(|m| m.as_ref())
}

/// The figure of one sweep plot: `plot.y` (mean ± 1 sd over trials) against the x axis, one
/// curve per combination of the other axes, legends in words, the x axis logarithmic for
/// log-spaced values ([`Scale::auto`]) with a tick at every swept value, markers dodged so
/// that equal curves stay visible, and the paper's value as a line where it has one.
pub fn sweep_figure(result: &SweepResult, plot: &PlotSpec) -> Result<Figure, SweepPlotError> {
    let spec = &result.spec;
    let xi = result.x_axis(plot)?;
    let x_axis = &spec.axes[xi];
    let xs: Vec<f64> = x_axis
        .values
        .iter()
        .map(|v| {
            v.as_f64().ok_or_else(|| SweepPlotError::NotNumeric {
                axis: x_axis.path.clone(),
            })
        })
        .collect::<Result<_, _>>()?;
    let x_scale = Scale::auto(xs.iter().copied());
    let mut curves: Vec<Series> = Vec::new();
    for p in &result.points {
        let x = p.values[xi].as_f64().expect("checked above");
        let name: Vec<String> = spec
            .axes
            .iter()
            .zip(&p.values)
            .enumerate()
            .filter(|(i, _)| *i != xi)
            .map(|(_, (a, v))| value_in_words(&a.path, v))
            .collect();
        let name = if name.is_empty() {
            "mean over trials ± 1 sd".to_string()
        } else {
            name.join(", ")
        };
        let k = match curves.iter().position(|s| s.name == name) {
            Some(k) => k,
            None => {
                curves.push(Series::new(name, Vec::new(), Style::LineMarkers));
                curves.len() - 1
            }
        };
        match summary_of(p, &plot.y) {
            Some(s) if !plot.log_y || s.mean > 0.0 => {
                curves[k].points.push((x, s.mean));
                curves[k].bars.push((s.mean - s.sd, s.mean + s.sd));
            }
            _ => {}
        }
    }
    curves.retain(|s| !s.points.is_empty());
    let single = curves.len() == 1;
    let x_words = path_in_words(&x_axis.path);
    let y_words = metric_in_words(&plot.y);
    let mut f = Figure::new(
        format!(
            "{}: {} against {}",
            spec.name,
            short(&y_words),
            short(&x_words)
        ),
        if x_scale == Scale::Log {
            format!("{x_words}, log scale")
        } else {
            x_words
        },
        y_words,
    );
    f.x_scale = x_scale;
    f.series = curves;
    // A log y axis, if the sweep asks for one, only where the values span a decade or more.
    let log_y = plot.log_y && {
        let ys = f.series.iter().flat_map(|s| s.points.iter().map(|p| p.1));
        let (lo, hi) = ys.fold((f64::INFINITY, 0.0f64), |(a, b), y| (a.min(y), b.max(y)));
        lo > 0.0 && hi >= 10.0 * lo
    };
    f.y_scale = if log_y { Scale::Log } else { Scale::Linear };
    f.y_from_zero = !log_y;
    if log_y {
        f.y_title = format!("{}, log scale", f.y_title);
    }
    f.x_ticks = Some(xs);
    f.dodge = true;
    if single {
        f.series[0].name = "mean over trials ± 1 sd".into();
    }
    if is_paper_base(result) {
        let paper = match plot.y.as_str() {
            "after_mean_mm" => Some(PAPER.after_mean_mm),
            "after_max_mm" => Some(PAPER.after_max_mm),
            "before_mean_mm" => Some(PAPER.before_mean_mm),
            "improvement_pct" => Some(PAPER.improvement_pct),
            _ => None,
        };
        if let Some(v) = paper {
            let text = if plot.y.ends_with("_pct") {
                format!("{} %", fmt::pct(v))
            } else {
                format!("{} mm", fmt::mm(v))
            };
            f.refs
                .push(RefLine::horizontal(format!("paper (Table 4): {text}"), v));
        }
    }
    Ok(f)
}

/// A metric's title without its unit and qualifiers, for figure titles.
fn short(words: &str) -> String {
    words
        .split([',', '('])
        .next()
        .unwrap_or(words)
        .trim()
        .to_string()
}

fn is_paper_base(result: &SweepResult) -> bool {
    result
        .spec
        .scenario
        .file_stem()
        .is_some_and(|s| is_paper(&s.to_string_lossy()))
}

/// The SVG of one sweep plot ([`sweep_figure`]).
pub fn sweep_svg(result: &SweepResult, plot: &PlotSpec) -> Result<String, SweepPlotError> {
    let f = sweep_figure(result, plot)?;
    Ok(plot::figure_svg(&f)?)
}

/// The file name of sweep plot `k` (0-based): `<metric>-<k+1>.svg`.
pub fn sweep_plot_file(plot: &PlotSpec, k: usize) -> String {
    format!("{}-{}.svg", plot.y, k + 1)
}

/// `report.html` of a sweep: `sweep.md` with every plot after the table.
pub fn sweep_page(result: &SweepResult, svgs: &[(String, String)]) -> String {
    let pictures: Vec<Picture> = svgs
        .iter()
        .zip(&result.spec.plots)
        .map(|((file, svg), plot)| Picture {
            after_heading: None,
            caption: format!(
                "{} against {}: mean over {} trials per point, bars ± 1 sd; curves that coincide are shifted sideways by a few pixels.",
                metric_in_words(&plot.y),
                path_in_words(plot.x.as_deref().unwrap_or(&result.spec.axes[0].path)),
                result.spec.trials
            ),
            file: file.clone(),
            svg: svg.clone(),
        })
        .collect();
    html::page(
        &format!("Sweep {}", result.spec.name),
        &result.to_markdown(),
        &pictures,
    )
}

/// `report.html` of a campaign: `summary.md` with the plots in place.
pub fn campaign_page(summary: &CampaignSummary, svgs: &[(String, String)]) -> String {
    let pictures: Vec<Picture> = svgs
        .iter()
        .map(|(file, svg)| {
            let (after, caption) = match file.as_str() {
                "per-pose-error.svg" => ("Table 4", "3-D error of each validation pose of the lowest-index trial, before calibration and after compensation (the paper's Fig. 7); dashed lines are the means."),
                "error-cdf.svg" => ("Table 4", "Share of the validation poses of that trial whose 3-D error is below a value, before and after."),
                "improvement-histogram.svg" => ("Table 4", "Improvement of the mean validation error, over all trials."),
                "recovery.svg" => ("Parameter recovery", "Recovery error (estimate − truth) per parameter over trials, mean ± 1 sd, lengths in mm and angles in arcseconds, in kinematic order."),
                "recovery-z.svg" => ("Parameter recovery", "z-score per parameter over trials, mean ± 1 sd: honest standard errors give mean 0 and sd 1."),
                "residual-budget.svg" => ("Residual budget: what the error after calibration is made of", "Validation error after compensation, mean over trials with p5–p95 bars, when the same trials are rerun with each error source outside the model switched off, with each alone, and with none."),
                _ => ("", "plot"),
            };
            Picture {
                after_heading: (!after.is_empty()).then(|| after.to_string()),
                caption: caption.to_string(),
                file: file.clone(),
                svg: svg.clone(),
            }
        })
        .collect();
    html::page(
        &format!("Campaign {}", summary.scenario.name),
        &summary.to_markdown(),
        &pictures,
    )
}

/// A sweep's figures and its `report.html`, as (file name, bytes): one SVG per plot of the
/// sweep file ([`sweep_plot_file`]) and the page.
///
/// # Errors
/// A plot whose x axis is not a numeric axis, or that cannot be drawn (message names the
/// plot).
pub fn sweep_outputs(result: &SweepResult) -> Result<Vec<(String, Vec<u8>)>, CampaignError> {
    let mut svgs = Vec::new();
    for (k, plot) in result.spec.plots.iter().enumerate() {
        let svg = sweep_svg(result, plot).map_err(|source| CampaignError::SweepPlot {
            plot: k + 1,
            source,
        })?;
        svgs.push((sweep_plot_file(plot, k), svg));
    }
    let mut files = vec![(
        "report.html".to_string(),
        sweep_page(result, &svgs).into_bytes(),
    )];
    files.extend(svgs.into_iter().map(|(n, s)| (n, s.into_bytes())));
    Ok(files)
}

/// The residual budget ([`crate::budget`]): the validation error after compensation (mean
/// over trials of each trial's mean, with the p5–p95 band over trials) with every source
/// outside the model, with each switched off, with each alone, and with none; for the paper's
/// scenarios, its Table-4 value as a reference line. `None` when a run has no figure.
pub fn budget_svg(
    name: &str,
    budget: &ResidualBudget,
    paper: bool,
) -> Result<Option<String>, PlotError> {
    let mut cats: Vec<String> = Vec::new();
    let mut series: Vec<Series> = Vec::new();
    let mut push = |label: &str, runs: Vec<(String, &RunFigures)>| -> Option<()> {
        let mut s = Series::new(label, Vec::new(), Style::Markers);
        for (cat, run) in runs {
            let m = run.after_mean_mm.as_ref()?;
            s.points.push((cats.len() as f64, m.mean));
            s.bars.push((m.p5, m.p95));
            cats.push(cat);
        }
        series.push(s);
        Some(())
    };
    let ok = push(
        "every source (the campaign)",
        vec![("all".to_string(), &budget.all)],
    )
    .and_then(|_| {
        push(
            "that source switched off",
            budget
                .sources
                .iter()
                .map(|r| (format!("no {}", r.source.short()), &r.without))
                .collect(),
        )
    })
    .and_then(|_| {
        push(
            "that source alone",
            budget
                .sources
                .iter()
                .map(|r| (format!("{} only", r.source.short()), &r.alone))
                .collect(),
        )
    })
    .and_then(|_| {
        push(
            "none: geometric errors only",
            vec![("none".to_string(), &budget.none)],
        )
    });
    if ok.is_none() || budget.sources.is_empty() {
        return Ok(None);
    }
    let mut f = Figure::new(
        format!("{name}: what the error after calibration is made of"),
        "error sources outside the model in the run (bars: p5–p95 over trials)",
        "validation error after compensation (mm)",
    );
    f.x_categories = Some(cats);
    f.y_from_zero = true;
    f.series = series;
    if paper {
        f.refs.push(RefLine::horizontal(
            format!("paper, mean after: {} mm", fmt::mm(PAPER.after_mean_mm)),
            PAPER.after_mean_mm,
        ));
    }
    figure_svg(&f).map(Some)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn kinematic_order_of_names() {
        let names = [
            "tool_x", "a1", "base_dz", "theta2", "alpha1", "beta2", "d2", "theta1", "zzz",
            "base_rx",
        ];
        assert_eq!(
            kinematic_order(names),
            [
                "theta1", "a1", "alpha1", "theta2", "d2", "beta2", "base_rx", "base_dz", "tool_x",
                "zzz"
            ]
        );
    }

    #[test]
    fn values_in_words() {
        let v = |s: &str| serde_json::from_str::<serde_json::Value>(s).unwrap();
        assert_eq!(
            value_in_words("identification.lm.damping", &v(r#"{"kind":"nielsen"}"#)),
            "Nielsen"
        );
        assert_eq!(
            value_in_words("identification.lm.damping.kind", &v(r#""levenberg""#)),
            "Levenberg"
        );
        assert_eq!(
            value_in_words("identification.lm.column_scaling", &v("false")),
            "unscaled (JᵀJ + μI)"
        );
        assert_eq!(
            value_in_words("identification.lm.damping.mu0", &v("1000000")),
            "1e6"
        );
        assert_eq!(value_in_words("x", &v("1e-9")), "1e-9");
    }
}
