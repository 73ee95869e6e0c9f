//! The timings page (`docs/timings.md`): the runs' figures, the extrapolations stated as
//! such, the machine.

use super::TimingsArgs;
use super::process::Measured;
use super::runs::{First, Rows};
use super::units::{megabytes, minutes, thousands};

/// The machine and the measurement as a whole.
pub(super) struct Machine {
    pub cpu: String,
    pub cores: usize,
    pub mem_gb: String,
    pub load_before: String,
    pub load_after: String,
    /// Seconds the whole measurement took.
    pub total: f64,
    /// This process's own peak memory, as text.
    pub own: String,
}

/// What the runs measured ([`super::runs`]).
pub(super) struct Runs {
    pub first: First,
    /// `(trials, threads, measured)`.
    pub no_iso: Vec<(u64, usize, Measured)>,
    /// `(poses, measured)`.
    pub pose_runs: Vec<(u64, Measured)>,
    pub rows: Rows,
    pub huge: Vec<Measured>,
}

/// The page.
pub(super) fn page(args: &TimingsArgs, scenario: &str, machine: &Machine, runs: &Runs) -> String {
    let Runs {
        first,
        no_iso,
        pose_runs,
        rows,
        huge,
    } = runs;
    let Machine {
        cpu,
        cores,
        mem_gb,
        load_before,
        load_after,
        total,
        own,
    } = machine;
    let total = *total;
    let First {
        first,
        no_budget,
        long,
        repeat,
        trials,
        rate,
        extra,
        budget,
        million,
    } = first;
    let (rate, extra, budget, million) = (*rate, *extra, *budget, *million);
    let Rows {
        robot,
        big_mb,
        identify,
        report_mb,
        predict,
        rows_identify,
    } = rows;
    let (big_mb, report_mb, rows_identify) = (*big_mb, *report_mb, *rows_identify);
    let no_iso_rows: String = no_iso
        .iter()
        .map(|(n, t, m)| {
            format!(
                "| {} | {t} | {} | {} |\n",
                thousands(*n),
                minutes(m.seconds),
                megabytes(m.peak_mb)
            )
        })
        .collect();
    // 10⁶ on two threads from the largest two-thread run (start-up included, so a slight
    // overestimate).
    let (n_big, _, m_big) = *no_iso.last().expect("at least one run");
    let no_iso_million = m_big.seconds * 1e6 / n_big as f64;
    let no_iso_100k = m_big.seconds * 1e5 / n_big as f64;

    let (n1, m1) = pose_runs[pose_runs.len() - 2];
    let (n2, m2) = pose_runs[pose_runs.len() - 1];
    let dn = (n2 - n1) as f64;
    let s_per_pose = (m2.seconds - m1.seconds) / dn;
    let mb_per_pose = (m2.peak_mb - m1.peak_mb) / dn;
    let to_million = 1e6 - n2 as f64;
    let million_poses_s = m2.seconds + to_million * s_per_pose;
    let million_poses_mb = m2.peak_mb + to_million * mb_per_pose;

    let pose_rows: String = pose_runs
        .iter()
        .map(|(n, m)| {
            format!(
                "| {} | {} | {} |\n",
                thousands(*n),
                minutes(m.seconds),
                megabytes(m.peak_mb)
            )
        })
        .collect();
    format!(
        "# Timings\n\n\
         Written by `cargo xtask timings` (do not edit by hand; it took {total} to measure all \
         of this); README.md, docs/scale.md and docs/performance.md cite these figures.\n\n\
         Machine: {cpu}, {cores} cores, {mem_gb} of memory; load average {load_before} before \
         and {load_after} after (a load above the core count means other processes shared the \
         cores: the times are then longer than on an idle machine). Binary: `{bin}`. Wall \
         time from spawn to exit; peak memory is the process's maximum resident set size \
         (`ru_maxrss`, which also counts the measuring process it was spawned from: {own} \
         here, a floor of these figures).\n\n\
         ## The first command and the trial rate\n\n\
         | what | command | wall time | peak memory |\n|---|---|---:|---:|\n\
         | the first command (200 trials, ISO test and residual budget on) | `kincal campaign {scenario}` | {first} (median of {repeat}) | {first_mb} |\n\
         | the same without the residual budget | `… --no-budget` | {no_budget} (median of {repeat}) | {no_budget_mb} |\n\
         | {trials} trials, budget off | `… --no-budget --trials {trials}` | {long} | {long_mb} |\n\n\
         Trial rate (ISO test on, all cores): {rate:.0} trials/s, from the {extra:.0} trials \
         beyond the first 200 of the last run. **10⁶ trials: about {million}**, extrapolated \
         from that rate plus the residual budget's fixed cost ({budget}); not run in full.\n\n\
         ## Trials and threads without the ISO test\n\n\
         `kincal campaign {scenario} --no-iso --no-budget --trials N --threads T` (the trials \
         alone):\n\n\
         | trials | threads | wall time | peak memory |\n|---:|---:|---:|---:|\n{no_iso_rows}\n\
         On two threads, extrapolated in proportion from the {n_big_fmt}-trial run (start-up \
         included, so slightly over), not run: **10⁵ trials (a sweep point of that size) about \
         {no_iso_100k}, 10⁶ trials about {no_iso_million}**.\n\n\
         ## Poses per trial\n\n\
         One trial of `{scenario}` with N identification poses (50 validation poses), on one \
         thread, residual budget off: `kincal campaign SCENARIO --trials 1 --threads 1 \
         --no-budget` on a copy of the scenario with `poses.identification` = N.\n\n\
         | N | wall time | peak memory |\n|---:|---:|---:|\n{pose_rows}\n\
         Per identification pose, from the last two: **{ms_per_pose:.2} ms and {kb_per_pose:.2} kB** \
         (per trial and worker thread). **10⁶ poses (the limit): about {million_poses} and \
         {million_poses_mem} per trial and thread**, extrapolated linearly from the \
         {n2}-pose run with these slopes (the identification's work and its Jacobian grow linearly \
         with the poses); not run in full.\n\n\
         ## A measurement file of many rows\n\n\
         The UR10 recording (`data/ur10-ipa/series-b-joint-configurations.csv`, 1,495 rows) \
         repeated to {rows_fmt} rows ({big_mb:.0} MB), robot `{robot}`.\n\n\
         | what | command | wall time | peak memory |\n|---|---|---:|---:|\n\
         | identify on every 1000th row ({rows_identify_fmt}), validate on the other {rows_validate_fmt} | `kincal identify --robot … --data FILE --every 1000 --out DIR` | {identify_s} | {identify_mb} |\n\
         | predict every row with the identified model | `kincal predict --robot DIR/identified.json --joints FILE --out F` | {predict_s} | {predict_mb} |\n\n\
         `report.html` of that run: {report_mb:.1} MB. Memory per row read: about \
         {bytes_per_row:.0} bytes (identify's peak divided by the rows).\n\n\
         ## Memory of a very long campaign\n\n\
         `kincal campaign {scenario} --trials 1000000000000` (ISO test and residual budget on), \
         stopped after {short_s:.0} s: peak memory {short_mb}; stopped after {huge_s:.0} s: \
         **{huge_mb}**. The aggregate is streamed and checkpointed, so the memory does not grow \
         with the trials run (the run itself would take years).\n",
        total = minutes(total),
        no_iso_million = minutes(no_iso_million),
        no_iso_100k = minutes(no_iso_100k),
        n_big_fmt = thousands(n_big),
        bin = args.kincal.display(),
        first_mb = megabytes(first.peak_mb),
        no_budget_mb = megabytes(no_budget.peak_mb),
        long_mb = megabytes(long.peak_mb),
        first = minutes(first.seconds),
        no_budget = minutes(no_budget.seconds),
        long = minutes(long.seconds),
        million = minutes(million),
        budget = minutes(budget),
        ms_per_pose = s_per_pose * 1e3,
        kb_per_pose = mb_per_pose * 1e3,
        million_poses = minutes(million_poses_s),
        million_poses_mem = megabytes(million_poses_mb),
        n2 = thousands(n2),
        rows_fmt = thousands(args.rows),
        rows_identify_fmt = thousands(rows_identify),
        rows_validate_fmt = thousands(args.rows - rows_identify),
        identify_s = minutes(identify.seconds),
        identify_mb = megabytes(identify.peak_mb),
        predict_s = minutes(predict.seconds),
        predict_mb = megabytes(predict.peak_mb),
        bytes_per_row = identify.peak_mb * 1e6 / args.rows as f64,
        short_s = huge[0].seconds,
        short_mb = megabytes(huge[0].peak_mb),
        huge_s = huge[1].seconds,
        huge_mb = megabytes(huge[1].peak_mb),
    )
}
