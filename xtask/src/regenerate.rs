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
    /// Only the outputs of these names (a scenario's or a sweep's `name`, or
    /// `cartesian-kr1000`), e.g. to write a new one \[all\].
    #[arg(long, value_name = "NAME")]
    pub only: Vec<String>,
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
    let wanted = |name: &str| args.only.is_empty() || args.only.iter().any(|o| o == name);
    let mut names = Vec::new();
    for path in list("scenarios")? {
        let name = Scenario::from_file(&path)
            .with_context(|| format!("loading {}", path.display()))?
            .scenario
            .name;
        if !wanted(&name) {
            continue;
        }
        let mut run = CampaignRun::new(&path);
        run.out = Some(target.join(&name));
        let outcome = run.run(&Progress::new(false))?;
        print_campaign(&outcome, true);
        names.push(name);
    }
    for path in list("scenarios/sweeps")? {
        let name = SweepSpec::from_file(&path)?.name;
        if !wanted(&name) {
            continue;
        }
        let mut run = SweepRun::new(&path);
        run.out = Some(target.join(&name));
        let outcome = run.run(&Progress::new(false))?;
        print_sweep(&outcome, true);
        names.push(name);
    }
    if wanted(CARTESIAN_PROOF) {
        names.push(cartesian_proof(&target)?);
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

/// The name of the Cartesian compensation proof's output directory.
const CARTESIAN_PROOF: &str = "cartesian-kr1000";

/// The proof of Cartesian compensation (issue 40, [`campaign::CartesianProof`]) on trial 0
/// of `scenarios/paper-kr1000.json`, into `<target>/cartesian-kr1000/`: `cartesian.md` and
/// `cartesian.json`. Returns the directory's name.
fn cartesian_proof(target: &Path) -> Result<String> {
    let name = CARTESIAN_PROOF;
    let outcome = campaign::CartesianProof::new("scenarios/paper-kr1000.json")
        .run()
        .context("the Cartesian compensation proof")?;
    let dir = target.join(name);
    std::fs::create_dir_all(&dir).with_context(|| format!("creating {}", dir.display()))?;
    let json = serde_json::to_string_pretty(&outcome)? + "\n";
    measurements::write_atomically(&dir.join("cartesian.json"), json.as_bytes())?;
    measurements::write_atomically(&dir.join("cartesian.md"), outcome.markdown().as_bytes())?;
    eprintln!(
        "{name}: {}",
        outcome
            .sets
            .iter()
            .map(|t| format!(
                "{} position mean {:.3} → {:.3} mm, orientation mean {:.4} → {:.4}°",
                t.name,
                t.before.position_mean_mm,
                t.after.position_mean_mm,
                t.before.orientation_mean_deg,
                t.after.orientation_mean_deg
            ))
            .collect::<Vec<_>>()
            .join("; ")
    );
    Ok(name.to_string())
}
