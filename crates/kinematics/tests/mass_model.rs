//! The robot file's optional mass model section: parsing, round trip and errors naming the field.

use kinematics::{ModelError, Robot, RobotSpec};

fn robot_file(name: &str) -> String {
    let path = format!(
        "{}/../../scenarios/robots/{name}",
        env!("CARGO_MANIFEST_DIR")
    );
    std::fs::read_to_string(path).unwrap()
}

/// The field named by a validation or parse error.
fn error_field(text: &str) -> String {
    match RobotSpec::from_json_str(text, "test").unwrap_err() {
        ModelError::Invalid { field, .. } | ModelError::Parse { field, .. } => field,
        e => panic!("unexpected error {e}"),
    }
}

#[test]
fn committed_robot_files_carry_their_mass_models() {
    let kr = RobotSpec::from_json_str(&robot_file("kr1000-titan.json"), "kr1000").unwrap();
    let m = kr.mass_model.as_ref().expect("KR1000 has a mass model");
    let total: f64 = m.links.iter().map(|l| l.mass_kg).sum();
    // The moving links of the data sheet's 4690 kg (1100 kg of the base frame carry no torque).
    assert_eq!(total, 3590.0);
    assert_eq!(m.gravity_m_per_s2, 9.80665);

    let ur = RobotSpec::from_json_str(&robot_file("ur10.json"), "ur10").unwrap();
    let m = ur.mass_model.as_ref().expect("UR10 has a mass model");
    let masses: Vec<f64> = m.links.iter().map(|l| l.mass_kg).collect();
    assert_eq!(masses, [7.1, 12.7, 4.27, 2.0, 2.0, 0.365]);
    assert_eq!(m.links[1].com_mm, [380.0, 0.0, 158.0]);
}

#[test]
fn mass_model_survives_the_robot_round_trip_and_is_optional() {
    let spec = RobotSpec::from_json_str(&robot_file("kr1000-titan.json"), "kr1000").unwrap();
    let robot = Robot::from_spec(&spec).unwrap();
    assert_eq!(robot.mass_model(), spec.mass_model.as_ref());
    assert_eq!(robot.to_spec().mass_model, spec.mass_model);
    let json = robot.to_spec().to_json_string();
    assert!(json.contains("\"mass_model\""));

    // Without the section the file parses and the output has no `mass_model` key.
    let mut bare = spec.clone();
    bare.mass_model = None;
    let json = bare.to_json_string();
    assert!(!json.contains("mass_model"));
    let back = RobotSpec::from_json_str(&json, "bare").unwrap();
    assert_eq!(back, bare);
    assert!(Robot::from_spec(&back).unwrap().mass_model().is_none());
}

#[test]
fn defaults_of_gravity_and_payload() {
    let text = robot_file("ur10.json")
        .replace("\"gravity_m_per_s2\": 9.80665,", "")
        .replace(
            ",\n    \"payload_kg\": 0,\n    \"payload_com_mm\": [0, 0, 0]",
            "",
        );
    let spec = RobotSpec::from_json_str(&text, "ur10").unwrap();
    let m = spec.mass_model.unwrap();
    assert_eq!(m.gravity_m_per_s2, 9.80665);
    assert_eq!(m.payload_kg, 0.0);
    assert_eq!(m.payload_com_mm, [0.0, 0.0, 250.0]);
}

#[test]
fn bad_mass_models_are_rejected_naming_the_field() {
    let kr = robot_file("kr1000-titan.json");
    assert_eq!(
        error_field(&kr.replace("\"mass_kg\": 850,", "\"mass_kg\": -850,")),
        "mass_model.links[1].mass_kg"
    );
    assert_eq!(
        error_field(&kr.replace("\"payload_kg\": 0,", "\"payload_kg\": -1,")),
        "mass_model.payload_kg"
    );
    assert_eq!(
        error_field(&kr.replace(
            "\"gravity_m_per_s2\": 9.80665,",
            "\"gravity_m_per_s2\": -9.8,"
        )),
        "mass_model.gravity_m_per_s2"
    );
    // One entry too few.
    assert_eq!(
        error_field(
            &kr.replace("      { \"mass_kg\": 20,   \"com_mm\": [0, 0, -20] }\n", "")
                .replace(
                    "{ \"mass_kg\": 70,   \"com_mm\": [0, 0, 150] },",
                    "{ \"mass_kg\": 70,   \"com_mm\": [0, 0, 150] }"
                )
        ),
        "mass_model.links"
    );
    // Unknown and missing fields are parse errors with the path.
    assert_eq!(
        error_field(&kr.replace("\"mass_kg\": 200,", "\"mass_kg\": 200, \"inertia\": 1,")),
        "mass_model.links[3].inertia"
    );
    let f = error_field(&kr.replace("\"mass_kg\": 200,", ""));
    assert_eq!(f, "mass_model.links[3]");
}
