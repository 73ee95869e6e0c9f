//! The output files of a campaign, rendered in memory and written all or nothing:
//! `summary.json`, `summary.md`, the trial report, the SVG plots and `report.html`.

use std::path::Path;

use crate::error::CampaignError;
use crate::plots;
use crate::run::Aggregate;
use crate::summary::{CampaignSummary, is_paper};
use crate::trial_report::TrialReport;

/// Renders every output file of a campaign in memory: `summary.json`, `summary.md`, the
/// trial report, the SVG plots and `report.html` (the summary with the plots in place), as
/// (file name, bytes).
pub fn render_outputs(
    summary: &CampaignSummary,
    agg: &Aggregate,
) -> Result<Vec<(String, Vec<u8>)>, CampaignError> {
    let plot_err = CampaignError::Plot;
    let name = &summary.scenario.name;
    let paper = is_paper(name);
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

/// Writes [`render_outputs`] into `dir` (created if needed). Everything is rendered before
/// the first file is written, and the set is written all or nothing
/// ([`measurements::write_all_atomically`]): on a full disk no output is replaced.
pub fn write_outputs(
    dir: &Path,
    summary: &CampaignSummary,
    agg: &Aggregate,
) -> Result<(), CampaignError> {
    let files = render_outputs(summary, agg)?;
    std::fs::create_dir_all(dir).map_err(|source| CampaignError::CreateDir {
        path: dir.to_path_buf(),
        source,
    })?;
    measurements::write_all_atomically(dir, &files).map_err(|source| CampaignError::Write {
        path: dir.to_path_buf(),
        source,
    })
}
