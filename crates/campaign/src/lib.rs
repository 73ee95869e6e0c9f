//! Monte Carlo campaigns: scenarios, trials, sweeps, deterministic aggregation and plots.

pub mod aggregate;
pub mod budget;
pub mod check;
pub mod checkpoint;
pub mod error;
pub mod outputs;
pub mod plots;
pub mod run;
pub mod scenario;
pub mod shard;
pub mod summary;
pub mod sweep;
pub mod trial;
pub mod trial_report;

pub use budget::{BudgetConfig, ResidualBudget, residual_budget};
pub use check::{Baseline, CheckFile, CheckSpec, Comparison, Figures, compare, run_check};
pub use checkpoint::{
    Checkpoint, CheckpointConfig, CheckpointManifest, code_version, run_range_checkpointed,
};
pub use error::CampaignError;
pub use outputs::{render_outputs, write_outputs};
pub use run::{Aggregate, run_range};
pub use scenario::{LoadedScenario, Scenario, ScenarioError};
pub use shard::{ShardFile, ShardManifest, merge_shards, shard_budget, shard_range};
pub use summary::CampaignSummary;
pub use sweep::{SweepResult, SweepSpec, run_sweep, run_sweep_checkpointed};
pub use trial::{Context, TrialResult, run_trial};
pub use trial_report::TrialReport;
