//! `cargo xtask timings`: measures the times and sizes the docs state, on the scenario as
//! committed, and writes them with the machine into `docs/timings.md`. README.md and
//! docs/scale.md cite that file; nothing there is measured by hand.
//!
//! - The first command (`kincal campaign scenarios/paper-kr1000.json`, 200 trials with the
//!   ISO test and the residual budget), the same without the budget, and the trial rate of a
//!   longer run, from which the time of 10⁶ trials is extrapolated (stated as such).
//! - Trials and threads without the ISO test (docs/performance.md): 10³ and 10⁴ trials on
//!   one and two threads, 2·10⁴ on two, with their peak memory; 10⁵ and 10⁶ extrapolated.
//! - Poses per trial: one trial on one thread with a few identification pose counts (the
//!   largest well below the limit of 10⁶, to keep the run short); time and memory per pose
//!   are the slopes between the two largest, and 10⁶ poses are extrapolated from them.
//! - A measurement file of 10⁶ rows (the UR10 recording repeated) through `identify --every
//!   1000` and `predict`: wall time, peak memory, the size of `report.html`.
//! - A campaign of 10¹² trials, stopped after a few seconds: its peak memory (the aggregate
//!   is streamed, so it does not grow with the trial count).
//!
//! Each command is a child process of the given `kincal` binary, timed from spawn to exit;
//! its peak memory is the child's maximum resident set size (`wait4`'s `ru_maxrss`). Linux
//! counts in it the memory of the process it was spawned from (the child starts as a copy
//! of, or sharing, this one), so this process keeps its own peak small (a few MB, stated).

use std::io::Write as _;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use anyhow::{Context as _, Result, bail};

/// Arguments of `timings`.
#[derive(clap::Args)]
pub struct TimingsArgs {
    /// The `kincal` binary to time [target/release/kincal]. Build it first
    /// (`cargo build --release -p kincal`).
    #[arg(long, default_value = "target/release/kincal")]
    pub kincal: PathBuf,
    /// Trials of the run that measures the trial rate (ISO test on, budget off).
    #[arg(long, default_value_t = 2000)]
    pub trials: u64,
    /// Repetitions of the first command (the median is reported).
    #[arg(long, default_value_t = 3)]
    pub repeat: usize,
    /// Identification pose counts of the one-trial runs, comma-separated, increasing [2000,
    /// 20000, 200000: the largest takes seconds and about 0.6 GB, a fifth of the limit]; the
    /// per-pose slopes come from the last two.
    #[arg(long, value_delimiter = ',', default_value = "2000,20000,200000")]
    pub poses: Vec<u64>,
    /// Rows of the large measurement file [10⁶, the largest file the docs speak of].
    #[arg(long, default_value_t = 1_000_000)]
    pub rows: u64,
    /// Largest trial count of the runs without the ISO test (on two threads; 10³ and 10⁴
    /// also run on one) [20,000: about 3 s on an idle 2-core machine; 10⁵ and 10⁶ are
    /// extrapolated from it].
    #[arg(long, default_value_t = 20_000)]
    pub no_iso_trials: u64,
    /// Seconds the 10¹²-trial campaign runs before it is stopped [15: long enough to be
    /// past the residual budget and into the streamed trials].
    #[arg(long, default_value_t = 15)]
    pub huge_seconds: u64,
    /// Output file.
    #[arg(long, default_value = "docs/timings.md")]
    pub out: PathBuf,
}

fn load_average() -> String {
    std::fs::read_to_string("/proc/loadavg")
        .ok()
        .and_then(|s| s.split_whitespace().next().map(String::from))
        .unwrap_or_else(|| "unknown".into())
}

/// What one child process took.
#[derive(Clone, Copy)]
struct Measured {
    /// Wall seconds from spawn to exit.
    seconds: f64,
    /// Peak resident memory in MB (10⁶ bytes).
    peak_mb: f64,
}

/// Runs `kincal args…` and measures it; it must succeed. With `stop_after`, it is killed
/// (SIGKILL) after that long if still running (and then counts as measured).
fn measure(
    kincal: &Path,
    args: &[&str],
    tmp: &Path,
    stop_after: Option<Duration>,
) -> Result<Measured> {
    let stderr_path = tmp.join("stderr.txt");
    let stderr = std::fs::File::create(&stderr_path)
        .with_context(|| format!("creating {}", stderr_path.display()))?;
    let started = Instant::now();
    let child = Command::new(kincal)
        .args(args)
        .env("CI", "1")
        .stdout(Stdio::null())
        .stderr(stderr)
        .spawn()
        .with_context(|| format!("running {}", kincal.display()))?;
    let pid = libc::pid_t::try_from(child.id()).context("child pid")?;
    let mut killed = false;
    let (status, max_rss_kib) = loop {
        let poll = stop_after.is_some() && !killed;
        if let Some(done) = wait4(pid, poll).context("waiting for kincal")? {
            break done;
        }
        // Still running (polled).
        if stop_after.is_some_and(|d| started.elapsed() >= d) {
            kill(pid);
            killed = true;
        } else {
            std::thread::sleep(Duration::from_millis(20));
        }
    };
    let seconds = started.elapsed().as_secs_f64();
    let exited_ok = libc::WIFEXITED(status) && libc::WEXITSTATUS(status) == 0;
    if !killed && !exited_ok {
        bail!(
            "{} {}: {}",
            kincal.display(),
            args.join(" "),
            std::fs::read_to_string(&stderr_path).unwrap_or_default()
        );
    }
    // Reaped above: dropping the handle does not wait again.
    drop(child);
    Ok(Measured {
        seconds,
        // ru_maxrss is in KiB on Linux.
        peak_mb: max_rss_kib as f64 * 1024.0 / 1e6,
    })
}

/// Waits for the child `pid` (`poll`: returns `None` at once if it is still running) and
/// returns its wait status and peak resident set size in KiB (`ru_maxrss`, Linux units).
#[allow(unsafe_code)]
fn wait4(pid: libc::pid_t, poll: bool) -> std::io::Result<Option<(libc::c_int, i64)>> {
    let flags = if poll { libc::WNOHANG } else { 0 };
    loop {
        let mut status: libc::c_int = 0;
        // SAFETY: `rusage` is a plain C struct for which all-zero bytes are a valid value.
        let mut usage: libc::rusage = unsafe { std::mem::zeroed() };
        // SAFETY: `pid` is a child of this process that nothing else waits for (its
        // `std::process::Child` is never waited on); both pointers are to live locals.
        let r = unsafe { libc::wait4(pid, &mut status, flags, &mut usage) };
        if r == pid {
            return Ok(Some((status, usage.ru_maxrss)));
        }
        if r == 0 {
            return Ok(None);
        }
        let e = std::io::Error::last_os_error();
        if e.kind() != std::io::ErrorKind::Interrupted {
            return Err(e);
        }
    }
}

/// Sends SIGKILL to the child `pid` (not yet reaped, so the pid is still ours).
#[allow(unsafe_code)]
fn kill(pid: libc::pid_t) {
    // SAFETY: `kill` has no memory-safety preconditions; the pid is our unreaped child.
    unsafe {
        libc::kill(pid, libc::SIGKILL);
    }
}

fn median(mut v: Vec<Measured>) -> Measured {
    v.sort_by(|a, b| a.seconds.total_cmp(&b.seconds));
    v[v.len() / 2]
}

fn minutes(s: f64) -> String {
    if s < 90.0 {
        format!("{s:.1} s")
    } else if s < 5400.0 {
        format!("{:.0} min {:.0} s", (s / 60.0).floor(), (s % 60.0).floor())
    } else {
        format!(
            "{:.0} h {:.0} min",
            (s / 3600.0).floor(),
            ((s % 3600.0) / 60.0).floor()
        )
    }
}

fn megabytes(mb: f64) -> String {
    if mb < 1000.0 {
        format!("{mb:.0} MB")
    } else {
        format!("{:.1} GB", mb / 1000.0)
    }
}

/// `1000000` → `1,000,000`.
fn thousands(n: u64) -> String {
    let s = n.to_string();
    let mut out = String::new();
    for (i, c) in s.chars().enumerate() {
        if i > 0 && (s.len() - i).is_multiple_of(3) {
            out.push(',');
        }
        out.push(c);
    }
    out
}

/// The paper scenario with `poses` identification poses, written into `dir` (its robot path
/// made absolute, as the copy is elsewhere).
fn scenario_with_poses(root: &Path, scenario: &str, poses: u64, dir: &Path) -> Result<PathBuf> {
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
fn repeated_rows(source: &Path, rows: u64, out: &Path) -> Result<()> {
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

/// This process's own peak resident memory in MB (`VmHWM` of `/proc/self/status`).
fn own_peak_mb() -> Option<f64> {
    let s = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = s.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kib: f64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib * 1024.0 / 1e6)
}

/// `cargo xtask timings`.
pub fn run(args: &TimingsArgs) -> Result<()> {
    let kincal = args.kincal.canonicalize().with_context(|| {
        format!(
            "{}: build it first (cargo build --release -p kincal) or name another with --kincal",
            args.kincal.display()
        )
    })?;
    if args.poses.len() < 2 || args.poses.windows(2).any(|w| w[0] >= w[1]) {
        bail!("--poses: need at least two increasing counts, e.g. 2000,20000,200000");
    }
    let root = std::env::current_dir().context("current directory")?;
    let tmp = std::env::temp_dir().join(format!("kincal-timings-{}", std::process::id()));
    std::fs::create_dir_all(&tmp).with_context(|| format!("creating {}", tmp.display()))?;
    let result = measure_all(args, &kincal, &root, &tmp);
    let _ = std::fs::remove_dir_all(&tmp);
    let text = result?;
    std::fs::write(&args.out, &text).with_context(|| format!("writing {}", args.out.display()))?;
    print!("{text}");
    Ok(())
}

fn measure_all(args: &TimingsArgs, kincal: &Path, root: &Path, tmp: &Path) -> Result<String> {
    let out = |name: &str| tmp.join(name).display().to_string();
    let scenario = "scenarios/paper-kr1000.json";
    let load_before = load_average();
    let started = Instant::now();

    // The first command, with and without the budget, and the trial rate.
    let repeat = args.repeat.max(1);
    let mut first = Vec::new();
    let mut no_budget = Vec::new();
    for i in 0..repeat {
        let o = out(&format!("first-{i}"));
        first.push(measure(
            kincal,
            &["campaign", scenario, "--quiet", "--out", &o],
            tmp,
            None,
        )?);
        let o = out(&format!("no-budget-{i}"));
        no_budget.push(measure(
            kincal,
            &["campaign", scenario, "--no-budget", "--quiet", "--out", &o],
            tmp,
            None,
        )?);
    }
    let (first, no_budget) = (median(first), median(no_budget));
    let trials = args.trials.to_string();
    let o = out("rate");
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

    // Trials and threads, ISO test and budget off (the trials alone).
    let mut no_iso = Vec::new();
    let mut counts: Vec<u64> = [1_000, 10_000]
        .into_iter()
        .filter(|&n| n < args.no_iso_trials)
        .collect();
    counts.push(args.no_iso_trials);
    for &n in &counts {
        let threads: &[usize] = if n <= 10_000 { &[1, 2] } else { &[2] };
        for &t in threads {
            let o = out(&format!("no-iso-{n}-{t}"));
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

    // Poses per trial: one trial, one thread, budget off (its reruns are a fixed extra).
    let mut pose_runs = Vec::new();
    for &n in &args.poses {
        let file = scenario_with_poses(root, scenario, n, tmp)?;
        let file = file.display().to_string();
        let o = out(&format!("poses-{n}"));
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
    let (n1, m1) = pose_runs[pose_runs.len() - 2];
    let (n2, m2) = pose_runs[pose_runs.len() - 1];
    let dn = (n2 - n1) as f64;
    let s_per_pose = (m2.seconds - m1.seconds) / dn;
    let mb_per_pose = (m2.peak_mb - m1.peak_mb) / dn;
    let to_million = 1e6 - n2 as f64;
    let million_poses_s = m2.seconds + to_million * s_per_pose;
    let million_poses_mb = m2.peak_mb + to_million * mb_per_pose;

    // A measurement file of many rows through identify and predict.
    let robot = "scenarios/robots/ur10.json";
    let source = root.join("data/ur10-ipa/series-b-joint-configurations.csv");
    let big = tmp.join("rows.csv");
    repeated_rows(&source, args.rows, &big)?;
    let big_mb = std::fs::metadata(&big)?.len() as f64 / 1e6;
    let big = big.display().to_string();
    let cal = out("rows-identify");
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
    let predicted = out("rows-predicted.csv");
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

    // 10¹² trials, stopped after a third of the time and after all of it: the memory of a
    // streamed aggregate, which must not grow with the trials run.
    let mut huge = Vec::new();
    for (i, seconds) in [args.huge_seconds.div_ceil(3), args.huge_seconds]
        .into_iter()
        .enumerate()
    {
        let o = out(&format!("huge-{i}"));
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
    let load_after = load_average();
    let total = started.elapsed().as_secs_f64();
    let own = own_peak_mb().map_or_else(|| "unknown".into(), megabytes);

    let cpu = campaign::cpu_model_name().unwrap_or_else(|| "unknown CPU".into());
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    let mem_gb = machine_memory_gb();
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
    Ok(format!(
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
    ))
}

/// The machine's memory (`MemTotal` of `/proc/meminfo`), e.g. "24.7 GB".
fn machine_memory_gb() -> String {
    std::fs::read_to_string("/proc/meminfo")
        .ok()
        .and_then(|s| {
            let line = s.lines().find(|l| l.starts_with("MemTotal:"))?;
            let kib: f64 = line.split_whitespace().nth(1)?.parse().ok()?;
            Some(format!("{:.1} GB", kib * 1024.0 / 1e9))
        })
        .unwrap_or_else(|| "unknown".into())
}
