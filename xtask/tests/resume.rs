//! Killing a campaign with SIGKILL at many moments and resuming it gives the uninterrupted
//! run's bytes (issue 23): the xtask binary itself is run, killed and rerun with `--resume`.

mod common;

use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::Duration;

use common::root as repo;

const TRIALS: &str = "120";
/// SIGKILLs in all.
const KILLS: usize = 24;

fn campaign(out: &Path, extra: &[&str]) -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_xtask"));
    c.current_dir(repo())
        .args([
            "campaign",
            "scenarios/paper-kr1000.json",
            "--no-iso",
            // The budget's reruns come after the last checkpoint; off, the kills spread over
            // the checkpointed trials this test is about.
            "--no-budget",
            "--quiet",
        ])
        .args(["--trials", TRIALS, "--threads", "2", "--out"])
        .arg(out)
        .args(extra)
        .env_remove("RUST_BACKTRACE")
        .stdout(Stdio::null())
        .stderr(Stdio::piped());
    c
}

/// The output files that must match byte for byte (timing.json is wall-clock).
fn outputs(dir: &Path) -> Vec<(String, Vec<u8>)> {
    let mut v: Vec<(String, Vec<u8>)> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap())
        .map(|e| (e.file_name().to_string_lossy().into_owned(), e.path()))
        .filter(|(n, _)| n != "timing.json")
        .map(|(n, p)| (n, std::fs::read(p).unwrap()))
        .collect();
    v.sort();
    v
}

/// A small deterministic generator for the kill moments.
fn next(state: &mut u64) -> u64 {
    *state = state
        .wrapping_mul(6_364_136_223_846_793_005)
        .wrapping_add(1_442_695_040_888_963_407);
    *state >> 33
}

fn finish(mut child: Child) -> std::process::ExitStatus {
    let status = child.wait().unwrap();
    if !status.success() {
        let mut err = String::new();
        use std::io::Read;
        child
            .stderr
            .take()
            .unwrap()
            .read_to_string(&mut err)
            .unwrap();
        panic!("campaign failed: {err}");
    }
    status
}

#[test]
fn sigkill_at_many_moments_then_resume_gives_the_same_bytes() {
    let tmp = tempfile::tempdir().unwrap();
    let reference = tmp.path().join("reference");
    finish(campaign(&reference, &[]).spawn().unwrap());
    let expected = outputs(&reference);
    assert!(expected.iter().any(|(n, _)| n == "summary.json"));

    let mut rng = 0x2023_u64;
    let (mut kills, mut runs) = (0, 0);
    // Kill moments seen: how far the checkpoint was when killed, and kills that left a
    // half-written temporary behind (a kill during an atomic write).
    let mut progress_at_kill = std::collections::BTreeSet::new();
    let mut during_write = 0;
    let hidden = |dir: &Path| -> std::collections::BTreeSet<String> {
        std::fs::read_dir(dir)
            .map(|d| {
                d.map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
                    .filter(|n| n.starts_with('.'))
                    .collect()
            })
            .unwrap_or_default()
    };
    while kills < KILLS {
        runs += 1;
        let dir = tmp.path().join(format!("run-{runs}"));
        loop {
            let mut child = campaign(&dir, &["--resume", "--checkpoint-every", "2"])
                .spawn()
                .unwrap();
            if kills >= KILLS {
                finish(child);
                break;
            }
            // Mostly 100 to 400 ms (after start-up: between and during checkpoint writes),
            // every fifth kill within the first 100 ms (during start-up).
            let delay_us = if kills % 5 == 4 {
                next(&mut rng) % 100_000
            } else {
                100_000 + next(&mut rng) % 300_000
            };
            let before = hidden(&dir);
            std::thread::sleep(Duration::from_micros(delay_us));
            if child.try_wait().unwrap().is_some() {
                finish(child);
                break;
            }
            child.kill().unwrap(); // SIGKILL
            child.wait().unwrap();
            kills += 1;
            if hidden(&dir).difference(&before).next().is_some() {
                during_write += 1;
            }
            progress_at_kill.insert(match std::fs::read(dir.join("checkpoint.json")) {
                Ok(text) => {
                    let v: serde_json::Value = serde_json::from_slice(&text).unwrap();
                    v["next_trial"].as_u64().unwrap()
                }
                Err(_) => 0,
            });
        }
        let got = outputs(&dir);
        let names = |v: &[(String, Vec<u8>)]| v.iter().map(|(n, _)| n.clone()).collect::<Vec<_>>();
        assert_eq!(
            names(&got),
            names(&expected),
            "run {runs}: files (checkpoint left?)"
        );
        for ((name, a), (_, b)) in got.iter().zip(&expected) {
            assert!(
                a == b,
                "run {runs}: {name} differs from the uninterrupted run"
            );
        }
    }
    eprintln!(
        "{kills} kills over {runs} runs; checkpoint positions at kill: {progress_at_kill:?}; \
         {during_write} kills during a checkpoint write"
    );
    // The kills landed at many different points of the runs.
    assert!(progress_at_kill.len() >= 8, "{progress_at_kill:?}");
}

/// A tiny sweep file in `dir`: four points of the paper scenario (ISO test, recovery and
/// budget off), 16 trials each; `shown` picks one of two sets of the settings that only change
/// how the results are shown (name, description, axis label, plots), the work is the same.
fn tiny_sweep(dir: &Path, shown: usize) -> PathBuf {
    let scenario = repo().join("scenarios/paper-kr1000.json");
    let (name, description, label, plots) = match shown {
        0 => (
            "tiny-sweep",
            "The error after calibration against the identification poses.",
            "poses",
            serde_json::json!([
                { "x": "poses.identification", "y": "after_mean_mm", "log_y": true }
            ]),
        ),
        _ => (
            "tiny-sweep-renamed",
            "Another description.",
            "identification poses",
            serde_json::json!([
                { "y": "lm_iterations" },
                { "x": "poses.identification", "y": "after_max_mm", "log_y": false }
            ]),
        ),
    };
    let sweep = serde_json::json!({
        "name": name,
        "description": description,
        "scenario": scenario,
        "trials": 16,
        "overrides": {
            "iso.enabled": false,
            "recovery.enabled": false,
            "residual_budget.enabled": false
        },
        "axes": [
            { "path": "poses.identification", "label": label, "values": [20, 30, 40, 50] }
        ],
        "plots": plots
    });
    let path = dir.join(format!("sweep-{shown}.json"));
    std::fs::write(&path, serde_json::to_string_pretty(&sweep).unwrap()).unwrap();
    path
}

fn sweep(file: &Path, out: &Path, extra: &[&str]) -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_xtask"));
    c.current_dir(repo())
        .arg("sweep")
        .arg(file)
        .args(["--threads", "2", "--out"])
        .arg(out)
        .args(extra)
        .env_remove("RUST_BACKTRACE")
        .stdout(Stdio::null())
        .stderr(Stdio::piped());
    c
}

/// A sweep killed after its first point (its checkpoint written), then its name, description,
/// axis label and plots changed, then resumed: it finishes with the bytes of an uninterrupted
/// run of the changed sweep file (the resume ignores how the results are shown, and shows
/// them as the file now says).
#[test]
fn a_sweep_resumed_after_its_plots_and_labels_changed_gives_the_changed_runs_bytes() {
    let tmp = tempfile::tempdir().unwrap();
    let before = tiny_sweep(tmp.path(), 0);
    let after = tiny_sweep(tmp.path(), 1);
    let reference = tmp.path().join("reference");
    finish(sweep(&after, &reference, &[]).spawn().unwrap());
    let expected = outputs(&reference);
    let names: Vec<&str> = expected.iter().map(|(n, _)| n.as_str()).collect();
    assert!(names.contains(&"sweep.json"), "{names:?}");

    // The first run, killed once its checkpoint holds a finished point and a point in progress.
    let dir = tmp.path().join("run");
    let checkpoint = dir.join("sweep-checkpoint.json");
    let mut child = sweep(&before, &dir, &["--resume", "--checkpoint-every", "2"])
        .spawn()
        .unwrap();
    let started = std::time::Instant::now();
    loop {
        let progress = std::fs::read(&checkpoint).ok().and_then(|text| {
            let v: serde_json::Value = serde_json::from_slice(&text).ok()?;
            Some((v["points"].as_array()?.len(), !v["current"].is_null()))
        });
        if progress.is_some_and(|(done, current)| done >= 1 && current) {
            break;
        }
        assert!(
            child.try_wait().unwrap().is_none(),
            "the sweep finished before it could be interrupted: give it more work"
        );
        assert!(
            started.elapsed() < Duration::from_secs(300),
            "no checkpoint"
        );
        std::thread::sleep(Duration::from_millis(2));
    }
    child.kill().unwrap(); // SIGKILL
    child.wait().unwrap();
    let saved: serde_json::Value =
        serde_json::from_slice(&std::fs::read(&checkpoint).expect("a checkpoint after the kill"))
            .unwrap();
    let done = saved["points"].as_array().unwrap().len();
    assert!((1..4).contains(&done), "{done} points done at the kill");
    // The checkpoint was written with the first settings.
    assert_eq!(saved["spec"]["name"], "tiny-sweep");
    assert!(!dir.join("sweep.json").exists(), "outputs before the end");

    // Resumed with the changed file: no refusal, and the changed run's bytes.
    let resumed = sweep(&after, &dir, &["--resume", "--checkpoint-every", "2"])
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&resumed.stderr);
    assert!(resumed.status.success(), "resume refused: {stderr}");
    let got = outputs(&dir);
    let got_names: Vec<&str> = got.iter().map(|(n, _)| n.as_str()).collect();
    assert_eq!(got_names, names, "files (checkpoint left?)");
    for ((name, a), (_, b)) in got.iter().zip(&expected) {
        assert!(
            a == b,
            "{name} differs from the uninterrupted run of the changed sweep"
        );
    }
}
