//! Import: the robot file's points equal the URDF's own kinematics.

use crate::common::{Rng, fixture, urdf_point};
use kinematics::Robot;
use nalgebra::Vector3;
use urdf::{ImportOptions, import_file};

fn check_chain(file: &str, base: &str, tip: &str, tool: [f64; 3]) -> f64 {
    let path = fixture(file);
    let opts = ImportOptions {
        tool_in_tip_mm: tool,
        ..Default::default()
    };
    let imported = import_file(&path, base, tip, &opts).unwrap();
    println!("{}", imported.spec.to_json_string());
    let robot = Robot::from_spec(&imported.spec).unwrap();
    let parsed = urdf_rs::read_file(&path).unwrap();
    let mut rng = Rng(7);
    let mut worst: f64 = 0.0;
    for _ in 0..1000 {
        let q = rng.pose(&robot);
        let a = robot.point(&q);
        let b = urdf_point(&parsed, base, tip, &q, &Vector3::from(tool));
        worst = worst.max((a - b).norm());
    }
    println!("{file} {base} → {tip}: worst |robot file − URDF| = {worst:e} mm");
    worst
}

#[test]
fn ur10_base_link_to_tool0_is_exact() {
    assert!(check_chain("ur10.urdf", "base_link", "tool0", [0.0, 0.0, 0.0]) < 1e-9);
    assert!(check_chain("ur10.urdf", "base_link", "tool0", [10.0, -20.0, 109.0]) < 1e-9);
}

#[test]
fn kr210_base_link_to_tool0_is_exact() {
    assert!(check_chain("kuka_kr210l150.urdf", "base_link", "tool0", [0.0; 3]) < 1e-9);
    assert!(
        check_chain(
            "kuka_kr210l150.urdf",
            "base_link",
            "tool0",
            [30.0, 5.0, 250.0]
        ) < 1e-9
    );
}
