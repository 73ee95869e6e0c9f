//! `cargo xtask timings`: measures the times and sizes the docs state, on the scenario as
//! committed, and writes them with the machine into `docs/timings.md`. README.md and
//! docs/scale.md cite that file; nothing there is measured by hand.
//!
//! - The first command (`kincal campaign scenarios/paper-kr1000.json`, 200 trials with the
//!   ISO test and the residual budget), the same without the budget, and the trial rate of a
//!   longer run, from which the time of 10⁶ trials is extrapolated (stated as such).
//! - Trials and threads without the ISO test (docs/performance.md): 10³ and 10⁴ trials on
//!   one and two threads, 2·10⁴ on two, with their peak memory; 10⁵ and 10⁶ extrapolated.
//! - Poses per trial: one trial on one thread with a few identification pose counts (the
//!   largest well below the limit of 10⁶, to keep the run short); time and memory per pose
//!   are the slopes between the two largest, and 10⁶ poses are extrapolated from them.
//! - A measurement file of 10⁶ rows (the UR10 recording repeated) through `identify --every
//!   1000` and `predict`: wall time, peak memory, the size of `report.html`.
//! - A campaign of 10¹² trials, stopped after a few seconds: its peak memory (the aggregate
//!   is streamed, so it does not grow with the trial count).
//!
//! Each command is a child process of the given `kincal` binary, timed from spawn to exit;
//! its peak memory is the child's maximum resident set size (`wait4`'s `ru_maxrss`). Linux
//! counts in it the memory of the process it was spawned from (the child starts as a copy
//! of, or sharing, this one), so this process keeps its own peak small (a few MB, stated).

mod inputs;
mod page;
mod process;
mod runs;
mod units;

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{Context as _, Result, bail};

/// Arguments of `timings`.
#[derive(clap::Args)]
pub struct TimingsArgs {
    /// The `kincal` binary to time [target/release/kincal]. Build it first
    /// (`cargo build --release -p kincal`).
    #[arg(long, default_value = "target/release/kincal")]
    pub kincal: PathBuf,
    /// Trials of the run that measures the trial rate (ISO test on, budget off).
    #[arg(long, default_value_t = 2000)]
    pub trials: u64,
    /// Repetitions of the first command (the median is reported).
    #[arg(long, default_value_t = 3)]
    pub repeat: usize,
    /// Identification pose counts of the one-trial runs, comma-separated, increasing [2000,
    /// 20000, 200000: the largest takes seconds and about 0.6 GB, a fifth of the limit]; the
    /// per-pose slopes come from the last two.
    #[arg(long, value_delimiter = ',', default_value = "2000,20000,200000")]
    pub poses: Vec<u64>,
    /// Rows of the large measurement file [10⁶, the largest file the docs speak of].
    #[arg(long, default_value_t = 1_000_000)]
    pub rows: u64,
    /// Largest trial count of the runs without the ISO test (on two threads; 10³ and 10⁴
    /// also run on one) [20,000: about 3 s on an idle 2-core machine; 10⁵ and 10⁶ are
    /// extrapolated from it].
    #[arg(long, default_value_t = 20_000)]
    pub no_iso_trials: u64,
    /// Seconds the 10¹²-trial campaign runs before it is stopped [15: long enough to be
    /// past the residual budget and into the streamed trials].
    #[arg(long, default_value_t = 15)]
    pub huge_seconds: u64,
    /// Output file.
    #[arg(long, default_value = "docs/timings.md")]
    pub out: PathBuf,
}

/// `cargo xtask timings`.
pub fn run(args: &TimingsArgs) -> Result<()> {
    let kincal = args.kincal.canonicalize().with_context(|| {
        format!(
            "{}: build it first (cargo build --release -p kincal) or name another with --kincal",
            args.kincal.display()
        )
    })?;
    if args.poses.len() < 2 || args.poses.windows(2).any(|w| w[0] >= w[1]) {
        bail!("--poses: need at least two increasing counts, e.g. 2000,20000,200000");
    }
    let root = std::env::current_dir().context("current directory")?;
    let tmp = std::env::temp_dir().join(format!("kincal-timings-{}", std::process::id()));
    std::fs::create_dir_all(&tmp).with_context(|| format!("creating {}", tmp.display()))?;
    let result = measure_all(args, &kincal, &root, &tmp);
    let _ = std::fs::remove_dir_all(&tmp);
    let text = result?;
    std::fs::write(&args.out, &text).with_context(|| format!("writing {}", args.out.display()))?;
    print!("{text}");
    Ok(())
}

fn measure_all(args: &TimingsArgs, kincal: &Path, root: &Path, tmp: &Path) -> Result<String> {
    let ctx = runs::Ctx {
        kincal,
        root,
        tmp,
        scenario: "scenarios/paper-kr1000.json",
    };
    let load_before = process::load_average();
    let started = Instant::now();
    let runs = page::Runs {
        first: runs::first_command(&ctx, args)?,
        no_iso: runs::without_iso(&ctx, args)?,
        pose_runs: runs::poses(&ctx, args)?,
        rows: runs::many_rows(&ctx, args)?,
        huge: runs::huge(&ctx, args)?,
    };
    let machine = page::Machine {
        load_after: process::load_average(),
        total: started.elapsed().as_secs_f64(),
        own: process::own_peak_mb().map_or_else(|| "unknown".into(), units::megabytes),
        cpu: campaign::cpu_model_name().unwrap_or_else(|| "unknown CPU".into()),
        cores: std::thread::available_parallelism().map_or(1, |n| n.get()),
        mem_gb: process::machine_memory_gb(),
        load_before,
    };
    Ok(page::page(args, ctx.scenario, &machine, &runs))
}
