//! `cargo xtask timings`: measures the times README.md states, on the scenario as committed,
//! and writes them with the machine into `docs/timings.md`: the first command (`kincal
//! campaign scenarios/paper-kr1000.json`, 200 trials with the ISO test and the residual
//! budget), the same without the budget, and the trial rate of a longer run, from which the
//! time of 10⁶ trials is extrapolated (stated as such). Each command is a child process of
//! the given `kincal` binary, timed from spawn to exit.

use std::path::{Path, PathBuf};
use std::process::Command;
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
    /// Output file.
    #[arg(long, default_value = "docs/timings.md")]
    pub out: PathBuf,
}

fn load_average() -> String {
    std::fs::read_to_string("/proc/loadavg")
        .ok()
        .and_then(|s| s.split_whitespace().next().map(String::from))
        .unwrap_or_else(|| "unknown".into())
}

/// Wall seconds of `kincal args…` (must succeed).
fn time(kincal: &Path, args: &[&str]) -> Result<f64> {
    let started = Instant::now();
    let out = Command::new(kincal)
        .args(args)
        .env("CI", "1")
        .output()
        .with_context(|| format!("running {}", kincal.display()))?;
    let s = started.elapsed().as_secs_f64();
    if !out.status.success() {
        bail!(
            "{} {}: {}",
            kincal.display(),
            args.join(" "),
            String::from_utf8_lossy(&out.stderr)
        );
    }
    Ok(s)
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn minutes(s: f64) -> String {
    if s < 90.0 {
        format!("{s:.1} s")
    } else {
        format!("{:.0} min {:.0} s", (s / 60.0).floor(), s % 60.0)
    }
}

/// `cargo xtask timings`.
pub fn run(args: &TimingsArgs) -> Result<()> {
    let kincal = args.kincal.canonicalize().with_context(|| {
        format!(
            "{}: build it first (cargo build --release -p kincal) or name another with --kincal",
            args.kincal.display()
        )
    })?;
    let tmp = std::env::temp_dir().join(format!("kincal-timings-{}", std::process::id()));
    let out = |name: &str| tmp.join(name).display().to_string();
    let scenario = "scenarios/paper-kr1000.json";
    let load_before = load_average();
    let repeat = args.repeat.max(1);
    let mut first = Vec::new();
    let mut no_budget = Vec::new();
    for i in 0..repeat {
        let o = out(&format!("first-{i}"));
        first.push(time(
            &kincal,
            &["campaign", scenario, "--quiet", "--out", &o],
        )?);
        let o = out(&format!("no-budget-{i}"));
        no_budget.push(time(
            &kincal,
            &["campaign", scenario, "--no-budget", "--quiet", "--out", &o],
        )?);
    }
    let (first, no_budget) = (median(first), median(no_budget));
    let trials = args.trials.to_string();
    let o = out("rate");
    let long = time(
        &kincal,
        &[
            "campaign",
            scenario,
            "--no-budget",
            "--trials",
            &trials,
            "--quiet",
            "--out",
            &o,
        ],
    )?;
    let load_after = load_average();
    let _ = std::fs::remove_dir_all(&tmp);
    // Start-up and the 200-trial run are in `no_budget`; the rate is of the extra trials.
    let extra = args.trials.saturating_sub(200).max(1) as f64;
    let rate = extra / (long - no_budget).max(1e-9);
    let budget = (first - no_budget).max(0.0);
    let million = 1e6 / rate + budget;
    let cpu = campaign::cpu_model_name().unwrap_or_else(|| "unknown CPU".into());
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    let text = format!(
        "# Timings\n\n\
         Written by `cargo xtask timings` (do not edit by hand); README.md quotes these figures.\n\n\
         Machine: {cpu}, {cores} cores; load average {load_before} before and {load_after} after \
         (a load above the core count means other processes shared the cores: the times are \
         then longer than on an idle machine). Binary: `{bin}`.\n\n\
         | what | command | wall time |\n|---|---|---:|\n\
         | the first command (200 trials, ISO test and residual budget on) | `kincal campaign {scenario}` | {first} (median of {repeat}) |\n\
         | the same without the residual budget | `… --no-budget` | {no_budget} (median of {repeat}) |\n\
         | {trials} trials, budget off | `… --no-budget --trials {trials}` | {long} |\n\n\
         Trial rate (ISO test on, all cores): {rate:.0} trials/s, from the {extra:.0} trials \
         beyond the first 200 of the last run. **10⁶ trials: about {million}**, extrapolated \
         from that rate plus the residual budget's fixed cost ({budget}); not run in full.\n",
        bin = args.kincal.display(),
        first = minutes(first),
        no_budget = minutes(no_budget),
        long = minutes(long),
        million = minutes(million),
        budget = minutes(budget),
    );
    std::fs::write(&args.out, &text).with_context(|| format!("writing {}", args.out.display()))?;
    print!("{text}");
    Ok(())
}
