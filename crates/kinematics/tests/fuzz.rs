//! Mutation fuzzing of the robot-model reader (see `measurements/tests/mutate/mod.rs`): no
//! panic, no hang, every rejection names the file and a line or field. Run with
//! `--nocapture` to see the case counts.

use std::cell::RefCell;

use crate::mutate::{Tally, apply, mutations, names_file_and_place};
use kinematics::{Robot, RobotSpec};
use proptest::test_runner::TestRunner;

fn read(bytes: &[u8], dir: &std::path::Path) -> Result<(), String> {
    let path = dir.join("robot.json");
    let result = match std::str::from_utf8(bytes) {
        Ok(text) => RobotSpec::from_json_str(text, &path.display().to_string()),
        Err(_) => {
            std::fs::write(&path, bytes).unwrap();
            RobotSpec::from_file(&path)
        }
    };
    let spec = result.map_err(|e| e.to_string())?;
    let robot = Robot::from_spec(&spec).map_err(|e| e.to_string())?;
    // An accepted model computes finite positions at its zero pose.
    let p = robot.point(&vec![0.0; robot.n_joints()]);
    assert!(p.iter().all(|v| v.is_finite()), "{p:?}");
    Ok(())
}

#[test]
fn mutated_robot_files_are_read_or_refused_clearly() {
    let dir = tempfile::tempdir().unwrap();
    let mut seeds = Vec::new();
    for name in ["kr1000-titan.json", "ur10.json"] {
        let path = format!(
            "{}/../../scenarios/robots/{name}",
            env!("CARGO_MANIFEST_DIR")
        );
        seeds.push(std::fs::read(path).unwrap());
    }
    for s in &seeds {
        read(s, dir.path()).expect("the seeds are valid");
    }
    let file = dir.path().join("robot.json").display().to_string();
    let tally = RefCell::new(Tally::default());
    let mut runner = TestRunner::new(crate::mutate::config(1500));
    runner
        .run(&(0..seeds.len(), mutations()), |(k, muts)| {
            let input = apply(&seeds[k], &muts);
            let (i, d) = (input.clone(), dir.path());
            tally.borrow_mut().case(
                &input,
                move || read(&i, d),
                |m| names_file_and_place(m, &file),
            )
        })
        .unwrap();
    let t = tally.into_inner();
    eprintln!("kinematics fuzz: {t:?}");
    assert!(t.rejected > t.cases / 4 && t.accepted > 0, "{t:?}");
}
