//! `cargo xtask slurm-smoke`: a real Slurm run of a sharded campaign on this machine. Builds
//! the release `kincal`, then runs `scripts/slurm/smoke.sh`, which installs `slurm-wlm` and
//! `munge` if missing (apt-get, as root), starts a one-node cluster in a temporary directory
//! (munged, slurmctld, slurmd as its own children), submits the campaign as a job array of
//! K shards plus a merge job that depends on it (`scripts/slurm/submit.sh`, the sbatch files
//! the docs show), requeues one running shard to show it resumes from its checkpoint, checks
//! that the merged `summary.json` equals a single run's byte for byte, and stops everything
//! it started on every path (`docs/scale.md`).

use std::process::Command;

use anyhow::{Context, Result, bail};

/// Arguments of `slurm-smoke`.
#[derive(clap::Args)]
pub struct SlurmSmokeArgs {
    /// Scenario to run [scenarios/paper-kr1000.json].
    #[arg(long, default_value = "scenarios/paper-kr1000.json")]
    scenario: std::path::PathBuf,
    /// Trials of the campaign (enough that a shard is still running when it is requeued).
    #[arg(long, default_value_t = 2000)]
    trials: u64,
    /// Shards (array tasks).
    #[arg(long, default_value_t = 4)]
    shards: u32,
    /// Seconds after which the smoke test gives up (and stops the cluster).
    #[arg(long, default_value_t = 480)]
    timeout_s: u64,
}

/// Runs `slurm-smoke`.
pub fn run(args: &SlurmSmokeArgs) -> Result<()> {
    let root = crate::bench::workspace_root()?;
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let status = Command::new(cargo)
        .args(["build", "--release", "--quiet", "-p", "kincal"])
        .current_dir(&root)
        .status()
        .context("building the release kincal")?;
    if !status.success() {
        bail!("cargo build --release -p kincal failed ({status})");
    }
    let kincal = root.join("target/release/kincal");
    let scenario = root.join(&args.scenario);
    let status = Command::new("bash")
        .arg(root.join("scripts/slurm/smoke.sh"))
        .arg(&kincal)
        .arg(&scenario)
        .arg(args.trials.to_string())
        .arg(args.shards.to_string())
        .env("SMOKE_TIMEOUT", args.timeout_s.to_string())
        .current_dir(&root)
        .status()
        .context("running scripts/slurm/smoke.sh")?;
    if !status.success() {
        bail!("the Slurm smoke test failed ({status}); its messages are above");
    }
    Ok(())
}
