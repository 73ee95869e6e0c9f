//! Command-line tests of `identify` on 6-DoF and multi-target data (issue 31): the flags
//! `--euler`, `--orientation-weight` and `--points-only`, their bad values (clear errors
//! naming the flag, file and line), `--select` with 6-DoF data, and the UR10 figures of
//! `docs/calibrating-real-data.md` (point-only 0.452 / 1.767 mm, 6-DoF 0.422 mm held out).

use std::path::Path;
use std::process::Output;

use crate::common::{kincal, ok, s};

const ROBOT: &str = "scenarios/robots/ur10.json";
const SIX: &str = "data/ur10-ipa/series-b-6dof.csv";

fn stderr(out: &Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

/// `kincal identify` on the UR10 robot with `data` and `extra`, into `out`.
fn identify(data: &str, out: &Path, extra: &[&str]) -> Output {
    let mut args = vec![
        "identify",
        "--robot",
        ROBOT,
        "--data",
        data,
        "--out",
        s(out),
    ];
    args.extend_from_slice(extra);
    kincal(&args)
}

/// A failed command whose stderr names every one of `needles`; nothing written.
fn fails_naming(out: &Output, dir: &Path, needles: &[&str]) {
    let err = stderr(out);
    assert!(!out.status.success(), "succeeded: {err}");
    for n in needles {
        assert!(err.contains(n), "{n:?} not in: {err}");
    }
    assert!(!dir.join("identified.json").exists());
}

#[test]
fn six_dof_and_points_only_keep_the_documented_figures() {
    let tmp = tempfile::tempdir().unwrap();
    let six = ok(&identify(SIX, &tmp.path().join("six"), &["--every", "15"]));
    assert!(
        six.contains("identified position mean 0.422 mm, max 1.936 mm"),
        "{six}"
    );
    assert!(six.contains("orientation rows 5 per degree"), "{six}");
    let robot = std::fs::read_to_string(tmp.path().join("six/identified.json")).unwrap();
    assert!(robot.contains("tool_rotation_deg"));
    // The HTML report shows position (mm) and orientation (degrees) errors separately.
    let html = std::fs::read_to_string(tmp.path().join("six/report.html")).unwrap();
    assert!(html.contains("error-cdf.svg") && html.contains("orientation-error-cdf.svg"));
    assert!(html.contains("position error") && html.contains("orientation error"));
    let points = ok(&identify(
        SIX,
        &tmp.path().join("points"),
        &["--every", "15", "--points-only"],
    ));
    assert!(
        points.contains("calibrated mean 0.452 mm, max 1.767 mm"),
        "{points}"
    );
    let robot = std::fs::read_to_string(tmp.path().join("points/identified.json")).unwrap();
    assert!(!robot.contains("tool_rotation_deg"));
}

/// Issue 37: 6-DoF `identify --out` writes the same set of files as point `identify` on the
/// same poses (the orientation error's plot besides), runs the same checks (a far parameter
/// is refused on both), and its `parameters.json` is the same table, naming the measurement.
#[test]
fn six_dof_identify_writes_the_files_of_point_identify() {
    let tmp = tempfile::tempdir().unwrap();
    let names = |dir: &Path| -> std::collections::BTreeSet<String> {
        std::fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect()
    };
    ok(&identify(SIX, &tmp.path().join("six"), &["--every", "15"]));
    let points = "data/ur10-ipa/series-b-joint-configurations.csv";
    ok(&identify(
        points,
        &tmp.path().join("points"),
        &["--every", "15"],
    ));
    let (six, pts) = (
        names(&tmp.path().join("six")),
        names(&tmp.path().join("points")),
    );
    for f in [
        "identified.json",
        "registered-nominal.json",
        "parameters.json",
        "report.md",
        "report.html",
        "pose-errors.svg",
        "error-cdf.svg",
        "residuals-per-axis.svg",
        "outliers.svg",
        "outliers.csv",
    ] {
        assert!(pts.contains(f), "{f} not in {pts:?}");
    }
    let extra: Vec<&String> = six.difference(&pts).collect();
    assert!(pts.is_subset(&six), "{pts:?} ⊄ {six:?}");
    assert_eq!(extra, ["orientation-error-cdf.svg"]);
    let table: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(tmp.path().join("six/parameters.json")).unwrap(),
    )
    .unwrap();
    assert_eq!(table["format"], "kincal-parameters/1");
    assert_eq!(
        table["measurement"],
        "6-DoF (point and orientation per pose)"
    );
    let names: Vec<&str> = table["parameters"]
        .as_array()
        .unwrap()
        .iter()
        .map(|p| p["name"].as_str().unwrap())
        .collect();
    assert!(
        names.contains(&"a2") && names.contains(&"tool_rx"),
        "{names:?}"
    );
    let registered =
        std::fs::read_to_string(tmp.path().join("six/registered-nominal.json")).unwrap();
    assert!(
        registered.contains("base registered on series-b-6dof.csv"),
        "{registered}"
    );
    // The same refusal on both kinds: a robot file whose a2 is 150 mm off.
    let mut robot: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(crate::common::root().join(ROBOT)).unwrap())
            .unwrap();
    let a2 = robot["joints"][1]["a_mm"].as_f64().unwrap();
    robot["joints"][1]["a_mm"] = serde_json::json!(a2 - 150.0);
    let far = tmp.path().join("far.json");
    std::fs::write(&far, robot.to_string()).unwrap();
    for data in [SIX, points] {
        let dir = tmp.path().join("far");
        let out = kincal(&[
            "identify",
            "--robot",
            s(&far),
            "--data",
            data,
            "--every",
            "15",
            "--out",
            s(&dir),
        ]);
        fails_naming(
            &out,
            &dir,
            &["parameters check", "--allow parameters", "a2 +1"],
        );
    }
}

#[test]
fn orientation_weight_is_a_typed_value() {
    let tmp = tempfile::tempdir().unwrap();
    for bad in ["abc", "-1", "0", "inf", "NaN", ""] {
        let dir = tmp.path().join("bad");
        let out = identify(SIX, &dir, &["--every", "15", "--orientation-weight", bad]);
        fails_naming(&out, &dir, &["--orientation-weight", "sigma", "> 0"]);
    }
    let ratio = ok(&identify(
        SIX,
        &tmp.path().join("ratio"),
        &["--every", "15", "--orientation-weight", "2.5"],
    ));
    assert!(
        ratio.contains("orientation rows 2.5 per degree (1° weighs as 2.5 mm, as asked)"),
        "{ratio}"
    );
    let sigma = ok(&identify(
        SIX,
        &tmp.path().join("sigma"),
        &["--every", "15", "--orientation-weight", "sigma"],
    ));
    assert!(sigma.contains("weighting: each row by its σ"), "{sigma}");
}

/// Euler columns: the convention is required (the error names `--euler`, the file and the
/// header line), a bad convention names the flag, a bad angle names the file, line and
/// column; with a convention the file identifies.
#[test]
fn euler_columns_and_their_errors() {
    let tmp = tempfile::tempdir().unwrap();
    // 12 poses of the 6-DoF file as Euler XYZ (intrinsic): R = Rx·Ry·Rz.
    let set = measurements::read_file(Path::new(&crate::common::root().join(SIX)), &{
        measurements::ReadOptions::new(6)
    })
    .unwrap();
    let mut csv = String::from("q1,q2,q3,q4,q5,q6,x,y,z,rx,ry,rz\n");
    for r in set.rows.iter().step_by(100).take(15) {
        let q = r.orientation.unwrap();
        let m = measurements::quaternion_to_matrix(q);
        let m = nalgebra::Matrix3::from(m).transpose();
        // XYZ intrinsic: R = Rx(a)·Ry(b)·Rz(c).
        let b = m[(0, 2)].clamp(-1.0, 1.0).asin();
        let a = (-m[(1, 2)]).atan2(m[(2, 2)]);
        let c = (-m[(0, 1)]).atan2(m[(0, 0)]);
        let p = r.point_mm.unwrap();
        let fields: Vec<String> = r
            .q_deg
            .iter()
            .chain(&p)
            .map(|v| v.to_string())
            .chain([a, b, c].iter().map(|v| v.to_degrees().to_string()))
            .collect();
        csv.push_str(&fields.join(","));
        csv.push('\n');
    }
    let file = tmp.path().join("euler.csv");
    std::fs::write(&file, &csv).unwrap();
    let dir = tmp.path().join("out");
    let missing = identify(s(&file), &dir, &[]);
    fails_naming(&missing, &dir, &["--euler", "euler.csv:1", "rx"]);
    let bad = identify(s(&file), &dir, &["--euler", "XQZ"]);
    fails_naming(&bad, &dir, &["--euler", "XQZ"]);
    let good = ok(&identify(s(&file), &dir, &["--euler", "XYZ"]));
    assert!(
        good.contains("6-DoF (point and orientation per pose): all 15 poses"),
        "{good}"
    );
    // The orientation read back: the fit's orientation error is that of the quaternion file
    // (well below a degree), not of a misread convention.
    let line = good.lines().find(|l| l.starts_with("fit:")).unwrap();
    let mean: f64 = line
        .split("orientation mean ")
        .nth(1)
        .and_then(|t| t.split('°').next())
        .and_then(|t| t.parse().ok())
        .unwrap();
    assert!(mean < 0.1, "{line}");
    let wrong = identify(s(&file), &tmp.path().join("zyx"), &["--euler", "ZYX"]);
    if wrong.status.success() {
        let out = String::from_utf8_lossy(&wrong.stdout).into_owned();
        let line = out.lines().find(|l| l.starts_with("fit:")).unwrap();
        assert!(
            !line.contains(&format!("orientation mean {mean}")),
            "{line}"
        );
    }
    let broken = csv.replacen(
        &csv.lines()
            .nth(3)
            .unwrap()
            .rsplit(',')
            .next()
            .unwrap()
            .to_string(),
        "abc",
        1,
    );
    std::fs::write(&file, broken).unwrap();
    let dir = tmp.path().join("bad-value");
    let bad_value = identify(s(&file), &dir, &["--euler", "XYZ"]);
    fails_naming(&bad_value, &dir, &["euler.csv:4", "rz", "abc"]);
}

/// `--select` chooses poses of 6-DoF data by their frame information (6 rows per pose) and
/// validates on the others; the identified robot carries the tool frame.
#[test]
fn select_works_with_six_dof_data() {
    let tmp = tempfile::tempdir().unwrap();
    let out = ok(&identify(
        SIX,
        &tmp.path().join("sel"),
        &["--select", "20", "--criterion", "i"],
    ));
    assert!(
        out.contains("20 of 1495 poses chosen by the I criterion on their frame information"),
        "{out}"
    );
    assert!(out.contains("(the 1475 other poses)"), "{out}");
    let robot = std::fs::read_to_string(tmp.path().join("sel/identified.json")).unwrap();
    assert!(robot.contains("tool_rotation_deg"));
    let dir = tmp.path().join("too-many");
    let many = identify(SIX, &dir, &["--select", "1495"]);
    fails_naming(&many, &dir, &["--select 1495"]);
}

/// Three reflectors per pose (synthetic, from the measured frame: `p + R·o_k`, the `o_k` at
/// 120° on a 100 mm circle), one of them mistyped by 3 mm at one pose: the targets start from
/// their closed form, the pose is flagged as one block (its 9 rows) and, 6 σ̂ off, dropped as a
/// gross error by the default robust screen; `--keep-outliers` keeps it.
#[test]
fn three_targets_per_pose_and_a_flagged_pose() {
    let tmp = tempfile::tempdir().unwrap();
    let set = measurements::read_file(
        &crate::common::root().join(SIX),
        &measurements::ReadOptions::new(6),
    )
    .unwrap();
    let mut csv = String::from("id,target,q1,q2,q3,q4,q5,q6,x,y,z\n");
    let mut bad_line = 0;
    let mut line = 1;
    for (j, r) in set.rows.iter().step_by(30).take(40).enumerate() {
        let m = nalgebra::Matrix3::from(measurements::quaternion_to_matrix(r.orientation.unwrap()))
            .transpose();
        let p = nalgebra::Vector3::from(r.point_mm.unwrap());
        for (k, deg) in [0.0_f64, 120.0, 240.0].iter().enumerate() {
            let a = deg.to_radians();
            let mut t = p + m * nalgebra::Vector3::new(100.0 * a.cos(), 100.0 * a.sin(), 0.0);
            line += 1;
            if j == 17 && k == 1 {
                t.x += 3.0;
                bad_line = line;
            }
            let q: Vec<String> = r.q_deg.iter().map(|v| v.to_string()).collect();
            csv.push_str(&format!(
                "p{j},T{k},{},{},{},{}\n",
                q.join(","),
                t.x,
                t.y,
                t.z
            ));
        }
    }
    let file = tmp.path().join("targets.csv");
    std::fs::write(&file, &csv).unwrap();
    let out = ok(&identify(
        s(&file),
        &tmp.path().join("t"),
        &["--keep-outliers"],
    ));
    assert!(out.contains("3 targets per pose: all 40 poses"), "{out}");
    assert!(
        out.contains("targets started from the closed-form estimate"),
        "{out}"
    );
    let flagged = out
        .lines()
        .find(|l| l.starts_with("outliers"))
        .unwrap()
        .to_string();
    assert!(
        flagged.contains(": 1 pose — line ") && flagged.contains("kept"),
        "{flagged}"
    );
    // The flagged pose's first row (its block of 9 rows holds the mistyped one).
    let first_row_of_pose = bad_line - 1;
    assert!(
        flagged.contains(&format!("line {first_row_of_pose} ")),
        "{flagged} (bad line {bad_line})"
    );
    let rejected = ok(&identify(s(&file), &tmp.path().join("r"), &[]));
    assert!(rejected.contains("on 39 poses"), "{rejected}");
    assert!(rejected.contains("dropped and refitted"), "{rejected}");
    assert!(
        rejected.contains(&format!("excluded 1 of 40 poses: line {first_row_of_pose}")),
        "{rejected}"
    );
    // `--reject-outliers` (every flagged pose) drops the same one here.
    let all = ok(&identify(
        s(&file),
        &tmp.path().join("a"),
        &["--reject-outliers"],
    ));
    assert!(all.contains("on 39 poses"), "{all}");
    let robot = std::fs::read_to_string(tmp.path().join("r/identified.json")).unwrap();
    assert!(robot.contains("\"targets\""), "{robot}");
}

/// `kincal simulate` of a scenario that measures frames or several reflectors writes the
/// files such data give (`qw,qx,qy,qz`; `id,target`, a row per reflector), and `identify`
/// calibrates from them: it wrote points only, silently, before.
#[test]
fn simulate_writes_the_scenarios_measurement_and_identify_reads_it() {
    let tmp = tempfile::tempdir().unwrap();
    let root = crate::common::root();
    let mut scenario: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(root.join("scenarios/noise-floor.json")).unwrap(),
    )
    .unwrap();
    scenario["robot"] = serde_json::json!(crate::common::kr1000());
    scenario["residual_budget"] = serde_json::json!({ "enabled": false });
    for (kind, header, rows_per_pose) in [
        ("frame", "id,q1,q2,q3,q4,q5,q6,x,y,z,qw,qx,qy,qz", 1),
        ("targets", "id,target,q1,q2,q3,q4,q5,q6,x,y,z", 3),
    ] {
        scenario["measurement"] = serde_json::json!({ "type": kind });
        let file = tmp.path().join(format!("{kind}.json"));
        std::fs::write(&file, serde_json::to_string_pretty(&scenario).unwrap()).unwrap();
        let dir = tmp.path().join(kind);
        let out = kincal(&["simulate", s(&file), "--out", s(&dir)]);
        assert!(out.status.success(), "{}", stderr(&out));
        let text = std::fs::read_to_string(dir.join("identification.csv")).unwrap();
        let mut lines = text.lines().filter(|l| !l.starts_with('#'));
        assert_eq!(lines.next(), Some(header), "{kind}");
        let rows: Vec<Vec<f64>> = lines
            .map(|l| l.split(',').filter_map(|v| v.parse().ok()).collect())
            .collect();
        assert_eq!(rows.len(), 50 * rows_per_pose, "{kind}");
        if kind == "frame" {
            for r in &rows {
                let norm = r[9..13].iter().map(|v| v * v).sum::<f64>().sqrt();
                assert!((norm - 1.0).abs() < 1e-12 && r[9] >= 0.0, "{r:?}");
            }
        } else {
            assert!(stderr(&out).contains("50 poses (150 rows) identification"));
        }
        let calibrated = ok(&kincal(&[
            "identify",
            "--robot",
            s(crate::common::kr1000()),
            "--data",
            s(&dir.join("identification.csv")),
            "--validate",
            s(&dir.join("validation.csv")),
            "--out",
            s(&tmp.path().join(format!("{kind}-cal"))),
        ]));
        let line = calibrated
            .lines()
            .find(|l| l.starts_with("validation on"))
            .unwrap();
        let mean = |after: &str| -> f64 {
            let tail = &line[line.find(after).unwrap() + after.len()..];
            tail.split_whitespace().next().unwrap().parse().unwrap()
        };
        let (before, after) = (
            mean("nominal position mean "),
            mean("identified position mean "),
        );
        // The noise floor's simulated robot: errors of a few tenths of a millimetre after.
        assert!(after < 0.5 && after < before, "{kind}: {line}");
        assert!(
            calibrated.contains(if kind == "frame" {
                "6-DoF (point and orientation per pose)"
            } else {
                "targets"
            }),
            "{calibrated}"
        );
    }
}

/// Issue 39, item 3: a point identify into a directory holding a 6-DoF run's set leaves
/// exactly its own set there (the 6-DoF run's `orientation-error-cdf.svg`, which a point run
/// does not draw, is gone: the previous set's manifest lists it), and keeps a file of the
/// user's.
#[test]
fn a_point_set_replaces_a_six_dof_set_whole() {
    let tmp = tempfile::tempdir().unwrap();
    let (mixed, fresh) = (tmp.path().join("mixed"), tmp.path().join("fresh"));
    let points = "data/ur10-ipa/series-b-joint-configurations.csv";
    ok(&identify(SIX, &mixed, &["--every", "15"]));
    assert!(mixed.join("orientation-error-cdf.svg").exists());
    std::fs::write(mixed.join("notes.txt"), "mine").unwrap();
    ok(&identify(points, &mixed, &["--every", "15"]));
    ok(&identify(points, &fresh, &["--every", "15"]));
    let names = |d: &Path| -> Vec<String> {
        let mut v: Vec<String> = std::fs::read_dir(d)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        v.sort();
        v
    };
    let mut expected = names(&fresh);
    expected.push("notes.txt".into());
    expected.sort();
    assert_eq!(names(&mixed), expected);
}

/// The columns `names` of the CSV `text` (comment lines skipped), one vector per row.
fn columns(text: &str, names: &[&str]) -> Vec<Vec<f64>> {
    let mut lines = text.lines().filter(|l| !l.starts_with('#'));
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let idx: Vec<usize> = names
        .iter()
        .map(|n| header.iter().position(|h| h == n).expect(n))
        .collect();
    lines
        .map(|l| {
            let f: Vec<&str> = l.split(',').collect();
            idx.iter().map(|&i| f[i].parse().unwrap()).collect()
        })
        .collect()
}

/// The angle (degrees) between two unit quaternions `[w, x, y, z]`.
fn quaternion_angle_deg(a: &[f64], b: &[f64]) -> f64 {
    let dot: f64 = a.iter().zip(b).map(|(x, y)| x * y).sum();
    let norm = |q: &[f64]| q.iter().map(|v| v * v).sum::<f64>().sqrt();
    let c = (dot.abs() / (norm(a) * norm(b))).min(1.0);
    2.0 * c.acos().to_degrees()
}

/// The mean of the number after `key` in the line of `text` that starts with `line`.
fn figure_after(text: &str, line: &str, key: &str) -> f64 {
    let l = text.lines().find(|l| l.starts_with(line)).expect(line);
    let rest = &l[l.rfind(key).expect(key) + key.len()..];
    rest.split('°').next().unwrap().trim().parse().unwrap()
}

/// Issue 40 item 1: `predict` of a 6-DoF calibration writes the measured frame's orientation
/// `qw, qx, qy, qz` (unit, w ≥ 0), which agrees with the file's orientations to the fit's
/// orientation residual (over all 1495 poses: the fit's and the validation's means, weighted
/// by their pose counts); a point calibration's `predict` writes no orientation.
#[test]
fn predict_of_a_six_dof_calibration_writes_the_orientation() {
    let tmp = tempfile::tempdir().unwrap();
    let six = ok(&identify(SIX, &tmp.path().join("six"), &["--every", "15"]));
    let out = tmp.path().join("predicted.csv");
    let robot = tmp.path().join("six/identified.json");
    let p = kincal(&[
        "predict",
        "--robot",
        s(&robot),
        "--joints",
        SIX,
        "--out",
        s(&out),
    ]);
    let err = stderr(&p);
    assert!(p.status.success(), "{err}");
    let text = std::fs::read_to_string(&out).unwrap();
    assert!(
        text.lines()
            .find(|l| !l.starts_with('#'))
            .unwrap()
            .ends_with(",x,y,z,qw,qx,qy,qz"),
        "{text:.600}"
    );
    let q = ["qw", "qx", "qy", "qz"];
    let predicted = columns(&text, &q);
    let measured = columns(
        &std::fs::read_to_string(crate::common::root().join(SIX)).unwrap(),
        &q,
    );
    assert_eq!(predicted.len(), 1495);
    assert_eq!(predicted.len(), measured.len());
    for o in &predicted {
        let n = o.iter().map(|v| v * v).sum::<f64>().sqrt();
        assert!((n - 1.0).abs() < 1e-15 && o[0] >= 0.0, "{o:?}");
    }
    let angles: Vec<f64> = predicted
        .iter()
        .zip(&measured)
        .map(|(a, b)| quaternion_angle_deg(a, b))
        .collect();
    let mean = angles.iter().sum::<f64>() / angles.len() as f64;
    let max = angles.iter().copied().fold(0.0, f64::max);
    // identify: fit orientation mean on its 100 poses, validation on the 1395 others.
    let fit = figure_after(&six, "fit:", "orientation mean ");
    let validation = figure_after(&six, "validation", "orientation mean ");
    let expected = (100.0 * fit + 1395.0 * validation) / 1495.0;
    eprintln!(
        "predicted vs measured orientation: mean {mean:.5}°, max {max:.4}° (fit {fit}°, \
         validation {validation}°)"
    );
    assert!((mean - expected).abs() < 1e-4, "{mean} vs {expected}");
    assert!(max < 0.2, "{max}");
    assert!(
        err.contains(&format!("angle file − predicted mean {:.4}°", mean)),
        "{err}"
    );
    // A point calibration of the same data: x, y, z only.
    ok(&identify(
        SIX,
        &tmp.path().join("points"),
        &["--every", "15", "--points-only"],
    ));
    let p = kincal(&[
        "predict",
        "--robot",
        s(&tmp.path().join("points/identified.json")),
        "--joints",
        SIX,
    ]);
    assert!(p.status.success(), "{}", stderr(&p));
    let text = String::from_utf8(p.stdout.clone()).unwrap();
    let header = text.lines().find(|l| !l.starts_with('#')).unwrap();
    assert!(header.ends_with(",x,y,z"), "{header}");
    assert!(!stderr(&p).contains("orientations"));
}
