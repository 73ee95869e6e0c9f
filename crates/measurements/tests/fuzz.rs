//! Mutation fuzzing of the measurement-file reader (see `mutate/mod.rs`): no panic, no hang,
//! every rejection names the file and, where the fault is on a line, the line. Run with
//! `--nocapture` to see the case counts.

use std::cell::RefCell;

use crate::mutate::{Tally, apply, mutations};
use measurements::{ReadOptions, read_file, read_str};
use proptest::test_runner::TestRunner;

/// A valid file: the first rows of the real UR10 series B, a comment, an `id` column.
fn seed() -> Vec<u8> {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../data/ur10-ipa/series-b-joint-configurations.csv"
    );
    let text = std::fs::read_to_string(path).unwrap();
    let mut out = String::from("# UR10 series B, first rows\n");
    for (i, line) in text.lines().take(8).enumerate() {
        if i == 0 {
            out.push_str(&format!("id,{line}\n"));
        } else {
            out.push_str(&format!("p{i},{line}\n"));
        }
    }
    out.into_bytes()
}

fn options() -> [ReadOptions; 2] {
    let mut joints_only = ReadOptions::new(6).with_limits_deg(vec![[-360.0, 360.0]; 6]);
    joints_only.require_points = false;
    [ReadOptions::new(6), joints_only]
}

/// Reads `bytes` as a file; the message if rejected, checked for naming.
fn read(bytes: &[u8], dir: &std::path::Path, opts: &ReadOptions) -> Result<(), String> {
    let path = dir.join("m.csv");
    // Through the file for non-UTF-8 (the check is read_file's), else straight from text.
    let result = match std::str::from_utf8(bytes) {
        Ok(text) => read_str(text, &path.display().to_string(), opts),
        Err(_) => {
            std::fs::write(&path, bytes).unwrap();
            read_file(&path, opts)
        }
    };
    match result {
        Ok(set) => {
            // Whatever is accepted is finite.
            assert!(
                set.rows
                    .iter()
                    .all(|r| r.q_deg.iter().all(|v| v.is_finite()))
            );
            Ok(())
        }
        Err(e) => {
            let msg = e.to_string();
            let file = path.display().to_string();
            assert_eq!(e.file(), file);
            if !msg.starts_with(&file) {
                return Err(format!("BAD does not start with the file: {msg}"));
            }
            if let Some(l) = e.line()
                && !msg.starts_with(&format!("{file}:{l}:"))
            {
                return Err(format!("BAD line {l} not in the message: {msg}"));
            }
            Err(msg)
        }
    }
}

#[test]
fn mutated_measurement_files_are_read_or_refused_clearly() {
    let dir = tempfile::tempdir().unwrap();
    let seed = seed();
    for opts in options() {
        read(&seed, dir.path(), &opts).expect("the seed is valid");
    }
    let tally = RefCell::new(Tally::default());
    let mut runner = TestRunner::new(crate::mutate::config(3000));
    runner
        .run(&mutations(), |muts| {
            let input = apply(&seed, &muts);
            for opts in options() {
                let d = dir.path();
                let i = input.clone();
                tally.borrow_mut().case(
                    &input,
                    move || read(&i, d, &opts),
                    |msg| msg.starts_with("BAD").then(|| msg.to_string()),
                )?;
            }
            Ok(())
        })
        .unwrap();
    let t = tally.into_inner();
    eprintln!("measurements fuzz: {t:?}");
    assert!(t.rejected > t.cases / 4 && t.accepted > 0, "{t:?}");
}
