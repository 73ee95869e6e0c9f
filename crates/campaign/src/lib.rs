//! Monte Carlo campaigns: scenarios, trials, sweeps, deterministic aggregation and plots.

pub mod aggregate;
pub mod plots;
