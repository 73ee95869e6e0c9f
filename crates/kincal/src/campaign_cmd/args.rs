//! The arguments of `kincal campaign | merge | simulate | sweep` (clap): `--help` text,
//! printed verbatim.

use std::path::PathBuf;

/// Arguments of `campaign`.
#[allow(rustdoc::broken_intra_doc_links, rustdoc::invalid_html_tags)] // clap help text
#[derive(clap::Args)]
#[command(after_help = "Examples:
  kincal campaign scenarios/paper-kr1000.json --out my-run     # the paper's experiment, 200 trials
  kincal campaign scenarios/paper-kr1000.json --trials 100000 --shard 3/32 --out shards/
  Outputs: summary.json, summary.md, trial-0.md, plots; timing.json (wall clock, not committed).")]
pub struct CampaignArgs {
    /// Scenario file (JSON), e.g. scenarios/paper-kr1000.json.
    pub scenario: PathBuf,
    /// Override the scenario's trial count.
    #[arg(long)]
    pub trials: Option<u64>,
    /// Worker threads [all cores; at least 1]. Results do not depend on it.
    #[arg(long)]
    pub threads: Option<usize>,
    /// Output directory [results/<scenario name> for the scenario as committed; with
    /// --trials, --no-iso, --no-budget or --shard: runs/<scenario name>-<settings>].
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Run one shard `k/K` (0-based k) and write `shard-k-of-K.json` for `merge`.
    #[arg(long)]
    pub shard: Option<String>,
    /// Do not print the summary table.
    #[arg(long)]
    pub quiet: bool,
    /// Switch the scenario's ISO 9283 test off (e.g. to time the trials alone).
    #[arg(long)]
    pub no_iso: bool,
    /// Switch the scenario's residual budget off (its reruns of the first trials with each
    /// error source outside the model off in turn; `residual_budget` in the scenario).
    #[arg(long)]
    pub no_budget: bool,
    /// `--resume`, `--checkpoint-every`.
    #[command(flatten)]
    pub checkpoint: CheckpointArgs,
}

/// Arguments of `merge`.
#[allow(rustdoc::broken_intra_doc_links, rustdoc::invalid_html_tags)] // clap help text
#[derive(clap::Args)]
#[command(after_help = "Example:
  kincal merge shards/shard-*-of-32.json --out paper-1e6")]
pub struct MergeArgs {
    /// Shard files written by `campaign --shard`.
    #[arg(required = true)]
    pub shards: Vec<PathBuf>,
    /// Output directory [runs/<scenario name>-merged: shards may be of any trial count, so
    /// results/ is written only when named].
    #[arg(long)]
    pub out: Option<PathBuf>,
}

/// Arguments of `simulate`.
#[allow(rustdoc::broken_intra_doc_links, rustdoc::invalid_html_tags)] // clap help text
#[derive(clap::Args)]
#[command(after_help = "Example:
  kincal simulate scenarios/paper-kr1000.json --out sim   # sim/identification.csv, validation.csv, truth.json")]
pub struct SimulateArgs {
    /// Scenario file (JSON).
    pub scenario: PathBuf,
    /// Output directory for identification.csv, validation.csv, truth.json.
    #[arg(long)]
    pub out: PathBuf,
    /// Trial index whose truth, poses and noise are drawn [0].
    #[arg(long, default_value_t = 0)]
    pub trial: u64,
}

/// Arguments of `sweep`.
#[allow(rustdoc::broken_intra_doc_links, rustdoc::invalid_html_tags)] // clap help text
#[derive(clap::Args)]
#[command(after_help = "Example:
  kincal sweep scenarios/sweeps/pose-count.json --trials 50 --out my-sweep")]
pub struct SweepArgs {
    /// Sweep file (JSON), e.g. scenarios/sweeps/pose-count.json.
    pub sweep: PathBuf,
    /// Override the trials per point.
    #[arg(long)]
    pub trials: Option<u64>,
    /// Worker threads [all cores; at least 1].
    #[arg(long)]
    pub threads: Option<usize>,
    /// Output directory [results/<sweep name> for the sweep as committed; with --trials:
    /// runs/<sweep name>-trials-N].
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// `--resume`, `--checkpoint-every`.
    #[command(flatten)]
    pub checkpoint: CheckpointArgs,
}

/// The checkpoint options of `campaign` and `sweep`.
#[allow(rustdoc::broken_intra_doc_links, rustdoc::invalid_html_tags)] // clap help text
#[derive(clap::Args)]
pub struct CheckpointArgs {
    /// Continue an interrupted run from the checkpoint in the output directory (a fresh
    /// start if there is none; refused if it belongs to another run, saying what differs).
    #[arg(long)]
    pub resume: bool,
    /// Checkpoint every N trials (default: every 10 s, in chunks of 64 trials per thread).
    #[arg(long, value_name = "N")]
    pub checkpoint_every: Option<u64>,
}
