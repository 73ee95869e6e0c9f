//! The Markdown report of one trial (`trial-<k>.md`): Table 4, the ISO 9283 table and the
//! parameter recovery of the lowest-index successful trial of a campaign.

use crate::scenario::Scenario;
use crate::trial::TrialResult;

/// The Markdown report of one trial (Table 4, ISO table, recovery), in `evaluate`'s layout.
pub fn trial_report(scenario: &Scenario, t: &TrialResult) -> evaluate::TrialReport {
    let recovery = (!t.recovery.is_empty()).then(|| t.recovery.clone());
    let f = &t.fit;
    evaluate::TrialReport {
        title: format!("Trial {} of `{}`", t.trial, scenario.name),
        scenario: scenario.name.clone(),
        table4: t.table4,
        show_paper_reference: scenario.name.starts_with("paper"),
        iso: t.iso,
        recovery,
        notes: vec![
            format!(
                "Seed {}, trial {}: identification on {} poses ({} free parameters, rank {}), validation on {} poses.",
                scenario.seed,
                t.trial,
                scenario.poses.identification.len(),
                f.free,
                f.rank
                    .map_or_else(|| "unknown".to_string(), |r| r.to_string()),
                scenario.poses.validation.len()
            ),
            format!(
                "LM: {} iterations, stopped on {}; fit RMS residual {:.4} mm.",
                f.iterations, f.stop, f.rms_mm
            ),
            format!(
                "Geometry error of the identified model on the validation poses: {:.4} mm; compensation failures: {}; unmeasurable poses: {}.",
                t.predicted_error_mm, t.compensation_failures, t.unmeasurable
            ),
        ],
    }
}
