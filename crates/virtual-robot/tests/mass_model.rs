//! The robot files' mass models agree with the virtual robot's compliance truth.

use kinematics::{Robot, RobotSpec};
use virtual_robot::{ComplianceConfig, ComplianceModel, LinkMass};

fn spec(name: &str) -> RobotSpec {
    let path = format!(
        "{}/../../scenarios/robots/{name}",
        env!("CARGO_MANIFEST_DIR")
    );
    RobotSpec::from_file(std::path::Path::new(&path)).unwrap()
}

/// A compliance configuration with the masses of a robot file's mass model.
fn config_from_file(spec: &RobotSpec) -> ComplianceConfig {
    let m = spec.mass_model.as_ref().unwrap();
    ComplianceConfig {
        gravity_m_per_s2: m.gravity_m_per_s2,
        links: m
            .links
            .iter()
            .map(|l| LinkMass {
                mass_kg: l.mass_kg,
                com_mm: l.com_mm,
            })
            .collect(),
        payload_kg: m.payload_kg,
        payload_com_mm: m.payload_com_mm,
        ..ComplianceConfig::default()
    }
}

#[test]
fn kr1000_file_has_the_virtual_robots_masses() {
    let s = spec("kr1000-titan.json");
    let from_file = config_from_file(&s);
    let truth = ComplianceConfig::default();
    assert_eq!(from_file, truth);
}

#[test]
fn ur10_gravity_torques_from_the_file() {
    let s = spec("ur10.json");
    let robot = Robot::from_spec(&s).unwrap();
    let model = ComplianceModel::new(&config_from_file(&s), 6).unwrap();
    let mut tau = [0.0; 6];
    let total: f64 = s.mass_model.as_ref().unwrap().links[1..]
        .iter()
        .map(|l| l.mass_kg)
        .sum();
    for q in [
        [0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
        [0.3, -1.0, 1.2, -0.4, 0.8, 0.1],
        [-2.0, -0.5, -1.5, 1.0, -0.7, 2.0],
    ] {
        model.torques_nm(&robot, &q, &mut tau);
        // Joint 1 is vertical: gravity exerts no torque about it.
        assert!(tau[0].abs() < 1e-9, "{tau:?}");
        // Joint 2 carries at most the weight of links 2–6 at the full reach (≈ 1.3 m).
        assert!(tau[1].abs() < total * 9.81 * 1.3, "{tau:?}");
    }
    // Stretched out horizontally (q = 0), the shoulder carries a large torque.
    model.torques_nm(&robot, &[0.0; 6], &mut tau);
    assert!(tau[1].abs() > 50.0, "{tau:?}");
}
