//! Command-line tests of `urdf import` and `urdf export` (issue 22): the UR10 description
//! of `ur_description` calibrated on the real series B gives the figures of
//! `scenarios/robots/ur10.json`; bad input writes nothing.

use crate::common::{kincal, ok, root, s};
use std::path::Path;

/// The `validation:` line of `identify`'s summary.
fn validation_line(out: &str) -> String {
    out.lines()
        .find(|l| l.starts_with("validation:"))
        .unwrap_or_else(|| panic!("no validation line in {out}"))
        .to_string()
}

#[test]
fn ur10_urdf_import_calibrates_series_b_like_the_hand_written_model() {
    let fixture = root().join("crates/urdf/tests/fixtures/ur10.urdf");
    let data = root().join("data/ur10-ipa/series-b-joint-configurations.csv");
    let tmp = tempfile::tempdir().unwrap();
    let robot = tmp.path().join("ur10-from-urdf.json");
    // tool0 is the flange; the data's point is the probe 109 mm out along its z axis,
    // the start value of scenarios/robots/ur10.json.
    let out = ok(&kincal(&[
        "urdf",
        "import",
        s(&fixture),
        "--base",
        "base_link",
        "--tip",
        "tool0",
        "--tool-mm",
        "0,0,109",
        "--out",
        s(&robot),
    ]));
    assert!(
        out.contains("6 revolute joints (shoulder_pan_joint, shoulder_lift_joint"),
        "{out}"
    );
    let identify = |robot: &Path, dir: &str| {
        ok(&kincal(&[
            "identify",
            "--robot",
            s(robot),
            "--data",
            s(&data),
            "--every",
            "15",
            "--out",
            s(&tmp.path().join(dir)),
        ]))
    };
    let from_urdf = identify(&robot, "cal-urdf");
    let hand = identify(&root().join("scenarios/robots/ur10.json"), "cal-hand");
    println!("{from_urdf}");
    let v = validation_line(&from_urdf);
    assert!(
        v.ends_with(
            "nominal (registered) mean 2.933 mm, max 5.011 mm → calibrated mean 0.452 mm, max 1.766 mm"
        ),
        "{v}"
    );
    assert_eq!(v, validation_line(&hand));
    assert!(from_urdf.contains("35 free parameters") && from_urdf.contains("rank 27 of 35"));

    // The calibrated robot goes back out as URDF, with the URDF's joint names (carried by
    // the robot files' `joint_names` through identify) and the offsets.
    let identified = tmp.path().join("cal-urdf/identified.json");
    let urdf_out = tmp.path().join("ur10-calibrated.urdf");
    let offsets = tmp.path().join("offsets.json");
    ok(&kincal(&[
        "urdf",
        "export",
        s(&identified),
        "--out",
        s(&urdf_out),
        "--offsets",
        s(&offsets),
        "--nominal",
        s(&tmp.path().join("cal-urdf/registered-nominal.json")),
    ]));
    let text = std::fs::read_to_string(&urdf_out).unwrap();
    assert!(text.contains("<joint name=\"wrist_3_joint\" type=\"revolute\">"));
    assert!(!text.contains("<calibration"));
    let off: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&offsets).unwrap()).unwrap();
    assert_eq!(off["joints"][5]["name"], "wrist_3_joint");
    assert!(
        off["joints"][1]["delta_deg"].as_f64().unwrap().abs() < 1.0,
        "{off}"
    );
}

#[test]
fn bad_input_names_the_element_and_writes_nothing() {
    let tmp = tempfile::tempdir().unwrap();
    let bad = tmp.path().join("bad.urdf");
    std::fs::write(
        &bad,
        r#"<robot name="r"><link name="a"/><link name="b"/>
        <joint name="slide" type="planar"><parent link="a"/><child link="b"/>
        <axis xyz="1 0 0"/><limit lower="0" upper="1" effort="1" velocity="1"/></joint></robot>"#,
    )
    .unwrap();
    let out_file = tmp.path().join("robot.json");
    let out = kincal(&[
        "urdf",
        "import",
        s(&bad),
        "--base",
        "a",
        "--tip",
        "b",
        "--out",
        s(&out_file),
    ]);
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("bad.urdf: <joint name=\"slide\" type=\"planar\">"),
        "{err}"
    );
    assert!(!out_file.exists());
    // Wrong number of joint names on export: nothing written either.
    let urdf_file = tmp.path().join("x.urdf");
    let out = kincal(&[
        "urdf",
        "export",
        s(&root().join("scenarios/robots/kr1000-titan.json")),
        "--out",
        s(&urdf_file),
        "--joint-names",
        "a,b",
    ]);
    assert!(!out.status.success());
    assert!(!urdf_file.exists());
}
