//! Monte Carlo campaigns: scenarios, trials, sweeps, deterministic aggregation and plots.
//!
//! A front end runs a campaign by building a request and calling it: [`CampaignRun`] (a
//! campaign or one shard of it), [`MergeRun`] (shards into the campaign's outputs),
//! [`SweepRun`], [`SimulateRun`] (one trial as measurement files); progress goes to an
//! [`Observer`] it attaches. The modules below are the parts those requests are made of.

#[path = "run/aggregate.rs"]
pub mod aggregate;
#[path = "run/budget.rs"]
pub mod budget;
#[path = "requests/campaign.rs"]
pub mod campaign_run;
#[path = "requests/check.rs"]
pub mod check;
#[path = "run/checkpoint.rs"]
pub mod checkpoint;
pub mod error;
#[path = "requests/in_memory.rs"]
pub mod in_memory;
pub mod observer;
#[path = "outputs/files.rs"]
pub mod outputs;
#[path = "outputs/plots.rs"]
pub mod plots;
#[path = "run/range.rs"]
pub mod run;
pub mod scenario;
#[path = "run/shard.rs"]
pub mod shard;
#[path = "outputs/summary.rs"]
pub mod summary;
#[path = "sweep/spec.rs"]
pub mod sweep;
#[path = "requests/sweep.rs"]
pub mod sweep_run;
pub mod trial;
#[path = "trial/frames.rs"]
mod trial_frames;
#[path = "outputs/trial_report.rs"]
pub mod trial_report;

pub use budget::{BudgetConfig, ResidualBudget, residual_budget};
pub use campaign_run::{
    CampaignOutcome, CampaignRun, Checkpointing, MergeOutcome, MergeRun, SimulateRun, default_out,
};
pub use check::{Baseline, CheckFile, CheckSpec, Comparison, Figures, compare, run_check};
pub use checkpoint::{
    Checkpoint, CheckpointConfig, CheckpointManifest, code_version, run_range_checkpointed,
};
pub use error::{CampaignError, FieldPathError, SweepPlotError};
pub use in_memory::{InMemoryOutcome, summarize};
pub use observer::{Observer, Phase, Silent};
pub use outputs::{cpu_model_name, render_outputs, write_outputs};
pub use run::{Aggregate, run_range};
pub use scenario::{LoadedScenario, Scenario, ScenarioError};
pub use shard::{Shard, ShardFile, ShardManifest, merge_shards, shard_budget, shard_range};
pub use summary::CampaignSummary;
pub use sweep::{SweepResult, SweepSpec, run_sweep, run_sweep_checkpointed};
pub use sweep_run::{SweepOutcome, SweepRun};
pub use trial::{Context, TrialResult, run_trial};
pub use trial_report::TrialReport;
