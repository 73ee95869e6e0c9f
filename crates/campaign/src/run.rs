//! Running trials in parallel and folding them into a mergeable [`Aggregate`].
//!
//! Trials run in chunks of [`CHUNK`] on rayon's pool; each chunk's results are collected in
//! trial order and folded sequentially, so memory stays flat in the trial count and the
//! aggregate (exact integer sums, histograms) is identical for any thread count. A range of
//! trials (a shard) gives an aggregate that merges exactly with the others'.

use std::collections::BTreeMap;
use std::ops::Range;

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::aggregate::{Counts, Stat};
use crate::trial::{Context, TrialResult, run_trial};

/// Trials per parallel chunk: bounds memory while keeping both cores busy.
pub const CHUNK: u64 = 512;

/// Accumulated recovery statistics of one parameter.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct RecoveryStat {
    /// Display unit.
    pub unit: String,
    /// estimate − truth.
    pub error: Stat,
    /// |estimate − truth|.
    pub abs_error: Stat,
    /// z-score.
    pub z: Stat,
    /// Reported standard error.
    pub std_error: Stat,
}

/// Everything a campaign (or a shard of it) accumulates; merging is exact.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Aggregate {
    /// Trials attempted.
    pub trials: u64,
    /// Trials that failed, by error message.
    pub failures: Counts,
    /// Scalar metrics by name.
    pub metrics: BTreeMap<String, Stat>,
    /// Recovery per minimal-set parameter.
    pub recovery: BTreeMap<String, RecoveryStat>,
    /// Categorical outcomes (`stop_reason`, `rank`) by name.
    pub counts: BTreeMap<String, Counts>,
    /// The lowest-index successful trial, whole: the per-pose plot (Fig. 7) and the trial
    /// report are drawn from it.
    pub typical: Option<TrialResult>,
}

impl Aggregate {
    fn metric(&mut self, name: &str, value: f64) {
        self.metrics
            .entry(name.to_string())
            .or_default()
            .push(value);
    }

    fn count(&mut self, name: &str, key: impl Into<String>) {
        self.counts.entry(name.to_string()).or_default().add(key);
    }

    /// Folds one trial's result in.
    pub fn add(&mut self, r: &TrialResult) {
        self.trials += 1;
        let t = &r.table4;
        let imp = t.improvement();
        self.metric("before_mean_mm", t.before.norm.mean_mm);
        self.metric("after_mean_mm", t.after.norm.mean_mm);
        self.metric("before_max_mm", t.before.norm.max_mm);
        self.metric("after_max_mm", t.after.norm.max_mm);
        self.metric("before_rms_mm", t.before.norm.rms_mm);
        self.metric("after_rms_mm", t.after.norm.rms_mm);
        self.metric("before_p95_mm", t.before.norm.p95_mm);
        self.metric("after_p95_mm", t.after.norm.p95_mm);
        for (axis, b, a) in [
            ("x", &t.before.x, &t.after.x),
            ("y", &t.before.y, &t.after.y),
            ("z", &t.before.z, &t.after.z),
        ] {
            self.metric(&format!("before_mean_{axis}_mm"), b.mean_mm);
            self.metric(&format!("after_mean_{axis}_mm"), a.mean_mm);
        }
        self.metric("improvement_pct", imp.norm.mean_pct.unwrap_or(f64::NAN));
        self.metric("improvement_max_pct", imp.norm.max_pct.unwrap_or(f64::NAN));
        self.metric("predicted_error_mm", r.predicted_error_mm);
        self.metric("fit_rms_mm", r.fit.rms_mm);
        self.metric("lm_iterations", r.fit.iterations as f64);
        self.metric("compensation_failures", r.compensation_failures as f64);
        self.metric("unmeasurable_poses", r.unmeasurable as f64);
        self.count("stop_reason", r.fit.stop.clone());
        self.count(
            "rank",
            r.fit
                .rank
                .map_or_else(|| "unknown".to_string(), |k| format!("{k:03}")),
        );
        for rec in &r.recovery {
            let e = self.recovery.entry(rec.name.clone()).or_default();
            e.unit.clone_from(&rec.unit);
            e.error.push(rec.error);
            e.abs_error.push(rec.error.abs());
            e.z.push(rec.z);
            e.std_error.push(rec.std_error);
        }
        if let Some(iso) = &r.iso {
            self.metric("iso_ap_before_mm", iso.mean_ap_p_before_mm());
            self.metric("iso_ap_after_mm", iso.mean_ap_p_after_mm());
            self.metric(
                "iso_ap_improvement_pct",
                iso.ap_p_improvement_pct().unwrap_or(f64::NAN),
            );
            self.metric("iso_rp_before_mm", iso.mean_rp_l_before_mm());
            self.metric("iso_rp_after_mm", iso.mean_rp_l_after_mm());
        }
        if self.typical.as_ref().is_none_or(|t| r.trial < t.trial) {
            self.typical = Some(r.clone());
        }
    }

    /// Counts a failed trial.
    pub fn add_failure(&mut self, message: &str) {
        self.trials += 1;
        self.failures.add(message);
    }

    /// Adds another aggregate (another shard) exactly.
    pub fn merge(&mut self, other: &Aggregate) {
        self.trials += other.trials;
        self.failures.merge(&other.failures);
        for (k, v) in &other.metrics {
            self.metrics.entry(k.clone()).or_default().merge(v);
        }
        for (k, v) in &other.recovery {
            let e = self.recovery.entry(k.clone()).or_default();
            e.unit.clone_from(&v.unit);
            e.error.merge(&v.error);
            e.abs_error.merge(&v.abs_error);
            e.z.merge(&v.z);
            e.std_error.merge(&v.std_error);
        }
        for (k, v) in &other.counts {
            self.counts.entry(k.clone()).or_default().merge(v);
        }
        if let Some(t) = &other.typical
            && self.typical.as_ref().is_none_or(|s| t.trial < s.trial)
        {
            self.typical = Some(t.clone());
        }
    }
}

/// Runs the trials in `range` on the current rayon pool; `progress(k)` is called after
/// each finished chunk with the number of trials done so far.
pub fn run_range(ctx: &Context, range: Range<u64>, progress: &(dyn Fn(u64) + Sync)) -> Aggregate {
    let mut agg = Aggregate::default();
    let mut start = range.start;
    while start < range.end {
        let end = (start + CHUNK).min(range.end);
        let results: Vec<_> = (start..end)
            .into_par_iter()
            .map(|t| {
                let r = run_trial(ctx, t);
                progress(1);
                r
            })
            .collect();
        for r in &results {
            match r {
                Ok(r) => agg.add(r),
                Err(e) => {
                    // Count by cause, not by trial: drop the "trial N: " prefix.
                    let msg = e.to_string();
                    let cause = match msg.split_once(": ") {
                        Some((head, rest)) if head.starts_with("trial ") => rest.to_string(),
                        _ => msg,
                    };
                    agg.add_failure(&cause)
                }
            }
        }
        start = end;
    }
    agg
}
