//! A campaign run in memory, for bindings (the Python package): the trials and the residual
//! budget of a [`CampaignRun`](crate::CampaignRun), on the caller's loaded scenario, returning
//! the summary instead of writing the output directory. The summary is the one `summary.json`
//! holds for the same scenario and trial count (same trials, same aggregation, so the same
//! bytes on any thread count).

use std::time::Instant;

use crate::error::CampaignError;
use crate::observer::{Observer, Phase};
use crate::outputs::summary::CampaignSummary;
use crate::requests::campaign::thread_pool;
use crate::run::budget::{budget_runs, budget_trials, residual_budget};
use crate::run::range::run_range_until;
use crate::scenario::LoadedScenario;
use crate::trial::Context;

/// What [`summarize`] computed.
#[derive(Clone, Debug, PartialEq)]
#[non_exhaustive]
pub struct InMemoryOutcome {
    /// The campaign's summary (`summary.json` is its [`CampaignSummary::to_json`]).
    pub summary: CampaignSummary,
    /// Worker threads used.
    pub threads: usize,
    /// Wall clock of the trials and the budget, s.
    pub seconds: f64,
}

/// Runs every trial of `loaded` (with its residual budget if the scenario enables it) on
/// `threads` workers (`None`: all cores) and returns the summary; nothing is written.
/// Progress goes to `observer`, as for [`CampaignRun::run`](crate::CampaignRun::run), which
/// may stop the run between trials ([`Observer::stop_requested`]).
///
/// # Errors
/// A trial count of 0, a thread pool that cannot be built, a scenario whose simulation
/// cannot be set up, a failing budget run, a stop ([`CampaignError::Stopped`]).
pub fn summarize(
    loaded: LoadedScenario,
    threads: Option<usize>,
    observer: &dyn Observer,
) -> Result<InMemoryOutcome, CampaignError> {
    if loaded.scenario.trials == 0 {
        return Err(CampaignError::ZeroTrials);
    }
    let scenario = loaded.scenario.clone();
    let (pool, threads) = thread_pool(threads)?;
    let started = Instant::now();
    let ctx = Context::new(loaded)?;
    let progress = |k| observer.trials_done(k);
    let stop = || observer.stop_requested();
    observer.phase_started(Phase::Trials, scenario.trials);
    let agg = pool
        .install(|| run_range_until(&ctx, 0..scenario.trials, &progress, &stop))
        .ok_or(CampaignError::Stopped { done: 0 })?;
    observer.phase_finished(Phase::Trials);
    let budget = if scenario.residual_budget.enabled {
        observer.phase_started(
            Phase::ResidualBudget,
            budget_runs(&scenario) * budget_trials(&scenario),
        );
        let b = pool.install(|| residual_budget(&ctx.loaded, &progress, &stop))?;
        observer.phase_finished(Phase::ResidualBudget);
        b
    } else {
        None
    };
    let summary = CampaignSummary::new(&scenario, &agg)
        .with_robot(&ctx.loaded.nominal)
        .with_budget(budget);
    Ok(InMemoryOutcome {
        summary,
        threads,
        seconds: started.elapsed().as_secs_f64(),
    })
}

#[cfg(test)]
mod tests {
    use std::path::Path;

    use super::*;
    use crate::{CampaignRun, Scenario, Silent};

    /// The in-memory summary is the bytes of the `summary.json` a [`CampaignRun`] writes,
    /// on another thread count.
    #[test]
    fn summary_equals_the_written_one() {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenarios/paper-kr1000.json");
        let dir = tempfile::tempdir().unwrap();
        let mut run = CampaignRun::new(&path);
        run.trials = Some(3);
        run.iso_off = true;
        run.budget_off = true;
        run.threads = Some(2);
        run.out = Some(dir.path().join("out"));
        run.run(&Silent).unwrap();
        let written = std::fs::read_to_string(dir.path().join("out/summary.json")).unwrap();
        let mut loaded = Scenario::from_file(&path).unwrap();
        loaded.scenario.trials = 3;
        loaded.scenario.iso.enabled = false;
        loaded.scenario.residual_budget.enabled = false;
        let outcome = summarize(loaded.clone(), Some(1), &Silent).unwrap();
        assert_eq!(outcome.threads, 1);
        assert_eq!(outcome.summary.to_json(), written);
        loaded.scenario.trials = 0;
        let e = summarize(loaded, None, &Silent).unwrap_err();
        assert!(matches!(e, CampaignError::ZeroTrials), "{e}");
    }
}
