//! `cargo xtask check [--bless]`: the identifiability regression of
//! `scenarios/checks/identifiability.json` against `results/baselines/` (see `campaign::check`).

use std::path::{Path, PathBuf};

use anyhow::{Context as _, Result, bail};
use campaign::{Baseline, CheckFile, compare, run_check};

/// Arguments of `check`.
#[derive(clap::Args)]
pub struct CheckArgs {
    /// Check file.
    #[arg(long, default_value = "scenarios/checks/identifiability.json")]
    pub checks: PathBuf,
    /// Directory of the baselines.
    #[arg(long, default_value = "results/baselines")]
    pub baselines: PathBuf,
    /// Write the baselines from this run instead of comparing (after an intended change;
    /// say why in the commit).
    #[arg(long)]
    pub bless: bool,
    /// Only the check with this name.
    #[arg(long)]
    pub only: Option<String>,
}

pub fn run(args: &CheckArgs) -> Result<()> {
    let file = CheckFile::from_file(&args.checks)?;
    let dir = args.checks.parent().unwrap_or(Path::new("."));
    let mut regressions = Vec::new();
    let mut ran = 0;
    for spec in &file.checks {
        if args.only.as_ref().is_some_and(|o| *o != spec.name) {
            continue;
        }
        ran += 1;
        let figures = run_check(spec, dir).with_context(|| format!("check `{}`", spec.name))?;
        let path = args.baselines.join(format!("{}.json", spec.name));
        if args.bless {
            let baseline = Baseline {
                check: spec.clone(),
                tolerances: file.tolerances,
                figures,
            };
            std::fs::create_dir_all(&args.baselines)
                .with_context(|| format!("creating {}", args.baselines.display()))?;
            let mut text = serde_json::to_string_pretty(&baseline)?;
            text.push('\n');
            measurements::write_atomically(&path, text.as_bytes())
                .with_context(|| format!("writing {}", path.display()))?;
            println!("{}: baseline written to {}", spec.name, path.display());
            continue;
        }
        let text = std::fs::read_to_string(&path).with_context(|| {
            format!(
                "reading the baseline {} (write it with `cargo xtask check --bless`)",
                path.display()
            )
        })?;
        let baseline: Baseline = serde_json::from_str(&text)
            .with_context(|| format!("parsing the baseline {}", path.display()))?;
        if baseline.check != *spec {
            bail!(
                "{}: the baseline was written for another definition of check `{}`; re-bless it",
                path.display(),
                spec.name
            );
        }
        let rows = compare(&baseline.figures, &figures, &file.tolerances);
        let bad: Vec<_> = rows.iter().filter(|r| !r.ok).collect();
        println!(
            "{}: {} figures, {} outside tolerance",
            spec.name,
            rows.len(),
            bad.len()
        );
        for r in &bad {
            println!(
                "  REGRESSION {}: baseline {} now {} (tolerance {})",
                r.figure, r.baseline, r.now, r.tolerance
            );
            regressions.push(format!("{}: {}", spec.name, r.figure));
        }
    }
    if let Some(o) = &args.only
        && ran == 0
    {
        bail!("no check named `{o}` in {}", args.checks.display());
    }
    if !regressions.is_empty() {
        bail!(
            "{} figure(s) regressed: {}",
            regressions.len(),
            regressions.join("; ")
        );
    }
    Ok(())
}
