//! Issue 30 in the campaign crate: trailing content after a JSON document is refused with
//! its line and column (scenario, sweep, shard, robot, virtual-robot sections), shard files
//! carry a digest and an edited one is refused naming it, and the settings that only change
//! how a sweep is shown do not block its resume.

use std::path::{Path, PathBuf};

use campaign::{Scenario, ShardFile, SweepSpec};

fn scenarios() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenarios")
}

fn trailing_refused(what: &str, e: impl std::fmt::Display) {
    let e = e.to_string();
    assert!(e.contains("trailing characters at line"), "{what}: {e}");
    assert!(e.contains("column"), "{what}: {e}");
}

#[test]
fn trailing_content_after_a_json_document_is_refused_with_line_and_column() {
    let read = |p: &str| std::fs::read_to_string(scenarios().join(p)).unwrap();
    let scenario = read("paper-kr1000.json");
    // Trailing white space is fine; `xx` after the closing brace is not.
    Scenario::from_json_str(&format!("{scenario}\n \n"), "s.json").unwrap();
    trailing_refused(
        "scenario",
        Scenario::from_json_str(&format!("{scenario}xx"), "s.json").unwrap_err(),
    );
    let e = Scenario::from_json_str(&format!("{scenario}{{}}"), "s.json").unwrap_err();
    trailing_refused("scenario", &e);
    assert!(e.to_string().starts_with("s.json: "), "{e}");

    let robot = read("robots/kr1000-titan.json");
    kinematics::RobotSpec::from_json_str(&robot, "r.json").unwrap();
    trailing_refused(
        "robot",
        kinematics::RobotSpec::from_json_str(&format!("{robot}xx"), "r.json").unwrap_err(),
    );

    trailing_refused(
        "virtual robot",
        virtual_robot::VirtualRobotConfig::from_json_str("{}\nxx").unwrap_err(),
    );

    let tmp = tempfile::tempdir().unwrap();
    let sweep_text = read("sweeps/pose-count.json");
    let sweep = tmp.path().join("sweep.json");
    std::fs::write(&sweep, format!("{sweep_text}xx")).unwrap();
    let e = SweepSpec::from_file(&sweep).unwrap_err();
    trailing_refused("sweep", &e);
    assert!(e.to_string().contains("sweep.json"), "{e}");

    let (_, [s0, _]) = crate::fuzz::shards();
    let text = s0.to_json_string().unwrap();
    ShardFile::from_json_str(&text, "shard.json").unwrap();
    trailing_refused(
        "shard",
        ShardFile::from_json_str(&format!("{text}xx"), "shard.json").unwrap_err(),
    );
}

/// The edits: a sum multiplied by 1000, `trials` changed, the file truncated, the
/// digest removed: each refused on reading, naming the file. The untouched file is read
/// back equal.
#[test]
fn an_edited_or_truncated_shard_is_refused_naming_it() {
    let (_, [s0, _]) = crate::fuzz::shards();
    let text = s0.to_json_string().unwrap();
    let back = ShardFile::from_json_str(&text, "shard-0-of-2.json").unwrap();
    assert_eq!(back.aggregate, s0.aggregate);
    assert_eq!(back.manifest, s0.manifest);

    // Text edits, as a user with an editor would make them.
    let after = |key: &str| text.find(key).map(|i| i + key.len()).expect(key);
    let digits_end = |from: usize| {
        from + text[from..]
            .find(|c: char| !(c.is_ascii_digit() || c == '-'))
            .unwrap()
    };
    let sum_at = after("\"sum_q\":");
    let sum_end = digits_end(sum_at);
    assert!(
        sum_end > sum_at && &text[sum_at..sum_end] != "0",
        "a nonzero sum"
    );
    let trials_at = after("\"aggregate\":{\"trials\":");
    let trials_end = digits_end(trials_at);
    let digest_at = text.find(",\"digest\":").expect("a digest");
    let cases = vec![
        (
            "a sum × 1000",
            format!("{}000{}", &text[..sum_end], &text[sum_end..]),
        ),
        (
            "trials edited",
            format!("{}1000{}", &text[..trials_at], &text[trials_end..]),
        ),
        ("digest removed", format!("{}}}", &text[..digest_at])),
        ("truncated", text[..text.len() / 2].to_string()),
    ];
    for (what, bad) in cases {
        let e = ShardFile::from_json_str(&bad, "shard-0-of-2.json").unwrap_err();
        let msg = e.to_string();
        assert!(msg.starts_with("shard-0-of-2.json"), "{what}: {msg}");
        if what != "truncated" {
            assert!(
                msg.contains("digest") || msg.contains("trials"),
                "{what}: {msg}"
            );
        }
    }
}

/// Every metric a campaign records is one a sweep plot may name (`METRICS`).
#[test]
fn every_recorded_metric_is_listed() {
    let (_, [s0, s1]) = crate::fuzz::shards();
    for s in [s0, s1] {
        for k in s.aggregate.metrics.keys() {
            assert!(
                campaign::METRICS.contains(&k.as_str()),
                "{k} missing from METRICS"
            );
        }
    }
}

/// What a sweep checkpoint must match: the work (scenario, trials, overrides, axis paths and
/// values), not the name, description, labels or plots.
#[test]
fn plots_and_labels_do_not_change_a_sweeps_work() {
    let text = std::fs::read_to_string(scenarios().join("sweeps/pose-count.json")).unwrap();
    let a: SweepSpec = serde_json::from_str(&text).unwrap();
    let mut b = a.clone();
    b.plots.clear();
    b.description = "other".into();
    b.axes[0].label = Some("other label".into());
    assert_eq!(a.work(), b.work());
    let mut c = a.clone();
    c.trials += 1;
    assert_ne!(a.work(), c.work());
    let mut d = a.clone();
    d.axes[0].values.pop();
    assert_ne!(a.work(), d.work());
}

/// `timing.json` after a resume reports the whole run: a checkpoint that says the run has
/// taken 1000 s so far (2 of 4 trials), resumed, gives at least 1000 s and a trial rate
/// over the whole run.
#[test]
fn timing_after_a_resume_counts_every_segment() {
    use campaign::{CampaignRun, Checkpoint, CheckpointManifest, Checkpointing, Context};
    let file = scenarios().join("paper-kr1000.json");
    let mut loaded = Scenario::from_file(&file).unwrap();
    loaded.scenario.iso.enabled = false;
    loaded.scenario.residual_budget.enabled = false;
    loaded.scenario.trials = 4;
    let ctx = Context::new(loaded).unwrap();
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("out");
    std::fs::create_dir(&out).unwrap();
    Checkpoint {
        manifest: CheckpointManifest::new("campaign", &ctx, 0..4, &campaign::code_version()),
        next_trial: 2,
        aggregate: campaign::run_range(&ctx, 0..2, &|_| {}),
        wall_seconds: 1000.0,
    }
    .write(&out.join("checkpoint.json"))
    .unwrap();
    let mut run = CampaignRun::new(&file);
    run.trials = Some(4);
    run.iso_off = true;
    run.budget_off = true;
    run.out = Some(out.clone());
    run.checkpoint = Some(Checkpointing {
        resume: true,
        every_trials: None,
    });
    run.run(&campaign::Silent).unwrap();
    let t: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("timing.json")).unwrap()).unwrap();
    let wall = t["wall_seconds"].as_f64().unwrap();
    assert!((1000.0..1100.0).contains(&wall), "{t}");
    assert!(
        t["trials_per_second"].as_f64().unwrap() < 4.0 / 1000.0 + 1e-12,
        "{t}"
    );
    assert!(!out.join("checkpoint.json").exists());
}

/// An observer that asks the run to stop once `after` trials are done.
struct StopAfter {
    after: u64,
    done: std::sync::atomic::AtomicU64,
}

impl campaign::Observer for StopAfter {
    fn trials_done(&self, k: u64) {
        self.done.fetch_add(k, std::sync::atomic::Ordering::Relaxed);
    }
    fn stop_requested(&self) -> bool {
        self.done.load(std::sync::atomic::Ordering::Relaxed) >= self.after
    }
}

/// A run stopped by its observer (Ctrl-C in Python) ends with `Stopped` before its
/// remaining trials, writes no outputs and keeps the checkpoint it wrote last; resumed, it
/// gives the bytes of an uninterrupted run. The in-memory run (Python's) stops the same way.
#[test]
fn a_stopped_run_keeps_its_checkpoint_and_resumes_to_the_same_bytes() {
    use campaign::{CampaignError, CampaignRun, Checkpointing, Silent};
    let file = scenarios().join("paper-kr1000.json");
    let tmp = tempfile::tempdir().unwrap();
    let run = |out: &Path, resume: bool, observer: &dyn campaign::Observer| {
        let mut run = CampaignRun::new(&file);
        run.trials = Some(12);
        run.iso_off = true;
        run.budget_off = true;
        run.threads = Some(1);
        run.out = Some(out.to_path_buf());
        run.checkpoint = Some(Checkpointing {
            resume,
            every_trials: Some(2),
        });
        run.run(observer)
    };
    let whole = tmp.path().join("whole");
    run(&whole, false, &Silent).unwrap();
    let out = tmp.path().join("stopped");
    let stop = StopAfter {
        after: 5,
        done: Default::default(),
    };
    let e = run(&out, false, &stop).unwrap_err();
    assert!(matches!(e, CampaignError::Stopped { done: 4 }), "{e}");
    assert!(stop.done.load(std::sync::atomic::Ordering::Relaxed) < 12);
    assert!(out.join("checkpoint.json").exists());
    assert!(!out.join("summary.json").exists());
    run(&out, true, &Silent).unwrap();
    assert_eq!(
        std::fs::read_to_string(out.join("summary.json")).unwrap(),
        std::fs::read_to_string(whole.join("summary.json")).unwrap()
    );
    let mut loaded = Scenario::from_file(&file).unwrap();
    loaded.scenario.trials = 12;
    let stop = StopAfter {
        after: 1,
        done: Default::default(),
    };
    let e = campaign::summarize(loaded, Some(1), &stop).unwrap_err();
    assert!(matches!(e, CampaignError::Stopped { .. }), "{e}");
    assert!(stop.done.load(std::sync::atomic::Ordering::Relaxed) < 12);
}

/// A scenario copied elsewhere without its `robots/` names the robot path as relative to the
/// scenario file's directory.
#[test]
fn a_missing_robot_file_is_named_as_relative_to_the_scenario() {
    let text = std::fs::read_to_string(scenarios().join("paper-kr1000.json")).unwrap();
    let tmp = tempfile::tempdir().unwrap();
    let copy = tmp.path().join("copy.json");
    std::fs::write(&copy, &text).unwrap();
    let e = Scenario::from_file(&copy).unwrap_err().to_string();
    assert!(
        e.contains("relative to the scenario file's directory"),
        "{e}"
    );
    assert!(e.contains("robots/kr1000-titan.json"), "{e}");
}

/// The default checkpoint cadence is by time: a run shorter than `every` writes no
/// checkpoint between its chunks (it wrote one after every chunk of 64 trials per thread,
/// a third of a campaign's time), and `every_trials = k` writes one every k trials. The
/// aggregate does not depend on the chunking.
#[test]
fn checkpoints_follow_their_cadence_and_leave_the_aggregate_alone() {
    use campaign::{CheckpointConfig, Context, run_chunks};
    let file = scenarios().join("paper-kr1000.json");
    let mut loaded = Scenario::from_file(&file).unwrap();
    loaded.scenario.iso.enabled = false;
    loaded.scenario.residual_budget.enabled = false;
    let ctx = Context::new(loaded).unwrap();
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(2)
        .build()
        .unwrap();
    let whole = pool.install(|| campaign::run_range(&ctx, 0..40, &|_| {}));
    let saves = |cfg: &CheckpointConfig| {
        let mut at = Vec::new();
        let agg = pool.install(|| {
            run_chunks(
                &ctx,
                0..40,
                campaign::Aggregate::default(),
                cfg,
                &|_| {},
                &|| false,
                &mut |n, _| {
                    at.push(n);
                    Ok(())
                },
            )
            .unwrap()
        });
        assert_eq!(agg, whole, "{cfg:?}");
        at
    };
    let tmp = tempfile::tempdir().unwrap();
    let mut cfg = pool.install(|| {
        CheckpointConfig::new(tmp.path().join("checkpoint.json"), false, "test".into())
    });
    assert_eq!((cfg.chunk_trials, cfg.every_trials), (128, None));
    cfg.chunk_trials = 8;
    assert_eq!(saves(&cfg), Vec::<u64>::new());
    cfg.every_trials = Some(16);
    assert_eq!(saves(&cfg), vec![16, 32]);
    cfg.every_trials = None;
    cfg.every = std::time::Duration::ZERO;
    assert_eq!(saves(&cfg), vec![8, 16, 24, 32]);
}
