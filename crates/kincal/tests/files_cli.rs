//! Command-line tests of issue 30, with real processes: output targets (a FIFO, a symbolic
//! link, `--out -`), concurrent `identify` runs into one output directory, a closed stdout
//! (broken pipe), sizes from input, settings checked before the work, runs with overridden
//! settings kept out of `results/`, failed campaigns, plain progress lines.

use std::io::Read as _;
use std::os::unix::process::ExitStatusExt as _;
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};

use crate::common::{dir_set, kincal, ok, root, s, stderr};

fn ur10() -> PathBuf {
    root().join("scenarios/robots/ur10.json")
}

fn ur10_data() -> PathBuf {
    root().join("data/ur10-ipa/series-b-joint-configurations.csv")
}

fn mkfifo(path: &Path) {
    let st = Command::new("mkfifo").arg(path).status().expect("mkfifo");
    assert!(st.success());
}

/// `predict --out FIFO`, `compensate --out FIFO`, `design --out FIFO`: refused before any
/// work, naming the FIFO, which stays a FIFO; a dangling link is refused and stays; a link
/// to a regular file is followed (the file is replaced, the link stays a link); `--out -`
/// writes to stdout.
#[test]
fn fifo_and_link_targets_are_refused_or_followed_and_dash_is_stdout() {
    let tmp = tempfile::tempdir().unwrap();
    let fifo = tmp.path().join("fifo");
    mkfifo(&fifo);
    let (robot, data) = (ur10(), ur10_data());
    let predict = |out: &Path| {
        kincal(&[
            "predict",
            "--robot",
            s(&robot),
            "--joints",
            s(&data),
            "--out",
            s(out),
        ])
    };
    let e = predict(&fifo);
    assert_eq!(e.status.code(), Some(1), "{}", stderr(&e));
    assert!(stderr(&e).contains("is a FIFO"), "{}", stderr(&e));
    assert!(stderr(&e).contains("--out"), "{}", stderr(&e));
    let e = kincal(&[
        "compensate",
        "--robot",
        s(&robot),
        "--nominal",
        s(&robot),
        "--targets",
        s(&data),
        "--out",
        s(&fifo),
    ]);
    assert_eq!(e.status.code(), Some(1), "{}", stderr(&e));
    assert!(stderr(&e).contains("is a FIFO"), "{}", stderr(&e));
    let e = kincal(&[
        "design",
        "--robot",
        s(&robot),
        "--candidates",
        s(&data),
        "--poses",
        "20",
        "--out",
        s(&fifo),
    ]);
    assert_eq!(e.status.code(), Some(1), "{}", stderr(&e));
    assert!(stderr(&e).contains("is a FIFO"), "{}", stderr(&e));
    let e = kincal(&[
        "identify",
        "--robot",
        s(&robot),
        "--data",
        s(&data),
        "--every",
        "15",
        "--out",
        s(&fifo),
    ]);
    assert_eq!(e.status.code(), Some(1), "{}", stderr(&e));
    assert!(stderr(&e).contains("is a FIFO"), "{}", stderr(&e));
    use std::os::unix::fs::FileTypeExt as _;
    assert!(
        std::fs::symlink_metadata(&fifo)
            .unwrap()
            .file_type()
            .is_fifo(),
        "the FIFO stays a FIFO"
    );

    // A dangling link: refused, left as it is.
    let dangling = tmp.path().join("dangling");
    std::os::unix::fs::symlink(tmp.path().join("nowhere"), &dangling).unwrap();
    let e = predict(&dangling);
    assert_eq!(e.status.code(), Some(1));
    assert!(stderr(&e).contains("does not exist"), "{}", stderr(&e));
    assert!(std::fs::symlink_metadata(&dangling).unwrap().is_symlink());
    assert!(!tmp.path().join("nowhere").exists());

    // A link to a regular file: the file is replaced, the link stays.
    let target = tmp.path().join("target.csv");
    std::fs::write(&target, "old\n").unwrap();
    let link = tmp.path().join("link.csv");
    std::os::unix::fs::symlink(&target, &link).unwrap();
    ok(&predict(&link));
    assert!(std::fs::symlink_metadata(&link).unwrap().is_symlink());
    let written = std::fs::read_to_string(&target).unwrap();
    assert!(written.lines().count() > 1000, "{written:.200}");

    // `--out -`: the same bytes on stdout.
    let out = ok(&predict(Path::new("-")));
    assert_eq!(out, written);
    assert!(!root().join("-").exists());
}

/// A child whose stdout is closed before it writes (`kincal predict … | head -0`): it stops
/// quietly, killed by SIGPIPE (status 141 in a shell) or with status 0, never a panic
/// (status 101, "failed printing to stdout").
#[test]
fn a_closed_stdout_stops_every_printing_command_quietly() {
    let (robot, data) = (ur10(), ur10_data());
    let kr = root().join("scenarios/robots/kr1000-titan.json");
    let commands: Vec<Vec<String>> = vec![
        vec!["predict", "--robot", s(&robot), "--joints", s(&data)],
        vec![
            "compensate",
            "--robot",
            s(&robot),
            "--nominal",
            s(&robot),
            "--targets",
            s(&data),
        ],
        vec!["identifiability", "--robot", s(&kr), "--random-poses", "50"],
    ]
    .into_iter()
    .map(|v| v.into_iter().map(String::from).collect())
    .collect();
    for args in commands {
        let mut child = Command::new(env!("CARGO_BIN_EXE_kincal"))
            .args(&args)
            .current_dir(root())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        drop(child.stdout.take()); // the reader goes away before the first write
        let mut err = String::new();
        child
            .stderr
            .take()
            .unwrap()
            .read_to_string(&mut err)
            .unwrap();
        let status = child.wait().unwrap();
        assert!(
            status.signal() == Some(13) || status.code() == Some(0),
            "{args:?}: {status:?}\n{err}"
        );
        assert!(!err.contains("panicked"), "{args:?}: {err}");
        assert!(!err.contains("Broken pipe"), "{args:?}: {err}");
    }
}

/// Two `identify` runs started together into one `--out`, `KINCAL_CONCURRENT_RUNS` pairs
/// (default 3): the directory always holds one run's complete set (0 mixed sets), and a
/// run either wrote its set or was refused naming the holder (0 silent losses: a run that
/// exits 0 while the other holds the lock cannot happen, the lock refuses it).
#[test]
fn concurrent_identify_runs_into_one_out_never_mix_their_sets() {
    let pairs: usize = std::env::var("KINCAL_CONCURRENT_RUNS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(3);
    let tmp = tempfile::tempdir().unwrap();
    let (robot, data) = (ur10(), ur10_data());
    let args = |every: &str, out: &Path| -> Vec<String> {
        [
            "identify",
            "--robot",
            s(&robot),
            "--data",
            s(&data),
            "--every",
            every,
            "--out",
            s(out),
        ]
        .map(String::from)
        .to_vec()
    };
    // The two sets, each written alone.
    let reference = |every: &str| {
        let out = tmp.path().join(format!("ref-{every}"));
        ok(&kincal(
            &args(every, &out)
                .iter()
                .map(String::as_str)
                .collect::<Vec<_>>(),
        ));
        dir_set(&out)
    };
    let (a, b) = (reference("15"), reference("16"));
    assert_ne!(a["identified.json"], b["identified.json"]);
    let shared = tmp.path().join("shared");
    let (mut refused, mut both) = (0, 0);
    for pair in 0..pairs {
        let spawn = |every: &str| {
            Command::new(env!("CARGO_BIN_EXE_kincal"))
                .args(args(every, &shared))
                .current_dir(root())
                .stdout(Stdio::null())
                .stderr(Stdio::piped())
                .spawn()
                .unwrap()
        };
        let (ca, cb) = (spawn("15"), spawn("16"));
        let (oa, ob) = (
            ca.wait_with_output().unwrap(),
            cb.wait_with_output().unwrap(),
        );
        let set = dir_set(&shared);
        assert!(
            set == a || set == b,
            "pair {pair}: a mixed set: {:?}",
            set.keys().collect::<Vec<_>>()
        );
        match (oa.status.success(), ob.status.success()) {
            (true, true) => both += 1,
            (true, false) | (false, true) => {
                let loser = if oa.status.success() { &ob } else { &oa };
                let e = stderr(loser);
                assert!(e.contains("another run is writing"), "pair {pair}: {e}");
                assert!(e.contains("pid "), "pair {pair}: {e}");
                // The winner's set is the one in place.
                let winner_set = if oa.status.success() { &a } else { &b };
                assert_eq!(&set, winner_set, "pair {pair}: the winner's set was lost");
                refused += 1;
            }
            (false, false) => panic!("pair {pair}: both failed: {}", stderr(&oa)),
        }
    }
    eprintln!("{pairs} pairs: {refused} with one refused, {both} one after the other, 0 mixed");
    // Nothing hidden is left beside the directory but the lock file.
    let leftovers: Vec<String> = std::fs::read_dir(tmp.path())
        .unwrap()
        .flatten()
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| n.starts_with(".shared.") && !n.ends_with("kincal-lock"))
        .collect();
    assert!(leftovers.is_empty(), "{leftovers:?}");
}

/// Sizes from input are refused before anything is allocated, with the field or option:
/// 1e8 and 1e18 identification poses in a scenario, `identifiability --random-poses 1e9`,
/// `design --random 1e18`.
#[test]
fn oversize_counts_are_refused_before_allocation() {
    let tmp = tempfile::tempdir().unwrap();
    let text = std::fs::read_to_string(root().join("scenarios/paper-kr1000.json")).unwrap();
    let mut v: serde_json::Value = serde_json::from_str(&text).unwrap();
    v["robot"] = root()
        .join("scenarios/robots/kr1000-titan.json")
        .to_str()
        .unwrap()
        .into();
    for n in [100_000_000u64, 1_000_000_000_000_000_000] {
        v["poses"]["identification"] = n.into();
        let file = tmp.path().join(format!("big-{n}.json"));
        std::fs::write(&file, v.to_string()).unwrap();
        let out_dir = tmp.path().join("out");
        let e = kincal(&["campaign", s(&file), "--out", s(&out_dir)]);
        assert_eq!(e.status.code(), Some(1), "{n}: {}", stderr(&e));
        let msg = stderr(&e);
        assert!(msg.contains("field `poses.identification`"), "{msg}");
        assert!(msg.contains("more than the limit of 1000000"), "{msg}");
        assert!(!out_dir.exists());
    }
    let kr = root().join("scenarios/robots/kr1000-titan.json");
    let e = kincal(&[
        "identifiability",
        "--robot",
        s(&kr),
        "--random-poses",
        "1000000000",
    ]);
    assert_eq!(e.status.code(), Some(1), "{}", stderr(&e));
    assert!(
        stderr(&e).contains("--random-poses 1000000000"),
        "{}",
        stderr(&e)
    );
    assert!(stderr(&e).contains("limit"), "{}", stderr(&e));
    let e = kincal(&[
        "design",
        "--robot",
        s(&kr),
        "--scenario",
        s(&root().join("scenarios/paper-kr1000.json")),
        "--random",
        "1000000000000000000",
        "--poses",
        "30",
        "--out",
        s(&tmp.path().join("plan.csv")),
    ]);
    assert_eq!(e.status.code(), Some(1), "{}", stderr(&e));
    assert!(
        stderr(&e).contains("--random 1000000000000000000"),
        "{}",
        stderr(&e)
    );
}

/// Runs `kincal` in `dir` with stderr not a terminal and progress lines every 0 s.
fn kincal_in(dir: &Path, args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_kincal"))
        .args(args)
        .current_dir(dir)
        .env("RUST_BACKTRACE", "0")
        .env("KINCAL_PROGRESS_SECONDS", "0")
        .output()
        .unwrap()
}

/// A campaign with `--trials` and no `--out` writes to `runs/<name>-trials-N…`, never into
/// `results/<name>`, and says so; `--threads 0` is refused; progress goes to stderr as plain
/// lines when stderr is not a terminal; a campaign whose every trial fails exits 1 (its
/// outputs list the causes).
#[test]
fn overridden_runs_stay_out_of_results_and_failures_are_errors() {
    let tmp = tempfile::tempdir().unwrap();
    let scenario = root().join("scenarios/paper-kr1000.json");
    let e = kincal_in(tmp.path(), &["campaign", s(&scenario), "--threads", "0"]);
    assert_eq!(e.status.code(), Some(1));
    assert!(stderr(&e).contains("--threads 0"), "{}", stderr(&e));
    assert!(stderr(&e).contains("all cores"), "{}", stderr(&e));

    let out = kincal_in(
        tmp.path(),
        &[
            "campaign",
            s(&scenario),
            "--trials",
            "2",
            "--no-iso",
            "--no-budget",
            "--quiet",
        ],
    );
    let err = stderr(&out);
    assert!(out.status.success(), "{err}");
    let expected = Path::new("runs/paper-kr1000-trials-2-no-iso-no-budget");
    assert!(
        tmp.path().join(expected).join("summary.json").exists(),
        "{err}"
    );
    assert!(!tmp.path().join("results").exists(), "{err}");
    assert!(err.contains("note: the settings differ"), "{err}");
    assert!(err.contains(s(expected)), "{err}");
    assert!(err.contains("trials: 2 of 2 (100.0 %)"), "{err}");

    // Every trial fails: 3 identification poses for 34 parameters.
    let mut v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&scenario).unwrap()).unwrap();
    v["robot"] = root()
        .join("scenarios/robots/kr1000-titan.json")
        .to_str()
        .unwrap()
        .into();
    v["poses"]["identification"] = 3.into();
    v["trials"] = 2.into();
    let file = tmp.path().join("fails.json");
    std::fs::write(&file, v.to_string()).unwrap();
    let out_dir = tmp.path().join("fails");
    let e = kincal_in(
        tmp.path(),
        &[
            "campaign",
            s(&file),
            "--no-iso",
            "--no-budget",
            "--out",
            s(&out_dir),
        ],
    );
    assert_eq!(e.status.code(), Some(1), "{}", stderr(&e));
    assert!(stderr(&e).contains("no trial succeeded"), "{}", stderr(&e));
    assert!(out_dir.join("summary.md").exists());
}

/// A sweep whose plot names an unknown metric is refused before any point runs, naming the
/// plot and listing the metrics.
#[test]
fn a_sweep_with_a_bad_plot_metric_is_refused_before_any_point() {
    let tmp = tempfile::tempdir().unwrap();
    let sweep = serde_json::json!({
        "name": "bad-plot",
        "scenario": s(&root().join("scenarios/paper-kr1000.json")),
        "trials": 2,
        "axes": [{ "path": "poses.identification", "values": [20, 30] }],
        "plots": [{ "y": "after_mean_mm" }, { "y": "no_such_metric" }]
    });
    let file = tmp.path().join("sweep.json");
    std::fs::write(&file, sweep.to_string()).unwrap();
    let out_dir = tmp.path().join("out");
    let started = std::time::Instant::now();
    let e = kincal_in(tmp.path(), &["sweep", s(&file), "--out", s(&out_dir)]);
    assert_eq!(e.status.code(), Some(1), "{}", stderr(&e));
    let msg = stderr(&e);
    assert!(msg.contains("no_such_metric"), "{msg}");
    assert!(msg.contains("after_mean_mm"), "{msg}");
    assert!(!msg.contains("point 1/"), "a point ran: {msg}");
    assert!(!out_dir.exists());
    eprintln!("refused in {:.2} s", started.elapsed().as_secs_f64());
}
