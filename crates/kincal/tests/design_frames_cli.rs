//! `kincal design --measure` (issue 31): how many poses a 6-DoF probe or several reflectors
//! need against a single reflector.

use crate::common::{kincal, ok, root, s};

fn design(robot: &str, measure: &str, poses: &str, out: &str) -> std::process::Output {
    let scenario = root().join("scenarios/paper-kr1000.json");
    kincal(&[
        "design",
        "--robot",
        robot,
        "--scenario",
        s(&scenario),
        "--random",
        "120",
        "--poses",
        poses,
        "--measure",
        measure,
        "--out",
        out,
    ])
}

/// Five 6-DoF poses make a plan for the KR1000's 30 unknowns where five single-reflector
/// poses are refused (27 unknowns need 9); three reflectors need a robot file with
/// `targets`, then five poses do (four are refused: one rigid motion per pose).
#[test]
fn design_measures_frames_and_targets() {
    let tmp = tempfile::tempdir().unwrap();
    let plan = tmp.path().join("plan.csv");
    let kr = root().join("scenarios/robots/kr1000-titan.json");
    let text = ok(&design(s(&kr), "frame", "5", s(&plan)));
    assert!(
        text.contains("minimal set (30 parameters)")
            && text.contains("measurement frame: 6 equations per pose")
            && text.contains("30 unknowns: at least 5 poses")
            && text.contains("a single reflector: 3 per pose, 27 unknowns: at least 9 poses"),
        "{text}"
    );
    assert_eq!(
        std::fs::read_to_string(&plan).unwrap().lines().count(),
        5 + 2
    );
    std::fs::remove_file(&plan).unwrap();

    let point = design(s(&kr), "point", "5", s(&plan));
    let err = String::from_utf8_lossy(&point.stderr);
    assert!(
        !point.status.success() && err.contains("need at least 9 poses"),
        "{err}"
    );
    assert!(!plan.exists());

    let none = design(s(&kr), "targets", "4", s(&plan));
    let err = String::from_utf8_lossy(&none.stderr);
    assert!(
        !none.status.success() && err.contains("--measure targets") && err.contains("targets"),
        "{err}"
    );

    let mut json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&kr).unwrap()).unwrap();
    json["targets"] = serde_json::json!([
        { "name": "r1", "point_mm": [120, 0, 250] },
        { "name": "r2", "point_mm": [-60, 104, 250] },
        { "name": "r3", "point_mm": [-60, -104, 250] }
    ]);
    let robot = tmp.path().join("kr1000-3-reflectors.json");
    std::fs::write(&robot, json.to_string()).unwrap();
    let four = design(s(&robot), "targets", "4", s(&plan));
    let err = String::from_utf8_lossy(&four.stderr);
    assert!(err.contains("need at least 5 poses"), "{err}");
    let text = ok(&design(s(&robot), "targets", "5", s(&plan)));
    assert!(
        text.contains("measurement targets: 9 equations per pose (3 targets × 3), 33 unknowns: at least 5 poses")
            && text.contains("r3_z"),
        "{text}"
    );
    let bad = design(s(&kr), "pose", "5", s(&plan));
    assert!(String::from_utf8_lossy(&bad.stderr).contains("point, frame, targets"));
}
