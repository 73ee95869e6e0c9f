//! Each writer's text read back by the reader of the same format gives the same targets
//! within the printed precision (crate docs, "Number formatting"), on the example targets,
//! on random joints (proptest) and through the robot file's axis mapping back to the
//! model's joints; the configuration data have their documented values at known poses; bad
//! text is refused naming the line and field.

use std::path::Path;

use controller::{Declaration, Format, ReadTarget, Target};
use kinematics::Robot;
use proptest::prelude::*;

use crate::rotation::rotation_angle;

pub fn robot(file: &str) -> Robot {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../scenarios/robots")
        .join(file);
    Robot::from_file(&path).unwrap()
}

/// Largest differences allowed after a round trip: (axis values °, position mm,
/// orientation rad), half the last printed digit plus rounding.
fn tolerance(format: Format) -> (f64, f64, f64) {
    match format {
        // 1e-4° axes and A, B, C (each rounding turns the frame by at most 0.5e-4°, the
        // three by at most 1.5e-4° = 2.62e-6 rad); 1e-3 mm.
        Format::KukaKrl => (0.5e-4 + 1e-9, 0.5e-3 + 1e-9, 2.7e-6),
        Format::AbbRapid | Format::Csv => (0.5e-4 + 1e-9, 0.5e-3 + 1e-9, 3e-9),
        // 1e-7 rad joints and rotation vector, 1e-6 m.
        Format::Urscript => ((0.5e-7f64).to_degrees() + 1e-9, 0.5e-3 + 1e-9, 2e-7),
    }
}

/// Checks one format's round trip of `decl`; returns the read targets.
fn check(robot: &Robot, format: Format, decl: &[Declaration]) -> Vec<ReadTarget> {
    let text = controller::write(format, "kincal_test", &["a header".to_owned()], decl).unwrap();
    let back = controller::read(format, &text, "t").unwrap();
    assert_eq!(back.len(), decl.len(), "{format}:\n{text}");
    let (tol_axis, tol_mm, tol_rad) = tolerance(format);
    let map = controller::mapping(robot);
    for (d, b) in decl.iter().zip(&back) {
        assert_eq!(b.name, d.name, "{format}");
        let axes = b.axes_deg.unwrap();
        for k in 0..6 {
            assert!(
                (axes[k] - d.axes_deg[k]).abs() <= tol_axis,
                "{format} {}: axis {k}",
                d.name
            );
        }
        let p = b.position_mm.unwrap();
        for k in 0..3 {
            assert!(
                (p[k] - d.position_mm[k]).abs() <= tol_mm,
                "{format} {}: {p:?}",
                d.name
            );
        }
        let e = rotation_angle(b.orientation_wxyz.unwrap(), d.orientation_wxyz);
        assert!(
            e <= tol_rad,
            "{format} {}: orientation off by {e:e} rad",
            d.name
        );
        // Back to the model's joints through the mapping.
        let joints = map.joints_of(&axes);
        let want = map.joints_of(&d.axes_deg);
        for k in 0..6 {
            assert!((joints[k] - want[k]).abs() <= tol_axis);
        }
        match format {
            Format::KukaKrl => assert_eq!(
                b.kuka_status_turn,
                Some((
                    controller::kuka_status(&d.config, &d.axes_deg),
                    controller::kuka_turn(&d.axes_deg)
                ))
            ),
            Format::AbbRapid => assert_eq!(
                b.abb_confdata,
                Some(controller::abb_confdata(&d.config, &d.axes_deg))
            ),
            _ => {}
        }
    }
    back
}

fn targets(robot: &Robot, sets: &[Vec<f64>]) -> Vec<Target> {
    sets.iter()
        .enumerate()
        .map(|(k, q)| {
            let (position_mm, orientation) = controller::tcp_pose(robot, q);
            Target {
                name: format!("target {k}, \"quoted\""),
                joints_deg: q.clone(),
                position_mm,
                orientation_wxyz: Some(orientation),
            }
        })
        .collect()
}

#[test]
fn every_format_round_trips_both_robots() {
    for file in ["kr1000-titan.json", "ur10.json"] {
        let robot = robot(file);
        let sets: Vec<Vec<f64>> = (0..25)
            .map(|k| {
                (0..6)
                    .map(|i| {
                        let [lo, hi] = robot.limits_rad(i).map(f64::to_degrees);
                        let f = ((k * 7 + i * 3) % 25) as f64 / 24.0;
                        lo + (hi - lo) * (0.05 + 0.9 * f)
                    })
                    .collect()
            })
            .collect();
        let decl = controller::declare(&robot, &targets(&robot, &sets)).unwrap();
        for format in Format::ALL {
            check(&robot, format, &decl);
        }
    }
}

/// A target without an orientation gets the nominal model's at its joints.
#[test]
fn missing_orientation_is_the_nominal_models() {
    let robot = robot("kr1000-titan.json");
    let q = vec![10.0, 20.0, -30.0, 40.0, 50.0, 60.0];
    let (p, r) = controller::tcp_pose(&robot, &q);
    let t = Target {
        name: "a".into(),
        joints_deg: q,
        position_mm: p,
        orientation_wxyz: None,
    };
    let d = controller::declare(&robot, &[t]).unwrap();
    assert_eq!(d[0].orientation_wxyz, r);
}

/// The KR1000 at its model zero is KUKA's {A1 0, A2 −90°, A3 90°, A4 0, A5 0, A6 0}: the
/// lower arm up, the forearm forward, the flange 600 + 1200 + 372 mm forward and
/// 1100 + 1400 + 65 mm high, pointing forward (flange z = +x, x = up, y = −y). Status: basic area,
/// wrist in front of the lower arm (bit 1), A5 ≤ 0 (bit 2): 6; Turn: A2 < 0: 2. ABB
/// confdata: quadrants 0, cfx 1 (A5 = 0 is not negative: 0).
#[test]
fn known_pose_has_kukas_home_values() {
    let robot = robot("kr1000-titan.json");
    let q = vec![0.0; 6];
    let (p, _) = controller::tcp_pose(&robot, &q);
    let tool = robot.tool_mm();
    let want = [2172.0 + tool.z, -tool.y, 2565.0 + tool.x];
    for k in 0..3 {
        assert!((p[k] - want[k]).abs() < 1e-9, "{p:?} vs {want:?}");
    }
    let d = controller::declare(
        &robot,
        &[Target {
            name: "home".into(),
            joints_deg: q,
            position_mm: p,
            orientation_wxyz: None,
        }],
    )
    .unwrap();
    assert_eq!(d[0].axes_deg, [0.0, -90.0, 90.0, 0.0, 0.0, 0.0]);
    assert_eq!(controller::kuka_status(&d[0].config, &d[0].axes_deg), 6);
    assert_eq!(controller::kuka_turn(&d[0].axes_deg), 2);
    assert_eq!(
        controller::abb_confdata(&d[0].config, &d[0].axes_deg),
        [0, 0, 0, 0]
    );
    let text = controller::write(Format::KukaKrl, "home", &[], &d).unwrap();
    assert!(text.contains("DECL E6AXIS XA1={A1 0.0000,A2 -90.0000,A3 90.0000,A4 0.0000,A5 0.0000,A6 0.0000,E1 0.0,"), "{text}");
    assert!(text.contains(",S 6,T 2,E1 0.0,"), "{text}");
}

/// Bit 1 changes where the wrist point crosses the line through A2 and A3: for the KR1000
/// (a3 = 65 mm, d4 = 1200 mm) at A3 = atan2(65, 1200) = 3.10°, not at 0°; overhead when the
/// wrist point is behind axis 1; turn bits follow the signs.
#[test]
fn status_bits_change_where_the_geometry_says() {
    let robot = robot("kr1000-titan.json");
    let phi = 65f64.atan2(1200.0).to_degrees();
    let status = |q: Vec<f64>| {
        let d = controller::declare(
            &robot,
            &[Target {
                name: "s".into(),
                joints_deg: q,
                position_mm: [0.0; 3],
                orientation_wxyz: None,
            }],
        )
        .unwrap();
        controller::kuka_status(&d[0].config, &d[0].axes_deg)
    };
    // q3 = A3 − 90°.
    assert_eq!(status(vec![0.0, 0.0, phi + 0.01 - 90.0, 0.0, 30.0, 0.0]), 2);
    assert_eq!(status(vec![0.0, 0.0, phi - 0.01 - 90.0, 0.0, 30.0, 0.0]), 0);
    assert_eq!(status(vec![0.0, 0.0, -90.0, 0.0, -30.0, 0.0]), 4);
    // Lower arm 40° back, forearm folded back over it: the wrist behind axis 1.
    assert_eq!(status(vec![0.0, -40.0, -180.0, 0.0, 30.0, 0.0]) & 1, 1);
    let turn = controller::kuka_turn(&[-1.0, 1.0, -1.0, 1.0, -1.0, -1.0]);
    assert_eq!(turn, 0b110101);
    let cf = controller::abb_confdata(
        &controller::ArmConfig {
            behind_axis1: true,
            behind_lower_arm: false,
            wrist_negative: true,
        },
        &[-0.5, 0.0, 0.0, 90.0, 0.0, -180.5],
    );
    assert_eq!(cf, [-1, 1, -3, 5]);
}

#[test]
fn bad_text_is_refused_naming_line_and_field() {
    let cases: [(Format, &str, &str); 8] = [
        (
            Format::KukaKrl,
            "DEFDAT x\n; target a\nDECL E6POS XP1={X 1.0,Y 2.0,Z nan,A 0,B 0,C 0}\nENDDAT\n",
            "t:3: XP1.Z: \"nan\" is not a finite number",
        ),
        (
            Format::KukaKrl,
            "DECL E6AXIS XA1={A1 0,A2 0,A3 0,A4 0,A5 0}\n",
            "t:1: XA1: field A6 is missing",
        ),
        (
            Format::KukaKrl,
            "DECL E6POS XP1={X 1,Y 2,Z 3,A 0,B 0,C 0,Q 1}\n",
            "t:1: XP1: unknown field Q in a E6POS",
        ),
        (
            Format::AbbRapid,
            "MODULE m\n  CONST robtarget p1:=[[1,2,3],[1,0,0],[0,0,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]];\n",
            "t:2: p1.rot: 3 values where 4 are expected",
        ),
        (
            Format::AbbRapid,
            "CONST robtarget p1:=[[1,2,3],[0.5,0,0,0],[0,0,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]];\n",
            "t:1: p1.rot: norm 0.5 is not that of a unit quaternion",
        ),
        (
            Format::Urscript,
            "def p():\n  global p1 = p[0.1, 0.2, 0.3, 0, 0]\nend\n",
            "t:2: p1 (pose): 5 values where 6 are expected",
        ),
        (
            Format::Urscript,
            "def p():\n  global q1 = [0, 0, 0, x, 0, 0]\nend\n",
            "t:2: q1 (joints)[3]: \"x\" is not a finite number",
        ),
        (Format::Csv, "target,a1\n", "t:1: the header row must be"),
    ];
    for (format, text, want) in cases {
        let e = controller::read(format, text, "t").unwrap_err().to_string();
        assert!(e.starts_with(want), "{format}: {e}\nwanted {want}");
    }
}

#[test]
fn bad_targets_and_robots_are_refused() {
    let robot = robot("kr1000-titan.json");
    let t = |name: &str, n: usize, q: Option<[f64; 4]>| Target {
        name: name.into(),
        joints_deg: vec![1.0; n],
        position_mm: [0.0; 3],
        orientation_wxyz: q,
    };
    let e = controller::declare(&robot, &[t("a", 6, None), t("b", 5, None)]).unwrap_err();
    assert_eq!(
        e.to_string(),
        "target 1 (\"b\"): 5 joint values for a robot of 6 joints"
    );
    let e = controller::declare(&robot, &[t("a\nb", 6, None)]).unwrap_err();
    assert!(e.to_string().contains("one line"), "{e}");
    let e = controller::declare(&robot, &[t(" a", 6, None)]).unwrap_err();
    assert!(e.to_string().contains("spaces around it"), "{e}");
    let e = controller::declare(&robot, &[t("a", 6, Some([0.5, 0.0, 0.0, 0.0]))]).unwrap_err();
    assert!(e.to_string().contains("not a unit quaternion"), "{e}");
    let track = self::robot("kr1000-track.json");
    let e = controller::declare(&track, &[t("a", 7, None)]).unwrap_err();
    assert!(e.to_string().contains("six revolute joints"), "{e}");
    let e = controller::write(Format::KukaKrl, "1abc", &[], &[]).unwrap_err();
    assert!(e.to_string().contains("program name \"1abc\""), "{e}");
    assert_eq!("kuka-krl".parse::<Format>().unwrap(), Format::KukaKrl);
    assert!(
        "krl"
            .parse::<Format>()
            .unwrap_err()
            .to_string()
            .contains("csv, kuka-krl")
    );
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    /// Random joints in the limits of either robot, random names without control
    /// characters: every format round-trips.
    #[test]
    fn random_targets_round_trip(
        ur in any::<bool>(),
        fractions in prop::collection::vec(prop::array::uniform6(0.0f64..1.0), 1..6),
        names in prop::collection::vec("[^\\p{Cc}]{1,12}", 6),
    ) {
        let robot = robot(if ur { "ur10.json" } else { "kr1000-titan.json" });
        let sets: Vec<Vec<f64>> = fractions
            .iter()
            .map(|f| {
                (0..6)
                    .map(|i| {
                        let [lo, hi] = robot.limits_rad(i).map(f64::to_degrees);
                        lo + (hi - lo) * f[i]
                    })
                    .collect()
            })
            .collect();
        let mut ts = targets(&robot, &sets);
        for (t, n) in ts.iter_mut().zip(&names) {
            // A name is one line; the readers trim it.
            t.name = n.trim().to_owned();
            if t.name.is_empty() {
                t.name = "x".into();
            }
        }
        let decl = controller::declare(&robot, &ts).unwrap();
        for format in Format::ALL {
            check(&robot, format, &decl);
        }
    }
}
