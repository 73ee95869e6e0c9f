//! Sweeps: the cross product of a scenario's axes, each point a full campaign.
//!
//! ```json
//! {
//!   "name": "pose-count",
//!   "scenario": "paper-kr1000.json",
//!   "trials": 100,
//!   "overrides": { "iso.enabled": false },
//!   "axes": [
//!     { "path": "poses.identification", "values": [10, 12, 15, 20, 30, 50, 100] },
//!     { "path": "identification.lm.damping", "label": "schedule",
//!       "values": [{ "kind": "levenberg" }, { "kind": "nielsen" }] }
//!   ],
//!   "plot": { "x": "poses.identification", "y": "after_mean_mm", "log_y": true }
//! }
//! ```
//! Paths are dotted field paths into the scenario JSON; values are any JSON. The first axis
//! is the plot's x unless `plot.x` says otherwise; every combination of the other axes is a
//! curve.

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use crate::error::CampaignError;
use crate::error::{FieldPathError, SweepPlotError};
use crate::outputs::summary::CampaignSummary;
use crate::run::aggregate::Summary;
use crate::run::checkpoint::{
    CHECKPOINT_FORMAT, Checkpoint, CheckpointConfig, CheckpointManifest, read_if_exists, run_chunks,
};
use crate::run::range::{Aggregate, run_range};
use crate::scenario::Scenario;
use crate::trial::Context;

/// One axis of a sweep.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Axis {
    /// Dotted path of the scenario field, e.g. `poses.identification`.
    pub path: String,
    /// Short name for tables and legends [the path].
    #[serde(default)]
    pub label: Option<String>,
    /// The values, any JSON.
    pub values: Vec<serde_json::Value>,
}

impl Axis {
    /// Label for tables.
    pub fn label(&self) -> &str {
        self.label.as_deref().unwrap_or(&self.path)
    }
}

/// What to plot.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PlotSpec {
    /// Path of the x axis (must be one of the axes, with numeric values) [the first axis].
    #[serde(default)]
    pub x: Option<String>,
    /// Metric on y (a `summary.json` metric; its mean over trials) \[after_mean_mm\].
    #[serde(default = "default_y")]
    pub y: String,
    /// Logarithmic y axis [false].
    #[serde(default)]
    pub log_y: bool,
}

fn default_y() -> String {
    "after_mean_mm".into()
}

/// A sweep file.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SweepSpec {
    /// Name; results go to `results/<name>/`.
    pub name: String,
    /// One paragraph: what the sweep shows.
    #[serde(default)]
    pub description: String,
    /// Base scenario, relative to the sweep file.
    pub scenario: PathBuf,
    /// Trials per point (overrides the scenario's).
    pub trials: u64,
    /// Fields set on the base scenario before the axes (dotted path → value).
    #[serde(default)]
    pub overrides: serde_json::Map<String, serde_json::Value>,
    /// The axes.
    pub axes: Vec<Axis>,
    /// Plots (one SVG each).
    #[serde(default)]
    pub plots: Vec<PlotSpec>,
}

/// A named curve: (label, points (x, y)).
pub type Curve = (String, Vec<(f64, f64)>);

/// One point of the sweep.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SweepPoint {
    /// The axis values at this point, in axis order.
    pub values: Vec<serde_json::Value>,
    /// Trials attempted and failed (e.g. too few poses for the free parameters).
    pub trials: u64,
    /// Failed trials.
    pub failed: u64,
    /// Causes of failure.
    pub failures: Vec<String>,
    /// Metric summaries over successful trials.
    pub metrics: std::collections::BTreeMap<String, Option<Summary>>,
    /// LM stop reasons.
    pub stop_reasons: std::collections::BTreeMap<String, u64>,
    /// Trials whose LM stopped on a small step or cost change short of the minimum
    /// ([`crate::trial::STALL_GRADIENT_COSINE`]).
    #[serde(default)]
    pub stalled: u64,
}

/// `sweep.json`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SweepResult {
    /// The sweep as run.
    pub spec: SweepSpec,
    /// Every point, the last axis varying fastest.
    pub points: Vec<SweepPoint>,
}

/// The scenario file at `path` as JSON with `overrides` (dotted path → value) and the trial
/// count set: the base of a sweep's points and of a check (`what` names which in errors).
pub(crate) fn scenario_json_with(
    path: &Path,
    overrides: &serde_json::Map<String, serde_json::Value>,
    trials: u64,
    what: &str,
) -> Result<serde_json::Value, CampaignError> {
    let text = std::fs::read_to_string(path).map_err(|source| CampaignError::Io {
        path: path.display().to_string(),
        source,
    })?;
    let mut v: serde_json::Value =
        serde_json::from_str(&text).map_err(|source| CampaignError::BaseScenarioJson {
            file: path.to_path_buf(),
            source,
        })?;
    if !v.is_object() {
        return Err(CampaignError::ScenarioNotAnObject {
            file: path.to_path_buf(),
        });
    }
    for (p, value) in overrides {
        set_path(&mut v, p, value.clone()).map_err(|source| CampaignError::Override {
            what: what.to_string(),
            path: p.clone(),
            source,
        })?;
    }
    v["trials"] = trials.into();
    Ok(v)
}

/// Sets the field at dotted `path` (`poses.identification`) of `root`, creating the objects
/// on the way that are missing.
fn set_path(
    root: &mut serde_json::Value,
    path: &str,
    value: serde_json::Value,
) -> Result<(), FieldPathError> {
    let parts: Vec<&str> = path.split('.').collect();
    let (last, init) = parts.split_last().expect("split gives at least one part");
    let mut cur = root;
    for (i, p) in init.iter().enumerate() {
        let obj = cur
            .as_object_mut()
            .ok_or_else(|| FieldPathError::NotAnObject {
                prefix: parts[..i].join("."),
            })?;
        cur = obj
            .entry((*p).to_string())
            .or_insert_with(|| serde_json::Value::Object(Default::default()));
    }
    let obj = cur
        .as_object_mut()
        .ok_or_else(|| FieldPathError::NotAnObject {
            prefix: init.join("."),
        })?;
    obj.insert((*last).to_string(), value);
    Ok(())
}

fn label_of(v: &serde_json::Value) -> String {
    match v {
        serde_json::Value::String(s) => s.clone(),
        serde_json::Value::Object(m) => m
            .iter()
            .map(|(k, v)| format!("{k}={}", label_of(v)))
            .collect::<Vec<_>>()
            .join(" "),
        other => other.to_string(),
    }
}

impl SweepSpec {
    /// Reads a sweep file.
    pub fn from_file(path: &Path) -> Result<SweepSpec, CampaignError> {
        let text = std::fs::read_to_string(path).map_err(|source| CampaignError::Io {
            path: path.display().to_string(),
            source,
        })?;
        let de = &mut serde_json::Deserializer::from_str(&text);
        let spec: SweepSpec =
            serde_path_to_error::deserialize(&mut *de).map_err(|e| CampaignError::Parse {
                file: path.display().to_string(),
                field: e.path().to_string(),
                message: e.into_inner().to_string(),
            })?;
        // Nothing but white space after the document.
        de.end().map_err(|e| CampaignError::Parse {
            file: path.display().to_string(),
            field: ".".to_string(),
            message: e.to_string(),
        })?;
        if spec.axes.is_empty() || spec.axes.iter().any(|a| a.values.is_empty()) {
            return Err(CampaignError::SweepWithoutAxes {
                file: path.to_path_buf(),
            });
        }
        if spec.trials == 0 {
            return Err(CampaignError::SweepWithoutTrials {
                file: path.to_path_buf(),
            });
        }
        Ok(spec)
    }

    /// Checks every setting before any point runs: each plot (`x` an axis with numeric
    /// values, `y` a metric of [`crate::run::range::METRICS`]) and each point's scenario (the base
    /// scenario with the overrides and the point's axis values, loaded and set up as a run
    /// would). `sweep_file`: the sweep file (named in errors; the base scenario is relative
    /// to its directory).
    pub fn validate(&self, sweep_file: &Path) -> Result<(), CampaignError> {
        let sweep_dir = sweep_file.parent().unwrap_or(Path::new("."));
        for (k, plot) in self.plots.iter().enumerate() {
            let err = |source: SweepPlotError| CampaignError::Parse {
                file: sweep_file.display().to_string(),
                field: format!("plots[{k}]"),
                message: source.to_string(),
            };
            let axis = match &plot.x {
                Some(x) => self
                    .axes
                    .iter()
                    .find(|a| &a.path == x)
                    .ok_or_else(|| err(SweepPlotError::NotAnAxis { x: x.clone() }))?,
                None => &self.axes[0],
            };
            if axis.values.iter().any(|v| !v.is_number()) {
                return Err(err(SweepPlotError::NotNumeric {
                    axis: axis.path.clone(),
                }));
            }
            if !crate::run::range::METRICS.contains(&plot.y.as_str()) {
                return Err(err(SweepPlotError::UnknownMetric {
                    y: plot.y.clone(),
                    known: crate::run::range::METRICS.join(", "),
                }));
            }
        }
        let scenario_path = sweep_dir.join(&self.scenario);
        let base = scenario_json_with(&scenario_path, &self.overrides, self.trials, "sweep")?;
        let scenario_dir = scenario_path.parent().unwrap_or(Path::new("."));
        for (i, combo) in self.combinations().iter().enumerate() {
            let mut v = base.clone();
            for (axis, value) in self.axes.iter().zip(combo) {
                set_path(&mut v, &axis.path, value.clone()).map_err(|source| {
                    CampaignError::SweepAxis {
                        axis: axis.path.clone(),
                        source,
                    }
                })?;
            }
            let label = format!("{} point {}", self.name, i);
            let loaded = Scenario::from_value(v, &label)?.load(scenario_dir, &label)?;
            Context::new(loaded)?;
        }
        Ok(())
    }

    /// The part of the sweep that decides the computed work (the base scenario, trials,
    /// overrides, axis paths and values): what a checkpoint must match to be resumed. Name,
    /// description, axis labels and plots only change how the results are shown.
    pub fn work(&self) -> serde_json::Value {
        serde_json::json!({
            "scenario": self.scenario,
            "trials": self.trials,
            "overrides": self.overrides,
            "axes": self.axes.iter().map(|a| (&a.path, &a.values)).collect::<Vec<_>>(),
        })
    }

    /// Every combination of axis values, last axis fastest.
    pub fn combinations(&self) -> Vec<Vec<serde_json::Value>> {
        let mut out: Vec<Vec<serde_json::Value>> = vec![vec![]];
        for axis in &self.axes {
            out = out
                .into_iter()
                .flat_map(|prefix| {
                    axis.values.iter().map(move |v| {
                        let mut p = prefix.clone();
                        p.push(v.clone());
                        p
                    })
                })
                .collect();
        }
        out
    }
}

/// Runs every point of the sweep (`sweep_dir` resolves the scenario path); `progress(i, n)`
/// is called before point i of n.
pub fn run_sweep(
    spec: &SweepSpec,
    sweep_dir: &Path,
    progress: &dyn Fn(usize, usize),
) -> Result<SweepResult, CampaignError> {
    run_sweep_checkpointed(spec, sweep_dir, None, progress)
}

/// A sweep's checkpoint: the finished points and the current point's progress.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SweepCheckpoint {
    /// Checkpoint format ([`crate::run::checkpoint::CHECKPOINT_FORMAT`]).
    pub format: u32,
    /// The sweep as run (trial count included).
    pub spec: SweepSpec,
    /// Code version ([`code_version`](crate::code_version)).
    pub code: String,
    /// The finished points, in order.
    pub points: Vec<SweepPoint>,
    /// The next point's progress, if it had started.
    pub current: Option<Checkpoint>,
}

impl SweepCheckpoint {
    fn read(path: &Path) -> Result<Option<SweepCheckpoint>, CampaignError> {
        let Some(text) = read_if_exists(path)? else {
            return Ok(None);
        };
        serde_json::from_slice(&text).map(Some).map_err(|source| {
            CampaignError::NotASweepCheckpoint {
                path: path.display().to_string(),
                source,
            }
        })
    }
}

/// [`run_sweep`] with checkpoints (see [`Checkpoint`](crate::Checkpoint)): with `cfg`, the finished
/// points and the current point's aggregate are saved to `cfg.path` as the trials run, and
/// with `cfg.resume` an interrupted sweep continues where it stopped. The caller writes the
/// outputs, then calls `finish` (`run/checkpoint.rs`) with their names.
pub fn run_sweep_checkpointed(
    spec: &SweepSpec,
    sweep_dir: &Path,
    cfg: Option<&CheckpointConfig>,
    progress: &dyn Fn(usize, usize),
) -> Result<SweepResult, CampaignError> {
    let scenario_path = sweep_dir.join(&spec.scenario);
    let base = scenario_json_with(&scenario_path, &spec.overrides, spec.trials, "sweep")?;
    let scenario_dir = scenario_path.parent().unwrap_or(Path::new("."));
    let combos = spec.combinations();
    let mut state = SweepCheckpoint {
        format: CHECKPOINT_FORMAT,
        spec: spec.clone(),
        code: cfg.map(|c| c.code.clone()).unwrap_or_default(),
        points: Vec::with_capacity(combos.len()),
        current: None,
    };
    if let Some(cfg) = cfg {
        if !cfg.resume && cfg.path.exists() {
            return Err(CampaignError::UnfinishedCheckpoint {
                path: cfg.path.clone(),
                what: "sweep",
            });
        }
        if cfg.resume
            && let Some(saved) = SweepCheckpoint::read(&cfg.path)?
        {
            let mut diff = Vec::new();
            if saved.format != state.format {
                diff.push(format!("format {} vs {}", saved.format, state.format));
            }
            if saved.code != state.code {
                diff.push(format!(
                    "code version: checkpoint has {}, this run {}",
                    saved.code, state.code
                ));
            }
            if saved.spec.work() != state.spec.work() {
                diff.push("the sweep file (axes, trials, overrides or scenario)".into());
            }
            if saved.points.len() > combos.len() {
                diff.push(format!(
                    "{} points done of {}",
                    saved.points.len(),
                    combos.len()
                ));
            }
            if !diff.is_empty() {
                return Err(CampaignError::CheckpointMismatch {
                    path: cfg.path.clone(),
                    what: "sweep",
                    differences: diff,
                });
            }
            // Plots, labels, name and description may have changed: this run's count.
            state = SweepCheckpoint {
                spec: spec.clone(),
                ..saved
            };
        }
    }
    for (i, combo) in combos.iter().enumerate().skip(state.points.len()) {
        progress(i, combos.len());
        let mut v = base.clone();
        for (axis, value) in spec.axes.iter().zip(combo) {
            set_path(&mut v, &axis.path, value.clone()).map_err(|source| {
                CampaignError::SweepAxis {
                    axis: axis.path.clone(),
                    source,
                }
            })?;
        }
        let label = format!("{} point {}", spec.name, i);
        let loaded = Scenario::from_value(v, &label)?.load(scenario_dir, &label)?;
        let scenario = loaded.scenario.clone();
        let ctx = Context::new(loaded)?;
        let agg = match cfg {
            None => run_range(&ctx, 0..scenario.trials, &|_| {}),
            Some(cfg) => {
                // Not the sweep's name: renaming it changes only how the results are shown,
                // and must not block resuming the point in progress (`SweepSpec::work`).
                let manifest = CheckpointManifest::new(
                    &format!("sweep point {i}"),
                    &ctx,
                    0..scenario.trials,
                    &cfg.code,
                );
                let (next, agg) = match state.current.take() {
                    Some(c) => {
                        let diff = c.manifest.differences(&manifest);
                        if !diff.is_empty() {
                            return Err(CampaignError::SweepPointMismatch {
                                path: cfg.path.clone(),
                                point: i,
                                differences: diff,
                            });
                        }
                        c.aggregate.check().map_err(|problem| {
                            CampaignError::SweepPointAggregate {
                                path: cfg.path.clone(),
                                point: i,
                                problem,
                            }
                        })?;
                        (c.next_trial, c.aggregate)
                    }
                    None => (0, Aggregate::default()),
                };
                let mut save = |n: u64, a: &Aggregate| {
                    state.current = Some(Checkpoint {
                        manifest: manifest.clone(),
                        next_trial: n,
                        aggregate: a.clone(),
                        wall_seconds: 0.0,
                    });
                    write_sweep_checkpoint(&cfg.path, &state)
                };
                let agg = run_chunks(
                    &ctx,
                    next..scenario.trials,
                    agg,
                    cfg,
                    &|_| {},
                    &|| false,
                    &mut save,
                )?;
                state.current = None;
                agg
            }
        };
        state
            .points
            .push(SweepPoint::new(combo.clone(), &scenario, &agg));
        if let Some(cfg) = cfg
            && state.points.len() < combos.len()
        {
            write_sweep_checkpoint(&cfg.path, &state)?;
        }
    }
    Ok(SweepResult {
        spec: spec.clone(),
        points: state.points,
    })
}

fn write_sweep_checkpoint(path: &Path, state: &SweepCheckpoint) -> Result<(), CampaignError> {
    let text = serde_json::to_vec(state).map_err(|source| CampaignError::Serialise {
        path: path.display().to_string(),
        source,
    })?;
    measurements::write_atomically(path, &text).map_err(|source| CampaignError::Io {
        path: path.display().to_string(),
        source,
    })
}

impl SweepPoint {
    /// The point at axis values `values` from its campaign's aggregate.
    pub fn new(values: Vec<serde_json::Value>, scenario: &Scenario, agg: &Aggregate) -> SweepPoint {
        let s = CampaignSummary::new(scenario, agg);
        SweepPoint {
            values,
            trials: s.trials,
            failed: s.failed_trials.values().sum(),
            failures: s.failed_trials.keys().cloned().collect(),
            metrics: s.metrics.clone(),
            stop_reasons: s.counts.get("stop_reason").cloned().unwrap_or_default(),
            stalled: s
                .counts
                .get("convergence")
                .and_then(|c| c.get("stalled"))
                .copied()
                .unwrap_or(0),
        }
    }

    /// Trials whose LM stopped on a cap (iterations or rejections) or stalled short of the
    /// minimum instead of converging.
    pub fn not_converged(&self) -> u64 {
        self.stop_reasons
            .iter()
            .filter(|(k, _)| k.as_str() == "max_iterations" || k.as_str() == "too_many_rejections")
            .map(|(_, v)| v)
            .sum::<u64>()
            + self.stalled
    }
}

/// The residual model's columns of a sweep's table and CSV (scenario `residual_model`):
/// metric, Markdown header, decimals. Present only when a point recorded them, so that
/// sweeps without the model keep their bytes.
const RESIDUAL_COLUMNS: [(&str, &str, usize); 5] = [
    ("residual_used", "gate kept (share of trials)", 2),
    ("geometry_after_mean_mm", "geometry after (mm)", 3),
    ("hybrid_after_mean_mm", "hybrid after (mm)", 3),
    ("geometry_after_max_mm", "geometry after max (mm)", 3),
    ("hybrid_after_max_mm", "hybrid after max (mm)", 3),
];

impl SweepResult {
    fn metric_mean(p: &SweepPoint, key: &str) -> Option<f64> {
        p.metrics.get(key).and_then(|m| m.as_ref()).map(|m| m.mean)
    }

    /// The residual model's columns, when any point has them.
    fn residual_columns(&self) -> &'static [(&'static str, &'static str, usize)] {
        if self
            .points
            .iter()
            .any(|p| p.metrics.contains_key(RESIDUAL_COLUMNS[0].0))
        {
            &RESIDUAL_COLUMNS
        } else {
            &[]
        }
    }

    /// One CSV row per point: axis values, trials, failed, and the main metrics' means.
    pub fn to_csv(&self) -> String {
        let keys = [
            "before_mean_mm",
            "after_mean_mm",
            "after_max_mm",
            "improvement_pct",
            "predicted_error_mm",
            "lm_iterations",
            "compensation_failures",
        ];
        let extra = self.residual_columns();
        let mut o = String::new();
        let head: Vec<String> = self
            .spec
            .axes
            .iter()
            .map(|a| a.label().to_string())
            .chain(["trials", "failed", "not_converged"].map(String::from))
            .chain(keys.iter().map(|k| k.to_string()))
            .chain(extra.iter().map(|(k, _, _)| k.to_string()))
            .collect();
        o.push_str(&head.join(","));
        o.push('\n');
        for p in &self.points {
            let not_conv = p.not_converged();
            let mut row: Vec<String> = p
                .values
                .iter()
                .map(|v| format!("\"{}\"", label_of(v).replace('"', "'")))
                .collect();
            row.push(p.trials.to_string());
            row.push(p.failed.to_string());
            row.push(not_conv.to_string());
            for k in keys.iter().chain(extra.iter().map(|(k, _, _)| k)) {
                row.push(Self::metric_mean(p, k).map_or_else(String::new, |v| format!("{v:.6}")));
            }
            o.push_str(&row.join(","));
            o.push('\n');
        }
        o
    }

    /// The Markdown table.
    pub fn to_markdown(&self) -> String {
        let mut o = format!("# Sweep `{}`\n\n", self.spec.name);
        if !self.spec.description.is_empty() {
            o.push_str(self.spec.description.trim());
            o.push_str("\n\n");
        }
        o.push_str(&format!(
            "Base scenario `{}`, {} trials per point. Means over successful trials.\n\n",
            self.spec.scenario.display(),
            self.spec.trials
        ));
        let labels: Vec<&str> = self.spec.axes.iter().map(|a| a.label()).collect();
        let extra = self.residual_columns();
        let extra_head: String = extra.iter().map(|(_, h, _)| format!(" {h} |")).collect();
        o.push_str(&format!(
            "| {} | failed | not converged | before (mm) | after (mm) | after max (mm) | improvement (%) | LM iterations |{extra_head}\n",
            labels.join(" | ")
        ));
        // Axis values left-aligned, figures right-aligned.
        o.push_str(&format!(
            "|{}{}\n",
            "---|".repeat(labels.len()),
            "---:|".repeat(7 + extra.len())
        ));
        for p in &self.points {
            let vals: Vec<String> = p
                .values
                .iter()
                .map(|v| v.as_f64().map_or_else(|| label_of(v), report::fmt::number))
                .collect();
            let not_conv = p.not_converged();
            let f = |k: &str, d: usize| {
                Self::metric_mean(p, k).map_or("–".into(), |v| format!("{v:.d$}"))
            };
            let extra_cells: String = extra
                .iter()
                .map(|(k, _, d)| format!(" {} |", f(k, *d)))
                .collect();
            o.push_str(&format!(
                "| {} | {}/{} | {} | {} | {} | {} | {} | {} |{extra_cells}\n",
                vals.join(" | "),
                p.failed,
                p.trials,
                not_conv,
                f("before_mean_mm", 3),
                f("after_mean_mm", 3),
                f("after_max_mm", 3),
                f("improvement_pct", 1),
                f("lm_iterations", 2),
            ));
        }
        o
    }

    /// The index of `plot`'s x axis among the sweep's axes (the first axis when the plot
    /// names none).
    pub fn x_axis(&self, plot: &PlotSpec) -> Result<usize, SweepPlotError> {
        match &plot.x {
            Some(x) => self
                .spec
                .axes
                .iter()
                .position(|a| &a.path == x)
                .ok_or_else(|| SweepPlotError::NotAnAxis { x: x.clone() }),
            None => Ok(0),
        }
    }

    /// Curves of `plot.y` against `plot.x`, one per combination of the other axes. Points
    /// without a value (every trial failed) are left out of the curve.
    pub fn curves(&self, plot: &PlotSpec) -> Result<Vec<Curve>, SweepPlotError> {
        let xi = self.x_axis(plot)?;
        let mut series: Vec<Curve> = Vec::new();
        for p in &self.points {
            let Some(x) = p.values[xi].as_f64() else {
                return Err(SweepPlotError::NotNumeric {
                    axis: self.spec.axes[xi].path.clone(),
                });
            };
            let name: Vec<String> = self
                .spec
                .axes
                .iter()
                .zip(&p.values)
                .enumerate()
                .filter(|(i, _)| *i != xi)
                .map(|(_, (a, v))| format!("{} {}", a.label(), label_of(v)))
                .collect();
            let name = if name.is_empty() {
                plot.y.clone()
            } else {
                name.join(", ")
            };
            let entry = match series.iter_mut().find(|(n, _)| *n == name) {
                Some(e) => e,
                None => {
                    series.push((name, Vec::new()));
                    series.last_mut().expect("just pushed")
                }
            };
            if let Some(y) = Self::metric_mean(p, &plot.y)
                && (!plot.log_y || y > 0.0)
            {
                entry.1.push((x, y));
            }
        }
        series.retain(|(_, pts)| !pts.is_empty());
        Ok(series)
    }
}
