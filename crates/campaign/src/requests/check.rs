//! Identifiability regression (`cargo xtask check`): small fixed-seed campaigns whose key
//! figures — rank, redundant set, recovery, improvement, observability — are compared with
//! baselines committed in `results/baselines/`, within tolerances stated in the check file.
//!
//! ```json
//! {
//!   "tolerances": { "rel_mm": 0.03, "abs_pct": 1.0, "rel_abs_error": 0.1, "abs_z_sd": 0.15,
//!                   "rel_observability": 0.01, "abs_iterations": 1.0 },
//!   "checks": [
//!     { "name": "paper-kr1000", "scenario": "paper-kr1000.json", "trials": 40,
//!       "overrides": { "iso.enabled": false } }
//!   ]
//! }
//! ```
//! Rank counts, the redundant set, the recovered parameter names and the failed-trial count
//! must match exactly; the other figures within their tolerance. A campaign is
//! deterministic, so on unchanged code every figure reproduces bit for bit; the tolerances
//! let rounding-level changes (a faster kernel, a reordered sum) pass and catch real
//! regressions (a lost parameter, a broken Jacobian column, a worse schedule).

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use crate::error::CampaignError;
use crate::outputs::summary::CampaignSummary;
use crate::run::range::run_range;
use crate::scenario::Scenario;
use crate::sweep::spec::scenario_json_with;
use crate::trial::Context;

/// Tolerances of a check file (all ≥ 0).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Tolerances {
    /// Relative, on the mean over trials of the millimetre figures (before/after mean, after
    /// max, geometry error on validation poses).
    pub rel_mm: f64,
    /// Absolute, in percentage points, on the mean improvement.
    pub abs_pct: f64,
    /// Relative, on each parameter's mean |estimate − truth|.
    pub rel_abs_error: f64,
    /// Absolute, on each parameter's z-score standard deviation.
    pub abs_z_sd: f64,
    /// Relative, on the mean of each observability index O1–O5.
    pub rel_observability: f64,
    /// Absolute, on the mean LM iteration count.
    pub abs_iterations: f64,
}

/// One check: a scenario, a trial count, overrides.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CheckSpec {
    /// Name; the baseline is `results/baselines/<name>.json`.
    pub name: String,
    /// What it guards.
    #[serde(default)]
    pub description: String,
    /// Scenario file, relative to the check file.
    pub scenario: PathBuf,
    /// Trials (overrides the scenario's).
    pub trials: u64,
    /// Scenario fields to set (dotted path → value), as in sweeps.
    #[serde(default)]
    pub overrides: serde_json::Map<String, serde_json::Value>,
}

/// A check file (`scenarios/checks.json`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CheckFile {
    /// Tolerances, shared by every check.
    pub tolerances: Tolerances,
    /// The checks.
    pub checks: Vec<CheckSpec>,
}

impl CheckFile {
    /// Reads and validates a check file.
    pub fn from_file(path: &Path) -> Result<CheckFile, CampaignError> {
        let text = std::fs::read_to_string(path).map_err(|source| CampaignError::Io {
            path: path.display().to_string(),
            source,
        })?;
        let file: CheckFile =
            serde_json::from_str(&text).map_err(|source| CampaignError::CheckFileJson {
                file: path.to_path_buf(),
                source,
            })?;
        let t = &file.tolerances;
        for (name, v) in [
            ("rel_mm", t.rel_mm),
            ("abs_pct", t.abs_pct),
            ("rel_abs_error", t.rel_abs_error),
            ("abs_z_sd", t.abs_z_sd),
            ("rel_observability", t.rel_observability),
            ("abs_iterations", t.abs_iterations),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                return Err(CampaignError::Tolerance {
                    file: path.to_path_buf(),
                    name,
                    value: v,
                });
            }
        }
        let mut seen = std::collections::BTreeSet::new();
        for c in &file.checks {
            if c.trials == 0 {
                return Err(CampaignError::CheckTrials {
                    file: path.to_path_buf(),
                    check: c.name.clone(),
                });
            }
            if c.name.is_empty() || c.name.contains(['/', '\\']) || !seen.insert(&c.name) {
                return Err(CampaignError::CheckName {
                    file: path.to_path_buf(),
                    check: c.name.clone(),
                });
            }
        }
        Ok(file)
    }
}

/// Recovery figures of one parameter.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct RecoveryFigures {
    /// Mean |estimate − truth| over trials (display unit).
    pub abs_error_mean: f64,
    /// Standard deviation of the z-scores over trials.
    pub z_sd: f64,
}

/// The key figures of one check's campaign.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Figures {
    /// Trials run.
    pub trials: u64,
    /// Trials that failed.
    pub failed: u64,
    /// Rank of the free parameters at the solution → number of trials.
    pub rank: BTreeMap<String, u64>,
    /// Parameters outside the minimal identifiable set (the redundant ones).
    pub redundant: Vec<String>,
    /// Mean over trials of the mean 3-D validation error before calibration, mm.
    pub before_mean_mm: f64,
    /// The same after compensation, mm.
    pub after_mean_mm: f64,
    /// Mean over trials of the max 3-D error after compensation, mm.
    pub after_max_mm: f64,
    /// Mean improvement of the mean error, %.
    pub improvement_pct: f64,
    /// Mean geometry error on the validation poses, mm.
    pub predicted_error_mm: f64,
    /// Mean LM iterations.
    pub lm_iterations: f64,
    /// Means of O1–O5.
    pub observability: [f64; 5],
    /// Per minimal-set parameter.
    pub recovery: BTreeMap<String, RecoveryFigures>,
}

/// A baseline file: the check as run, its tolerances, its figures.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Baseline {
    /// The check.
    pub check: CheckSpec,
    /// Tolerances it was written with (the check file's are the ones applied).
    pub tolerances: Tolerances,
    /// The figures.
    pub figures: Figures,
}

/// One compared figure.
#[derive(Clone, Debug, PartialEq)]
pub struct Comparison {
    /// Figure name.
    pub figure: String,
    /// Baseline value.
    pub baseline: String,
    /// Value now.
    pub now: String,
    /// Tolerance applied.
    pub tolerance: String,
    /// Within tolerance.
    pub ok: bool,
}

/// Runs one check's campaign (`check_dir` resolves the scenario path).
pub fn run_check(spec: &CheckSpec, check_dir: &Path) -> Result<Figures, CampaignError> {
    let path = check_dir.join(&spec.scenario);
    let v = scenario_json_with(
        &path,
        &spec.overrides,
        spec.trials,
        &format!("check `{}`", spec.name),
    )?;
    let label = format!("check {}", spec.name);
    let dir = path.parent().unwrap_or(Path::new("."));
    let loaded = Scenario::from_value(v, &label)?.load(dir, &label)?;
    let scenario = loaded.scenario.clone();
    let layout = loaded.nominal.layout().clone();
    let ctx = Context::new(loaded)?;
    let redundant = (0..layout.len())
        .filter(|k| !ctx.minimal_free.contains(k))
        .map(|k| layout.get(k).name.to_string())
        .collect();
    let agg = run_range(&ctx, 0..scenario.trials, &|_| {});
    let s = CampaignSummary::new(&scenario, &agg);
    let mean = |key: &str| s.metric(key).map_or(f64::NAN, |m| m.mean);
    Ok(Figures {
        trials: s.trials,
        failed: s.failed_trials.values().sum(),
        rank: s.counts.get("rank").cloned().unwrap_or_default(),
        redundant,
        before_mean_mm: mean("before_mean_mm"),
        after_mean_mm: mean("after_mean_mm"),
        after_max_mm: mean("after_max_mm"),
        improvement_pct: mean("improvement_pct"),
        predicted_error_mm: mean("predicted_error_mm"),
        lm_iterations: mean("lm_iterations"),
        observability: [1, 2, 3, 4, 5].map(|i| mean(&format!("observability_o{i}"))),
        recovery: s
            .recovery
            .iter()
            .map(|(name, r)| {
                (
                    name.clone(),
                    RecoveryFigures {
                        abs_error_mean: r.abs_error.map_or(f64::NAN, |m| m.mean),
                        z_sd: r.z.map_or(f64::NAN, |m| m.sd),
                    },
                )
            })
            .collect(),
    })
}

fn exact<T: std::fmt::Debug + PartialEq>(figure: &str, base: &T, now: &T) -> Comparison {
    Comparison {
        figure: figure.to_string(),
        baseline: format!("{base:?}"),
        now: format!("{now:?}"),
        tolerance: "exact".into(),
        ok: base == now,
    }
}

fn within(figure: &str, base: f64, now: f64, tol: f64, relative: bool) -> Comparison {
    let allowed = if relative { tol * base.abs() } else { tol };
    Comparison {
        figure: figure.to_string(),
        baseline: format!("{base:.6}"),
        now: format!("{now:.6}"),
        tolerance: if relative {
            format!("±{:.1} %", 100.0 * tol)
        } else {
            format!("±{tol}")
        },
        // NaN on both sides (a metric absent in both) matches; NaN on one side does not.
        ok: (base.is_nan() && now.is_nan()) || (now - base).abs() <= allowed,
    }
}

/// Compares figures with a baseline under `tol`: one row per figure.
pub fn compare(base: &Figures, now: &Figures, tol: &Tolerances) -> Vec<Comparison> {
    let mut rows = vec![
        exact("trials", &base.trials, &now.trials),
        exact("failed trials", &base.failed, &now.failed),
        exact("rank (value: trials)", &base.rank, &now.rank),
        exact("redundant set", &base.redundant, &now.redundant),
        within(
            "before_mean_mm",
            base.before_mean_mm,
            now.before_mean_mm,
            tol.rel_mm,
            true,
        ),
        within(
            "after_mean_mm",
            base.after_mean_mm,
            now.after_mean_mm,
            tol.rel_mm,
            true,
        ),
        within(
            "after_max_mm",
            base.after_max_mm,
            now.after_max_mm,
            tol.rel_mm,
            true,
        ),
        within(
            "predicted_error_mm",
            base.predicted_error_mm,
            now.predicted_error_mm,
            tol.rel_mm,
            true,
        ),
        within(
            "improvement_pct",
            base.improvement_pct,
            now.improvement_pct,
            tol.abs_pct,
            false,
        ),
        within(
            "lm_iterations",
            base.lm_iterations,
            now.lm_iterations,
            tol.abs_iterations,
            false,
        ),
    ];
    for (i, (b, n)) in base
        .observability
        .iter()
        .zip(&now.observability)
        .enumerate()
    {
        rows.push(within(
            &format!("O{}", i + 1),
            *b,
            *n,
            tol.rel_observability,
            true,
        ));
    }
    let names = |f: &Figures| f.recovery.keys().cloned().collect::<Vec<_>>();
    rows.push(exact("recovered parameters", &names(base), &names(now)));
    for (name, b) in &base.recovery {
        if let Some(n) = now.recovery.get(name) {
            rows.push(within(
                &format!("{name}: mean |error|"),
                b.abs_error_mean,
                n.abs_error_mean,
                tol.rel_abs_error,
                true,
            ));
            rows.push(within(
                &format!("{name}: z sd"),
                b.z_sd,
                n.z_sd,
                tol.abs_z_sd,
                false,
            ));
        }
    }
    rows
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tol() -> Tolerances {
        Tolerances {
            rel_mm: 0.03,
            abs_pct: 1.0,
            rel_abs_error: 0.1,
            abs_z_sd: 0.15,
            rel_observability: 0.01,
            abs_iterations: 1.0,
        }
    }

    fn figures() -> Figures {
        Figures {
            trials: 20,
            failed: 0,
            rank: [("027".to_string(), 20)].into(),
            redundant: vec!["d1".into(), "d3".into()],
            before_mean_mm: 1.1,
            after_mean_mm: 0.36,
            after_max_mm: 0.9,
            improvement_pct: 68.0,
            predicted_error_mm: 0.6,
            lm_iterations: 4.0,
            observability: [0.086, 0.026, 0.052, 0.0014, 0.0125],
            recovery: [(
                "a2".to_string(),
                RecoveryFigures {
                    abs_error_mean: 0.05,
                    z_sd: 1.0,
                },
            )]
            .into(),
        }
    }

    fn failed(rows: &[Comparison]) -> Vec<&str> {
        rows.iter()
            .filter(|r| !r.ok)
            .map(|r| r.figure.as_str())
            .collect()
    }

    #[test]
    fn identical_figures_pass_and_rounding_changes_pass() {
        let base = figures();
        assert!(failed(&compare(&base, &base, &tol())).is_empty());
        let mut now = base.clone();
        now.after_mean_mm *= 1.0 + 1e-9;
        now.recovery.get_mut("a2").unwrap().z_sd += 0.01;
        assert!(failed(&compare(&base, &now, &tol())).is_empty());
    }

    #[test]
    fn regressions_are_caught_and_named() {
        let base = figures();
        let mut now = base.clone();
        now.rank = [("026".to_string(), 20)].into();
        now.redundant.push("theta6".into());
        now.after_mean_mm = 0.40; // +11 %
        now.improvement_pct = 66.5;
        now.recovery.get_mut("a2").unwrap().z_sd = 1.3;
        assert_eq!(
            failed(&compare(&base, &now, &tol())),
            [
                "rank (value: trials)",
                "redundant set",
                "after_mean_mm",
                "improvement_pct",
                "a2: z sd"
            ]
        );
        let mut lost = base.clone();
        lost.recovery.clear();
        lost.observability[1] = f64::NAN;
        assert_eq!(
            failed(&compare(&base, &lost, &tol())),
            ["O2", "recovered parameters"]
        );
    }
}
