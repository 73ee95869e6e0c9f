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
