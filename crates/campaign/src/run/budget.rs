//! The residual budget: what a campaign's error after calibration is made of.
//!
//! A geometric model cannot remove errors it does not contain. The scenario's
//! `residual_budget` section asks the campaign to say how much of the validation error after
//! compensation each injected source outside the model explains. For every source the scenario
//! switches on — joint compliance, gear errors, repeatability, thermal drift (`unmodelled`) and
//! the tracker noise (`tracker.noise`) — the campaign's first `trials` trials are run again
//! on the same seeds:
//!
//! - **without it** (every other source as in the scenario): `removed = all − without` is the
//!   part of the after-error that switching the source off removes;
//! - **alone** (every other source off): the after-error that source leaves by itself;
//!
//! plus the two ends, **all** sources (the campaign itself) and **none** (geometric errors
//! only, which the model contains: its after-error is the solver's and the compensation's
//! floor, ≈ 0). Every random stream of a trial is keyed by (seed, trial, purpose), so
//! switching a source off changes nothing else: the geometric truth, the poses and the other
//! sources' draws stay the same, and the differences are the sources' alone.
//!
//! The sources do not add linearly: independent errors add roughly in quadrature, so the
//! `removed` column does not sum to the total, and `alone` values satisfy
//! `all² ≈ Σ alone²` only approximately (the identification absorbs part of each source,
//! differently in combination). Both columns are reported for that reason.
//!
//! The ISO test is off in the budget's runs (it does not change the Table-4 figures).

use serde::{Deserialize, Serialize};

use crate::error::CampaignError;
use crate::run::aggregate::Summary;
use crate::run::range::run_range_until;
use crate::scenario::{LoadedScenario, Scenario};
use crate::trial::Context;
use report::fmt;

/// An error source outside the identification model that the budget can switch.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Source {
    /// Joint compliance under self-weight (`unmodelled.compliance`).
    Compliance,
    /// Gear cyclic errors (`unmodelled.gears`).
    Gears,
    /// Repeatability scatter (`unmodelled.repeatability`).
    Repeatability,
    /// Thermal drift (`unmodelled.drift`).
    Drift,
    /// Tracker measurement noise (`tracker.noise`).
    TrackerNoise,
}

impl Source {
    /// Every source, in the order the budget lists them.
    pub const ALL: [Source; 5] = [
        Source::Compliance,
        Source::Gears,
        Source::Repeatability,
        Source::Drift,
        Source::TrackerNoise,
    ];

    /// The source in words, for tables.
    pub fn words(self) -> &'static str {
        match self {
            Source::Compliance => "joint compliance under self-weight",
            Source::Gears => "gear cyclic errors",
            Source::Repeatability => "repeatability",
            Source::Drift => "thermal drift",
            Source::TrackerNoise => "tracker noise",
        }
    }

    /// A short name, for plot categories.
    pub fn short(self) -> &'static str {
        match self {
            Source::Compliance => "compliance",
            Source::Gears => "gears",
            Source::Repeatability => "repeatability",
            Source::Drift => "drift",
            Source::TrackerNoise => "tracker noise",
        }
    }

    /// Whether the scenario switches this source on (with a non-zero size).
    pub fn is_on(self, s: &Scenario) -> bool {
        let u = &s.unmodelled;
        match self {
            Source::Compliance => u.compliance.enabled,
            Source::Gears => u.gears.enabled && !u.gears.terms.is_empty(),
            Source::Repeatability => u.repeatability.enabled && u.repeatability.sigma_mm > 0.0,
            Source::Drift => u.drift.enabled,
            Source::TrackerNoise => s.tracker.noise && s.tracker.noise_scale > 0.0,
        }
    }

    /// The sources `s` switches on, in [`Source::ALL`] order: the budget's lines.
    pub fn on_in(s: &Scenario) -> Vec<Source> {
        Source::ALL.into_iter().filter(|x| x.is_on(s)).collect()
    }

    /// Switches this source off in `s`.
    pub fn switch_off(self, s: &mut Scenario) {
        let u = &mut s.unmodelled;
        match self {
            Source::Compliance => u.compliance.enabled = false,
            Source::Gears => u.gears.enabled = false,
            Source::Repeatability => u.repeatability.enabled = false,
            Source::Drift => u.drift.enabled = false,
            Source::TrackerNoise => s.tracker.noise = false,
        }
    }
}

/// The after-compensation validation error of one budget run (mean over its trials of each
/// trial's mean and max 3-D error, mm).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RunFigures {
    /// Per-trial mean 3-D error after compensation, over trials.
    pub after_mean_mm: Option<Summary>,
    /// Per-trial max 3-D error after compensation, over trials.
    pub after_max_mm: Option<Summary>,
    /// Trials that failed in this run.
    pub failed_trials: u64,
}

impl RunFigures {
    fn mean(&self) -> Option<f64> {
        self.after_mean_mm.as_ref().map(|s| s.mean)
    }
}

/// One source's line of the budget.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct BudgetRow {
    /// Which source.
    pub source: Source,
    /// Every other source as in the scenario, this one off.
    pub without: RunFigures,
    /// This source only (geometric errors still injected).
    pub alone: RunFigures,
}

/// The residual budget of a campaign (see the module docs).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ResidualBudget {
    /// Trials per run (trials 0..trials of the campaign).
    pub trials: u64,
    /// Every source as in the scenario.
    pub all: RunFigures,
    /// No source outside the model: geometric errors only.
    pub none: RunFigures,
    /// One line per source the scenario switches on, in [`Source::ALL`] order.
    pub sources: Vec<BudgetRow>,
}

/// Runs the budget of a loaded scenario on the current rayon pool: `None` when its
/// `residual_budget` is off. `progress(1)` is called after each finished trial of every run
/// (there are [`budget_trials`] trials per run and [`budget_runs`] runs), `stop()` before
/// each as in [`run_range_until`] (a stop is [`CampaignError::Stopped`]).
pub fn residual_budget(
    loaded: &LoadedScenario,
    progress: &(dyn Fn(u64) + Sync),
    stop: &(dyn Fn() -> bool + Sync),
) -> Result<Option<ResidualBudget>, CampaignError> {
    let cfg = &loaded.scenario.residual_budget;
    if !cfg.enabled {
        return Ok(None);
    }
    let trials = budget_trials(&loaded.scenario);
    let on = Source::on_in(&loaded.scenario);
    let run = |edit: &dyn Fn(&mut Scenario)| -> Result<RunFigures, CampaignError> {
        let mut l = loaded.clone();
        l.scenario.iso.enabled = false;
        edit(&mut l.scenario);
        let ctx = Context::new(l)?;
        let agg = run_range_until(&ctx, 0..trials, progress, stop)
            .ok_or(CampaignError::Stopped { done: 0 })?;
        let get = |k: &str| agg.metrics.get(k).and_then(|s| s.summary());
        Ok(RunFigures {
            after_mean_mm: get("after_mean_mm"),
            after_max_mm: get("after_max_mm"),
            failed_trials: agg.failures.0.values().sum(),
        })
    };
    let all_off = |s: &mut Scenario| {
        for src in Source::ALL {
            src.switch_off(s);
        }
    };
    let all = run(&|_| {})?;
    let none = run(&all_off)?;
    let mut sources = Vec::with_capacity(on.len());
    for &src in &on {
        let without = run(&|s| src.switch_off(s))?;
        let alone = run(&|s| {
            for other in Source::ALL {
                if other != src {
                    other.switch_off(s);
                }
            }
        })?;
        sources.push(BudgetRow {
            source: src,
            without,
            alone,
        });
    }
    Ok(Some(ResidualBudget {
        trials,
        all,
        none,
        sources,
    }))
}

/// Trials per budget run: the section's `trials`, at most the campaign's.
pub fn budget_trials(s: &Scenario) -> u64 {
    s.residual_budget.trials.min(s.trials)
}

/// Number of runs the budget makes (0 when it is off): all, none, and two per source on.
pub fn budget_runs(s: &Scenario) -> u64 {
    if !s.residual_budget.enabled {
        return 0;
    }
    2 + 2 * Source::on_in(s).len() as u64
}

/// A length in mm by the report rules, or to 3 significant digits below 0.0001 mm (the
/// geometric-only run's numerical floor would print as 0.0000).
fn length(v: f64) -> String {
    if v != 0.0 && v.abs() < 1e-4 {
        fmt::significant(v)
    } else {
        fmt::mm(v)
    }
}

impl ResidualBudget {
    /// √Σ (mean after-error with each source alone)², mm: what the sources would leave
    /// together if they added in quadrature; `None` when a run has no figure.
    pub fn quadrature_mm(&self) -> Option<f64> {
        let mut sum = 0.0;
        for r in &self.sources {
            let m = r.alone.mean()?;
            sum += m * m;
        }
        Some(sum.sqrt())
    }

    /// The Markdown section of `summary.md`.
    pub fn to_markdown(&self) -> String {
        let mut o = String::new();
        let cell = |f: &RunFigures| match (&f.after_mean_mm, &f.after_max_mm) {
            (Some(m), Some(x)) => format!("{} | {}", length(m.mean), length(x.mean)),
            _ => "n/a | n/a".into(),
        };
        o.push_str("## Residual budget: what the error after calibration is made of\n\n");
        o.push_str(&format!(
            "Validation 3-D error after compensation, mean over trials 0–{} of each run (same \
             seeds, so the geometric errors, poses and every other draw are the same): with \
             every source outside the model, with each switched off in turn, with each alone, \
             and with none (geometric errors only, which the model contains).\n\n",
            self.trials.saturating_sub(1)
        ));
        o.push_str(
            "| run | mean after (mm) | max after (mm) | removed by switching it off (mm) |\n\
             |---|---:|---:|---:|\n",
        );
        let all = self.all.mean();
        o.push_str(&format!("| every source | {} | – |\n", cell(&self.all)));
        for r in &self.sources {
            let removed = match (all, r.without.mean()) {
                (Some(a), Some(w)) if a > 0.0 => {
                    format!("{} ({} %)", fmt::mm(a - w), fmt::pct(100.0 * (a - w) / a))
                }
                _ => "n/a".into(),
            };
            o.push_str(&format!(
                "| without {} | {} | {removed} |\n",
                r.source.words(),
                cell(&r.without)
            ));
        }
        for r in &self.sources {
            o.push_str(&format!(
                "| {} alone | {} | – |\n",
                r.source.words(),
                cell(&r.alone)
            ));
        }
        o.push_str(&format!(
            "| none (geometric errors only) | {} | – |\n\n",
            cell(&self.none)
        ));
        if let Some(a) = all {
            let mut ranked: Vec<(&BudgetRow, f64)> = self
                .sources
                .iter()
                .filter_map(|r| r.without.mean().map(|w| (r, a - w)))
                .collect();
            ranked.sort_by(|x, y| y.1.total_cmp(&x.1));
            if let Some((top, removed)) = ranked.first() {
                o.push_str(&format!(
                    "Of the {} mm mean after calibration, switching off {} removes the most \
                     ({} mm, {} %); ",
                    fmt::mm(a),
                    top.source.words(),
                    fmt::mm(*removed),
                    fmt::pct(100.0 * removed / a)
                ));
                let alone: Vec<String> = self
                    .sources
                    .iter()
                    .filter_map(|r| {
                        r.alone
                            .mean()
                            .map(|m| format!("{} {} mm", r.source.words(), fmt::mm(m)))
                    })
                    .collect();
                o.push_str(&format!(
                    "alone, the sources leave {}. Independent errors add roughly in quadrature \
                     (√Σ alone² = {} mm against {} mm with every source), so the removed parts \
                     do not sum to the total.",
                    alone.join(", "),
                    fmt::mm(self.quadrature_mm().unwrap_or(f64::NAN)),
                    fmt::mm(a),
                ));
                if let Some(n) = self.none.mean() {
                    o.push_str(&format!(
                        " With geometric errors only, which the model contains, {} mm remains.",
                        length(n)
                    ));
                }
                o.push_str("\n\n");
            }
        }
        o
    }
}
