//! The runs the timings page reports, each a child process of the `kincal` binary
//! ([`measure`]): the first command and the trial rate, trials and threads without the ISO
//! test, poses per trial, a measurement file of many rows, a very long campaign.

use std::path::Path;
use std::time::Duration;

use anyhow::{Context as _, Result};

use super::TimingsArgs;
use super::inputs::{repeated_rows, scenario_with_poses};
use super::process::{Measured, measure, median};

/// Where the runs happen.
pub(super) struct Ctx<'a> {
    pub kincal: &'a Path,
    pub root: &'a Path,
    pub tmp: &'a Path,
    /// The scenario timed (the paper's, as committed).
    pub scenario: &'a str,
}

impl Ctx<'_> {
    /// An output path `name` in the scratch directory.
    fn out(&self, name: &str) -> String {
        self.tmp.join(name).display().to_string()
    }
}

/// The first command, with and without the residual budget, and the trial rate.
pub(super) struct First {
    pub first: Measured,
    pub no_budget: Measured,
    pub long: Measured,
    pub repeat: usize,
    pub trials: String,
    /// Trials per second beyond the first 200, and how many.
    pub rate: f64,
    pub extra: f64,
    /// The residual budget's fixed cost and the extrapolated 10⁶ trials, seconds.
    pub budget: f64,
    pub million: f64,
}

pub(super) fn first_command(ctx: &Ctx<'_>, args: &TimingsArgs) -> Result<First> {
    let (kincal, tmp, scenario) = (ctx.kincal, ctx.tmp, ctx.scenario);
    let repeat = args.repeat.max(1);
    let mut first = Vec::new();
    let mut no_budget = Vec::new();
    for i in 0..repeat {
        let o = ctx.out(&format!("first-{i}"));
        first.push(measure(
            kincal,
            &["campaign", scenario, "--quiet", "--out", &o],
            tmp,
            None,
        )?);
        let o = ctx.out(&format!("no-budget-{i}"));
        no_budget.push(measure(
            kincal,
            &["campaign", scenario, "--no-budget", "--quiet", "--out", &o],
            tmp,
            None,
        )?);
    }
    let (first, no_budget) = (median(first), median(no_budget));
    let trials = args.trials.to_string();
    let o = ctx.out("rate");
    let long = measure(
        kincal,
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
        tmp,
        None,
    )?;
    // Start-up and the 200-trial run are in `no_budget`; the rate is of the extra trials.
    let extra = args.trials.saturating_sub(200).max(1) as f64;
    let rate = extra / (long.seconds - no_budget.seconds).max(1e-9);
    let budget = (first.seconds - no_budget.seconds).max(0.0);
    let million = 1e6 / rate + budget;

    Ok(First {
        first,
        no_budget,
        long,
        repeat,
        trials,
        rate,
        extra,
        budget,
        million,
    })
}

/// Trials and threads without the ISO test and the budget (the trials alone): `(trials,
/// threads, measured)`.
pub(super) fn without_iso(
    ctx: &Ctx<'_>,
    args: &TimingsArgs,
) -> Result<Vec<(u64, usize, Measured)>> {
    let (kincal, tmp, scenario) = (ctx.kincal, ctx.tmp, ctx.scenario);
    let mut no_iso = Vec::new();
    let mut counts: Vec<u64> = [1_000, 10_000]
        .into_iter()
        .filter(|&n| n < args.no_iso_trials)
        .collect();
    counts.push(args.no_iso_trials);
    for &n in &counts {
        let threads: &[usize] = if n <= 10_000 { &[1, 2] } else { &[2] };
        for &t in threads {
            let o = ctx.out(&format!("no-iso-{n}-{t}"));
            let (n_s, t_s) = (n.to_string(), t.to_string());
            let m = measure(
                kincal,
                &[
                    "campaign",
                    scenario,
                    "--no-iso",
                    "--no-budget",
                    "--trials",
                    &n_s,
                    "--threads",
                    &t_s,
                    "--quiet",
                    "--out",
                    &o,
                ],
                tmp,
                None,
            )?;
            no_iso.push((n, t, m));
        }
    }
    Ok(no_iso)
}

/// One trial on one thread with each identification pose count: `(poses, measured)`.
pub(super) fn poses(ctx: &Ctx<'_>, args: &TimingsArgs) -> Result<Vec<(u64, Measured)>> {
    let (kincal, root, tmp, scenario) = (ctx.kincal, ctx.root, ctx.tmp, ctx.scenario);
    // Budget off (its reruns are a fixed extra).
    let mut pose_runs = Vec::new();
    for &n in &args.poses {
        let file = scenario_with_poses(root, scenario, n, tmp)?;
        let file = file.display().to_string();
        let o = ctx.out(&format!("poses-{n}"));
        let m = measure(
            kincal,
            &[
                "campaign",
                &file,
                "--trials",
                "1",
                "--threads",
                "1",
                "--no-budget",
                "--quiet",
                "--out",
                &o,
            ],
            tmp,
            None,
        )?;
        pose_runs.push((n, m));
    }
    Ok(pose_runs)
}

/// A measurement file of many rows through identify and predict.
pub(super) struct Rows {
    pub robot: &'static str,
    pub big_mb: f64,
    pub identify: Measured,
    pub report_mb: f64,
    pub predict: Measured,
    /// Rows that identify (every 1000th).
    pub rows_identify: u64,
}

pub(super) fn many_rows(ctx: &Ctx<'_>, args: &TimingsArgs) -> Result<Rows> {
    let (kincal, root, tmp) = (ctx.kincal, ctx.root, ctx.tmp);
    let robot = "scenarios/robots/ur10.json";
    let source = root.join("data/ur10-ipa/series-b-joint-configurations.csv");
    let big = tmp.join("rows.csv");
    repeated_rows(&source, args.rows, &big)?;
    let big_mb = std::fs::metadata(&big)?.len() as f64 / 1e6;
    let big = big.display().to_string();
    let cal = ctx.out("rows-identify");
    let identify = measure(
        kincal,
        &[
            "identify", "--robot", robot, "--data", &big, "--every", "1000", "--out", &cal,
        ],
        tmp,
        None,
    )?;
    let report_mb = std::fs::metadata(tmp.join("rows-identify/report.html"))
        .context("identify wrote no report.html")?
        .len() as f64
        / 1e6;
    let identified = tmp
        .join("rows-identify/identified.json")
        .display()
        .to_string();
    let predicted = ctx.out("rows-predicted.csv");
    let predict = measure(
        kincal,
        &[
            "predict",
            "--robot",
            &identified,
            "--joints",
            &big,
            "--out",
            &predicted,
        ],
        tmp,
        None,
    )?;
    let rows_identify = args.rows / 1000 + u64::from(!args.rows.is_multiple_of(1000));

    Ok(Rows {
        robot,
        big_mb,
        identify,
        report_mb,
        predict,
        rows_identify,
    })
}

/// 10¹² trials, stopped after a third of the time and after all of it: the memory of a
/// streamed aggregate, which must not grow with the trials run.
pub(super) fn huge(ctx: &Ctx<'_>, args: &TimingsArgs) -> Result<Vec<Measured>> {
    let (kincal, tmp, scenario) = (ctx.kincal, ctx.tmp, ctx.scenario);
    let mut huge = Vec::new();
    for (i, seconds) in [args.huge_seconds.div_ceil(3), args.huge_seconds]
        .into_iter()
        .enumerate()
    {
        let o = ctx.out(&format!("huge-{i}"));
        let m = measure(
            kincal,
            &[
                "campaign",
                scenario,
                "--trials",
                "1000000000000",
                "--quiet",
                "--out",
                &o,
            ],
            tmp,
            Some(Duration::from_secs(seconds)),
        )?;
        huge.push(m);
    }
    Ok(huge)
}
