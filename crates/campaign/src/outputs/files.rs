//! The output files of a campaign — `summary.json`, `summary.md`, the trial report, the SVG
//! plots and `report.html` —, rendered in memory and written all or nothing (a sweep's are in
//! `sweep/plots.rs`); and
//! `timing.json`, the wall-clock record kept apart from the reproducible outputs.

use std::path::Path;

use crate::error::CampaignError;
use crate::outputs::plots;
use crate::outputs::summary::{CampaignSummary, is_paper};
use crate::outputs::trial_report::TrialReport;
use crate::run::range::Aggregate;

/// Renders every output file of a campaign in memory: `summary.json`, `summary.md`, the
/// trial report, the SVG plots and `report.html` (the summary with the plots in place), as
/// (file name, bytes).
pub fn render_outputs(
    summary: &CampaignSummary,
    agg: &Aggregate,
) -> Result<Vec<(String, Vec<u8>)>, CampaignError> {
    let plot_err = CampaignError::Plot;
    let name = &summary.scenario.name;
    let paper = is_paper(name) && summary.paper.is_some();
    let mut files = vec![
        ("summary.json".to_string(), summary.to_json().into_bytes()),
        ("summary.md".to_string(), summary.to_markdown().into_bytes()),
    ];
    let mut svgs: Vec<(String, String)> = Vec::new();
    if let Some(t) = &agg.typical {
        svgs.push((
            "per-pose-error.svg".into(),
            plots::per_pose_error_svg(name, t.trial, &t.before_mm, &t.after_mm, paper)
                .map_err(plot_err)?,
        ));
        svgs.push((
            "error-cdf.svg".into(),
            plots::error_cdf_svg(name, t.trial, &t.before_mm, &t.after_mm, paper)
                .map_err(plot_err)?,
        ));
        let md = TrialReport::new(&summary.scenario, t).to_markdown();
        files.push((format!("trial-{}.md", t.trial), md.into_bytes()));
    }
    if let Some(stat) = agg.metrics.get("improvement_pct")
        && let Some(s) = stat.summary()
    {
        let values: Vec<(f64, u64)> = stat.buckets().collect();
        svgs.push((
            "improvement-histogram.svg".into(),
            plots::improvement_histogram_svg(name, &values, &s, paper).map_err(plot_err)?,
        ));
    }
    if let Some(svg) = plots::recovery_svg(name, &summary.recovery).map_err(plot_err)? {
        svgs.push(("recovery.svg".into(), svg));
    }
    if let Some(svg) = plots::z_scores_svg(name, &summary.recovery).map_err(plot_err)? {
        svgs.push(("recovery-z.svg".into(), svg));
    }
    if let Some(b) = &summary.residual_budget
        && let Some(svg) = plots::budget_svg(name, b, paper).map_err(plot_err)?
    {
        svgs.push(("residual-budget.svg".into(), svg));
    }
    files.push((
        "report.html".into(),
        plots::campaign_page(summary, &svgs).into_bytes(),
    ));
    files.extend(svgs.into_iter().map(|(n, s)| (n, s.into_bytes())));
    Ok(files)
}

/// Writes [`render_outputs`] into `dir` as its new set, as a whole
/// ([`measurements::OutputDir`]: the directory is locked against other writers, and a
/// reader sees the complete previous set or the complete new one, after a failure or a kill
/// at any step). Everything is rendered before the first file is written.
pub fn write_outputs(
    dir: &Path,
    summary: &CampaignSummary,
    agg: &Aggregate,
) -> Result<(), CampaignError> {
    let files = render_outputs(summary, agg)?;
    measurements::OutputDir::lock(dir)?.write_set(&files)?;
    Ok(())
}

/// `timing.json`: the wall clock of a run of `trials` trials on `threads` threads that took
/// `seconds` (the whole run: a resumed run's segments summed), and the machine's CPU
/// ([`cpu_model_name`]). Not a reproducible output (`summary.json` holds no wall-clock
/// figure).
pub fn timing_json(trials: u64, threads: usize, seconds: f64) -> String {
    let timing = serde_json::json!({
        "trials": trials,
        "threads": threads,
        "wall_seconds": seconds,
        "trials_per_second": trials as f64 / seconds.max(1e-12),
        "ms_per_trial_per_thread": seconds * 1e3 * threads as f64 / trials.max(1) as f64,
        "cpu": cpu_model_name().unwrap_or_default(),
    });
    format!("{timing:#}\n")
}

/// The CPU's model name from `/proc/cpuinfo` (`None` where there is none): recorded beside
/// every wall-clock figure (a campaign's `timing.json`, the benchmarks' `bench.json`).
pub fn cpu_model_name() -> Option<String> {
    std::fs::read_to_string("/proc/cpuinfo").ok().and_then(|s| {
        s.lines()
            .find(|l| l.starts_with("model name"))
            .and_then(|l| l.split_once(':'))
            .map(|(_, v)| v.trim().to_string())
    })
}
