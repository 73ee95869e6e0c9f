//! Every command with standard output, then standard error, on a full device (`/dev/full`,
//! every write fails with ENOSPC): a clean exit, never a panic (status 101, "failed printing
//! to stdout"). Issue 39: a command whose results go to standard output ends with status 1
//! and says so on standard error; a command whose notes could not be written ends with
//! status 1 after its work; an error path with standard error full still ends with status 1.

use std::fs::File;
use std::path::Path;
use std::process::{Command, Output, Stdio};

use crate::common::{kr1000, ok, root, s, stderr};

#[derive(Clone, Copy, PartialEq)]
enum Stream {
    Stdout,
    Stderr,
}

fn full() -> File {
    File::options()
        .write(true)
        .open("/dev/full")
        .expect("/dev/full")
}

fn run_with_full(args: &[String], stream: Stream) -> Output {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_kincal"));
    cmd.args(args)
        .current_dir(root())
        .env("RUST_BACKTRACE", "0")
        .stdin(Stdio::null());
    match stream {
        Stream::Stdout => cmd.stdout(full()).stderr(Stdio::piped()),
        Stream::Stderr => cmd.stdout(Stdio::piped()).stderr(full()),
    };
    cmd.output().expect("run kincal")
}

/// One command of the list: its arguments, whether it prints results on standard output
/// and whether it writes anything on standard error, each of which must then fail it.
struct Case {
    args: Vec<String>,
    prints_stdout: bool,
    prints_stderr: bool,
    /// An error path: status 1 whichever stream is full.
    error: bool,
}

fn case(args: &[&str], prints_stdout: bool, prints_stderr: bool) -> Case {
    Case {
        args: args.iter().map(|a| a.to_string()).collect(),
        prints_stdout,
        prints_stderr,
        error: false,
    }
}

#[test]
fn every_command_exits_cleanly_with_stdout_or_stderr_on_a_full_device() {
    if !Path::new("/dev/full").exists() {
        panic!("/dev/full is missing: this test needs a Linux machine");
    }
    let tmp = tempfile::tempdir().unwrap();
    let t = |name: &str| tmp.path().join(name).to_str().unwrap().to_string();
    let ur10 = root().join("scenarios/robots/ur10.json");
    let data = root().join("data/ur10-ipa/series-b-joint-configurations.csv");
    let kr = kr1000();
    // Inputs the commands below read: one identification and the shards of a campaign.
    let cal = t("cal");
    ok(&crate::common::kincal(&[
        "identify",
        "--robot",
        s(&ur10),
        "--data",
        s(&data),
        "--every",
        "15",
        "--out",
        &cal,
    ]));
    let shards = t("shards");
    for k in ["0/2", "1/2"] {
        ok(&crate::common::kincal(&[
            "campaign",
            "scenarios/noise-floor.json",
            "--trials",
            "4",
            "--no-iso",
            "--no-budget",
            "--quiet",
            "--shard",
            k,
            "--out",
            &shards,
        ]));
    }
    let sweep = t("sweep.json");
    std::fs::write(
        &sweep,
        serde_json::json!({
            "name": "full-device",
            "scenario": s(&root().join("scenarios/noise-floor.json")),
            "trials": 2,
            "axes": [{ "path": "poses.identification", "values": [30, 40] }],
            "plots": [{ "y": "after_mean_mm" }]
        })
        .to_string(),
    )
    .unwrap();
    let identified = format!("{cal}/identified.json");
    let registered = format!("{cal}/registered-nominal.json");
    let (shard0, shard1) = (
        format!("{shards}/shard-0-of-2.json"),
        format!("{shards}/shard-1-of-2.json"),
    );
    let cases = [
        case(
            &[
                "campaign",
                "scenarios/noise-floor.json",
                "--trials",
                "4",
                "--no-iso",
                "--no-budget",
                "--out",
                &t("campaign"),
            ],
            true,
            true,
        ),
        case(
            &["merge", &shard0, &shard1, "--out", &t("merged")],
            true,
            true,
        ),
        case(&["sweep", &sweep, "--out", &t("swept")], true, true),
        case(
            &["simulate", "scenarios/noise-floor.json", "--out", &t("sim")],
            false,
            true,
        ),
        case(
            &[
                "identify",
                "--robot",
                s(&ur10),
                "--data",
                s(&data),
                "--every",
                "15",
                "--out",
                &t("cal2"),
            ],
            true,
            false,
        ),
        case(
            &[
                "predict",
                "--robot",
                &identified,
                "--joints",
                s(&data),
                "--out",
                &t("p.csv"),
            ],
            false,
            true,
        ),
        case(
            &["predict", "--robot", &identified, "--joints", s(&data)],
            true,
            true,
        ),
        case(
            &[
                "compensate",
                "--robot",
                &identified,
                "--nominal",
                &registered,
                "--targets",
                s(&data),
                "--out",
                &t("c.csv"),
            ],
            false,
            true,
        ),
        case(
            &["identifiability", "--robot", s(kr), "--random-poses", "50"],
            true,
            false,
        ),
        case(
            &[
                "design",
                "--robot",
                s(kr),
                "--scenario",
                "scenarios/paper-kr1000.json",
                "--random",
                "200",
                "--poses",
                "30",
                "--out",
                &t("plan.csv"),
            ],
            true,
            false,
        ),
        case(
            &["urdf", "export", &identified, "--out", &t("robot.urdf")],
            true,
            false,
        ),
        // With `--out -` the URDF is on stdout and the notes go to stderr.
        case(&["urdf", "export", &identified, "--out", "-"], true, true),
        // An error path: the data file does not exist.
        case(
            &[
                "identify",
                "--robot",
                s(&ur10),
                "--data",
                "no-such-file.csv",
                "--out",
                &t("never"),
            ],
            false,
            true,
        ),
    ];
    let mut cases = cases;
    cases.last_mut().unwrap().error = true;
    for c in &cases {
        for stream in [Stream::Stdout, Stream::Stderr] {
            let out = run_with_full(&c.args, stream);
            let code = out.status.code();
            let what = format!(
                "{:?} with {} full: {:?}\nstdout: {}\nstderr: {}",
                c.args,
                if stream == Stream::Stdout {
                    "stdout"
                } else {
                    "stderr"
                },
                out.status,
                String::from_utf8_lossy(&out.stdout),
                stderr(&out)
            );
            assert_ne!(code, Some(101), "a panic: {what}");
            assert!(!stderr(&out).contains("panicked"), "{what}");
            let must_fail = match stream {
                Stream::Stdout => c.prints_stdout,
                Stream::Stderr => c.prints_stderr,
            };
            if must_fail || c.error {
                assert_eq!(code, Some(1), "{what}");
            } else {
                assert_eq!(code, Some(0), "{what}");
            }
            if stream == Stream::Stdout && c.prints_stdout {
                assert!(
                    stderr(&out).contains("error: writing to standard output"),
                    "{what}"
                );
            }
        }
    }
}

/// An output that is the same file as an input, through any spelling (the path itself, a
/// `..` detour, a symbolic link, a hard link), is refused before any work, naming both
/// arguments, and the input is left as it was (issue 39).
#[test]
fn an_output_that_is_an_input_is_refused_and_the_input_kept() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path();
    let data = dir.join("m.csv");
    std::fs::copy(
        root().join("data/ur10-ipa/series-b-joint-configurations.csv"),
        &data,
    )
    .unwrap();
    let robot = dir.join("r.json");
    std::fs::copy(root().join("scenarios/robots/ur10.json"), &robot).unwrap();
    std::os::unix::fs::symlink(&data, dir.join("link.csv")).unwrap();
    std::fs::hard_link(&robot, dir.join("hard.json")).unwrap();
    std::fs::create_dir(dir.join("sub")).unwrap();
    let before = (
        std::fs::read(&data).unwrap(),
        std::fs::read(&robot).unwrap(),
    );
    let (d, r) = (s(&data), s(&robot));
    let detour = format!("{}/sub/../m.csv", s(dir));
    let link = format!("{}/link.csv", s(dir));
    let hard = format!("{}/hard.json", s(dir));
    let cal = dir.join("cal");
    std::fs::create_dir(&cal).unwrap();
    let in_cal = cal.join("identified.json");
    std::fs::copy(&robot, &in_cal).unwrap();
    let cases: Vec<(Vec<&str>, &str, &str)> = vec![
        (
            vec!["predict", "--robot", r, "--joints", d, "--out", d],
            "--out",
            "--joints",
        ),
        (
            vec!["predict", "--robot", r, "--joints", d, "--out", &detour],
            "--out",
            "--joints",
        ),
        (
            vec!["predict", "--robot", r, "--joints", d, "--out", &link],
            "--out",
            "--joints",
        ),
        (
            vec!["predict", "--robot", r, "--joints", d, "--out", &hard],
            "--out",
            "--robot",
        ),
        (
            vec![
                "compensate",
                "--robot",
                r,
                "--nominal",
                r,
                "--targets",
                d,
                "--out",
                d,
            ],
            "--out",
            "--targets",
        ),
        (
            vec![
                "design",
                "--robot",
                r,
                "--candidates",
                d,
                "--poses",
                "20",
                "--out",
                d,
            ],
            "--out",
            "--candidates",
        ),
        (
            vec!["urdf", "export", r, "--out", r],
            "--out",
            "the robot file",
        ),
        (
            vec![
                "identify",
                "--robot",
                s(&in_cal),
                "--data",
                d,
                "--out",
                s(&cal),
            ],
            "--robot",
            "identified.json",
        ),
    ];
    for (args, a, b) in &cases {
        let out = crate::common::kincal(args);
        let msg = stderr(&out);
        assert_eq!(out.status.code(), Some(1), "{args:?}: {msg}");
        assert!(msg.contains(a) && msg.contains(b), "{args:?}: {msg}");
        assert!(
            msg.contains("its own input") || msg.contains("overwrite its own input"),
            "{args:?}: {msg}"
        );
        assert_eq!(
            (
                std::fs::read(&data).unwrap(),
                std::fs::read(&robot).unwrap()
            ),
            before,
            "{args:?} changed an input"
        );
    }
    // A different file of the same name elsewhere is not an input.
    let other = dir.join("sub/m.csv");
    ok(&crate::common::kincal(&[
        "predict",
        "--robot",
        r,
        "--joints",
        d,
        "--out",
        s(&other),
    ]));
}

/// `--threads` far beyond the cores is capped with a note, and the run's results are those
/// of any other thread count.
#[test]
fn threads_beyond_the_cores_are_capped_with_a_note() {
    let tmp = tempfile::tempdir().unwrap();
    let run = |threads: &str, out: &str| {
        crate::common::kincal(&[
            "campaign",
            "scenarios/noise-floor.json",
            "--trials",
            "5",
            "--no-iso",
            "--no-budget",
            "--quiet",
            "--threads",
            threads,
            "--out",
            out,
        ])
    };
    let (a, b) = (
        tmp.path().join("a").to_str().unwrap().to_string(),
        tmp.path().join("b").to_str().unwrap().to_string(),
    );
    let started = std::time::Instant::now();
    let big = run("100000", &a);
    ok(&big);
    let msg = stderr(&big);
    assert!(msg.contains("--threads 100000 capped at"), "{msg}");
    ok(&run("1", &b));
    assert_eq!(
        std::fs::read(format!("{a}/summary.json")).unwrap(),
        std::fs::read(format!("{b}/summary.json")).unwrap()
    );
    eprintln!(
        "5 trials at --threads 100000: {:.1} s",
        started.elapsed().as_secs_f64()
    );
}
