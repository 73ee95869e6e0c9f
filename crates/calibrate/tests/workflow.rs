//! The workflow as a library: the real UR10 (data/ur10-ipa) every 15th row, validated on the
//! rest, against the independent SciPy MINPACK fit quoted in data/ur10-ipa/README.md; bad
//! requests are refused before anything is read, naming the request field. (The rendered
//! outputs and the plots shown in docs/img: `crates/report/tests/render.rs`; the flags the
//! command line names and a failed write: `crates/kincal/tests/calibrate_cli.rs`.)

use std::path::PathBuf;

use calibrate::{CalibrateError, IdentifyRequest, Refusal, Split};

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn ur10_request() -> IdentifyRequest {
    IdentifyRequest {
        split: Split::Every {
            every: 15,
            offset: 0,
        },
        ..IdentifyRequest::new(
            root().join("scenarios/robots/ur10.json"),
            root().join("data/ur10-ipa/series-b-joint-configurations.csv"),
        )
    }
}

#[test]
fn ur10_every_15th_row_matches_the_independent_fit() {
    let cal = calibrate::run(&ur10_request()).unwrap();
    assert_eq!(cal.used.len(), 100);
    let v = cal.validation.as_ref().expect("the other rows validate");
    assert_eq!(v.rows.len(), 1395);
    let after = &v.table.after.norm;
    // SciPy's MINPACK LM on the same split: 0.45 mm mean, 1.77 mm max (README of the data).
    assert!((after.mean_mm - 0.45).abs() < 0.01, "{}", after.mean_mm);
    assert!((after.max_mm - 1.77).abs() < 0.02, "{}", after.max_mm);
    assert!(v.table.before.norm.mean_mm > 2.5);
}

#[test]
fn bad_options_are_refused_with_the_field_named() {
    let mut r = ur10_request();
    r.outlier_k = f64::NAN;
    let e = calibrate::run(&r).unwrap_err();
    assert!(matches!(e, CalibrateError::Refused(_)));
    assert!(e.to_string().contains("outlier_k = NaN"), "{e}");
    let mut r = ur10_request();
    r.split = Split::Every {
        every: 3,
        offset: 3,
    };
    let e = calibrate::run(&r).unwrap_err();
    assert!(matches!(
        e,
        CalibrateError::Refused(Refusal::OffsetNotBelowEvery {
            every: 3,
            offset: 3
        })
    ));
    assert!(e.to_string().contains("offset = 3"), "{e}");
    let mut r = ur10_request();
    r.robot = root().join("scenarios/robots/missing.json");
    let e = calibrate::run(&r).unwrap_err();
    assert!(e.to_string().contains("missing.json"), "{e}");
}

/// `--select N --criterion C`: identify on the rows `design::select_rows` chooses from the
/// joints alone, validate on every other row.
#[test]
fn select_identifies_on_the_designed_rows_and_validates_on_the_rest() {
    let mut r = ur10_request();
    r.split = Split::Select {
        poses: 20,
        criterion: design::Criterion::D,
    };
    let cal = calibrate::run(&r).unwrap();
    assert_eq!(cal.used.len(), 20);
    let v = cal.validation.as_ref().unwrap();
    assert_eq!(v.rows.len(), 1495 - 20);
    let mut lines: Vec<usize> = cal.used.iter().chain(&v.rows).map(|m| m.line).collect();
    lines.sort_unstable();
    lines.dedup();
    assert_eq!(
        lines.len(),
        1495,
        "every row identifies or validates, none both"
    );
    // The same rows as the design crate chooses on the nominal model.
    let robot = kinematics::Robot::from_file(&r.robot).unwrap();
    let mut rows: Vec<_> = cal.used.iter().chain(&v.rows).cloned().collect();
    rows.sort_by_key(|m| m.line);
    let q_deg: Vec<f64> = rows.iter().flat_map(|m| m.q_deg.clone()).collect();
    let chosen = design::select_rows(&robot, &q_deg, 20, design::Criterion::D, None).unwrap();
    let chosen_lines: Vec<usize> = chosen.iter().map(|&i| rows[i].line).collect();
    let used_lines: Vec<usize> = cal.used.iter().map(|m| m.line).collect();
    assert_eq!(used_lines, chosen_lines);
    // 20 designed rows validate about as well as 100 rows every 15th (0.452 mm): geometry
    // plus what the UR10's compliance leaves.
    let after = &v.table.after.norm;
    assert!(after.mean_mm < 0.5, "{}", after.mean_mm);
    // The summary prints the selection (`report::calibration::summary`).
    assert!(cal.selection.contains("chosen by the D criterion"));
}

#[test]
fn select_refuses_too_few_or_too_many_rows() {
    for (n, says) in [(5, "need at least"), (1495, "choose fewer")] {
        let mut r = ur10_request();
        r.split = Split::Select {
            poses: n,
            criterion: design::Criterion::I,
        };
        let e = calibrate::run(&r).unwrap_err().to_string();
        assert!(
            e.contains(&format!("select {n} rows")) && e.contains(says),
            "{e}"
        );
    }
}

/// Joint values in radians in a file read as degrees are flagged (a notice the CLI prints),
/// and data in degrees are not.
#[test]
fn joints_that_look_like_radians_are_flagged() {
    let robot =
        calibrate::LoadedRobot::load(&root().join("scenarios/robots/ur10.json"), "robot").unwrap();
    let data = root().join("data/ur10-ipa/series-b-joint-configurations.csv");
    let degrees = robot.read_set(&data, true, (1, None), "data").unwrap();
    assert!(
        degrees.notices.iter().all(|n| !n.contains("radians")),
        "{:?}",
        degrees.notices
    );
    let text = std::fs::read_to_string(&data).unwrap();
    let mut out = String::new();
    for (i, line) in text
        .lines()
        .filter(|l| !l.starts_with('#'))
        .take(20)
        .enumerate()
    {
        if i == 0 {
            out += line;
        } else {
            let v: Vec<&str> = line.split(',').collect();
            let q: Vec<String> = v[..6]
                .iter()
                .map(|x| format!("{}", x.parse::<f64>().unwrap().to_radians()))
                .collect();
            out += &format!("{},{}", q.join(","), v[6..].join(","));
        }
        out += "\n";
    }
    let tmp = tempfile::tempdir().unwrap();
    let file = tmp.path().join("rad.csv");
    std::fs::write(&file, out).unwrap();
    let radians = robot.read_set(&file, true, (1, None), "data").unwrap();
    assert!(
        radians
            .notices
            .iter()
            .any(|n| n.contains("are these radians?") && n.contains("rad.csv")),
        "{:?}",
        radians.notices
    );
}
