//! Mutation fuzzing of the campaign crate's readers of outside input — scenario, sweep,
//! shard and checkpoint files (see `measurements/tests/mutate/mod.rs`): no panic, no hang,
//! every rejection names the file and a line or field. Run with `--nocapture` for the
//! case counts.

use std::cell::RefCell;
use std::path::{Path, PathBuf};

use crate::mutate::{Tally, apply, mutations, names_file_and_place};
use campaign::{
    Checkpoint, CheckpointManifest, Context, Scenario, ShardFile, ShardManifest, SweepSpec,
    merge_shards, run_range, shard_range,
};
use proptest::test_runner::TestRunner;

fn scenarios() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenarios")
}

/// A reader under test: the bytes and the file it names.
type Reader<'a> = dyn Fn(&[u8], &Path) -> Result<(), String> + 'a;

/// Runs `cases` mutations of `seed` through `read` (which gets the bytes and the file to
/// name); returns the tally.
fn fuzz(what: &str, seed: &[u8], cases: u32, read: &Reader<'_>) -> Tally {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join(format!("{what}.json"));
    read(seed, &file).unwrap_or_else(|e| panic!("the {what} seed is valid: {e}"));
    let tally = RefCell::new(Tally::default());
    let mut runner = TestRunner::new(crate::mutate::config(cases));
    let name = file.display().to_string();
    runner
        .run(&mutations(), |muts| {
            let input = apply(seed, &muts);
            let result = std::panic::AssertUnwindSafe(|| read(&input, &file));
            tally
                .borrow_mut()
                .case(&input, result, |m| names_file_and_place(m, &name))
        })
        .unwrap();
    let t = tally.into_inner();
    eprintln!("{what} fuzz: {t:?}");
    assert!(t.rejected > t.cases / 4, "{t:?}");
    t
}

/// Non-UTF-8 input goes through the file, as the readers see it.
fn text_or_file<'a>(bytes: &'a [u8], file: &Path) -> Option<&'a str> {
    match std::str::from_utf8(bytes) {
        Ok(t) => Some(t),
        Err(_) => {
            std::fs::write(file, bytes).unwrap();
            None
        }
    }
}

fn read_scenario(bytes: &[u8], file: &Path) -> Result<(), String> {
    let label = file.display().to_string();
    let loaded = match text_or_file(bytes, file) {
        Some(text) => Scenario::from_json_str(text, &label)
            .and_then(|s| s.load(&scenarios(), &label))
            .map_err(|e| e.to_string())?,
        None => Scenario::from_file(file).map_err(|e| e.to_string())?,
    };
    assert!(loaded.scenario.trials >= 1);
    Ok(())
}

#[test]
fn mutated_scenario_files_are_read_or_refused_clearly() {
    let seed = std::fs::read(scenarios().join("paper-kr1000.json")).unwrap();
    fuzz("scenario", &seed, 1500, &read_scenario);
}

#[test]
fn mutated_sweep_files_are_read_or_refused_clearly() {
    let seed = std::fs::read(scenarios().join("sweeps/pose-count.json")).unwrap();
    fuzz("sweep", &seed, 800, &|bytes, file| {
        std::fs::write(file, bytes).unwrap();
        let spec = SweepSpec::from_file(file).map_err(|e| e.to_string())?;
        // Every combination of the axes is computed without trouble.
        let _ = spec.combinations().len();
        Ok(())
    });
}

/// Two shards of a two-trial campaign (ISO off: smaller files), and the context.
pub(crate) fn shards() -> (Context, [ShardFile; 2]) {
    let mut loaded = Scenario::from_file(&scenarios().join("paper-kr1000.json")).unwrap();
    loaded.scenario.iso.enabled = false;
    loaded.scenario.residual_budget.enabled = false;
    loaded.scenario.trials = 2;
    let scenario = loaded.scenario.clone();
    let ctx = Context::new(loaded).unwrap();
    let shard = |k: u64| {
        let range = shard_range(2, k, 2);
        ShardFile {
            manifest: ShardManifest {
                scenario: scenario.clone(),
                version: "fuzz".into(),
                shard: k,
                shards: 2,
                first_trial: range.start,
                end_trial: range.end,
            },
            aggregate: run_range(&ctx, range, &|_| {}),
            residual_budget: None,
            digest: None,
        }
    };
    let files = [shard(0), shard(1)];
    (ctx, files)
}

#[test]
fn mutated_shard_and_checkpoint_files_are_read_or_refused_clearly() {
    let (ctx, [s0, s1]) = shards();
    let seed = s0.to_json_string().unwrap().into_bytes();
    fuzz("shard", &seed, 400, &|bytes, file| {
        let label = file.display().to_string();
        let shard = match text_or_file(bytes, file) {
            Some(text) => ShardFile::from_json_str(text, &label),
            None => ShardFile::from_file(file),
        }
        .map_err(|e| e.to_string())?;
        // Merging a damaged but parseable shard is refused, or gives a summary.
        let (scenario, agg) = merge_shards(&[shard, s1.clone()])
            .map_err(|e| format!("{label}: field `merge`: {e}"))?;
        let _ = campaign::CampaignSummary::new(&scenario, &agg);
        Ok(())
    });
    let checkpoint = Checkpoint {
        manifest: CheckpointManifest::new("campaign", &ctx, 0..2, "fuzz"),
        next_trial: 1,
        aggregate: s0.aggregate.clone(),
        wall_seconds: 1.5,
    };
    let seed = serde_json::to_vec(&checkpoint).unwrap();
    fuzz("checkpoint", &seed, 400, &|bytes, file| {
        std::fs::write(file, bytes).unwrap();
        match Checkpoint::read(file).map_err(|e| e.to_string())? {
            Some(c) => {
                let _ = c.manifest.differences(&checkpoint.manifest);
                Ok(())
            }
            None => unreachable!("the file is there"),
        }
    });
}

/// Regression corpus: inputs the fuzzers (or the fault-path review) found mishandled.
#[test]
fn corpus_of_found_cases_is_refused_clearly() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("case.json");
    let label = file.display().to_string();
    // 1. A huge number in a scenario was written out with 309 digits.
    let mut v: serde_json::Value =
        serde_json::from_slice(&std::fs::read(scenarios().join("paper-kr1000.json")).unwrap())
            .unwrap();
    v["unmodelled"]["compliance"]["counterbalance_fraction"][0] = serde_json::json!(1e308);
    let err = read_scenario(v.to_string().as_bytes(), &file).unwrap_err();
    assert!(
        err.contains("1e308") && err.contains("counterbalance_fraction"),
        "{err}"
    );
    //    The same in the LM options (found by the fuzzer in a later session: μ0 = −1e308
    //    was printed in full).
    v["unmodelled"]["compliance"]["counterbalance_fraction"][0] = serde_json::json!(0);
    v["identification"]["lm"]["damping"]["mu0"] = serde_json::json!(-1e308);
    let err = read_scenario(v.to_string().as_bytes(), &file).unwrap_err();
    assert!(
        err.contains("-1e308") && err.contains("damping.mu0") && err.len() < 400,
        "{err}"
    );
    // 2. A shard claiming 2^64 - 1 shards sized an allocation from it (abort); 3. a trial
    //    count near 2^64 overflowed the shard range.
    let (_, [s0, s1]) = shards();
    let mut huge = s0.clone();
    huge.manifest.shards = u64::MAX;
    let text = huge.to_json_string().unwrap();
    let parsed = ShardFile::from_json_str(&text, &label).unwrap();
    let err = merge_shards(&[parsed, s1.clone()]).unwrap_err().to_string();
    assert!(err.contains("2 shard file(s)"), "{err}");
    let mut many = s0.clone();
    many.manifest.scenario.trials = u64::MAX;
    let err = merge_shards(&[many, s1]).unwrap_err().to_string();
    assert!(err.contains("expected 0..9223372036854775807"), "{err}");
    assert_eq!(shard_range(u64::MAX, 3, 4), u64::MAX / 4 * 3 + 2..u64::MAX);
    // 4. Non-UTF-8 in a shard file names the file and line.
    std::fs::write(&file, b"{\n\"manifest\": \xff}").unwrap();
    let err = ShardFile::from_file(&file).unwrap_err().to_string();
    assert!(
        err.starts_with(&format!("{label}:2: not valid UTF-8")),
        "{err}"
    );
}
