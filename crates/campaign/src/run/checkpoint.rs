//! Checkpoints: a campaign (or a shard of one, or a sweep) that can be killed at any moment
//! and resumed to the same bytes.
//!
//! The trials run in fixed chunks; after a chunk, the running [`Aggregate`] and the index of
//! the next trial are written atomically ([`measurements::write_atomically`]: a temporary
//! file, `fsync`, `rename`) to a checkpoint file beside the outputs, every
//! [`CheckpointConfig::every`] seconds (by default), or every
//! [`CheckpointConfig::every_trials`] trials when asked, whichever comes first. Every part of an aggregate merges exactly and independently of
//! order (see [`crate::run::aggregate`]), so "the aggregate of trials `a..n`, then the
//! aggregate of `n..b` merged in" is bit for bit the aggregate of `a..b`: a resumed run gives
//! the same bytes as an uninterrupted one, whatever the chunking, thread count or where it
//! was killed. A kill during a checkpoint write leaves the previous checkpoint (and at worst
//! a hidden temporary file, removed when the run finishes).
//!
//! A checkpoint records what it belongs to ([`CheckpointManifest`]: the scenario with its
//! seed and trial count, the trial range, the robot model and the code version); resuming
//! anything else is refused with a message that says what differs. A finished run removes
//! its checkpoint.

use std::ops::Range;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use serde::{Deserialize, Serialize};

use crate::error::CampaignError;
use crate::run::range::{Aggregate, run_range_until};
use crate::scenario::Scenario;
use crate::trial::Context;

/// Format version of checkpoint files.
pub const CHECKPOINT_FORMAT: u32 = 1;

/// When and where to checkpoint.
#[derive(Clone, Debug)]
pub struct CheckpointConfig {
    /// The checkpoint file.
    pub path: PathBuf,
    /// Continue from an existing checkpoint (none: start afresh). Without it an existing
    /// checkpoint is refused rather than overwritten.
    pub resume: bool,
    /// Trials run between two looks at the clock, when [`Self::every_trials`] is `None` \[64
    /// per worker thread: about 0.1 s of the paper's trials, so a checkpoint is at most a
    /// chunk late, and each thread has 64 trials to balance its load between two joins\].
    pub chunk_trials: u64,
    /// Checkpoint after this many trials (also the chunk size) \[`None`: by time only. A
    /// checkpoint serialises, `fsync`s and renames the aggregate with its typical trial,
    /// tens of milliseconds: written after every chunk, it cost a third of a campaign's
    /// time\].
    pub every_trials: Option<u64>,
    /// Checkpoint when this much time has passed since the last one \[10 s: a kill loses at
    /// most 10 s of work, for under 1 % of the run spent writing\].
    pub every: Duration,
    /// The code version (see [`code_version`]); a checkpoint of another version is refused.
    pub code: String,
}

impl CheckpointConfig {
    /// Default cadence: every 10 s, in chunks of 64 trials per worker thread.
    pub fn new(path: PathBuf, resume: bool, code: String) -> CheckpointConfig {
        CheckpointConfig {
            path,
            resume,
            chunk_trials: 64 * rayon::current_num_threads().max(1) as u64,
            every_trials: None,
            every: Duration::from_secs(10),
            code,
        }
    }
}

/// What a checkpoint belongs to; resuming requires every field to match.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CheckpointManifest {
    /// Checkpoint format (`CHECKPOINT_FORMAT`).
    pub format: u32,
    /// What is being run, e.g. `campaign`, `shard 1/4`, `sweep pose-count point 3`.
    pub what: String,
    /// The scenario as run (seed and trial count included).
    pub scenario: Scenario,
    /// Fingerprint of the loaded nominal robot model (FNV-1a of its exact contents, hex).
    pub robot: String,
    /// Code version ([`code_version`]).
    pub code: String,
    /// First trial of the run (inclusive).
    pub first_trial: u64,
    /// End of the run (exclusive).
    pub end_trial: u64,
}

impl CheckpointManifest {
    /// The manifest of running `range` of `ctx`'s scenario.
    pub fn new(what: &str, ctx: &Context, range: Range<u64>, code: &str) -> CheckpointManifest {
        CheckpointManifest {
            format: CHECKPOINT_FORMAT,
            what: what.to_string(),
            scenario: ctx.loaded.scenario.clone(),
            robot: format!(
                "{:016x}",
                fnv1a(format!("{:?}", ctx.loaded.nominal).as_bytes())
            ),
            code: code.to_string(),
            first_trial: range.start,
            end_trial: range.end,
        }
    }

    /// What differs between a checkpoint's manifest (`self`) and this run's, one item per
    /// difference (scenario fields by dotted path); empty when they match.
    pub fn differences(&self, run: &CheckpointManifest) -> Vec<String> {
        let mut d = Vec::new();
        let mut field = |name: &str, a: String, b: String| {
            if a != b {
                d.push(format!("{name}: checkpoint has {a}, this run {b}"));
            }
        };
        field("format", self.format.to_string(), run.format.to_string());
        field("run", self.what.clone(), run.what.clone());
        field("code version", self.code.clone(), run.code.clone());
        field(
            "trial range",
            format!("{}..{}", self.first_trial, self.end_trial),
            format!("{}..{}", run.first_trial, run.end_trial),
        );
        field("robot model", self.robot.clone(), run.robot.clone());
        let (a, b) = (
            serde_json::to_value(&self.scenario).unwrap_or_default(),
            serde_json::to_value(&run.scenario).unwrap_or_default(),
        );
        let mut paths = Vec::new();
        json_differences("scenario", &a, &b, &mut paths);
        for p in paths {
            let (x, y) = (lookup(&a, &p), lookup(&b, &p));
            d.push(format!("{p}: checkpoint has {x}, this run {y}"));
        }
        d
    }
}

/// The value at dotted `path` (`scenario.` prefix skipped), as compact JSON or `absent`.
fn lookup(root: &serde_json::Value, path: &str) -> String {
    let mut cur = root;
    for part in path.split('.').skip(1) {
        match cur.get(part) {
            Some(v) => cur = v,
            None => return "absent".into(),
        }
    }
    let s = cur.to_string();
    if s.len() > 80 {
        format!("{}…", &s[..s.floor_char_boundary(80)])
    } else {
        s
    }
}

/// Dotted paths where two JSON values differ (objects descended into).
fn json_differences(
    path: &str,
    a: &serde_json::Value,
    b: &serde_json::Value,
    out: &mut Vec<String>,
) {
    match (a, b) {
        (serde_json::Value::Object(x), serde_json::Value::Object(y)) => {
            let keys: std::collections::BTreeSet<&String> = x.keys().chain(y.keys()).collect();
            for k in keys {
                let null = serde_json::Value::Null;
                json_differences(
                    &format!("{path}.{k}"),
                    x.get(k).unwrap_or(&null),
                    y.get(k).unwrap_or(&null),
                    out,
                );
            }
        }
        _ if a != b => out.push(path.to_string()),
        _ => {}
    }
}

/// A checkpoint file: what it belongs to, how far it got, and the aggregate so far.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Checkpoint {
    /// What it belongs to.
    pub manifest: CheckpointManifest,
    /// Trials `first_trial..next_trial` are in `aggregate`.
    pub next_trial: u64,
    /// Their aggregate.
    pub aggregate: Aggregate,
    /// Wall-clock seconds the run has taken up to this checkpoint, summed over its segments
    /// (a resumed run adds its own to the checkpoint's): what `timing.json` reports for the
    /// whole run. Not a result: the outputs never depend on it.
    #[serde(default)]
    pub wall_seconds: f64,
}

/// The bytes of the checkpoint file `path`, `None` when there is none; other errors name it.
pub(crate) fn read_if_exists(path: &Path) -> Result<Option<Vec<u8>>, CampaignError> {
    match std::fs::read(path) {
        Ok(t) => Ok(Some(t)),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(None),
        Err(source) => Err(CampaignError::Io {
            path: path.display().to_string(),
            source,
        }),
    }
}

impl Checkpoint {
    /// Reads and checks a checkpoint file; `Ok(None)` when there is none. Errors name the
    /// file (and the JSON line and column, or the inconsistent field).
    pub fn read(path: &Path) -> Result<Option<Checkpoint>, CampaignError> {
        let Some(text) = read_if_exists(path)? else {
            return Ok(None);
        };
        let c: Checkpoint =
            serde_json::from_slice(&text).map_err(|source| CampaignError::NotACheckpoint {
                path: path.display().to_string(),
                source,
            })?;
        let m = &c.manifest;
        let bad = |field: &'static str, problem: String| {
            Err(CampaignError::InconsistentCheckpoint {
                path: path.display().to_string(),
                field,
                problem,
            })
        };
        if !(m.first_trial..=m.end_trial).contains(&c.next_trial) {
            return bad(
                "next_trial",
                format!(
                    "{} outside {}..{}",
                    c.next_trial, m.first_trial, m.end_trial
                ),
            );
        }
        if c.aggregate.trials != c.next_trial - m.first_trial {
            return bad(
                "aggregate.trials",
                format!(
                    "{} but trials {}..{} done",
                    c.aggregate.trials, m.first_trial, c.next_trial
                ),
            );
        }
        if let Err(e) = c.aggregate.check() {
            return bad("aggregate", e);
        }
        Ok(Some(c))
    }

    /// Writes the checkpoint atomically.
    pub fn write(&self, path: &Path) -> Result<(), CampaignError> {
        let text = serde_json::to_vec(self).map_err(|source| CampaignError::Serialise {
            path: path.display().to_string(),
            source,
        })?;
        measurements::write_atomically(path, &text).map_err(|source| CampaignError::Io {
            path: path.display().to_string(),
            source,
        })
    }
}

/// Where a run starts: the checkpoint's aggregate and next trial, or nothing done. Refuses
/// a checkpoint that belongs to another run (saying what differs), and an existing
/// checkpoint when `cfg.resume` is off.
pub fn starting_point(
    cfg: &CheckpointConfig,
    manifest: &CheckpointManifest,
) -> Result<(u64, Aggregate), CampaignError> {
    let fresh = (manifest.first_trial, Aggregate::default());
    if !cfg.resume {
        if cfg.path.exists() {
            return Err(CampaignError::UnfinishedCheckpoint {
                path: cfg.path.clone(),
                what: "run",
            });
        }
        return Ok(fresh);
    }
    let Some(c) = Checkpoint::read(&cfg.path)? else {
        return Ok(fresh);
    };
    let diff = c.manifest.differences(manifest);
    if !diff.is_empty() {
        return Err(CampaignError::CheckpointMismatch {
            path: cfg.path.clone(),
            what: "run",
            differences: diff,
        });
    }
    Ok((c.next_trial, c.aggregate))
}

/// Runs trials `trials` (`next..end`) in chunks (of `cfg.every_trials` if set, else of
/// `cfg.chunk_trials`) on the current rayon pool, adding them to `agg`; after a chunk, calls
/// `save(next_trial, &aggregate)` when `cfg.every_trials` trials or `cfg.every` have passed
/// since the last save (never after the last chunk). `progress(k)` and `stop_requested()` as
/// in [`run_range_until`]; a stop drops the chunk in progress and is
/// [`CampaignError::Stopped`].
pub fn run_chunks(
    ctx: &Context,
    trials: Range<u64>,
    mut agg: Aggregate,
    cfg: &CheckpointConfig,
    progress: &(dyn Fn(u64) + Sync),
    stop_requested: &(dyn Fn() -> bool + Sync),
    save: &mut dyn FnMut(u64, &Aggregate) -> Result<(), CampaignError>,
) -> Result<Aggregate, CampaignError> {
    let chunk = cfg.every_trials.unwrap_or(cfg.chunk_trials).max(1);
    let (mut next, end) = (trials.start, trials.end);
    let (mut last, mut since) = (Instant::now(), 0u64);
    while next < end {
        let stop = end.min(next.saturating_add(chunk));
        // A stop drops the chunk in progress: the last checkpoint written stays the place a
        // resumed run continues from.
        let Some(part) = run_range_until(ctx, next..stop, progress, stop_requested) else {
            return Err(CampaignError::Stopped { done: agg.trials });
        };
        agg.merge(&part);
        since += stop - next;
        next = stop;
        let by_count = cfg.every_trials.is_some_and(|k| since >= k);
        if next < end && (by_count || last.elapsed() >= cfg.every) {
            save(next, &agg)?;
            last = Instant::now();
            since = 0;
        }
    }
    Ok(agg)
}

/// Runs `range` of `ctx`'s scenario with checkpoints (see the module docs): resumes from
/// `cfg.path` if asked and possible, and returns the whole range's aggregate. The caller
/// writes its outputs, then calls `finish`.
pub fn run_range_checkpointed(
    ctx: &Context,
    what: &str,
    range: Range<u64>,
    cfg: &CheckpointConfig,
    progress: &(dyn Fn(u64) + Sync),
    stop_requested: &(dyn Fn() -> bool + Sync),
) -> Result<Aggregate, CampaignError> {
    let manifest = CheckpointManifest::new(what, ctx, range.clone(), &cfg.code);
    let started = Instant::now();
    let prior = prior_wall_seconds(cfg);
    let (next, agg) = starting_point(cfg, &manifest)?;
    if next > range.start {
        progress(next - range.start);
    }
    let save = &mut |n, a: &Aggregate| {
        Checkpoint {
            manifest: manifest.clone(),
            next_trial: n,
            aggregate: a.clone(),
            wall_seconds: prior + started.elapsed().as_secs_f64(),
        }
        .write(&cfg.path)
    };
    run_chunks(
        ctx,
        next..range.end,
        agg,
        cfg,
        progress,
        stop_requested,
        save,
    )
}

/// The wall-clock seconds of the earlier segments of a resumed run (the checkpoint's
/// [`Checkpoint::wall_seconds`]); 0 for a fresh start or an unreadable checkpoint (which the
/// run then refuses anyway).
pub fn prior_wall_seconds(cfg: &CheckpointConfig) -> f64 {
    if !cfg.resume {
        return 0.0;
    }
    match Checkpoint::read(&cfg.path) {
        Ok(Some(c)) if c.wall_seconds.is_finite() && c.wall_seconds >= 0.0 => c.wall_seconds,
        _ => 0.0,
    }
}

/// After the outputs are written: removes the checkpoint and any temporary file that a
/// killed write of the checkpoint or of one of `outputs` (file names in the checkpoint's
/// directory) left there. Other files' temporaries are left alone: in a directory shared by
/// the shards of a job array they may belong to a run still writing.
pub fn finish(path: &Path, outputs: &[String]) -> Result<(), CampaignError> {
    match std::fs::remove_file(path) {
        Ok(()) => {}
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {}
        Err(source) => {
            return Err(CampaignError::Io {
                path: path.display().to_string(),
                source,
            });
        }
    }
    let (Some(dir), Some(name)) = (path.parent(), path.file_name()) else {
        return Ok(());
    };
    let dir = if dir.as_os_str().is_empty() {
        Path::new(".")
    } else {
        dir
    };
    // write_atomically's temporaries: `.<name>.<pid>.<n>.tmp`.
    let prefixes: Vec<String> = std::iter::once(name.to_string_lossy().into_owned())
        .chain(outputs.iter().cloned())
        .map(|n| format!(".{n}."))
        .collect();
    if let Ok(entries) = std::fs::read_dir(dir) {
        for e in entries.flatten() {
            let f = e.file_name();
            let f = f.to_string_lossy();
            let ours = prefixes.iter().any(|p| {
                f.strip_prefix(p.as_str())
                    .and_then(|rest| rest.strip_suffix(".tmp"))
                    .is_some_and(|mid| {
                        let mut parts = mid.split('.');
                        parts.clone().count() == 2
                            && parts.all(|x| !x.is_empty() && x.bytes().all(|b| b.is_ascii_digit()))
                    })
            });
            if ours {
                let _ = std::fs::remove_file(e.path());
            }
        }
    }
    Ok(())
}

/// 64-bit FNV-1a: a stable fingerprint (not a cryptographic hash).
pub fn fnv1a(bytes: &[u8]) -> u64 {
    bytes.iter().fold(0xcbf2_9ce4_8422_2325, |h, b| {
        (h ^ u64::from(*b)).wrapping_mul(0x0000_0100_0000_01b3)
    })
}

/// A fast 64-bit fingerprint of a large byte string (an executable): FNV-1a over 8-byte
/// little-endian words, then the tail and the length; stable across platforms. The reference
/// [`fingerprint_reader`] is tested against.
#[cfg(test)]
pub fn fingerprint(bytes: &[u8]) -> u64 {
    const PRIME: u64 = 0x0000_0100_0000_01b3;
    let mut words = bytes.chunks_exact(8);
    let mut h = words.by_ref().fold(0xcbf2_9ce4_8422_2325u64, |h, w| {
        (h ^ u64::from_le_bytes(w.try_into().expect("8 bytes"))).wrapping_mul(PRIME)
    });
    h = words
        .remainder()
        .iter()
        .fold(h, |h, b| (h ^ u64::from(*b)).wrapping_mul(PRIME));
    (h ^ bytes.len() as u64).wrapping_mul(PRIME)
}

/// The code version a checkpoint is tied to: the crate version and a fingerprint of the
/// running executable, so that a rebuilt binary (which might compute other bits) does not
/// resume an old run's checkpoint. Falls back to the crate version alone when the
/// executable cannot be read. The executable is read in blocks (`fingerprint_reader`), not
/// whole: it is tens of megabytes, which would otherwise be every run's peak memory.
pub fn code_version() -> String {
    let version = env!("CARGO_PKG_VERSION");
    match std::env::current_exe()
        .and_then(std::fs::File::open)
        .and_then(fingerprint_reader)
    {
        Ok(h) => format!("{version} (executable {h:016x})"),
        Err(_) => version.to_string(),
    }
}

/// [`fingerprint`] of everything `r` yields, read in 64 KiB blocks (the same value as
/// `fingerprint` of the bytes in memory).
pub fn fingerprint_reader(mut r: impl std::io::Read) -> std::io::Result<u64> {
    const PRIME: u64 = 0x0000_0100_0000_01b3;
    let mut h = 0xcbf2_9ce4_8422_2325u64;
    let mut len = 0u64;
    // `block[..filled]`: bytes read and not yet hashed (fewer than 8 after each round).
    let mut block = vec![0u8; 1 << 16];
    let mut filled = 0;
    loop {
        let n = match r.read(&mut block[filled..]) {
            Ok(0) => break,
            Ok(n) => n,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => continue,
            Err(e) => return Err(e),
        };
        len += n as u64;
        filled += n;
        let whole = filled - filled % 8;
        for w in block[..whole].chunks_exact(8) {
            h = (h ^ u64::from_le_bytes(w.try_into().expect("8 bytes"))).wrapping_mul(PRIME);
        }
        block.copy_within(whole..filled, 0);
        filled -= whole;
    }
    h = block[..filled]
        .iter()
        .fold(h, |h, b| (h ^ u64::from(*b)).wrapping_mul(PRIME));
    Ok((h ^ len).wrapping_mul(PRIME))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Read in blocks of any size (a reader that returns 1 to 13 bytes at a time, and a
    /// file larger than the 64 KiB block), the fingerprint is that of the bytes in memory.
    #[test]
    fn the_streamed_fingerprint_equals_the_in_memory_one() {
        struct Trickle<'a>(&'a [u8], usize);
        impl std::io::Read for Trickle<'_> {
            fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
                self.1 = self.1 % 13 + 1;
                let n = self.1.min(buf.len()).min(self.0.len());
                buf[..n].copy_from_slice(&self.0[..n]);
                self.0 = &self.0[n..];
                Ok(n)
            }
        }
        let bytes: Vec<u8> = (0..200_003u32)
            .map(|i| (i.wrapping_mul(2_654_435_761) >> 24) as u8)
            .collect();
        for len in [0, 1, 7, 8, 9, 65_535, 65_536, 65_537, 200_003] {
            let b = &bytes[..len];
            assert_eq!(fingerprint_reader(b).unwrap(), fingerprint(b), "{len}");
            assert_eq!(
                fingerprint_reader(Trickle(b, 0)).unwrap(),
                fingerprint(b),
                "{len} in pieces"
            );
        }
        assert_ne!(fingerprint(&bytes[..8]), fingerprint(&bytes[..9]));
    }

    #[test]
    fn fnv1a_matches_the_reference_vectors() {
        // From the FNV reference test suite.
        assert_eq!(fnv1a(b""), 0xcbf2_9ce4_8422_2325);
        assert_eq!(fnv1a(b"a"), 0xaf63_dc4c_8601_ec8c);
        assert_eq!(fnv1a(b"foobar"), 0x8594_4171_f739_67e8);
    }

    #[test]
    fn json_differences_name_dotted_paths() {
        let a = serde_json::json!({"seed": 1, "poses": {"identification": 50, "x": [1]}});
        let b = serde_json::json!({"seed": 2, "poses": {"identification": 50, "x": [2]}, "n": 1});
        let mut d = Vec::new();
        json_differences("scenario", &a, &b, &mut d);
        assert_eq!(d, ["scenario.n", "scenario.poses.x", "scenario.seed"]);
        assert_eq!(lookup(&a, "scenario.poses.x"), "[1]");
        assert_eq!(lookup(&a, "scenario.n"), "absent");
    }
}
