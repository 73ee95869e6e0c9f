//! Mutation fuzzing of the URDF import (the shared mutator of
//! `measurements/tests/mutate/mod.rs`): the two vendor fixtures with 1 to 4 mutations each
//! (bytes flipped or inserted, truncation, lines deleted or duplicated, numbers and strings
//! swapped for NaN, inf, 1e308, empty, non-UTF-8, …). No panic, no hang; an accepted file
//! gives a robot with finite points; every rejection names the file and the element (or is
//! the XML parser's message, prefixed with the file). Run with `--nocapture` for the counts.

use std::cell::RefCell;
use std::path::Path;

use crate::mutate::{Tally, apply, mutations};
use kinematics::Robot;
use proptest::test_runner::TestRunner;
use urdf::{ImportOptions, import_file, import_str};

fn import(bytes: &[u8], dir: &Path) -> Result<(), String> {
    let path = dir.join("robot.urdf");
    let opts = ImportOptions::default();
    let result = match std::str::from_utf8(bytes) {
        Ok(text) => import_str(
            text,
            &path.display().to_string(),
            "base_link",
            "tool0",
            &opts,
        ),
        Err(_) => {
            std::fs::write(&path, bytes).unwrap();
            import_file(&path, "base_link", "tool0", &opts)
        }
    };
    let imported = result.map_err(|e| e.to_string())?;
    let robot = Robot::from_spec(&imported.spec).map_err(|e| e.to_string())?;
    let p = robot.point(&vec![0.0; robot.n_joints()]);
    assert!(p.iter().all(|v| v.is_finite()), "{p:?}");
    Ok(())
}

/// What is wrong with a rejection message, if anything.
fn unclear(msg: &str, file: &str) -> Option<String> {
    if !msg.starts_with(file) {
        return Some(format!("does not start with {file}"));
    }
    let names_place = msg.contains('<')
        || msg.contains("not a readable URDF")
        || msg.contains("cannot read")
        || msg.contains("joint_names[")
        || msg.contains('`');
    (!names_place).then(|| "names no element".to_string())
}

#[test]
fn mutated_urdf_files_are_imported_or_refused_clearly() {
    let dir = tempfile::tempdir().unwrap();
    let fixtures = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/fixtures");
    let seeds: Vec<Vec<u8>> = ["ur10.urdf", "kuka_kr210l150.urdf"]
        .iter()
        .map(|f| std::fs::read(Path::new(fixtures).join(f)).unwrap())
        .collect();
    for s in &seeds {
        import(s, dir.path()).expect("the fixtures import");
    }
    let file = dir.path().join("robot.urdf").display().to_string();
    let tally = RefCell::new(Tally::default());
    let mut runner = TestRunner::new(crate::mutate::config(1000));
    runner
        .run(&(0..seeds.len(), mutations()), |(k, muts)| {
            let input = apply(&seeds[k], &muts);
            let (i, d) = (input.clone(), dir.path());
            tally
                .borrow_mut()
                .case(&input, move || import(&i, d), |m| unclear(m, &file))
        })
        .unwrap();
    let t = tally.into_inner();
    eprintln!("urdf fuzz: {t:?}");
    // Both outcomes must occur, or the mutator tests nothing (about 5 % of the mutated files
    // are still valid robots: a changed origin or limit is still a chain).
    assert!(t.rejected > t.cases / 10 && t.accepted > 0, "{t:?}");
}
