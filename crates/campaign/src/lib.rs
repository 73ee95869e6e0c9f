//! Monte Carlo campaigns: scenarios, trials, sweeps, deterministic aggregation and plots.

pub mod aggregate;
pub mod check;
pub mod plots;
pub mod report;
pub mod run;
pub mod scenario;
pub mod sweep;
pub mod trial;

pub use check::{Baseline, CheckFile, CheckSpec, Comparison, Figures, compare, run_check};
pub use report::{
    CampaignSummary, ShardFile, ShardManifest, merge_shards, shard_range, write_outputs,
};
pub use run::{Aggregate, run_range};
pub use scenario::{LoadedScenario, Scenario, ScenarioError};
pub use sweep::{SweepResult, SweepSpec, run_sweep};
pub use trial::{CampaignError, Context, TrialResult, run_trial};
