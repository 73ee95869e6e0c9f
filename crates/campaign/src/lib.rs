//! Monte Carlo campaigns: scenarios, trials, sweeps, deterministic aggregation and plots.
//!
//! A front end runs a campaign by building a request and calling it: [`CampaignRun`] (a
//! campaign or one shard of it), [`MergeRun`] (shards into the campaign's outputs),
//! [`SweepRun`], [`SimulateRun`] (one trial as measurement files); progress goes to an
//! [`Observer`] it attaches. The modules below are the parts those requests are made of.

//! The crate is laid out by what runs where:
//!
//! | folder | what |
//! |---|---|
//! | `scenario.rs` | the scenario file: everything a campaign needs, in one JSON document |
//! | `trial/` | one trial end to end: the shared context, the point or frame identification (one `TrialFit`), the ISO test, the result |
//! | `run/` | many trials: the parallel fold into an exact aggregate, checkpoints, shards, the residual budget |
//! | `outputs/` | what a campaign writes: summary, trial report, figures, the file set |
//! | `sweep/` | a sweep: its file, its points as campaigns, its outputs |
//! | `requests/` | what a front end calls: [`CampaignRun`], [`MergeRun`], [`SimulateRun`], [`SweepRun`], [`summarize`], [`run_check`] |
//!
//! Each folder imports only those above it in this table (and `error.rs`, `observer.rs`);
//! the modules are private and what other crates use is re-exported here.

mod error;
mod observer;
mod outputs;
mod requests;
mod run;
mod scenario;
mod sweep;
mod trial;

pub use error::{CampaignError, FieldPathError, SweepPlotError};
pub use observer::{Observer, Phase, Silent};
pub use outputs::files::{cpu_model_name, render_outputs, write_outputs};
pub use outputs::summary::{
    CampaignSummary, PAPER, PaperFigures, RecoverySummary, SCHEMA_VERSION, Tool,
};
pub use outputs::trial_report::TrialReport;
pub use requests::campaign::{
    CampaignOutcome, CampaignRun, Checkpointing, MAX_THREADS_PER_CORE, MergeOutcome, MergeRun,
    SimulateRun, cap_threads, default_out,
};
pub use requests::cartesian::{CartesianProof, CartesianProofOutcome, PoseErrors, TargetSetProof};
pub use requests::check::{
    Baseline, CheckFile, CheckSpec, Comparison, Figures, RecoveryFigures, Tolerances, compare,
    run_check,
};
pub use requests::in_memory::{InMemoryOutcome, summarize};
pub use requests::sweep::{SWEEP_CHECKPOINT, SweepOutcome, SweepRun};
pub use run::aggregate::{Counts, Stat, Summary};
pub use run::budget::{
    BudgetRow, ResidualBudget, RunFigures, Source as BudgetSource, budget_runs, budget_trials,
    residual_budget,
};
pub use run::checkpoint::{
    Checkpoint, CheckpointConfig, CheckpointManifest, code_version, run_chunks,
    run_range_checkpointed,
};
pub use run::range::{Aggregate, METRICS, RecoveryStat, run_range, run_range_until};
pub use run::shard::{Shard, ShardFile, ShardManifest, merge_shards, shard_budget, shard_range};
pub use scenario::{
    BYTES_PER_POSE, BudgetConfig, CompensationConfig, DEFAULT_BUDGET_TRIALS, IdentificationConfig,
    IsoConfig, LoadedScenario, MAX_POSES, MAX_REACH_MM, MIN_REACH_MM, MeasurementConfig,
    PoseSelection, RecoveryConfig, ResidualModelConfig, Scenario, ScenarioError, SelectionMethod,
    check_poses,
};
pub use sweep::spec::{
    Axis, Curve, PlotSpec, SweepPoint, SweepResult, SweepSpec, run_sweep, run_sweep_checkpointed,
};
pub use trial::{
    Context, FitSummary, Gain, IsoPlan, ResidualTrial, STALL_GRADIENT_COSINE, TrialResult,
    run_trial,
};
