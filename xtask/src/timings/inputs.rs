//! The inputs the timings run on: the paper scenario with more poses, a measurement file of
//! many rows.

use std::io::Write as _;
use std::path::{Path, PathBuf};

use anyhow::{Context as _, Result, bail};

/// The paper scenario with `poses` identification poses, written into `dir` (its robot path
/// made absolute, as the copy is elsewhere).
pub(super) fn scenario_with_poses(
    root: &Path,
    scenario: &str,
    poses: u64,
    dir: &Path,
) -> Result<PathBuf> {
    let path = root.join(scenario);
    let text =
        std::fs::read_to_string(&path).with_context(|| format!("reading {}", path.display()))?;
    let mut v: serde_json::Value =
        serde_json::from_str(&text).with_context(|| format!("parsing {}", path.display()))?;
    let robot = v["robot"]
        .as_str()
        .with_context(|| format!("{}: no robot path", path.display()))?;
    let robot = path.parent().unwrap_or(root).join(robot);
    v["robot"] = robot.display().to_string().into();
    v["poses"]["identification"] = poses.into();
    v["name"] = format!("timings-poses-{poses}").into();
    let out = dir.join(format!("poses-{poses}.json"));
    std::fs::write(&out, serde_json::to_string_pretty(&v)?)
        .with_context(|| format!("writing {}", out.display()))?;
    Ok(out)
}

/// A measurement file of `rows` data rows: the rows of `source` repeated in order.
pub(super) fn repeated_rows(source: &Path, rows: u64, out: &Path) -> Result<()> {
    let text =
        std::fs::read_to_string(source).with_context(|| format!("reading {}", source.display()))?;
    let mut lines = text
        .lines()
        .filter(|l| !l.trim().is_empty() && !l.starts_with('#'));
    let header = lines
        .next()
        .with_context(|| format!("{}: empty", source.display()))?;
    let data: Vec<&str> = lines.collect();
    if data.is_empty() {
        bail!("{}: no data rows", source.display());
    }
    // Streamed: this process's own peak memory is a floor of every child's `ru_maxrss`
    // (see `measure`), so it must stay small.
    let write = || -> std::io::Result<()> {
        let mut w = std::io::BufWriter::new(std::fs::File::create(out)?);
        writeln!(w, "{header}")?;
        for i in 0..rows as usize {
            writeln!(w, "{}", data[i % data.len()])?;
        }
        w.into_inner().map_err(|e| e.into_error())?.sync_all()
    };
    write().with_context(|| format!("writing {}", out.display()))
}
