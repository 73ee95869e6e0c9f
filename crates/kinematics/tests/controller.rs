//! The robot file's optional `controller` section (issue 40, `docs/controller.md`): checked
//! on reading with the field named, carried through the robot and back, and absent from
//! files without it.

use kinematics::{ControllerKind, ModelError, Robot, RobotSpec};

fn repo_file(name: &str) -> String {
    let path = format!(
        "{}/../../scenarios/robots/{name}",
        env!("CARGO_MANIFEST_DIR")
    );
    std::fs::read_to_string(path).unwrap()
}

/// The error of the KR1000's file with `edit` applied to its JSON.
fn refusal(edit: impl FnOnce(&mut serde_json::Value)) -> ModelError {
    let mut v: serde_json::Value = serde_json::from_str(&repo_file("kr1000-titan.json")).unwrap();
    edit(&mut v);
    RobotSpec::from_json_str(&v.to_string(), "robot.json").unwrap_err()
}

#[test]
fn committed_files_carry_their_mapping() {
    let kr = RobotSpec::from_json_str(&repo_file("kr1000-titan.json"), "kr").unwrap();
    let c = kr.controller.as_ref().unwrap();
    assert_eq!(c.kind, ControllerKind::Kuka);
    // The KR1000's datasheet ranges (A2 +17.5°/−130°, A3 +145°/−110°) are the model's
    // limits mapped: A2 = q2 − 90°, A3 = q3 + 90°.
    let lo: Vec<f64> = kr.joints.iter().map(|j| j.limits_deg[0]).collect();
    let hi: Vec<f64> = kr.joints.iter().map(|j| j.limits_deg[1]).collect();
    let (a, b) = (c.axes_of(&lo), c.axes_of(&hi));
    assert_eq!([a[1].min(b[1]), a[1].max(b[1])], [-130.0, 17.5]);
    assert_eq!([a[2].min(b[2]), a[2].max(b[2])], [-110.0, 145.0]);
    let q = [10.0, -20.0, 30.0, -40.0, 50.0, -60.0];
    assert_eq!(c.joints_of(&c.axes_of(&q)), q);
    let ur = RobotSpec::from_json_str(&repo_file("ur10.json"), "ur").unwrap();
    let c = ur.controller.as_ref().unwrap();
    assert_eq!(c.kind, ControllerKind::Ur);
    assert_eq!(c.axes_of(&q), q);
}

#[test]
fn mapping_survives_the_robot_and_files_without_it_write_as_before() {
    let kr = RobotSpec::from_json_str(&repo_file("kr1000-titan.json"), "kr").unwrap();
    let back = Robot::from_spec(&kr).unwrap().to_spec();
    assert_eq!(back.controller, kr.controller);
    assert_eq!(
        Robot::from_spec(&kr).unwrap().controller(),
        kr.controller.as_ref()
    );
    let mut plain = kr.clone();
    plain.controller = None;
    let text = plain.to_json_string();
    assert!(!text.contains("controller"), "{text}");
    assert!(kr.to_json_string().contains("\"controller\""));
    let again = RobotSpec::from_json_str(&kr.to_json_string(), "t").unwrap();
    assert_eq!(again, kr);
}

#[test]
fn bad_mappings_are_refused_naming_the_field() {
    let field = |e: &ModelError| match e {
        ModelError::Invalid { field, .. } | ModelError::Parse { field, .. } => field.clone(),
        other => panic!("{other:?}"),
    };
    let e = refusal(|v| v["controller"]["axes"][3]["sign"] = 2.into());
    assert_eq!(field(&e), "controller.axes[3].sign", "{e}");
    assert!(e.to_string().contains("1 or -1"), "{e}");
    let e = refusal(|v| v["controller"]["axes"][0]["sign"] = 0.into());
    assert_eq!(field(&e), "controller.axes[0].sign", "{e}");
    let e = refusal(|v| v["controller"]["axes"][2]["offset_deg"] = 1e300.into());
    assert_eq!(field(&e), "controller.axes[2].offset_deg", "{e}");
    let e = refusal(|v| {
        v["controller"]["axes"].as_array_mut().unwrap().pop();
    });
    assert_eq!(field(&e), "controller.axes", "{e}");
    assert!(
        e.to_string().contains("one entry per joint (6), has 5"),
        "{e}"
    );
    let e = refusal(|v| v["controller"]["kind"] = "fanuc".into());
    assert_eq!(field(&e), "controller.kind", "{e}");
    let e = refusal(|v| v["controller"]["axes"][1]["scale"] = 1.into());
    assert_eq!(field(&e), "controller.axes[1].scale", "{e}");
}
