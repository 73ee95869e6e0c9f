//! Requests that run a campaign end to end, as the front ends (`kincal campaign | merge |
//! simulate`, `cargo xtask regenerate`) ask for it: [`CampaignRun`], [`MergeRun`],
//! [`SimulateRun`]. Each is a value with named fields (start from `new`, set what the caller
//! overrides) and one `run` method that loads the scenario, applies the overrides, runs on
//! its own thread pool, writes every output file atomically and returns what a front end
//! prints. Progress goes to an [`Observer`].

use std::ops::Range;
use std::path::{Path, PathBuf};
use std::time::Instant;

use crate::error::CampaignError;
use crate::observer::{Observer, Phase};
use crate::outputs::files::{render_outputs, timing_json};
use crate::outputs::summary::CampaignSummary;
use crate::run::budget::{budget_runs, budget_trials, residual_budget};
use crate::run::checkpoint::{
    Checkpoint, CheckpointConfig, code_version, finish, run_range_checkpointed,
};
use crate::run::range::run_range_until;
use crate::run::shard::{Shard, ShardFile, merge_shards, shard_budget};
use crate::scenario::Scenario;
use crate::trial::Context;

/// Checkpoints of a run (see [`Checkpoint`](crate::Checkpoint)): written into the output directory as
/// the trials run, removed when the run finishes.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Checkpointing {
    /// Continue from the checkpoint in the output directory (a fresh start if there is
    /// none; refused if it belongs to another run). Without it an existing checkpoint is
    /// refused rather than overwritten.
    pub resume: bool,
    /// Checkpoint every this many trials (at least 1) (`None`: every 10 s, in chunks of 64
    /// trials per thread).
    pub every_trials: Option<u64>,
}

impl Checkpointing {
    /// Refuses an interval of 0 trials.
    pub fn check(self) -> Result<(), CampaignError> {
        if self.every_trials == Some(0) {
            return Err(CampaignError::ZeroCheckpointInterval);
        }
        Ok(())
    }

    /// The library's configuration for the checkpoint at `path`, its chunk size taken on
    /// the current rayon pool.
    pub(crate) fn config(self, path: PathBuf) -> CheckpointConfig {
        let mut cfg = CheckpointConfig::new(path, self.resume, code_version());
        if let Some(k) = self.every_trials {
            cfg.every_trials = Some(k.max(1));
        }
        cfg
    }
}

/// A campaign to run: a scenario file and the caller's overrides.
///
/// ```no_run
/// let mut run = campaign::CampaignRun::new("scenarios/paper-kr1000.json");
/// run.trials = Some(1000);
/// run.out = Some("my-run".into());
/// let outcome = run.run(&campaign::Silent)?;
/// # Ok::<(), campaign::CampaignError>(())
/// ```
#[derive(Clone, Debug, PartialEq)]
#[non_exhaustive]
pub struct CampaignRun {
    /// The scenario file (JSON).
    pub scenario: PathBuf,
    /// Override the scenario's trial count (at least 1).
    pub trials: Option<u64>,
    /// Switch the scenario's ISO 9283 test off.
    pub iso_off: bool,
    /// Switch the scenario's residual budget off.
    pub budget_off: bool,
    /// Worker threads (`None`: all cores). The results do not depend on it.
    pub threads: Option<usize>,
    /// Output directory (`None`: `results/<scenario name>`).
    pub out: Option<PathBuf>,
    /// Run only this shard of the campaign and write its shard file for [`MergeRun`].
    pub shard: Option<Shard>,
    /// Checkpoint the run (`None`: no checkpoint).
    pub checkpoint: Option<Checkpointing>,
}

/// What a [`CampaignRun`] did.
#[derive(Clone, Debug, PartialEq)]
#[non_exhaustive]
pub enum CampaignOutcome {
    /// A whole campaign: its outputs and `timing.json` are in `out`.
    Campaign {
        /// The summary written.
        summary: Box<CampaignSummary>,
        /// The output directory.
        out: PathBuf,
        /// Worker threads used.
        threads: usize,
        /// Wall clock, s.
        seconds: f64,
    },
    /// One shard: its shard file is written.
    Shard {
        /// The shard.
        shard: Shard,
        /// Its trials.
        trials: Range<u64>,
        /// The shard file.
        file: PathBuf,
        /// Wall clock, s.
        seconds: f64,
    },
}

/// The default output directory of a campaign or sweep named `name`: `results/<name>`.
pub fn default_out(name: &str) -> PathBuf {
    Path::new("results").join(name)
}

/// The default output directory of a run whose settings differ from its committed file
/// (`overrides`, e.g. `["trials-20", "no-iso"]`, not empty): `runs/<name>-<overrides>`,
/// never `results/<name>`, whose files are the committed scenario's. Naming an output
/// directory explicitly (`out`) writes wherever it says.
pub fn scratch_out(name: &str, overrides: &[String]) -> PathBuf {
    Path::new("runs").join(format!("{name}-{}", overrides.join("-")))
}

/// Takes the output directory `out` for this run ([`measurements::OutputDir::lock`]: a
/// path that is not a directory is refused, another run writing it is refused naming the
/// holder, an interrupted run's leftovers are removed) and creates it, so that checkpoints
/// can be written into it while the run goes on.
pub(crate) fn lock_out_dir(out: &Path) -> Result<measurements::OutputDir, CampaignError> {
    let held = measurements::OutputDir::lock(out)?;
    std::fs::create_dir_all(held.path()).map_err(|source| CampaignError::CreateDir {
        path: out.to_path_buf(),
        source,
    })?;
    Ok(held)
}

/// Takes the output directory `out` as the member `shard` of the campaign's shards
/// ([`measurements::OutputDir::lock_member`]) and creates it.
fn lock_member_dir(
    out: &Path,
    shard: &Shard,
) -> Result<measurements::SharedOutputDir, CampaignError> {
    let member = shard.file_name();
    let member = member.strip_suffix(".json").unwrap_or(&member);
    let held = measurements::OutputDir::lock_member(out, member)?;
    std::fs::create_dir_all(held.path()).map_err(|source| CampaignError::CreateDir {
        path: out.to_path_buf(),
        source,
    })?;
    Ok(held)
}

/// How a campaign run holds its output directory.
enum Held {
    /// A whole campaign: its set is written at the end.
    Whole(measurements::OutputDir),
    /// A shard: it writes its own files beside the other shards'.
    #[allow(dead_code, reason = "held for its locks, released when dropped")]
    Member(measurements::SharedOutputDir),
}

/// Refuses a run where every trial failed (its outputs, written by then, list the causes).
pub(crate) fn check_some_succeeded(
    agg: &crate::run::range::Aggregate,
    out: &Path,
) -> Result<(), CampaignError> {
    let failed: u64 = agg.failures.0.values().sum();
    if agg.trials > 0 && failed >= agg.trials {
        let cause = agg
            .failures
            .0
            .iter()
            .max_by_key(|(_, n)| **n)
            .map(|(c, _)| c.clone())
            .unwrap_or_default();
        return Err(CampaignError::NoSuccessfulTrial {
            trials: agg.trials,
            cause,
            out: out.to_path_buf(),
        });
    }
    Ok(())
}

/// At most this many worker threads per core: results do not depend on the count, and more
/// threads than a few per core only add switching and memory (each thread keeps its own
/// workspace). A larger count is capped (with a note from [`cap_threads`]), not refused.
pub const MAX_THREADS_PER_CORE: usize = 4;

/// A thread count the user asked for, capped at [`MAX_THREADS_PER_CORE`] × the cores this
/// process may use: the count to use, and when it was capped a note for the user that starts
/// with the count asked for (the front end puts its option's name before it: `--threads`,
/// `threads=`). Both front ends (the CLI and Python) cap through this.
pub fn cap_threads(asked: usize) -> (usize, Option<String>) {
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    let max = MAX_THREADS_PER_CORE * cores;
    if asked > max {
        let note = format!(
            "{asked} capped at {max} ({MAX_THREADS_PER_CORE} per core, {cores} core(s) here); \
             the results do not depend on the thread count"
        );
        (max, Some(note))
    } else {
        (asked, None)
    }
}

/// A thread pool of `threads` workers (`None`: all cores), and that count. A count of 0 is
/// refused ([`CampaignError::ZeroThreads`]).
pub(crate) fn thread_pool(
    threads: Option<usize>,
) -> Result<(rayon::ThreadPool, usize), CampaignError> {
    if threads == Some(0) {
        return Err(CampaignError::ZeroThreads);
    }
    let threads =
        threads.unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()));
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .map_err(CampaignError::ThreadPool)?;
    Ok((pool, threads))
}

/// The names of the files in `dir` that are not hidden (the outputs just written).
pub(crate) fn visible_files(dir: &Path) -> Vec<String> {
    std::fs::read_dir(dir)
        .map(|d| {
            d.flatten()
                .map(|e| e.file_name().to_string_lossy().into_owned())
                .filter(|n| !n.starts_with('.'))
                .collect()
        })
        .unwrap_or_default()
}

impl CampaignRun {
    /// The campaign of the scenario file `scenario` as the file says: every trial, all
    /// cores, output in `results/<scenario name>`, no checkpoint.
    pub fn new(scenario: impl Into<PathBuf>) -> CampaignRun {
        CampaignRun {
            scenario: scenario.into(),
            trials: None,
            iso_off: false,
            budget_off: false,
            threads: None,
            out: None,
            shard: None,
            checkpoint: None,
        }
    }

    /// Runs the campaign (or its shard) and writes its outputs: for a whole campaign
    /// `summary.json`, `summary.md`, the trial report, the plots and `report.html` (all or
    /// nothing) and `timing.json`; for a shard its file `shard-k-of-K.json`. The residual
    /// budget is computed by a whole campaign or by shard 0 ([`Shard::runs_budget`]). A
    /// finished run removes its checkpoint.
    pub fn run(&self, observer: &dyn Observer) -> Result<CampaignOutcome, CampaignError> {
        // Every setting is checked before any work starts.
        if self.trials == Some(0) {
            return Err(CampaignError::ZeroTrials);
        }
        if self.threads == Some(0) {
            return Err(CampaignError::ZeroThreads);
        }
        self.checkpoint.map(Checkpointing::check).transpose()?;
        let mut loaded = Scenario::from_file(&self.scenario)?;
        let committed_trials = loaded.scenario.trials;
        let s = &mut loaded.scenario;
        s.iso.enabled &= !self.iso_off;
        s.residual_budget.enabled &= !self.budget_off;
        if let Some(t) = self.trials {
            s.trials = t;
        }
        let scenario = loaded.scenario.clone();
        let out = match &self.out {
            Some(out) => out.clone(),
            None => {
                let overrides = self.overrides(committed_trials);
                if overrides.is_empty() {
                    default_out(&scenario.name)
                } else {
                    let out = scratch_out(&scenario.name, &overrides);
                    observer.note(&format!(
                        "the settings differ from {} ({}): writing to {}, not {} (which holds \
                         the committed scenario's results; name an output directory to choose)",
                        self.scenario.display(),
                        overrides.join(", "),
                        out.display(),
                        default_out(&scenario.name).display()
                    ));
                    out
                }
            }
        };
        let (pool, threads) = thread_pool(self.threads)?;
        let range = match self.shard {
            Some(shard) => shard.range(scenario.trials),
            None => 0..scenario.trials,
        };
        // The output directory is taken (checked, locked) before the work: as a whole by a
        // campaign, as one member by a shard (the shards of a campaign write their files side
        // by side into one directory, each refusing a second run of itself).
        let held = match self.shard {
            Some(shard) => Held::Member(lock_member_dir(&out, &shard)?),
            None => Held::Whole(lock_out_dir(&out)?),
        };
        let started = Instant::now();
        let ctx = Context::new(loaded)?;
        // The chunk size is taken on the campaign's pool (64 trials per thread of it).
        let checkpoint = pool.install(|| match (self.checkpoint, self.shard) {
            (None, _) => None,
            (Some(c), Some(shard)) => Some(c.config(out.join(shard.checkpoint_name()))),
            (Some(c), None) => Some(c.config(out.join("checkpoint.json"))),
        });
        let mut prior_seconds = 0.0;
        if let Some(cfg) = checkpoint.as_ref().filter(|c| c.resume)
            && let Ok(Some(c)) = Checkpoint::read(&cfg.path)
        {
            let m = &c.manifest;
            observer.resuming(
                &cfg.path,
                m.first_trial..c.next_trial,
                m.first_trial..m.end_trial,
            );
            prior_seconds = crate::run::checkpoint::prior_wall_seconds(cfg);
        }
        let what = match self.shard {
            Some(shard) => format!("shard {shard}"),
            None => "campaign".to_string(),
        };
        let progress = |k| observer.trials_done(k);
        let stop = || observer.stop_requested();
        observer.phase_started(Phase::Trials, range.end - range.start);
        let agg = pool.install(|| match &checkpoint {
            None => run_range_until(&ctx, range.clone(), &progress, &stop)
                .ok_or(CampaignError::Stopped { done: 0 }),
            Some(cfg) => run_range_checkpointed(&ctx, &what, range.clone(), cfg, &progress, &stop),
        })?;
        observer.phase_finished(Phase::Trials);
        let budget = if Shard::runs_budget(self.shard) {
            let total = budget_runs(&scenario) * budget_trials(&scenario);
            observer.phase_started(Phase::ResidualBudget, total);
            let b = pool.install(|| residual_budget(&ctx.loaded, &progress, &stop))?;
            observer.phase_finished(Phase::ResidualBudget);
            b
        } else {
            None
        };
        // The whole run's wall clock: this segment and those before a resume.
        let seconds = prior_seconds + started.elapsed().as_secs_f64();
        let finish_checkpoint = |outputs: &[String]| match &checkpoint {
            Some(cfg) => finish(&cfg.path, outputs),
            None => Ok(()),
        };
        if let Some(shard) = self.shard {
            let file = out.join(shard.file_name());
            ShardFile::new(scenario, shard, agg.clone(), budget).write(&file)?;
            finish_checkpoint(&[shard.file_name()])?;
            check_some_succeeded(&agg, &file)?;
            return Ok(CampaignOutcome::Shard {
                shard,
                trials: range,
                file,
                seconds,
            });
        }
        let summary = CampaignSummary::new(&scenario, &agg)
            .with_robot(&ctx.loaded.nominal)
            .with_budget(budget);
        let mut files = render_outputs(&summary, &agg)?;
        files.push((
            "timing.json".to_string(),
            timing_json(scenario.trials, threads, seconds).into_bytes(),
        ));
        // The new set replaces the old one as a whole, and the checkpoint goes with the
        // old one.
        let dropped: Vec<&str> = checkpoint
            .as_ref()
            .and_then(|c| c.path.file_name())
            .and_then(|n| n.to_str())
            .into_iter()
            .collect();
        let Held::Whole(held) = held else {
            unreachable!("a campaign that is not a shard holds its directory as a whole")
        };
        held.write_set_dropping(&files, &dropped)?;
        finish_checkpoint(&visible_files(&out))?;
        drop(held);
        check_some_succeeded(&agg, &out)?;
        Ok(CampaignOutcome::Campaign {
            summary: Box::new(summary),
            out,
            threads,
            seconds,
        })
    }

    /// What this run changes of its scenario file, as short names for a directory
    /// (`trials-20`, `no-iso`, `no-budget`, `shards`): empty when it runs the file as
    /// committed. `committed_trials`: the file's trial count.
    pub fn overrides(&self, committed_trials: u64) -> Vec<String> {
        let mut v = Vec::new();
        if let Some(t) = self.trials.filter(|t| *t != committed_trials) {
            v.push(format!("trials-{t}"));
        }
        if self.iso_off {
            v.push("no-iso".to_string());
        }
        if self.budget_off {
            v.push("no-budget".to_string());
        }
        if self.shard.is_some() {
            v.push("shards".to_string());
        }
        v
    }
}

/// Shard files to merge into the campaign's outputs (those of the single run).
#[derive(Clone, Debug, PartialEq)]
#[non_exhaustive]
pub struct MergeRun {
    /// The shard files written by the shards' [`CampaignRun`]s.
    pub shards: Vec<PathBuf>,
    /// Output directory (`None`: `runs/<scenario name>-merged`: shards may have any trial
    /// count, so a merge never writes into `results/` unless named).
    pub out: Option<PathBuf>,
}

/// What a [`MergeRun`] wrote.
#[derive(Clone, Debug, PartialEq)]
#[non_exhaustive]
pub struct MergeOutcome {
    /// The merged campaign's summary.
    pub summary: CampaignSummary,
    /// The output directory.
    pub out: PathBuf,
}

impl MergeRun {
    /// A merge of the shard files `shards` into `runs/<scenario name>-merged`.
    pub fn new(shards: Vec<PathBuf>) -> MergeRun {
        MergeRun { shards, out: None }
    }

    /// Reads the shard files, checks that they are the shards of one campaign, each once
    /// ([`merge_shards`]), and writes the campaign's outputs (all or nothing), which are the
    /// single run's.
    pub fn run(&self) -> Result<MergeOutcome, CampaignError> {
        let files = self
            .shards
            .iter()
            .map(|p| ShardFile::from_file(p))
            .collect::<Result<Vec<_>, _>>()?;
        let (scenario, agg) = merge_shards(&files)?;
        // Shards may be of any trial count: never `results/` unless named.
        let out = self
            .out
            .clone()
            .unwrap_or_else(|| scratch_out(&scenario.name, &["merged".to_string()]));
        let held = lock_out_dir(&out)?;
        let summary = CampaignSummary::new(&scenario, &agg).with_budget(shard_budget(&files));
        held.write_set(&render_outputs(&summary, &agg)?)?;
        drop(held);
        check_some_succeeded(&agg, &out)?;
        Ok(MergeOutcome { summary, out })
    }
}

/// One simulated trial of a scenario, written as measurement files.
#[derive(Clone, Debug, PartialEq)]
#[non_exhaustive]
pub struct SimulateRun {
    /// The scenario file (JSON).
    pub scenario: PathBuf,
    /// Output directory of `identification.csv`, `validation.csv` and `truth.json`.
    pub out: PathBuf,
    /// The trial whose truth, poses and noise are drawn.
    pub trial: u64,
}

impl SimulateRun {
    /// Trial 0 of `scenario`, written into `out`.
    pub fn new(scenario: impl Into<PathBuf>, out: impl Into<PathBuf>) -> SimulateRun {
        SimulateRun {
            scenario: scenario.into(),
            out: out.into(),
            trial: 0,
        }
    }

    /// Simulates the trial and writes its files; returns the simulation (measurements,
    /// truth and pose-sampling statistics).
    pub fn run(&self) -> Result<virtual_robot::Simulation, CampaignError> {
        let loaded = Scenario::from_file(&self.scenario)?;
        let held = measurements::OutputDir::lock(&self.out)?;
        let sim = virtual_robot::simulate_with(
            &loaded.nominal,
            &loaded.virtual_robot(),
            loaded.scenario.seed,
            self.trial,
            &loaded.scenario.measurement.probe(),
        )
        .map_err(|source| CampaignError::Sim {
            trial: self.trial,
            source,
        })?;
        let csv = |r: Result<String, virtual_robot::SimError>| {
            r.map_err(|source| CampaignError::WriteSimulation {
                dir: self.out.clone(),
                source,
            })
        };
        let files = [
            (
                virtual_robot::IDENTIFICATION_FILE,
                csv(sim.identification_csv())?,
            ),
            (virtual_robot::VALIDATION_FILE, csv(sim.validation_csv())?),
            (virtual_robot::TRUTH_FILE, sim.truth_json()),
        ];
        held.write_set(&files)?;
        Ok(sim)
    }
}
