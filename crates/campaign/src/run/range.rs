//! Running trials in parallel and folding them into a mergeable [`Aggregate`].
//!
//! Trials run on rayon's pool; each worker thread folds the trials it runs into its own
//! [`Aggregate`] as they finish, and the per-thread aggregates are merged at the end. Every
//! part of an aggregate merges exactly and independently of order (integer sums, extremes,
//! histogram buckets, counts, the lowest-index trial), so the result is identical for any
//! thread count and any assignment of trials to threads, memory stays flat in the trial
//! count (one aggregate per thread, no per-trial results kept), and no thread waits for a
//! sequential fold. A range of trials
//! (a shard) gives an aggregate that merges exactly with the others'.

use std::collections::BTreeMap;
use std::ops::Range;
use std::sync::Mutex;

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::run::aggregate::{Counts, Stat};
use crate::trial::{Context, TrialResult, run_trial};

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

/// The name of every scalar metric a campaign records (the keys of
/// [`Aggregate::metrics`], of `summary.json`'s `metrics` and of a sweep point's): what a
/// sweep plot's `y` may name. The ISO and observability ones exist only when the scenario
/// computes them, the residual model's (`residual_*`, `geometry_after_*`, `hybrid_*`) only
/// with the scenario's `residual_model`.
pub const METRICS: &[&str] = &[
    "before_mean_mm",
    "after_mean_mm",
    "before_max_mm",
    "after_max_mm",
    "before_rms_mm",
    "after_rms_mm",
    "before_p95_mm",
    "after_p95_mm",
    "before_mean_x_mm",
    "after_mean_x_mm",
    "before_mean_y_mm",
    "after_mean_y_mm",
    "before_mean_z_mm",
    "after_mean_z_mm",
    "improvement_pct",
    "improvement_max_pct",
    "predicted_error_mm",
    "fit_rms_mm",
    "lm_iterations",
    "gradient_cosine",
    "compensation_failures",
    "unmeasurable_poses",
    "pose_rejection_rate",
    "observability_o1",
    "observability_o2",
    "observability_o3",
    "observability_o4",
    "observability_o5",
    "iso_ap_before_mm",
    "iso_ap_after_mm",
    "iso_ap_improvement_pct",
    "iso_rp_before_mm",
    "iso_rp_after_mm",
    "iso_compensation_failures",
    "residual_used",
    "residual_cv_mean_gain_mm",
    "residual_cv_p95_gain_mm",
    "geometry_after_mean_mm",
    "geometry_after_max_mm",
    "geometry_after_p95_mm",
    "hybrid_after_mean_mm",
    "hybrid_after_max_mm",
    "hybrid_after_p95_mm",
    "hybrid_compensation_failures",
    "residual_coverage_1sd",
    "residual_coverage_2sd",
];

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
        // Look up before inserting: no key allocation once the metric exists.
        match self.metrics.get_mut(name) {
            Some(s) => s.push(value),
            None => self
                .metrics
                .entry(name.to_string())
                .or_default()
                .push(value),
        }
    }

    fn count(&mut self, name: &str, key: &str) {
        match self.counts.get_mut(name) {
            Some(c) => c.add_str(key),
            None => self.counts.entry(name.to_string()).or_default().add(key),
        }
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
        for (names, b, a) in [
            (
                ["before_mean_x_mm", "after_mean_x_mm"],
                &t.before.x,
                &t.after.x,
            ),
            (
                ["before_mean_y_mm", "after_mean_y_mm"],
                &t.before.y,
                &t.after.y,
            ),
            (
                ["before_mean_z_mm", "after_mean_z_mm"],
                &t.before.z,
                &t.after.z,
            ),
        ] {
            self.metric(names[0], b.mean_mm);
            self.metric(names[1], a.mean_mm);
        }
        self.metric("improvement_pct", imp.norm.mean_pct.unwrap_or(f64::NAN));
        self.metric("improvement_max_pct", imp.norm.max_pct.unwrap_or(f64::NAN));
        self.metric("predicted_error_mm", r.predicted_error_mm);
        self.metric("fit_rms_mm", r.fit.rms_mm);
        self.metric("lm_iterations", r.fit.iterations as f64);
        self.metric("gradient_cosine", r.fit.gradient_cosine);
        self.metric("compensation_failures", r.compensation_failures as f64);
        self.metric("unmeasurable_poses", r.unmeasurable as f64);
        self.metric("pose_rejection_rate", r.pose_rejection_rate);
        self.count("stop_reason", r.fit.stop.as_str());
        self.count("convergence", r.fit.convergence());
        self.count(
            "rank",
            &r.fit
                .rank
                .map_or_else(|| "unknown".to_string(), |k| format!("{k:03}")),
        );
        for rec in &r.recovery {
            let e = match self.recovery.get_mut(&*rec.name) {
                Some(e) => e,
                None => self.recovery.entry(rec.name.to_string()).or_default(),
            };
            if e.unit != rec.unit {
                e.unit = rec.unit.to_string();
            }
            e.error.push(rec.error);
            e.abs_error.push(rec.error.abs());
            e.z.push(rec.z);
            e.std_error.push(rec.std_error);
        }
        if let Some(o) = &r.observability {
            for (name, v) in [
                ("observability_o1", o.o1),
                ("observability_o2", o.o2),
                ("observability_o3", o.o3),
                ("observability_o4", o.o4),
                ("observability_o5", o.o5),
            ] {
                self.metric(name, v);
            }
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
            self.metric(
                "iso_compensation_failures",
                r.iso_compensation_failures as f64,
            );
        }
        if let Some(h) = &r.residual {
            self.metric("residual_used", f64::from(u8::from(h.used)));
            self.metric("residual_cv_mean_gain_mm", h.cv_mean_gain.mean_mm);
            self.metric("residual_cv_p95_gain_mm", h.cv_p95_gain.mean_mm);
            self.metric("geometry_after_mean_mm", h.geometry_after.mean_mm);
            self.metric("geometry_after_max_mm", h.geometry_after.max_mm);
            self.metric("geometry_after_p95_mm", h.geometry_after.p95_mm);
            if let Some(a) = &h.hybrid_after {
                self.metric("hybrid_after_mean_mm", a.mean_mm);
                self.metric("hybrid_after_max_mm", a.max_mm);
                self.metric("hybrid_after_p95_mm", a.p95_mm);
            }
            self.metric(
                "hybrid_compensation_failures",
                h.hybrid_compensation_failures as f64,
            );
            self.metric("residual_coverage_1sd", h.coverage_1sd);
            self.metric("residual_coverage_2sd", h.coverage_2sd);
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

    /// Checks an aggregate read from a file (a shard): every statistic well-formed (see
    /// [`Stat::check`]). The message names the statistic.
    pub fn check(&self) -> Result<(), String> {
        for (name, stat) in &self.metrics {
            stat.check().map_err(|e| format!("metric {name}: {e}"))?;
        }
        for (name, r) in &self.recovery {
            for (part, stat) in [
                ("error", &r.error),
                ("abs_error", &r.abs_error),
                ("z", &r.z),
                ("std_error", &r.std_error),
            ] {
                stat.check()
                    .map_err(|e| format!("recovery {name} {part}: {e}"))?;
            }
        }
        Ok(())
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

/// Runs the trials in `range` on the current rayon pool; `progress(1)` is called after
/// each finished trial. [`run_range_until`] without a stop.
pub fn run_range(ctx: &Context, range: Range<u64>, progress: &(dyn Fn(u64) + Sync)) -> Aggregate {
    run_range_until(ctx, range, progress, &|| false).unwrap_or_default()
}

/// Runs the trials in `range` on the current rayon pool; `progress(1)` is called after
/// each finished trial, and `stop()` before each trial: once it is true no further trial
/// starts (those in progress finish) and the result is `None`.
///
/// Each worker thread folds the trials it runs into its own [`Aggregate`] (a slot indexed by
/// its pool index, locked only by that thread), and the slots are merged at the end: memory
/// is one aggregate per thread whatever the trial count, and since every part of an
/// aggregate merges exactly and order-free, which thread ran which trial does not matter.
pub fn run_range_until(
    ctx: &Context,
    range: Range<u64>,
    progress: &(dyn Fn(u64) + Sync),
    stop: &(dyn Fn() -> bool + Sync),
) -> Option<Aggregate> {
    let slots: Vec<Mutex<Aggregate>> = (0..rayon::current_num_threads().max(1))
        .map(|_| Mutex::new(Aggregate::default()))
        .collect();
    let stopped = std::sync::atomic::AtomicBool::new(false);
    range.into_par_iter().for_each(|t| {
        if stopped.load(std::sync::atomic::Ordering::Relaxed) || stop() {
            stopped.store(true, std::sync::atomic::Ordering::Relaxed);
            return;
        }
        let result = run_trial(ctx, t);
        let slot = rayon::current_thread_index().unwrap_or(0) % slots.len();
        // A panic elsewhere cannot leave a slot half-updated in a way that matters: the
        // panic propagates out of `for_each` and the slots are dropped.
        let mut agg = slots[slot].lock().unwrap_or_else(|e| e.into_inner());
        match result {
            Ok(r) => {
                agg.add(&r);
                // Its series back to the thread for its next trial.
                r.recycle();
            }
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
        drop(agg);
        progress(1);
    });
    if stopped.into_inner() {
        return None;
    }
    // Merge into the first slot rather than a fresh aggregate: one aggregate fewer at the
    // peak.
    let mut slots = slots
        .into_iter()
        .map(|s| s.into_inner().unwrap_or_else(|e| e.into_inner()));
    let mut total = slots.next().unwrap_or_default();
    for slot in slots {
        total.merge(&slot);
    }
    Some(total)
}
