//! Bad scenario fields give errors naming the field; good ones round-trip.

use crate::common::{ideal, kr1000};
use kinematics::{Robot, RobotSpec};
use virtual_robot::{
    ConfigError, PoseSet, RandomErrors, ScaleTarget, SimError, VirtualRobotConfig, World,
};

/// Validation error of `cfg` on the KR1000; the world refuses it with the same error.
fn field_of(cfg: &VirtualRobotConfig) -> String {
    let robot = kr1000();
    let err = cfg.validate(&robot).expect_err("config should be rejected");
    match World::new(&robot, cfg, 0, 0) {
        Err(SimError::Config(e)) => assert_eq!(e, err),
        other => panic!("world accepted a bad config: {:?}", other.map(|_| ())),
    }
    assert!(err.to_string().starts_with(&format!("`{}`", err.field())));
    err.field().to_string()
}

#[test]
fn defaults_are_valid() {
    let robot = kr1000();
    VirtualRobotConfig::default().validate(&robot).unwrap();
    ideal().validate(&robot).unwrap();
    assert_eq!(
        VirtualRobotConfig::from_json_str("{}").unwrap(),
        VirtualRobotConfig::default()
    );
}

#[test]
fn negative_sigmas_are_named() {
    let mut c = ideal();
    c.truth.random = Some(RandomErrors {
        length_sigma_mm: -0.1,
        ..RandomErrors::default()
    });
    assert_eq!(field_of(&c), "truth.random.length_sigma_mm");
    let mut c = ideal();
    c.truth.random = Some(RandomErrors {
        joint_angle_sigma_deg: f64::NAN,
        ..RandomErrors::default()
    });
    assert_eq!(field_of(&c), "truth.random.joint_angle_sigma_deg");
    let mut c = ideal();
    c.unmodelled.repeatability.sigma_mm = -0.028;
    assert_eq!(field_of(&c), "unmodelled.repeatability.sigma_mm");
    let mut c = ideal();
    c.tracker.noise_scale = -1.0;
    assert_eq!(field_of(&c), "tracker.noise_scale");
    let mut c = ideal();
    c.tracker.mpe_b_um_per_m = -6.0;
    assert_eq!(field_of(&c), "tracker.mpe_b_um_per_m");
}

#[test]
fn unknown_parameter_names_are_named() {
    let mut c = ideal();
    c.truth.explicit.insert("thetaX".into(), 0.1);
    assert_eq!(field_of(&c), "truth.explicit.thetaX");
    let robot = kr1000();
    match c.validate(&robot) {
        Err(ConfigError::UnknownParameter { name, known, .. }) => {
            assert_eq!(name, "thetaX");
            assert!(known.contains("beta2"));
        }
        other => panic!("{other:?}"),
    }
    let mut c = ideal();
    c.truth.explicit.insert("beta3".into(), 0.1); // the KR1000 has β2 only
    assert_eq!(field_of(&c), "truth.explicit.beta3");
    let mut c = ideal();
    c.unmodelled.drift.enabled = true;
    c.unmodelled
        .drift
        .rate_per_move
        .insert("length7".into(), 1e-3);
    assert_eq!(field_of(&c), "unmodelled.drift.rate_per_move.length7");
}

#[test]
fn tracker_placement_and_window_are_checked() {
    let mut c = ideal();
    c.tracker.position_mm = [2000.0, 1000.0, 1500.0]; // 2.24 m from axis 1: inside the robot
    assert_eq!(field_of(&c), "tracker.position_mm");
    let robot = kr1000();
    let msg = c.validate(&robot).unwrap_err().to_string();
    assert!(msg.contains("2236.1 mm from axis 1"), "{msg}");
    for bad in [0.0, -10.0, 90.0, 120.0, f64::INFINITY] {
        let mut c = ideal();
        c.tracker.elevation_limit_deg = bad;
        assert_eq!(field_of(&c), "tracker.elevation_limit_deg", "{bad}");
    }
    for bad in [0.0, 1.5, -0.5] {
        let mut c = ideal();
        c.tracker.sigma_fraction = bad;
        assert_eq!(field_of(&c), "tracker.sigma_fraction", "{bad}");
    }
    let mut c = ideal();
    c.tracker.range_m = [5.0, 2.0];
    assert_eq!(field_of(&c), "tracker.range_m");
    let mut c = ideal();
    c.tracker.base_residual.dz_mm = f64::NAN;
    assert_eq!(field_of(&c), "tracker.base_residual.dz_mm");
}

#[test]
fn pose_sets_are_checked() {
    let mut c = ideal();
    c.poses.identification = PoseSet::Count(0);
    assert_eq!(field_of(&c), "poses.identification");
    let mut c = ideal();
    c.poses.validation = PoseSet::ListDeg(vec![]);
    assert_eq!(field_of(&c), "poses.validation");
    let mut c = ideal();
    c.poses.validation = PoseSet::ListDeg(vec![vec![0.0, 10.0, 0.0, 0.0, 30.0]]);
    assert_eq!(field_of(&c), "poses.validation[0]");
    let mut c = ideal();
    c.poses.validation = PoseSet::ListDeg(vec![
        vec![0.0, 10.0, 0.0, 0.0, 30.0, 0.0],
        vec![0.0, 110.0, 0.0, 0.0, 30.0, 0.0],
    ]);
    assert_eq!(field_of(&c), "poses.validation[1][1]");
    let mut c = ideal();
    c.poses.max_condition = Some(0.5);
    assert_eq!(field_of(&c), "poses.max_condition");
    let mut c = ideal();
    c.poses.max_draws_per_pose = 0;
    assert_eq!(field_of(&c), "poses.max_draws_per_pose");
    let mut c = ideal();
    c.truth.scale_to = Some(ScaleTarget {
        mean_error_mm: -1.0,
        poses: 10,
    });
    assert_eq!(field_of(&c), "truth.scale_to.mean_error_mm");
}

#[test]
fn unmodelled_sizes_are_checked() {
    let mut c = ideal();
    c.unmodelled.compliance.enabled = true;
    c.unmodelled.compliance.stiffness_nm_per_rad.pop();
    assert_eq!(field_of(&c), "unmodelled.compliance.stiffness_nm_per_rad");
    let mut c = ideal();
    c.unmodelled.compliance.stiffness_nm_per_rad[2] = 0.0;
    assert_eq!(
        field_of(&c),
        "unmodelled.compliance.stiffness_nm_per_rad[2]"
    );
    let mut c = ideal();
    c.unmodelled.compliance.links = virtual_robot::ComplianceConfig::default().links;
    c.unmodelled.compliance.links[3].mass_kg = -1.0;
    assert_eq!(field_of(&c), "unmodelled.compliance.links[3].mass_kg");
    let mut c = ideal();
    c.unmodelled.compliance.counterbalance_fraction[1] = 1.2;
    assert_eq!(
        field_of(&c),
        "unmodelled.compliance.counterbalance_fraction[1]"
    );
    let mut c = ideal();
    c.unmodelled.gears.enabled = true;
    c.unmodelled.gears.terms[0].joint = 7;
    assert_eq!(field_of(&c), "unmodelled.gears.terms[0].joint");
    let mut c = ideal();
    c.unmodelled.gears.terms[2].amplitude_arcsec = -5.0;
    assert_eq!(field_of(&c), "unmodelled.gears.terms[2].amplitude_arcsec");
}

#[test]
fn json_errors_name_the_field() {
    let parse = |s: &str| VirtualRobotConfig::from_json_str(s).unwrap_err();
    let e = parse(r#"{ "tracker": { "sigma_fracton": 0.5 } }"#);
    assert_eq!(e.field(), "tracker.sigma_fracton");
    assert!(e.to_string().contains("unknown field"), "{e}");
    let e = parse(r#"{ "poses": { "identification": -3 } }"#);
    assert_eq!(e.field(), "poses.identification");
    assert!(e.to_string().contains("negative"), "{e}");
    let e = parse(r#"{ "poses": { "validation": [[0, 1, 2, 3, 4, "x"]] } }"#);
    assert!(e.field().starts_with("poses.validation"), "{}", e.field());
    let e = parse(r#"{ "tracker": { "noise_model": "gaussian" } }"#);
    assert_eq!(e.field(), "tracker.noise_model");
    let e = parse(r#"{ "truth": { "random": { "distribution": "normal", "sigma": 1 } } }"#);
    assert_eq!(e.field(), "truth.random.sigma");
    let e = parse(r#"{ "extra": 1 }"#);
    assert_eq!(e.field(), "extra");
    // The base residual (a `kinematics::BaseSpec`) refuses unknown fields like the rest.
    let e = parse(r#"{ "tracker": { "base_residual": { "rz_deg": 0.01, "dw_mm": 1 } } }"#);
    assert!(
        e.field().starts_with("tracker.base_residual"),
        "{}",
        e.field()
    );
    assert!(e.to_string().contains("unknown field `dw_mm`"), "{e}");
}

#[test]
fn json_round_trip_and_partial_sections() {
    let c = VirtualRobotConfig::from_json_str(
        r#"{ "truth": { "explicit": { "a2": 0.3 }, "scale_to": {} },
             "tracker": { "noise_model": "isotropic", "sigma_fraction": 0.3333333333333333,
                          "base_residual": { "rz_deg": 0.01 } },
             "unmodelled": { "gears": { "enabled": true } },
             "poses": { "identification": 30, "validation": [[0, 10, -20, 0, 45, 0]],
                        "max_condition": null } }"#,
    )
    .unwrap();
    assert_eq!(c.truth.scale_to, Some(ScaleTarget::default()));
    assert_eq!(c.tracker.base_residual.rz_deg, 0.01);
    assert_eq!(
        c.tracker.base_residual.values(),
        [0.0, 0.0, 0.01, 0.0, 0.0, 0.0]
    );
    assert_eq!(c.tracker.position_mm, [4000.0, -1500.0, 1200.0]);
    assert!(c.unmodelled.gears.enabled && c.unmodelled.compliance.enabled);
    assert_eq!(c.poses.identification, PoseSet::Count(30));
    assert_eq!(c.poses.max_condition, None);
    c.validate(&kr1000()).unwrap();
    let text = serde_json::to_string_pretty(&c).unwrap();
    assert_eq!(VirtualRobotConfig::from_json_str(&text).unwrap(), c);
}

#[test]
fn trial_numbers_beyond_the_stream_id_are_rejected() {
    let robot = kr1000();
    let err = World::new(&robot, &ideal(), 0, 1 << 56).unwrap_err();
    assert!(matches!(err, SimError::Trial { .. }), "{err}");
}

#[test]
fn json_examples_in_the_module_docs_parse_and_validate() {
    let robot = kr1000();
    let mut found = 0;
    for (name, src) in [
        ("truth", include_str!("../src/truth.rs")),
        ("tracker", include_str!("../src/tracker.rs")),
        ("unmodelled", include_str!("../src/unmodelled.rs")),
        ("poses", include_str!("../src/poses.rs")),
    ] {
        let docs: Vec<&str> = src
            .lines()
            .take_while(|l| l.starts_with("//!"))
            .map(|l| l.trim_start_matches("//!").trim_start_matches(' '))
            .collect();
        let start = docs.iter().position(|l| *l == "```json").unwrap() + 1;
        let len = docs[start..].iter().position(|l| *l == "```").unwrap();
        let text = format!("{{ {} }}", docs[start..start + len].join("\n"));
        let cfg = VirtualRobotConfig::from_json_str(&text)
            .unwrap_or_else(|e| panic!("{name} example: {e}\n{text}"));
        cfg.validate(&robot)
            .unwrap_or_else(|e| panic!("{name} example: {e}"));
        found += 1;
    }
    assert_eq!(found, 4);
}

/// Issue 29: compliance without `links` weighs the robot by its own file's `mass_model`
/// (not the KR1000's), and is refused, naming the field and the ways out, for a robot file
/// without one.
#[test]
fn compliance_uses_the_robot_files_mass_model_or_refuses() {
    let ur10_text = include_str!("../../../scenarios/robots/ur10.json");
    let ur10 =
        Robot::from_spec(&RobotSpec::from_json_str(ur10_text, "ur10.json").unwrap()).unwrap();
    let cfg = VirtualRobotConfig::from_json_str(
        r#"{ "unmodelled": { "compliance": { "enabled": true } } }"#,
    )
    .unwrap();
    assert!(cfg.unmodelled.compliance.links.is_empty());
    let mut resolved = cfg.unmodelled.clone();
    resolved.use_robot_mass_model(&ur10).unwrap();
    let masses: Vec<f64> = resolved
        .compliance
        .links
        .iter()
        .map(|l| l.mass_kg)
        .collect();
    assert_eq!(masses, [7.1, 12.7, 4.27, 2.0, 2.0, 0.365]);
    cfg.validate(&ur10).unwrap();
    // The KR1000 file's own masses are the crate's KR1000 split: the paper's scenarios keep
    // their bytes.
    let mut k = cfg.unmodelled.clone();
    k.use_robot_mass_model(&kr1000()).unwrap();
    assert_eq!(
        k.compliance.links,
        virtual_robot::ComplianceConfig::default().links
    );
    // A robot file without a mass model: refused with the field named.
    let mut spec = RobotSpec::from_json_str(ur10_text, "ur10.json").unwrap();
    spec.mass_model = None;
    let bare = Robot::from_spec(&spec).unwrap();
    let err = cfg.validate(&bare).unwrap_err();
    assert_eq!(err.field(), "unmodelled.compliance.links");
    assert!(err.to_string().contains("has no `mass_model`"), "{err}");
    assert!(World::new(&bare, &cfg, 0, 0).is_err());
    // Compliance off needs none.
    let off = VirtualRobotConfig::from_json_str(
        r#"{ "unmodelled": { "compliance": { "enabled": false } } }"#,
    )
    .unwrap();
    off.validate(&bare).unwrap();
}
