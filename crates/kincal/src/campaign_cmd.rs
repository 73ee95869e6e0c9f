//! `kincal campaign | merge | simulate | sweep`: thin wrappers over the campaign crate.

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Instant;

use anyhow::{Context as _, Result, bail};
use campaign::{
    Aggregate, CampaignSummary, Context, Scenario, ShardFile, ShardManifest, merge_shards,
    run_range, shard_range, write_outputs,
};
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};

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
    /// Worker threads [all cores]. Results do not depend on it.
    #[arg(long)]
    pub threads: Option<usize>,
    /// Output directory [results/<scenario name>].
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
    /// Continue an interrupted run from the checkpoint in the output directory (a fresh
    /// start if there is none; refused if it belongs to another run, saying what differs).
    #[arg(long)]
    pub resume: bool,
    /// Checkpoint every N trials (default: every 10 s, in chunks of 64 trials per thread).
    #[arg(long, value_name = "N")]
    pub checkpoint_every: Option<u64>,
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
    /// Output directory [results/<scenario name>].
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

fn parse_shard(s: &str) -> Result<(u64, u64)> {
    let (k, n) = s
        .split_once('/')
        .with_context(|| format!("--shard {s:?}: expected k/K, e.g. 0/4"))?;
    let k: u64 = k
        .trim()
        .parse()
        .with_context(|| format!("--shard {s:?}: k"))?;
    let n: u64 = n
        .trim()
        .parse()
        .with_context(|| format!("--shard {s:?}: K"))?;
    if n == 0 || k >= n {
        bail!("--shard {s:?}: need 0 <= k < K");
    }
    Ok((k, n))
}

fn progress_bar(total: u64) -> ProgressBar {
    let pb = ProgressBar::with_draw_target(Some(total), ProgressDrawTarget::stderr());
    if std::env::var_os("CI").is_some() {
        pb.set_draw_target(ProgressDrawTarget::hidden());
    }
    pb.set_style(
        ProgressStyle::with_template(
            "{bar:40} {pos}/{len} trials  {trials_per_sec}/s  ETA {eta}  {elapsed_precise}",
        )
        .expect("valid template")
        // A whole number of trials per second, thousands separated (not indicatif's
        // `1,834.4204/s`).
        .with_key(
            "trials_per_sec",
            |state: &indicatif::ProgressState, w: &mut dyn std::fmt::Write| {
                let _ = w.write_str(&report::fmt::rate(state.per_sec()));
            },
        ),
    );
    pb
}

/// The `progress(k)` callback of a run: counts finished trials and moves `pb` every 16.
fn ticker(pb: &ProgressBar) -> impl Fn(u64) + Sync + '_ {
    let done = AtomicU64::new(0);
    move |k| {
        let d = done.fetch_add(k, Ordering::Relaxed) + k;
        if d.is_multiple_of(16) {
            pb.set_position(d);
        }
    }
}

fn default_out(name: &str) -> PathBuf {
    Path::new("results").join(name)
}

fn write_timing(dir: &Path, trials: u64, threads: usize, seconds: f64) -> Result<()> {
    let cpu = crate::cpu_model_name().unwrap_or_default();
    let timing = serde_json::json!({
        "trials": trials,
        "threads": threads,
        "wall_seconds": seconds,
        "trials_per_second": trials as f64 / seconds.max(1e-12),
        "ms_per_trial_per_thread": seconds * 1e3 * threads as f64 / trials.max(1) as f64,
        "cpu": cpu,
    });
    let path = dir.join("timing.json");
    measurements::write_atomically(&path, format!("{timing:#}\n").as_bytes())
        .with_context(|| format!("writing {}", path.display()))
}

/// `kincal campaign`.
pub fn campaign(args: CampaignArgs) -> Result<()> {
    run_campaign(
        &args.scenario,
        args.trials,
        args.threads,
        args.out,
        args.shard.as_deref(),
        args.quiet,
        args.no_iso,
        args.no_budget,
        Some(Checkpointing {
            resume: args.resume,
            every: args.checkpoint_every,
        }),
    )
}

/// `--resume` and `--checkpoint-every`.
#[derive(Clone, Copy)]
pub struct Checkpointing {
    /// Continue from the checkpoint in the output directory.
    pub resume: bool,
    /// Checkpoint every N trials (`None`: by time).
    pub every: Option<u64>,
}

impl Checkpointing {
    /// The library's configuration for the checkpoint at `path` (on the current pool).
    fn config(self, path: PathBuf) -> Result<campaign::CheckpointConfig> {
        let mut cfg = campaign::CheckpointConfig::new(path, self.resume, campaign::code_version());
        if let Some(k) = self.every {
            if k == 0 {
                bail!("--checkpoint-every must be at least 1");
            }
            cfg.every_trials = k;
        }
        Ok(cfg)
    }
}

fn threads_or_all(threads: Option<usize>) -> usize {
    threads.unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()))
}

/// Creates the output directory `--out` (and its parents); a file of that name is refused
/// with the option named, not as a bare "File exists".
fn create_out_dir(out: &Path) -> Result<()> {
    if out.exists() && !out.is_dir() {
        bail!(
            "--out {}: a file of that name exists; --out names a directory",
            out.display()
        );
    }
    std::fs::create_dir_all(out)
        .with_context(|| format!("--out {}: creating the directory", out.display()))
}

/// Runs a campaign (or one shard of it) and writes its outputs; returns the output directory.
#[allow(clippy::too_many_arguments)] // one argument per command-line option
pub fn run_campaign(
    scenario_path: &Path,
    trials: Option<u64>,
    threads: Option<usize>,
    out: Option<PathBuf>,
    shard: Option<&str>,
    quiet: bool,
    no_iso: bool,
    no_budget: bool,
    checkpointing: Option<Checkpointing>,
) -> Result<()> {
    let mut loaded = Scenario::from_file(scenario_path)
        .with_context(|| format!("loading scenario {}", scenario_path.display()))?;
    if no_iso {
        loaded.scenario.iso.enabled = false;
    }
    if no_budget {
        loaded.scenario.residual_budget.enabled = false;
    }
    if let Some(t) = trials {
        if t == 0 {
            bail!("--trials must be at least 1");
        }
        loaded.scenario.trials = t;
    }
    let scenario = loaded.scenario.clone();
    let out = out.unwrap_or_else(|| default_out(&scenario.name));
    let threads = threads_or_all(threads);
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .context("building the thread pool")?;
    let (range, shard) = match shard {
        Some(s) => {
            let (k, n) = parse_shard(s)?;
            (shard_range(scenario.trials, k, n), Some((k, n)))
        }
        None => (0..scenario.trials, None),
    };
    let started = Instant::now();
    let ctx = Context::new(loaded).context("preparing the campaign")?;
    let pb = progress_bar(range.end - range.start);
    create_out_dir(&out)?;
    let checkpoint = match (checkpointing, shard) {
        (None, _) => None,
        (Some(c), Some((k, n))) => {
            Some(c.config(out.join(format!("shard-{k}-of-{n}.checkpoint.json")))?)
        }
        (Some(c), None) => Some(c.config(out.join("checkpoint.json"))?),
    };
    if let Some(cfg) = checkpoint.as_ref().filter(|c| c.resume)
        && let Ok(Some(c)) = campaign::Checkpoint::read(&cfg.path)
    {
        eprintln!(
            "resuming from {}: trials {}..{} of {}..{} done",
            cfg.path.display(),
            c.manifest.first_trial,
            c.next_trial,
            c.manifest.first_trial,
            c.manifest.end_trial
        );
    }
    let what = match shard {
        Some((k, n)) => format!("shard {k}/{n}"),
        None => "campaign".to_string(),
    };
    let progress = ticker(&pb);
    let agg: Aggregate = pool.install(|| -> Result<Aggregate> {
        Ok(match &checkpoint {
            None => run_range(&ctx, range.clone(), &progress),
            Some(cfg) => {
                campaign::run_range_checkpointed(&ctx, &what, range.clone(), cfg, &progress)?
            }
        })
    })?;
    pb.finish_and_clear();
    // The residual budget reruns trials 0..budget trials: a single run or shard 0 does it.
    let budget = if shard.is_none_or(|(k, _)| k == 0) {
        let runs = campaign::budget::budget_runs(&scenario);
        let pb = progress_bar(runs * campaign::budget::budget_trials(&scenario));
        let progress = ticker(&pb);
        let b = pool
            .install(|| campaign::residual_budget(&ctx.loaded, &progress))
            .context("computing the residual budget")?;
        pb.finish_and_clear();
        b
    } else {
        None
    };
    let seconds = started.elapsed().as_secs_f64();
    let finish = |outputs: &[String]| -> Result<()> {
        if let Some(cfg) = &checkpoint {
            campaign::checkpoint::finish(&cfg.path, outputs)?;
        }
        Ok(())
    };
    if let Some((k, n)) = shard {
        let file = ShardFile {
            manifest: ShardManifest {
                scenario,
                version: env!("CARGO_PKG_VERSION").into(),
                shard: k,
                shards: n,
                first_trial: range.start,
                end_trial: range.end,
            },
            aggregate: agg,
            residual_budget: budget,
        };
        let path = out.join(format!("shard-{k}-of-{n}.json"));
        let text = serde_json::to_string(&file).context("serialising the shard")?;
        measurements::write_atomically(&path, text.as_bytes())
            .with_context(|| format!("writing {}", path.display()))?;
        finish(&[format!("shard-{k}-of-{n}.json")])?;
        eprintln!(
            "shard {k}/{n}: trials {}..{} in {seconds:.2} s → {}",
            range.start,
            range.end,
            path.display()
        );
        return Ok(());
    }
    let summary = CampaignSummary::new(&scenario, &agg).with_budget(budget);
    write_outputs(&out, &summary, &agg).with_context(|| format!("writing {}", out.display()))?;
    write_timing(&out, scenario.trials, threads, seconds)?;
    finish(&visible_files(&out))?;
    if !quiet {
        println!("{}", summary.to_markdown());
    }
    eprintln!(
        "{} trials in {seconds:.2} s on {threads} thread(s) → {}",
        scenario.trials,
        out.display()
    );
    Ok(())
}

/// The names of the files in `dir` that are not hidden (the outputs just written).
fn visible_files(dir: &Path) -> Vec<String> {
    std::fs::read_dir(dir)
        .map(|d| {
            d.flatten()
                .map(|e| e.file_name().to_string_lossy().into_owned())
                .filter(|n| !n.starts_with('.'))
                .collect()
        })
        .unwrap_or_default()
}

/// `kincal merge`.
pub fn merge(args: MergeArgs) -> Result<()> {
    let files = args
        .shards
        .iter()
        .map(|p| Ok(ShardFile::from_file(p)?))
        .collect::<Result<Vec<_>>>()?;
    let (scenario, agg) = merge_shards(&files).context("merging shards")?;
    let budget = campaign::shard_budget(&files);
    let out = args.out.unwrap_or_else(|| default_out(&scenario.name));
    let summary = CampaignSummary::new(&scenario, &agg).with_budget(budget);
    write_outputs(&out, &summary, &agg).with_context(|| format!("writing {}", out.display()))?;
    println!("{}", summary.to_markdown());
    eprintln!("merged {} shards → {}", files.len(), out.display());
    Ok(())
}

/// `kincal simulate`.
pub fn simulate(args: SimulateArgs) -> Result<()> {
    let loaded = Scenario::from_file(&args.scenario)
        .with_context(|| format!("loading scenario {}", args.scenario.display()))?;
    let sim = virtual_robot::simulate(
        &loaded.nominal,
        &loaded.virtual_robot(),
        loaded.scenario.seed,
        args.trial,
    )
    .context("simulating")?;
    create_out_dir(&args.out)?;
    sim.write(&args.out)
        .with_context(|| format!("writing into {}", args.out.display()))?;
    let t = sim.truth.sampling.total();
    eprintln!(
        "{} identification and {} validation measurements, truth → {}\n\
         pose sampling: {} candidate draws, {} rejected ({:.1} %: wrist {}, floor {}, \
         elevation {}, range {}, condition {})",
        sim.identification.rows.len(),
        sim.validation.rows.len(),
        args.out.display(),
        t.draws,
        t.rejected(),
        100.0 * t.rejection_rate(),
        t.rejected_wrist,
        t.rejected_floor,
        t.rejected_elevation,
        t.rejected_range,
        t.rejected_condition,
    );
    Ok(())
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
    /// Worker threads [all cores].
    #[arg(long)]
    pub threads: Option<usize>,
    /// Output directory [results/<sweep name>].
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Continue an interrupted run from the checkpoint in the output directory (a fresh
    /// start if there is none; refused if it belongs to another run, saying what differs).
    #[arg(long)]
    pub resume: bool,
    /// Checkpoint every N trials (default: every 10 s, in chunks of 64 trials per thread).
    #[arg(long, value_name = "N")]
    pub checkpoint_every: Option<u64>,
}

/// `kincal sweep`.
pub fn sweep(args: SweepArgs) -> Result<()> {
    run_sweep_to(
        &args.sweep,
        args.trials,
        args.threads,
        args.out,
        false,
        Some(Checkpointing {
            resume: args.resume,
            every: args.checkpoint_every,
        }),
    )
}

pub fn run_sweep_to(
    sweep_path: &Path,
    trials: Option<u64>,
    threads: Option<usize>,
    out: Option<PathBuf>,
    quiet: bool,
    checkpointing: Option<Checkpointing>,
) -> Result<()> {
    let mut spec = campaign::SweepSpec::from_file(sweep_path)
        .with_context(|| format!("loading sweep {}", sweep_path.display()))?;
    if let Some(t) = trials {
        if t == 0 {
            bail!("--trials must be at least 1");
        }
        spec.trials = t;
    }
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads_or_all(threads))
        .build()
        .context("building the thread pool")?;
    let dir = sweep_path.parent().unwrap_or(Path::new("."));
    let started = Instant::now();
    let out = out.unwrap_or_else(|| default_out(&spec.name));
    create_out_dir(&out)?;
    let result = pool.install(|| -> Result<campaign::SweepResult> {
        let checkpoint = checkpointing
            .map(|c| c.config(out.join("sweep-checkpoint.json")))
            .transpose()?;
        Ok(campaign::run_sweep_checkpointed(
            &spec,
            dir,
            checkpoint.as_ref(),
            &|i, n| {
                if !quiet {
                    eprintln!("point {}/{n}", i + 1)
                }
            },
        )?)
    })?;
    let mut json = serde_json::to_string_pretty(&result).context("serialising the sweep")?;
    json.push('\n');
    let mut files: Vec<(String, Vec<u8>)> = vec![
        ("sweep.json".into(), json.into_bytes()),
        ("sweep.csv".into(), result.to_csv().into_bytes()),
        ("sweep.md".into(), result.to_markdown().into_bytes()),
    ];
    files.extend(campaign::plots::sweep_outputs(&result).map_err(anyhow::Error::msg)?);
    // All or nothing: on a full disk no output of an earlier run is replaced.
    measurements::write_all_atomically(&out, &files)
        .with_context(|| format!("writing the sweep into {}", out.display()))?;
    if checkpointing.is_some() {
        campaign::checkpoint::finish(&out.join("sweep-checkpoint.json"), &visible_files(&out))?;
    }
    if !quiet {
        println!("{}", result.to_markdown());
    }
    eprintln!(
        "{}: {} points × {} trials in {:.1} s → {}",
        spec.name,
        result.points.len(),
        spec.trials,
        started.elapsed().as_secs_f64(),
        out.display()
    );
    Ok(())
}
