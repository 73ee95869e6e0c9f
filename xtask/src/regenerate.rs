//! `cargo xtask regenerate [--check]`: rebuild `results/` from the committed scenarios and
//! sweeps with the same requests as `kincal campaign | sweep` ([`CampaignRun`],
//! [`SweepRun`]).

use std::path::{Path, PathBuf};

use anyhow::{Context as _, Result, bail};
use campaign::{CampaignRun, Scenario, SweepRun, SweepSpec};
use kincal::campaign_cmd::{Progress, print_campaign, print_sweep};

/// Arguments of `regenerate`.
#[derive(clap::Args)]
pub struct RegenerateArgs {
    /// Regenerate into a temporary directory and fail if any file differs from results/
    /// (wall-clock files timing.json and bench.json excepted).
    #[arg(long)]
    pub check: bool,
}

/// Files in `results/` that hold wall-clock figures, not reproducible bytes.
const WALL_CLOCK_FILES: [&str; 2] = ["timing.json", "bench.json"];

/// `cargo xtask regenerate`: every committed scenario (`scenarios/*.json`) and sweep
/// (`scenarios/sweeps/*.json`) into `results/<name>/`.
pub fn regenerate(args: RegenerateArgs) -> Result<()> {
    let list = |dir: &str| -> Result<Vec<PathBuf>> {
        let mut v: Vec<PathBuf> = std::fs::read_dir(dir)
            .with_context(|| format!("listing {dir}"))?
            .filter_map(|e| e.ok().map(|e| e.path()))
            .filter(|p| p.extension().is_some_and(|e| e == "json"))
            .collect();
        v.sort();
        Ok(v)
    };
    let target = if args.check {
        std::env::temp_dir().join(format!("kincal-regenerate-{}", std::process::id()))
    } else {
        PathBuf::from("results")
    };
    let mut names = Vec::new();
    for path in list("scenarios")? {
        let name = Scenario::from_file(&path)
            .with_context(|| format!("loading {}", path.display()))?
            .scenario
            .name;
        let mut run = CampaignRun::new(&path);
        run.out = Some(target.join(&name));
        let outcome = run.run(&Progress::new(false))?;
        print_campaign(&outcome, true);
        names.push(name);
    }
    for path in list("scenarios/sweeps")? {
        let name = SweepSpec::from_file(&path)?.name;
        let mut run = SweepRun::new(&path);
        run.out = Some(target.join(&name));
        let outcome = run.run(&Progress::new(false))?;
        print_sweep(&outcome, true);
        names.push(name);
    }
    if !args.check {
        return Ok(());
    }
    let mut differ = Vec::new();
    for name in &names {
        let fresh = target.join(name);
        for entry in std::fs::read_dir(&fresh)? {
            let file = entry?.file_name();
            if WALL_CLOCK_FILES.iter().any(|w| file == *w) {
                continue;
            }
            let committed = Path::new("results").join(name).join(&file);
            let a = std::fs::read(fresh.join(&file))?;
            if std::fs::read(&committed).ok().as_deref() != Some(&a[..]) {
                differ.push(committed.display().to_string());
            }
        }
    }
    let _ = std::fs::remove_dir_all(&target);
    if !differ.is_empty() {
        bail!(
            "results/ does not match the committed scenarios; run `cargo xtask regenerate` and commit: {}",
            differ.join(", ")
        );
    }
    eprintln!(
        "results/ regenerates byte for byte ({} outputs)",
        names.len()
    );
    Ok(())
}
