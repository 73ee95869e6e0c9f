//! `kincal compensate --format` (issue 40, docs/controller.md): the compensated joints as a
//! controller program, read back by the `controller` crate's reader: the joints as the robot
//! file's controller axes, the Cartesian targets the nominal TCP poses, named by the ids.

use controller::Format;
use kinematics::Robot;

use crate::common::{kincal, kr1000, ok, s, stderr};

#[test]
fn compensate_writes_every_format_and_it_reads_back() {
    let dir = tempfile::tempdir().unwrap();
    let targets = dir.path().join("targets.csv");
    let joints = [
        [10.0, 20.0, -30.0, 40.0, 50.0, 60.0],
        [-45.0, 35.0, -60.0, -20.0, -75.0, 40.0],
    ];
    let mut text = "id,q1,q2,q3,q4,q5,q6\n".to_owned();
    for (k, q) in joints.iter().enumerate() {
        let row: Vec<String> = q.iter().map(|v| v.to_string()).collect();
        text += &format!("p{k},{}\n", row.join(","));
    }
    std::fs::write(&targets, text).unwrap();
    let robot = Robot::from_file(kr1000()).unwrap();
    let map = robot.controller().unwrap();
    // The calibrated robot is the nominal one here: the joints to command are the targets'.
    let compensate = |extra: &[&str]| {
        let mut args = vec![
            "compensate",
            "--robot",
            s(kr1000()),
            "--nominal",
            s(kr1000()),
            "--targets",
            s(&targets),
        ];
        args.extend_from_slice(extra);
        kincal(&args)
    };
    for format in Format::ALL {
        let out = dir.path().join(format!("cell_1.{}", format.extension()));
        ok(&compensate(&[
            "--format",
            format.as_str(),
            "--out",
            s(&out),
        ]));
        let written = std::fs::read_to_string(&out).unwrap();
        if format == Format::Csv {
            assert!(
                written.contains("id,q1,q2,q3,q4,q5,q6,x,y,z\n"),
                "{written}"
            );
            continue;
        }
        assert!(
            written.contains("cell_1"),
            "the program is named after --out:\n{written}"
        );
        let back = controller::read(format, &written, "out").unwrap();
        assert_eq!(back.len(), 2, "{written}");
        for (k, (b, q)) in back.iter().zip(&joints).enumerate() {
            assert_eq!(b.name, format!("p{k}"));
            let axes = b.axes_deg.unwrap();
            let want = map.axes_of(q);
            for i in 0..6 {
                assert!(
                    (axes[i] - want[i]).abs() < 1e-4,
                    "{format}: {axes:?} vs {want:?}"
                );
            }
            let (p, _) = controller::tcp_pose(&robot, q);
            let got = b.position_mm.unwrap();
            for i in 0..3 {
                assert!((got[i] - p[i]).abs() < 1e-3, "{format}: {got:?} vs {p:?}");
            }
        }
    }
    let bad = compensate(&["--format", "krl"]);
    assert!(!bad.status.success());
    assert!(
        stderr(&bad).contains("csv, kuka-krl, abb-rapid, urscript"),
        "{}",
        stderr(&bad)
    );
}

/// `identify` keeps the robot file's controller mapping in both files it writes, and
/// `compensate --format` with that pair writes the compensated joints (the CSV's) as the
/// controller's axes.
#[test]
fn identify_keeps_the_mapping_and_compensate_uses_it() {
    let root = crate::common::root();
    let robot = root.join("scenarios/robots/ur10.json");
    let data = root.join("data/ur10-ipa/series-b-joint-configurations.csv");
    let dir = tempfile::tempdir().unwrap();
    let cal = dir.path().join("cal");
    ok(&kincal(&[
        "identify",
        "--robot",
        s(&robot),
        "--data",
        s(&data),
        "--every",
        "15",
        "--out",
        s(&cal),
    ]));
    let nominal = kinematics::RobotSpec::from_file(&robot).unwrap();
    assert!(nominal.controller.is_some());
    for file in ["identified.json", "registered-nominal.json"] {
        let spec = kinematics::RobotSpec::from_file(&cal.join(file)).unwrap();
        assert_eq!(spec.controller, nominal.controller, "{file}");
    }
    let targets = dir.path().join("targets.csv");
    std::fs::write(
        &targets,
        "id,q1,q2,q3,q4,q5,q6\na,10,-80,70,-90,-80,20\nb,-30,-100,90,-60,-100,45\n",
    )
    .unwrap();
    let run = |format: &str| {
        ok(&kincal(&[
            "compensate",
            "--robot",
            s(&cal.join("identified.json")),
            "--nominal",
            s(&cal.join("registered-nominal.json")),
            "--targets",
            s(&targets),
            "--allow-unreachable",
            "--format",
            format,
        ]))
    };
    let csv = run("csv");
    let rows: Vec<Vec<f64>> = csv
        .lines()
        .filter(|l| !l.starts_with('#'))
        .skip(1)
        .map(|l| {
            l.split(',')
                .skip(1)
                .take(6)
                .map(|v| v.parse().unwrap())
                .collect()
        })
        .collect();
    let back = controller::read(Format::AbbRapid, &run("abb-rapid"), "out").unwrap();
    assert_eq!(back.len(), rows.len());
    for (b, q) in back.iter().zip(&rows) {
        let axes = b.axes_deg.unwrap();
        for i in 0..6 {
            assert!((axes[i] - q[i]).abs() <= 0.5e-4 + 1e-9, "{axes:?} vs {q:?}");
        }
    }
}
