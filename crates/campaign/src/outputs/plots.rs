//! The campaign's figures, drawn through the `report` crate's plotting layer,
//! and its `report.html` page.
//!
//! Every function is pure and deterministic (data in, SVG or HTML text out). Axis titles,
//! legends and captions are in words with units; parameter lists are in kinematic order
//! ([`kinematic_order`]).

use evaluate::{mean, norms};
use report::fmt;
use report::html::{self, Picture};
use report::plot::{cdf_figure, figure_svg, histogram_svg, panels_svg, rebin};
use report::{Figure, PlotError, RefLine, Series, Style};

use crate::outputs::summary::kinematic_order;
use crate::outputs::summary::{CampaignSummary, PAPER, RecoverySummary};
use crate::run::aggregate::Summary;
use crate::run::budget::{ResidualBudget, RunFigures};

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

/// The residual budget ([`crate::residual_budget`]): the validation error after compensation (mean
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
}
