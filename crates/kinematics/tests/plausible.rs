//! A robot file's numbers are a robot's (issue 38): angles within ±360°, lengths within
//! ±100 m, checked on reading and named by field, with huge values in exponent form.

use kinematics::{MAX_ANGLE_DEG, MAX_LENGTH_MM, ModelError, RobotSpec};

fn ur10() -> serde_json::Value {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../scenarios/robots/ur10.json"
    );
    serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
}

/// The error of the UR10's file with `edit` applied.
fn refusal(edit: impl FnOnce(&mut serde_json::Value)) -> ModelError {
    let mut v = ur10();
    edit(&mut v);
    RobotSpec::from_json_str(&v.to_string(), "robot.json").unwrap_err()
}

#[test]
fn theta1_of_two_to_the_64_is_refused_naming_the_field_and_its_value() {
    let e = refusal(|v| v["joints"][0]["theta_deg"] = 2f64.powi(64).into());
    let msg = e.to_string();
    assert!(
        matches!(&e, ModelError::Invalid { field, .. } if field == "joints[0].theta_deg"),
        "{e:?}"
    );
    assert!(
        msg.contains("joints[0].theta_deg = 1.8446744073709552e19°"),
        "{msg}"
    );
    assert!(msg.starts_with("robot.json: "), "{msg}");
}

/// A change of the robot file's JSON.
type Edit = fn(&mut serde_json::Value);

#[test]
fn every_angle_and_length_has_its_bound() {
    let cases: [(&str, Edit); 8] = [
        ("joints[2].alpha_deg", |v| {
            v["joints"][2]["alpha_deg"] = (-400.0).into()
        }),
        ("joints[1].a_mm", |v| v["joints"][1]["a_mm"] = 1e300.into()),
        ("joints[3].d_mm", |v| v["joints"][3]["d_mm"] = (-2e5).into()),
        ("base.rz_deg", |v| v["base"]["rz_deg"] = 720.0.into()),
        ("base.dx_mm", |v| v["base"]["dx_mm"] = 1e6.into()),
        ("tool_mm[2]", |v| v["tool_mm"][2] = 1e9.into()),
        ("tool_rotation_deg[1]", |v| {
            v["tool_rotation_deg"] = serde_json::json!([0.0, 361.0, 0.0])
        }),
        (
            "targets[0].point_mm[0]",
            |v| v["targets"] = serde_json::json!([{ "name": "A", "point_mm": [1e7, 0, 0] }]),
        ),
    ];
    for (field, edit) in cases {
        let e = refusal(edit);
        assert!(
            matches!(&e, ModelError::Invalid { field: f, .. } if f == field),
            "{field}: {e}"
        );
        assert!(e.to_string().len() < 300, "{e}");
    }
    let msg = refusal(|v| v["joints"][1]["a_mm"] = 1e300.into()).to_string();
    assert!(msg.contains("= 1e300 mm is beyond ±100000 mm"), "{msg}");
}

#[test]
fn values_at_the_bounds_are_accepted() {
    let mut v = ur10();
    v["joints"][0]["theta_deg"] = MAX_ANGLE_DEG.into();
    v["joints"][1]["alpha_deg"] = (-MAX_ANGLE_DEG).into();
    v["joints"][1]["a_mm"] = (-MAX_LENGTH_MM).into();
    v["base"]["dy_mm"] = MAX_LENGTH_MM.into();
    RobotSpec::from_json_str(&v.to_string(), "robot.json").unwrap();
}
