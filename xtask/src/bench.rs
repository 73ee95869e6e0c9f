//! `cargo xtask bench [--quick] [FILTER]`: runs the criterion benchmarks of the kinematics,
//! identify and campaign crates and writes `results/bench.json` — the medians with the
//! machine they were measured on (CPU model, SIMD features, cores, the vector width the
//! kernels chose) and the issue-8 targets they are held to. Wall-clock figures: this file is
//! not part of `regenerate`.

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::SystemTime;

use anyhow::{Context as _, Result, bail};
use serde_json::{Value, json};

/// Arguments of `bench`.
#[derive(clap::Args)]
pub struct BenchArgs {
    /// Short measurements (criterion's quick mode, ~1 s per benchmark): about a minute in all.
    #[arg(long)]
    pub quick: bool,
    /// Only benchmarks whose id contains this (criterion's filter, e.g. `identify/`).
    pub filter: Option<String>,
    /// Output file.
    #[arg(long, default_value = "results/bench.json")]
    pub out: PathBuf,
}

/// The targets of issue 8: benchmark id, target median in ns, what it stands for.
const TARGETS: &[(&str, f64, &str)] = &[
    (
        "identify/identify_levenberg_50x34",
        75e3,
        "one identification (50 poses × 34 parameters, LM + covariance) ≤ 75 µs",
    ),
    (
        "identify/lm_levenberg_50x34",
        75e3,
        "one LM solve (50 × 34, from nominal to convergence) ≤ 75 µs",
    ),
    ("kinematics/ik_one_pose", 5e3, "IK of one pose ≤ 5 µs"),
    (
        "identify/identify_levenberg_50x52_extended",
        150e3,
        "one identification with the extended model (50 × 52: + compliance, gear harmonics) ≤ 2 × 75 µs",
    ),
    (
        "campaign/trial_paper-kr1000_no_iso",
        500e3,
        "one paper-kr1000 trial without ISO ≤ 0.5 ms",
    ),
    (
        "identify/identify_ur10_real_100x35",
        1e6,
        "real UR10 identification (100 poses × 35 parameters) ≤ 1 ms",
    ),
];

/// The workspace the command runs in: the nearest directory at or above the current one
/// whose `Cargo.toml` has a `[workspace]` table (`cargo xtask` runs in the workspace root),
/// so the benchmarks measure the tree the user is in, not the one this binary was built from.
pub(crate) fn workspace_root() -> Result<PathBuf> {
    let cwd = std::env::current_dir().context("reading the current directory")?;
    cwd.ancestors()
        .find(|d| {
            std::fs::read_to_string(d.join("Cargo.toml"))
                .is_ok_and(|t| t.lines().any(|l| l.trim() == "[workspace]"))
        })
        .map(Path::to_path_buf)
        .with_context(|| {
            format!(
                "{} is not inside a cargo workspace: run `cargo xtask bench` in the kincal \
                 repository",
                cwd.display()
            )
        })
}

use campaign::cpu_model_name;

fn cpu_model() -> String {
    cpu_model_name().unwrap_or_else(|| "unknown".into())
}

/// SIMD features that matter here, as the running CPU reports them.
fn simd_features() -> Value {
    #[cfg(target_arch = "x86_64")]
    {
        macro_rules! has {
            ($($f:tt),*) => { json!({ $($f: std::arch::is_x86_feature_detected!($f)),* }) };
        }
        has!(
            "sse2", "sse4.2", "avx", "avx2", "fma", "avx512f", "avx512dq", "avx512vl"
        )
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        json!({})
    }
}

fn rustc_version() -> String {
    Command::new(std::env::var("RUSTC").unwrap_or_else(|_| "rustc".into()))
        .arg("-V")
        .output()
        .ok()
        .and_then(|o| String::from_utf8(o.stdout).ok())
        .map(|s| s.trim().to_string())
        .unwrap_or_default()
}

/// Every `<group>/<bench>/new/` directory under `dir` written after `since`.
fn fresh_results(dir: &Path, since: SystemTime) -> Result<Vec<Value>> {
    let mut out = Vec::new();
    let Ok(groups) = std::fs::read_dir(dir) else {
        return Ok(out);
    };
    for group in groups.flatten() {
        let Ok(benches) = std::fs::read_dir(group.path()) else {
            continue;
        };
        for bench in benches.flatten() {
            let new = bench.path().join("new");
            let estimates = new.join("estimates.json");
            let fresh = std::fs::metadata(&estimates)
                .and_then(|m| m.modified())
                .is_ok_and(|t| t >= since);
            if !fresh {
                continue;
            }
            let read = |f: &str| -> Result<Value> {
                let p = new.join(f);
                let text =
                    std::fs::read_to_string(&p).with_context(|| format!("{}", p.display()))?;
                serde_json::from_str(&text).with_context(|| format!("{}", p.display()))
            };
            let meta = read("benchmark.json")?;
            let est = read("estimates.json")?;
            let ns = |stat: &str, field: &str| est[stat][field].as_f64();
            out.push(json!({
                "id": meta["full_id"],
                "median_ns": ns("median", "point_estimate"),
                "median_ci95_ns": [
                    est["median"]["confidence_interval"]["lower_bound"].as_f64(),
                    est["median"]["confidence_interval"]["upper_bound"].as_f64(),
                ],
                "mean_ns": ns("mean", "point_estimate"),
            }));
        }
    }
    out.sort_by(|a, b| a["id"].as_str().cmp(&b["id"].as_str()));
    Ok(out)
}

fn human(ns: f64) -> String {
    if ns >= 1e6 {
        format!("{:.3} ms", ns / 1e6)
    } else if ns >= 1e3 {
        format!("{:.2} µs", ns / 1e3)
    } else {
        format!("{ns:.0} ns")
    }
}

/// `cargo xtask bench`.
pub fn run(args: BenchArgs) -> Result<()> {
    let root = workspace_root()?;
    let target_dir = std::env::var_os("CARGO_TARGET_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|| root.join("target"));
    let since = SystemTime::now();
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let mut cmd = Command::new(cargo);
    cmd.current_dir(&root).args([
        "bench",
        "-p",
        "kinematics",
        "-p",
        "identify",
        "-p",
        "campaign",
        "--bench",
        "kinematics",
        "--bench",
        "identify",
        "--bench",
        "trial",
        "--",
    ]);
    if args.quick {
        cmd.arg("--quick").env("KINCAL_BENCH_QUICK", "1");
    }
    if let Some(f) = &args.filter {
        cmd.arg(f);
    }
    let status = cmd.status().context("running cargo bench")?;
    if !status.success() {
        bail!("cargo bench failed ({status})");
    }
    let results = fresh_results(&target_dir.join("criterion"), since)?;
    if results.is_empty() {
        bail!("no criterion results were written (filter matched nothing?)");
    }
    let median = |id: &str| {
        results
            .iter()
            .find(|r| r["id"] == id)
            .and_then(|r| r["median_ns"].as_f64())
    };
    let targets: Vec<Value> = TARGETS
        .iter()
        .filter_map(|(id, target, what)| {
            median(id).map(|m| {
                json!({
                    "id": id, "what": what, "target_ns": target, "median_ns": m, "met": m <= *target,
                })
            })
        })
        .collect();
    let cores = std::thread::available_parallelism().map_or(0, |n| n.get());
    let report = json!({
        "format": "kincal-bench/1",
        "quick": args.quick,
        "filter": args.filter,
        "machine": {
            "cpu": cpu_model(),
            "cores": cores,
            "simd_features": simd_features(),
            "kernels_simd_level": kinematics::simd::simd_level().name(),
            "os": std::env::consts::OS,
            "arch": std::env::consts::ARCH,
        },
        "rustc": rustc_version(),
        "profile": "bench (release, default target CPU; vector width chosen at run time)",
        "unix_time": since.duration_since(SystemTime::UNIX_EPOCH).map_or(0, |d| d.as_secs()),
        "benchmarks": results,
        "targets": targets,
    });
    let out = if args.out.is_absolute() {
        args.out.clone()
    } else {
        root.join(&args.out)
    };
    if let Some(dir) = out.parent() {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    }
    measurements::write_atomically(&out, format!("{report:#}\n").as_bytes())
        .with_context(|| format!("writing {}", out.display()))?;

    println!("\n{:<48} {:>12}", "benchmark (median)", "time");
    for r in report["benchmarks"].as_array().into_iter().flatten() {
        let id = r["id"].as_str().unwrap_or("?");
        let m = r["median_ns"].as_f64().unwrap_or(f64::NAN);
        println!("{id:<48} {:>12}", human(m));
    }
    println!();
    for t in &targets {
        println!(
            "{} {} (median {})",
            if t["met"] == true {
                "met    "
            } else {
                "NOT MET"
            },
            t["what"].as_str().unwrap_or(""),
            human(t["median_ns"].as_f64().unwrap_or(f64::NAN)),
        );
    }
    println!(
        "\n{} on {}, {} cores, kernels at {} → {}",
        if args.quick { "quick run" } else { "full run" },
        cpu_model(),
        cores,
        kinematics::simd::simd_level().name(),
        out.display()
    );
    Ok(())
}
