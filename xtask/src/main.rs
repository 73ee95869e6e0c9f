//! `cargo xtask …`: the kincal command line. Parses arguments, calls the library crates,
//! prints. No calibration logic lives here.
// The argument docs of the clap types are `--help` text, printed verbatim: defaults are
// written `[stdout]` and placeholders `<scenario>` there, not rustdoc links or HTML, so those
// types allow the two rustdoc lints.

mod bench;
mod calibrate;
mod campaign_cmd;
mod check_cmd;
mod identifiability;
mod identify_cmd;
mod urdf_cmd;

use std::path::PathBuf;

use anyhow::{Context, Result};
use clap::{Parser, Subcommand};
use kinematics::Robot;

#[derive(Parser)]
#[command(name = "xtask", about = "kincal: kinematic calibration harness")]
struct Cli {
    #[command(subcommand)]
    cmd: Cmd,
}

#[allow(rustdoc::broken_intra_doc_links, rustdoc::invalid_html_tags)] // clap help text
#[derive(Subcommand)]
enum Cmd {
    /// Print the forward kinematics of a robot model at a few reference poses.
    Poses {
        /// Robot model file (JSON).
        #[arg(long, default_value = "scenarios/robots/kr1000-titan.json")]
        robot: PathBuf,
    },
    /// Identifiability of a robot's parameters on a pose set: rank, redundant parameters and
    /// what they are confounded with, condition number, observability indices O1–O5.
    Identifiability(identifiability::IdentifiabilityArgs),
    /// Run a Monte Carlo campaign of a scenario: trials in parallel, summary against the
    /// paper, plots, in results/<scenario name>/.
    Campaign(campaign_cmd::CampaignArgs),
    /// Merge shard files written by `campaign --shard k/K` into one summary.
    Merge(campaign_cmd::MergeArgs),
    /// Simulate one trial of a scenario: identification.csv, validation.csv (spec §8) and
    /// truth.json.
    Simulate(campaign_cmd::SimulateArgs),
    /// Run a sweep: the cross product of a scenario's axes, one campaign per point, one
    /// table and curves in results/<sweep name>/.
    Sweep(campaign_cmd::SweepArgs),
    /// Regenerate results/ from every committed scenario and sweep (`--check`: compare only).
    Regenerate(campaign_cmd::RegenerateArgs),
    /// Identifiability regression: small fixed-seed campaigns (rank, redundant set,
    /// recovery, improvement, O1–O5) against results/baselines/ within the check file's
    /// tolerances; non-zero exit on regression (`--bless` writes the baselines).
    Check(check_cmd::CheckArgs),
    /// Calibrate a robot from measurements (spec §8 CSV): register, identify, screen
    /// outliers, validate; writes identified.json, registered-nominal.json, parameters.json
    /// and report.md.
    Identify(identify_cmd::IdentifyArgs),
    /// Predicted x, y, z of a robot model for each row of a joint file.
    Predict(calibrate::PredictArgs),
    /// Joints to command so that the calibrated robot reaches the nominal targets.
    Compensate(calibrate::CompensateArgs),
    /// Run the criterion benchmarks (kinematics, identification, one campaign trial) and
    /// write results/bench.json with the machine's CPU, SIMD features and cores.
    Bench(bench::BenchArgs),
    /// URDF in and out: `urdf import` a chain of a URDF as a robot file, `urdf export` a
    /// robot file (e.g. identified.json) as a URDF.
    Urdf(urdf_cmd::UrdfArgs),
}

fn main() -> Result<()> {
    let cli = Cli::parse();
    match cli.cmd {
        Cmd::Poses { robot } => poses(&robot),
        Cmd::Identifiability(args) => identifiability::run(&args),
        Cmd::Campaign(args) => campaign_cmd::campaign(args),
        Cmd::Merge(args) => campaign_cmd::merge(args),
        Cmd::Simulate(args) => campaign_cmd::simulate(args),
        Cmd::Sweep(args) => campaign_cmd::sweep(args),
        Cmd::Regenerate(args) => campaign_cmd::regenerate(args),
        Cmd::Check(args) => check_cmd::run(&args),
        Cmd::Identify(args) => identify_cmd::run(&args),
        Cmd::Predict(args) => calibrate::predict(&args),
        Cmd::Compensate(args) => calibrate::compensate_cmd(&args),
        Cmd::Bench(args) => bench::run(args),
        Cmd::Urdf(args) => urdf_cmd::run(&args),
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
