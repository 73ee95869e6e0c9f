//! `identify --residual-model gp`, `predict` with the model it writes, and `urdf export` of
//! such a robot, on the UR10 recording (every 5th row identifies: 299 poses, on which the
//! hybrid helps — `docs/residual-model.md`).

use crate::common::{kincal, ok, s, stderr};

const DATA: &str = "data/ur10-ipa/series-b-joint-configurations.csv";

fn identify(out: &std::path::Path) -> String {
    ok(&kincal(&[
        "identify",
        "--robot",
        "scenarios/robots/ur10.json",
        "--data",
        DATA,
        "--every",
        "5",
        "--residual-model",
        "gp",
        "--out",
        s(out),
    ]))
}

/// The mean |file − predicted| that `predict` prints on stderr.
fn mean_error(stderr: &str) -> f64 {
    let at = stderr.find("mean ").expect("a mean") + 5;
    stderr[at..].split(' ').next().unwrap().parse().unwrap()
}

#[test]
fn identify_keeps_the_model_and_predict_applies_it() {
    let dir = tempfile::tempdir().unwrap();
    let (a, b) = (dir.path().join("a"), dir.path().join("b"));
    let console = identify(&a);
    assert!(console.contains("residual model (gp): used"), "{console}");
    assert!(
        console.contains("residual-model.json (the learned residual model"),
        "{console}"
    );
    let model = std::fs::read(a.join("residual-model.json")).unwrap();
    let robot = std::fs::read_to_string(a.join("identified.json")).unwrap();
    assert!(robot.contains("\"residual_model\"") && robot.contains("residual-model.json"));
    let report = std::fs::read_to_string(a.join("report.md")).unwrap();
    assert!(report.contains("## Learned residual model") && report.contains("| 5 |"));
    // The same run again: the same bytes.
    identify(&b);
    assert_eq!(std::fs::read(b.join("residual-model.json")).unwrap(), model);
    assert_eq!(
        std::fs::read_to_string(b.join("identified.json")).unwrap(),
        robot
    );

    // predict: the hybrid is closer to the measured points than the geometry (on all
    // 1,495 rows, 1,196 of them never seen), and --with-sd writes sx, sy, sz.
    let robot_path = a.join("identified.json");
    let out = dir.path().join("p.csv");
    let hybrid = kincal(&[
        "predict",
        "--robot",
        s(&robot_path),
        "--joints",
        DATA,
        "--with-sd",
        "--out",
        s(&out),
    ]);
    ok(&hybrid);
    let text = std::fs::read_to_string(&out).unwrap();
    assert!(
        text.contains("q1,q2,q3,q4,q5,q6,x,y,z,sx,sy,sz"),
        "{}",
        &text[..400]
    );
    let geometry = kincal(&[
        "predict",
        "--robot",
        s(&robot_path),
        "--joints",
        DATA,
        "--geometry-only",
    ]);
    ok(&geometry);
    let (h, g) = (mean_error(&stderr(&hybrid)), mean_error(&stderr(&geometry)));
    assert!(stderr(&hybrid).contains("include the learned residual model"));
    assert!(h < 0.85 * g, "hybrid {h} mm, geometry {g} mm");

    compensate_applies_the_model(dir.path(), &a);

    // urdf export says what it cannot carry.
    let urdf = kincal(&[
        "urdf",
        "export",
        s(&robot_path),
        "--out",
        s(&dir.path().join("r.urdf")),
    ]);
    assert!(
        ok(&urdf).contains("cannot be expressed in URDF"),
        "{}",
        ok(&urdf)
    );

    // A model file that is not the one named is refused, naming it.
    std::fs::write(a.join("residual-model.json"), b"{}").unwrap();
    let bad = kincal(&["predict", "--robot", s(&robot_path), "--joints", DATA]);
    assert!(!bad.status.success());
    assert!(
        stderr(&bad).contains("--robot") && stderr(&bad).contains("SHA-256"),
        "{}",
        stderr(&bad)
    );
}

/// `compensate` of the identify output in `a` (150 of the recording's poses as joint
/// targets): the model is applied and the header and console say so; `predict` with the model
/// at the joints to command gives back the targets (the fixed point: `FK(q) + r(q) =
/// target`), where the geometry-only joints miss them by the model's correction;
/// `--geometry-only` gives the bytes of the same robot naming no model (the geometric path,
/// as before the model was applied); the same run, the same bytes; a model file missing is
/// refused, as `predict` refuses it.
fn compensate_applies_the_model(dir: &std::path::Path, a: &std::path::Path) {
    let text = std::fs::read_to_string(crate::common::root().join(DATA)).unwrap();
    let targets = dir.join("targets.csv");
    let lines: Vec<&str> = text.lines().collect();
    std::fs::write(&targets, lines[..151].join("\n") + "\n").unwrap();
    let (robot, nominal) = (a.join("identified.json"), a.join("registered-nominal.json"));
    let compensate = |robot: &std::path::Path, out: &std::path::Path, extra: &[&str]| {
        let mut args = vec![
            "compensate",
            "--robot",
            s(robot),
            "--nominal",
            s(&nominal),
            "--targets",
            s(&targets),
            "--allow-unreachable",
            "--out",
            s(out),
        ];
        args.extend_from_slice(extra);
        let o = kincal(&args);
        ok(&o);
        (stderr(&o), std::fs::read_to_string(out).unwrap())
    };
    let (console, hybrid) = compensate(&robot, &dir.join("h.csv"), &[]);
    assert!(
        console.contains("include the learned residual model named in")
            && console.contains("--geometry-only to leave it out"),
        "{console}"
    );
    assert!(
        hybrid.contains("# residual model: applied (residual-model.json, docs/residual-model.md)"),
        "{}",
        &hybrid[..hybrid.len().min(1500)]
    );
    assert_eq!(compensate(&robot, &dir.join("h2.csv"), &[]).1, hybrid);
    let (_, krl) = compensate(&robot, &dir.join("h.dat"), &["--format", "kuka-krl"]);
    assert!(
        krl.contains("residual model applied: the joints include the mean of residual-model.json"),
        "{}",
        &krl[..krl.len().min(800)]
    );
    let (console, geometric) = compensate(&robot, &dir.join("g.csv"), &["--geometry-only"]);
    assert!(console.contains("--geometry-only"), "{console}");
    assert!(!geometric.contains("residual model") && geometric != hybrid);
    // The same robot naming no model (its provenance without `residual_model`): the bytes
    // of the geometric path.
    let plain = dir.join("plain");
    std::fs::create_dir(&plain).unwrap();
    let json = std::fs::read_to_string(&robot).unwrap();
    let stripped = regex::Regex::new(r#",\s*"residual_model"\s*:\s*\{[^}]*\}"#)
        .unwrap()
        .replace(&json, "");
    assert_ne!(stripped, json);
    std::fs::write(plain.join("identified.json"), stripped.as_bytes()).unwrap();
    let (_, old) = compensate(
        &plain.join("identified.json"),
        &dir.join("g.csv"),
        &["--allow", "provenance"],
    );
    assert_eq!(old, geometric);

    // The hybrid model at the joints to command: the targets (to the fixed point's
    // tolerance); at the geometry-only joints, off by the model's correction.
    let at = |joints: &str| {
        let f = dir.join("j.csv");
        std::fs::write(&f, joints).unwrap();
        let o = kincal(&["predict", "--robot", s(&robot), "--joints", s(&f)]);
        mean_error(&stderr(&o))
    };
    let (h, g) = (at(&hybrid), at(&geometric));
    assert!(h < 1e-5 && g > 0.02, "hybrid {h} mm, geometry-only {g} mm");

    // A model file missing is refused, naming it.
    let model = a.join("residual-model.json");
    let bytes = std::fs::read(&model).unwrap();
    std::fs::remove_file(&model).unwrap();
    let bad = kincal(&[
        "compensate",
        "--robot",
        s(&robot),
        "--nominal",
        s(&nominal),
        "--targets",
        s(&targets),
    ]);
    assert!(!bad.status.success());
    assert!(
        stderr(&bad).contains("--robot") && stderr(&bad).contains("cannot be read"),
        "{}",
        stderr(&bad)
    );
    std::fs::write(&model, bytes).unwrap();
}

#[test]
fn with_sd_needs_a_model() {
    let out = kincal(&[
        "predict",
        "--robot",
        "scenarios/robots/ur10.json",
        "--joints",
        DATA,
        "--with-sd",
    ]);
    assert!(!out.status.success());
    assert!(
        stderr(&out).contains("--with-sd") && stderr(&out).contains("names no residual model"),
        "{}",
        stderr(&out)
    );
}

/// The mean angle `predict` prints on stderr (`angle file − predicted mean X°`).
fn mean_angle(stderr: &str) -> f64 {
    let key = "angle file − predicted mean ";
    let at = stderr.find(key).expect("an angle") + key.len();
    stderr[at..].split('°').next().unwrap().parse().unwrap()
}

/// 6-DoF data end to end (`kincal simulate` of the paper KR1000 measured by a probe, with its
/// compliance and gear errors): `identify --residual-model gp` keeps both parts and writes a
/// `kincal-residual-model/2` file; `predict` with it is closer to the validation poses'
/// orientations than `--geometry-only`; `compensate` of Cartesian targets applies the
/// orientation part and says so.
#[test]
fn six_dof_identify_predict_compensate() {
    let dir = tempfile::tempdir().unwrap();
    let root = crate::common::root();
    let mut scenario: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(root.join("scenarios/paper-kr1000.json")).unwrap(),
    )
    .unwrap();
    scenario["robot"] = serde_json::json!(s(&root.join("scenarios/robots/kr1000-titan.json")));
    scenario["measurement"] = serde_json::json!({"type": "frame"});
    scenario["poses"] = serde_json::json!({"identification": 150, "validation": 40});
    scenario["iso"] = serde_json::json!({"enabled": false});
    scenario["residual_budget"] = serde_json::json!({"enabled": false});
    let scenario_path = dir.path().join("scenario.json");
    std::fs::write(&scenario_path, scenario.to_string()).unwrap();
    let sim = dir.path().join("sim");
    ok(&kincal(&["simulate", s(&scenario_path), "--out", s(&sim)]));
    let out = dir.path().join("id");
    let console = ok(&kincal(&[
        "identify",
        "--robot",
        "scenarios/robots/kr1000-titan.json",
        "--data",
        s(&sim.join("identification.csv")),
        "--residual-model",
        "gp",
        "--out",
        s(&out),
    ]));
    assert!(
        console.contains("residual model (gp): used")
            && console.contains("orientation part: applied"),
        "{console}"
    );
    let model = std::fs::read_to_string(out.join("residual-model.json")).unwrap();
    assert!(model.contains("\"format\": \"kincal-residual-model/2\""));
    let report = std::fs::read_to_string(out.join("report.md")).unwrap();
    assert!(report.contains("Orientation part (6-DoF data"), "{report}");

    let robot = out.join("identified.json");
    let validation = sim.join("validation.csv");
    let predict = |extra: &[&str]| {
        let mut args = vec![
            "predict",
            "--robot",
            s(&robot),
            "--joints",
            s(&validation),
            "--out",
            "-",
        ];
        args.extend(extra);
        let o = kincal(&args);
        ok(&o);
        stderr(&o)
    };
    let (hybrid, geometric) = (predict(&["--with-sd"]), predict(&["--geometry-only"]));
    assert!(
        hybrid.contains("points and orientations include"),
        "{hybrid}"
    );
    let (h, g) = (mean_angle(&hybrid), mean_angle(&geometric));
    assert!(h < 0.8 * g, "held-out angle: hybrid {h}°, geometry {g}°");

    // Cartesian targets: the validation poses as measured, in the measurement frame.
    let text = std::fs::read_to_string(&validation).unwrap();
    let mut lines = text.lines().filter(|l| !l.starts_with('#'));
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let cols: Vec<usize> = ["id", "x", "y", "z", "qw", "qx", "qy", "qz"]
        .iter()
        .map(|c| header.iter().position(|h| h == c).unwrap())
        .collect();
    let mut targets = String::from("id,x,y,z,qw,qx,qy,qz\n");
    let mut start = String::new();
    for (k, l) in lines.take(10).enumerate() {
        let v: Vec<&str> = l.split(',').collect();
        if k == 0 {
            start = v[1..7].join(",");
        }
        let row: Vec<&str> = cols.iter().map(|&i| v[i]).collect();
        targets.push_str(&row.join(","));
        targets.push('\n');
    }
    let targets_path = dir.path().join("targets.csv");
    std::fs::write(&targets_path, targets).unwrap();
    let o = kincal(&[
        "compensate",
        "--robot",
        s(&robot),
        "--nominal",
        s(&out.join("registered-nominal.json")),
        "--targets",
        s(&targets_path),
        "--frame",
        "measurement",
        &format!("--start-joints={start}"),
        "--allow-unreachable",
        "--out",
        "-",
    ]);
    let csv = ok(&o);
    assert!(csv.contains("with its orientation part"), "{csv}");
    assert!(
        stderr(&o).contains("orientation part |r_o| max"),
        "{}",
        stderr(&o)
    );
}
