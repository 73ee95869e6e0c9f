//! `cargo xtask …`: the repository's automation — regenerate and check the committed
//! results, run the benchmarks — and every user command of `kincal` (so `cargo xtask
//! campaign …` works from a checkout without installing). Parses arguments and prints; the
//! commands live in the `kincal` front end and the library crates.

mod bench;
mod check_cmd;
mod regenerate;
mod slurm_cmd;
mod tidy;
mod timings;

use anyhow::{Context, Result};
use clap::{Parser, Subcommand};
use kinematics::Robot;

#[derive(Parser)]
#[command(
    name = "xtask",
    version,
    about = "kincal's repository automation (regenerate, check, bench, slurm-smoke) and its user commands"
)]
struct Cli {
    #[command(subcommand)]
    cmd: Cmd,
}

#[allow(rustdoc::broken_intra_doc_links, rustdoc::invalid_html_tags)] // clap help text
#[derive(Subcommand)]
// Parsed once per process: the size of its largest variant costs nothing.
#[allow(clippy::large_enum_variant)]
enum Cmd {
    /// Print the forward kinematics of a robot model at a few reference poses.
    Poses {
        /// Robot model file (JSON).
        #[arg(long, default_value = "scenarios/robots/kr1000-titan.json")]
        robot: std::path::PathBuf,
    },
    /// Regenerate results/ from every committed scenario and sweep (`--check`: compare only).
    Regenerate(regenerate::RegenerateArgs),
    /// Identifiability regression: small fixed-seed campaigns (rank, redundant set,
    /// recovery, improvement, O1–O5) against results/baselines/ within the check file's
    /// tolerances; non-zero exit on regression (`--bless` writes the baselines).
    Check(check_cmd::CheckArgs),
    /// Run the criterion benchmarks (kinematics, identification, one campaign trial) of the
    /// current tree and write results/bench.json with the machine's CPU, SIMD features and
    /// cores.
    Bench(bench::BenchArgs),
    /// Measure the times README.md states (the first command, the trial rate, 10⁶ trials
    /// extrapolated) on the committed scenario and write docs/timings.md with the machine.
    Timings(timings::TimingsArgs),
    /// A real Slurm run: a one-node cluster in a temporary directory, the campaign as a job
    /// array of shards plus a dependent merge, one shard requeued and resumed; the merged
    /// summary.json must equal a single run's (installs slurm-wlm and munge if missing).
    SlurmSmoke(slurm_cmd::SlurmSmokeArgs),
    #[command(flatten)]
    User(kincal::Command),
}

fn main() {
    kincal::exit_on_error(run(Cli::parse()));
}

fn run(cli: Cli) -> Result<()> {
    match cli.cmd {
        Cmd::Poses { robot } => poses(&robot),
        Cmd::Regenerate(args) => regenerate::regenerate(args),
        Cmd::Check(args) => check_cmd::run(&args),
        Cmd::Bench(args) => bench::run(args),
        Cmd::Timings(args) => timings::run(&args),
        Cmd::SlurmSmoke(args) => slurm_cmd::run(&args),
        Cmd::User(cmd) => kincal::run(cmd),
    }
}

fn poses(path: &std::path::Path) -> Result<()> {
    let robot = Robot::from_file(path).with_context(|| format!("loading {}", path.display()))?;
    let n = robot.n_joints();
    println!(
        "{} — {} joints, {} parameters",
        robot.name(),
        n,
        robot.n_params()
    );
    println!(
        "{:>40} | {:>10} {:>10} {:>10}",
        "q (deg)", "x (mm)", "y (mm)", "z (mm)"
    );
    let mut rows: Vec<Vec<f64>> = vec![vec![0.0; n]];
    for j in 0..n {
        let [lo, hi] = robot.limits_rad(j);
        let mut q = vec![0.0; n];
        q[j] = (0.5 * hi).max(0.5 * lo).min(hi);
        rows.push(q);
    }
    for q in rows {
        let p = robot.point(&q);
        let qs: Vec<String> = q.iter().map(|v| format!("{:.1}", v.to_degrees())).collect();
        println!(
            "{:>40} | {:>10.3} {:>10.3} {:>10.3}",
            qs.join(" "),
            p.x,
            p.y,
            p.z
        );
    }
    Ok(())
}
