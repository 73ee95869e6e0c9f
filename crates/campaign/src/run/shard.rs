//! Shards: a campaign split into K contiguous trial ranges run apart (e.g. as a Slurm job
//! array), each writing a shard file (its manifest and exact aggregate) that
//! [`merge_shards`] combines into the single run's aggregate. The file's name
//! ([`Shard::file_name`]), its writer ([`ShardFile::write`]) and its reader
//! ([`ShardFile::from_file`]) live here together, and so does the rule that the residual
//! budget is computed by shard 0 alone ([`Shard::runs_budget`]).

use std::fmt;
use std::ops::Range;
use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::error::CampaignError;
use crate::run::budget::ResidualBudget;
use crate::run::range::Aggregate;
use crate::scenario::Scenario;

/// One shard of a campaign: shard `index` (0-based) of `count`, with `index < count`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Shard {
    index: u64,
    count: u64,
}

impl Shard {
    /// Shard `index` (0-based) of `count`; refused unless `0 <= index < count`.
    pub fn new(index: u64, count: u64) -> Result<Shard, CampaignError> {
        if count == 0 || index >= count {
            return Err(CampaignError::InvalidShard {
                shard: index,
                shards: count,
            });
        }
        Ok(Shard { index, count })
    }

    /// The shard's index k, 0-based.
    pub fn index(self) -> u64 {
        self.index
    }

    /// The number of shards K.
    pub fn count(self) -> u64 {
        self.count
    }

    /// The shard's trials of a campaign of `trials` trials ([`shard_range`]).
    pub fn range(self, trials: u64) -> Range<u64> {
        shard_range(trials, self.index, self.count)
    }

    /// The shard file's name, `shard-k-of-K.json`.
    pub fn file_name(self) -> String {
        format!("shard-{}-of-{}.json", self.index, self.count)
    }

    /// The name of the shard's checkpoint file, `shard-k-of-K.checkpoint.json`.
    pub fn checkpoint_name(self) -> String {
        format!("shard-{}-of-{}.checkpoint.json", self.index, self.count)
    }

    /// Whether a run of this shard (`None`: the whole campaign) computes the residual
    /// budget. The budget reruns trials `0..budget trials` whatever the split, so exactly
    /// one shard, shard 0, computes it, and the merge takes it from there.
    pub fn runs_budget(shard: Option<Shard>) -> bool {
        shard.is_none_or(|s| s.index == 0)
    }
}

impl fmt::Display for Shard {
    /// `k/K`.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}/{}", self.index, self.count)
    }
}

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

/// A shard file: manifest plus the exact aggregate (written by [`ShardFile::write`], read by
/// [`ShardFile::from_file`]).
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
    /// The digest of the rest of the file ([`ShardFile::content_digest`]), written by
    /// [`ShardFile::write`] and checked by the reader: a shard file edited (a sum changed, a
    /// trial count changed), truncated or put together from two files is refused, naming
    /// it. `None` in memory until written. An integrity check against accidents, not a
    /// signature: whoever can write the file can recompute it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub digest: Option<String>,
}

/// The trial range of shard `k` of `shards` over `trials` trials (contiguous, sizes differ by
/// at most one).
pub fn shard_range(trials: u64, k: u64, shards: u64) -> Range<u64> {
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
    let first = files.first().ok_or(CampaignError::NoShards)?;
    let m0 = &first.manifest;
    // Every shard must be there, once: more shards than files means some are missing (and
    // a shard count read from a file must not size an allocation).
    if m0.shards == 0 || m0.shards > files.len() as u64 {
        return Err(CampaignError::ShardCount {
            files: files.len(),
            shards: m0.shards,
        });
    }
    let mut seen = vec![false; m0.shards as usize];
    let mut agg = Aggregate::default();
    for f in files {
        let m = &f.manifest;
        if m.scenario != m0.scenario || m.version != m0.version || m.shards != m0.shards {
            return Err(CampaignError::ForeignShard { shard: m.shard });
        }
        let expect = shard_range(m.scenario.trials, m.shard, m.shards);
        if m.shard >= m.shards || expect != (m.first_trial..m.end_trial) {
            return Err(CampaignError::ShardRange {
                shard: m.shard,
                shards: m.shards,
                trials: m.first_trial..m.end_trial,
                expected: expect,
            });
        }
        let (shard, shards) = (m.shard, m.shards);
        // In range: checked above.
        let budgeted = Shard::runs_budget(Some(Shard {
            index: shard,
            count: shards,
        })) && m.scenario.residual_budget.enabled;
        match (f.residual_budget.is_some(), budgeted) {
            (true, false) => return Err(CampaignError::UnexpectedShardBudget { shard, shards }),
            (false, true) => return Err(CampaignError::MissingShardBudget { shard, shards }),
            _ => {}
        }
        if std::mem::replace(&mut seen[m.shard as usize], true) {
            return Err(CampaignError::DuplicateShard { shard });
        }
        f.aggregate
            .check()
            .map_err(|problem| CampaignError::ShardAggregate {
                shard,
                shards,
                problem,
            })?;
        agg.merge(&f.aggregate);
    }
    if let Some(k) = seen.iter().position(|s| !s) {
        return Err(CampaignError::MissingShard {
            shard: k as u64,
            shards: m0.shards,
        });
    }
    Ok((m0.scenario.clone(), agg))
}

impl ShardFile {
    /// The shard file of `shard` of a campaign of `scenario` (its trial count included):
    /// the aggregate of the shard's trials and, for shard 0 of a budgeted scenario, the
    /// residual budget.
    pub fn new(
        scenario: Scenario,
        shard: Shard,
        aggregate: Aggregate,
        residual_budget: Option<ResidualBudget>,
    ) -> ShardFile {
        let range = shard.range(scenario.trials);
        ShardFile {
            manifest: ShardManifest {
                scenario,
                version: env!("CARGO_PKG_VERSION").into(),
                shard: shard.index,
                shards: shard.count,
                first_trial: range.start,
                end_trial: range.end,
            },
            aggregate,
            residual_budget,
            digest: None,
        }
    }

    /// The digest of the file's content: `fnv1a64:` and the 16 hex digits of FNV-1a (64
    /// bits) over the compact JSON of the manifest (the scenario, its trial count and seed
    /// included), the aggregate and the residual budget, the `digest` field left out.
    pub fn content_digest(&self) -> Result<String, serde_json::Error> {
        let body = ShardFile {
            digest: None,
            ..self.clone()
        };
        let text = serde_json::to_string(&body)?;
        Ok(format!(
            "fnv1a64:{:016x}",
            crate::run::checkpoint::fnv1a(text.as_bytes())
        ))
    }

    /// The shard file's text as written: compact JSON with its digest.
    pub fn to_json_string(&self) -> Result<String, serde_json::Error> {
        let file = ShardFile {
            digest: Some(self.content_digest()?),
            ..self.clone()
        };
        serde_json::to_string(&file)
    }

    /// Writes the shard file (compact JSON, with its digest) atomically to `path`.
    pub fn write(&self, path: &Path) -> Result<(), CampaignError> {
        let text = self
            .to_json_string()
            .map_err(|source| CampaignError::Serialise {
                path: path.display().to_string(),
                source,
            })?;
        measurements::write_atomically(path, text.as_bytes()).map_err(|source| {
            CampaignError::Write {
                path: path.to_path_buf(),
                source,
            }
        })
    }

    /// Parses a shard file's text and checks it; `source` names it in errors, with the
    /// field and the line and column. Refused: trailing content after the document, a
    /// missing or wrong digest (an edited or truncated file), an aggregate whose trial count
    /// is not the shard's range.
    pub fn from_json_str(text: &str, source: &str) -> Result<ShardFile, CampaignError> {
        let de = &mut serde_json::Deserializer::from_str(text);
        let file: ShardFile =
            serde_path_to_error::deserialize(&mut *de).map_err(|e| CampaignError::Parse {
                file: source.to_string(),
                field: e.path().to_string(),
                message: format!("not a shard file: {}", e.into_inner()),
            })?;
        // Nothing but white space after the document.
        de.end().map_err(|e| CampaignError::Parse {
            file: source.to_string(),
            field: ".".to_string(),
            message: format!("not a shard file: {e}"),
        })?;
        let inconsistent = |field: &'static str, problem: String| CampaignError::ShardContent {
            file: source.to_string(),
            field,
            problem,
        };
        let Some(found) = &file.digest else {
            return Err(inconsistent(
                "digest",
                "it has no digest (written by an older kincal, or edited): rerun the shard"
                    .to_string(),
            ));
        };
        let expected = file
            .content_digest()
            .map_err(|e| inconsistent("digest", format!("cannot compute its digest: {e}")))?;
        if *found != expected {
            return Err(inconsistent(
                "digest",
                format!(
                    "its content does not match its digest ({found} recorded, {expected} \
                 computed): the file was edited or damaged after it was written; rerun the \
                 shard"
                ),
            ));
        }
        let m = &file.manifest;
        if m.end_trial.checked_sub(m.first_trial) != Some(file.aggregate.trials) {
            return Err(inconsistent(
                "aggregate.trials",
                format!(
                    "its aggregate holds {} trials but its range is {}..{}",
                    file.aggregate.trials, m.first_trial, m.end_trial
                ),
            ));
        }
        Ok(file)
    }

    /// Reads a shard file written by [`ShardFile::write`].
    pub fn from_file(path: &Path) -> Result<ShardFile, CampaignError> {
        let source = path.display().to_string();
        let bytes = std::fs::read(path).map_err(|e| CampaignError::Io {
            path: source.clone(),
            source: e,
        })?;
        let text = std::str::from_utf8(&bytes).map_err(|e| CampaignError::NotUtf8 {
            path: source.clone(),
            line: 1 + bytes[..e.valid_up_to()]
                .iter()
                .filter(|b| **b == b'\n')
                .count(),
        })?;
        ShardFile::from_json_str(text, &source)
    }
}
