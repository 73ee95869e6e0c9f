//! Shards: a campaign split into K contiguous trial ranges run apart (e.g. as a Slurm job
//! array), each writing a shard file (its manifest and exact aggregate) that
//! [`merge_shards`] combines into the single run's aggregate. The writer
//! ([`ShardFile::write`]) and the reader ([`ShardFile::from_file`]) of the file format live
//! here together.

use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::budget::ResidualBudget;
use crate::error::CampaignError;
use crate::run::Aggregate;
use crate::scenario::{Scenario, ScenarioError};

/// Identifies a shard: which slice of which campaign it holds.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ShardManifest {
    /// The scenario (with the trial count used).
    pub scenario: Scenario,
    /// Tool version.
    pub version: String,
    /// Shard index, 0-based.
    pub shard: u64,
    /// Number of shards.
    pub shards: u64,
    /// First trial (inclusive).
    pub first_trial: u64,
    /// Last trial (exclusive).
    pub end_trial: u64,
}

/// A shard file: manifest plus the exact aggregate.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ShardFile {
    /// What this shard is.
    pub manifest: ShardManifest,
    /// Its trials' aggregate.
    pub aggregate: Aggregate,
    /// The residual budget, computed by shard 0 only (it runs trials 0..budget trials
    /// whatever the split), so that the merge gives a single run's summary.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub residual_budget: Option<ResidualBudget>,
}

/// The trial range of shard `k` of `shards` over `trials` trials (contiguous, sizes differ by
/// at most one).
pub fn shard_range(trials: u64, k: u64, shards: u64) -> std::ops::Range<u64> {
    // In u128: no overflow for any trial count; for k < shards the bounds fit in u64.
    let at = |k: u64| (u128::from(trials) * u128::from(k) / u128::from(shards.max(1))) as u64;
    at(k)..at(k.saturating_add(1))
}

/// The residual budget of a set of shard files: shard 0's ([`merge_shards`] checks that it
/// is there exactly when the scenario asks for one).
pub fn shard_budget(files: &[ShardFile]) -> Option<ResidualBudget> {
    files
        .iter()
        .find(|f| f.manifest.shard == 0)
        .and_then(|f| f.residual_budget.clone())
}

/// Merges shard files: checks they belong to one campaign and cover every trial exactly
/// once, and returns the merged aggregate and the scenario.
pub fn merge_shards(files: &[ShardFile]) -> Result<(Scenario, Aggregate), CampaignError> {
    let first = files
        .first()
        .ok_or_else(|| CampaignError::Other("no shard files to merge".into()))?;
    let m0 = &first.manifest;
    // Every shard must be there, once: more shards than files means some are missing (and
    // a shard count read from a file must not size an allocation).
    if m0.shards == 0 || m0.shards > files.len() as u64 {
        return Err(CampaignError::Other(format!(
            "{} shard file(s) given for a campaign of {} shards",
            files.len(),
            m0.shards
        )));
    }
    let mut seen = vec![false; m0.shards as usize];
    let mut agg = Aggregate::default();
    for f in files {
        let m = &f.manifest;
        if m.scenario != m0.scenario || m.version != m0.version || m.shards != m0.shards {
            return Err(CampaignError::Other(format!(
                "shard {} belongs to another campaign (scenario, version or shard count differ)",
                m.shard
            )));
        }
        let expect = shard_range(m.scenario.trials, m.shard, m.shards);
        if m.shard >= m.shards || expect != (m.first_trial..m.end_trial) {
            return Err(CampaignError::Other(format!(
                "shard {} of {} has trials {}..{}, expected {:?}",
                m.shard, m.shards, m.first_trial, m.end_trial, expect
            )));
        }
        if f.residual_budget.is_some() != (m.shard == 0 && m.scenario.residual_budget.enabled) {
            return Err(CampaignError::Other(format!(
                "shard {} of {}: {}",
                m.shard,
                m.shards,
                if f.residual_budget.is_some() {
                    "carries a residual budget, which only shard 0 of a budgeted scenario may"
                } else {
                    "the scenario asks for a residual budget and shard 0 has none"
                }
            )));
        }
        if std::mem::replace(&mut seen[m.shard as usize], true) {
            return Err(CampaignError::Other(format!(
                "shard {} appears twice",
                m.shard
            )));
        }
        f.aggregate
            .check()
            .map_err(|e| CampaignError::Other(format!("shard {} of {}: {e}", m.shard, m.shards)))?;
        agg.merge(&f.aggregate);
    }
    if let Some(k) = seen.iter().position(|s| !s) {
        return Err(CampaignError::Other(format!(
            "shard {k} of {} is missing",
            m0.shards
        )));
    }
    Ok((m0.scenario.clone(), agg))
}

impl ShardFile {
    /// Parses a shard file's text; `source` names it in errors, with the field and the line
    /// and column.
    pub fn from_json_str(text: &str, source: &str) -> Result<ShardFile, CampaignError> {
        let de = &mut serde_json::Deserializer::from_str(text);
        serde_path_to_error::deserialize(de).map_err(|e| {
            CampaignError::Scenario(ScenarioError::Parse {
                file: source.to_string(),
                field: e.path().to_string(),
                message: format!("not a shard file: {}", e.into_inner()),
            })
        })
    }

    /// Reads a shard file written by `campaign --shard`.
    pub fn from_file(path: &Path) -> Result<ShardFile, CampaignError> {
        let source = path.display().to_string();
        let bytes = std::fs::read(path).map_err(|e| CampaignError::Io {
            path: source.clone(),
            source: e,
        })?;
        let text = std::str::from_utf8(&bytes).map_err(|e| {
            CampaignError::Other(format!(
                "{source}:{}: not valid UTF-8",
                1 + bytes[..e.valid_up_to()]
                    .iter()
                    .filter(|b| **b == b'\n')
                    .count()
            ))
        })?;
        ShardFile::from_json_str(text, &source)
    }
}
