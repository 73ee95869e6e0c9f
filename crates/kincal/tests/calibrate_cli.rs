//! Command-line tests of `identify`, `predict` and `compensate` (issue 7): the simulated round
//! trip, malformed inputs, file-format variants, outliers, unreachable targets and the real
//! UR10 data.

use crate::common::{kincal, kr1000, ok, root, s, sim, stderr};
use std::collections::BTreeMap;
use std::path::Path;

use kinematics::{Robot, RobotSpec};
use measurements::{ReadOptions, read_file};
use nalgebra::Vector3;

/// The number after `key` in `text` (up to the next space or comma).
fn number_after(text: &str, key: &str) -> f64 {
    let rest = &text[text
        .find(key)
        .unwrap_or_else(|| panic!("{key:?} in {text}"))
        + key.len()..];
    let end = rest.find([' ', ',']).unwrap_or(rest.len());
    rest[..end]
        .parse()
        .unwrap_or_else(|_| panic!("number after {key:?}"))
}

/// The first line of `text` starting with `prefix`.
fn line_with<'a>(text: &'a str, prefix: &str) -> &'a str {
    text.lines()
        .find(|l| l.starts_with(prefix))
        .unwrap_or_else(|| panic!("no line {prefix:?} in {text}"))
}

/// `id → point` of a §8 file (joints-only files give no entries).
fn points_by_id(path: &Path, n: usize) -> BTreeMap<String, Vector3<f64>> {
    let set = read_file(path, &ReadOptions::new(n)).unwrap();
    set.rows
        .into_iter()
        .map(|r| (r.id.expect("ids kept"), Vector3::from(r.point_mm.unwrap())))
        .collect()
}

/// Mean and max of ‖a[id] − b[id]‖ over the ids of `a` (all must be in `b`).
fn compare(a: &BTreeMap<String, Vector3<f64>>, b: &BTreeMap<String, Vector3<f64>>) -> (f64, f64) {
    let e: Vec<f64> = a.iter().map(|(id, p)| (p - b[id]).norm()).collect();
    (
        e.iter().sum::<f64>() / e.len() as f64,
        e.iter().copied().fold(0.0, f64::max),
    )
}

#[test]
fn simulate_identify_predict_compensate_round_trip() {
    let sim = sim();
    let tmp = tempfile::tempdir().unwrap();
    let cal = tmp.path().join("cal");
    let out = ok(&kincal(&[
        "identify",
        "--robot",
        s(kr1000()),
        "--data",
        s(&sim.join("identification.csv")),
        "--validate",
        s(&sim.join("validation.csv")),
        "--out",
        s(&cal),
    ]));

    // The outputs: a loadable robot file, the parameter table, the report.
    let identified = Robot::from_file(&cal.join("identified.json")).unwrap();
    assert_eq!(identified.n_params(), 34);
    let table: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(cal.join("parameters.json")).unwrap())
            .unwrap();
    let params = table["parameters"].as_array().unwrap();
    assert_eq!(params.len(), 34);
    let a2 = params.iter().find(|p| p["name"] == "a2").unwrap();
    assert_eq!(a2["unit"], "mm");
    assert_eq!(a2["nominal"], 1400.0);
    assert_eq!(a2["identifiable"], true);
    assert!(a2["std_error"].as_f64().unwrap() > 0.0);
    let delta = a2["identified"].as_f64().unwrap() - 1400.0;
    assert!((a2["delta"].as_f64().unwrap() - delta).abs() < 1e-9);
    let d1 = params.iter().find(|p| p["name"] == "d1").unwrap();
    assert_eq!(d1["identifiable"], false, "d1 ≡ base_dz is redundant");
    assert!(d1["std_error"].is_null());
    let report = std::fs::read_to_string(cal.join("report.md")).unwrap();
    for section in [
        "## Fit residuals",
        "Rank 27 of 34",
        "O1 ",
        "Redundant set (7",
        "## Correlations above 0.9",
        "## Outliers",
        "## Worst identification points",
        "| mean 3-D |",
        "### Worst validation points",
    ] {
        assert!(report.contains(section), "{section:?} missing in\n{report}");
    }

    // The noise floor: the true robot's own prediction error is pure tracker noise.
    let truth: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(sim.join("truth.json")).unwrap()).unwrap();
    let true_spec: RobotSpec = serde_json::from_value(truth["true_robot"].clone()).unwrap();
    let true_file = tmp.path().join("true.json");
    std::fs::write(&true_file, true_spec.to_json_string()).unwrap();
    let validation = sim.join("validation.csv");
    let measured = points_by_id(&validation, 6);
    let predict = |robot: &Path, joints: &Path, name: &str| {
        let p = tmp.path().join(name);
        ok(&kincal(&[
            "predict",
            "--robot",
            s(robot),
            "--joints",
            s(joints),
            "--out",
            s(&p),
        ]));
        points_by_id(&p, 6)
    };
    let (noise_mean, _) = compare(
        &measured,
        &predict(&true_file, &validation, "truth-pred.csv"),
    );
    // AT960 at 4–6 m: σ ≈ 0.01–0.02 mm per axis, so a mean 3-D noise of ≈ 1.6σ ≤ 0.035 mm.
    assert!(
        (0.01..0.035).contains(&noise_mean),
        "noise floor {noise_mean}"
    );

    // identify → predict reproduces the validation points to the noise floor.
    let calibrated = predict(&cal.join("identified.json"), &validation, "pred.csv");
    assert_eq!(calibrated.len(), 50);
    let (mean, max) = compare(&measured, &calibrated);
    assert!(
        mean < 1.5 * noise_mean && mean < 0.05,
        "calibrated mean {mean} vs noise {noise_mean}"
    );
    assert!(max < 5.0 * noise_mean, "calibrated max {max}");
    // identify's own validation figures are the same numbers.
    let validation_line = line_with(&out, "validation:");
    let reported_mean = number_after(validation_line, "calibrated mean ");
    let reported_max = number_after(
        validation_line,
        &format!("calibrated mean {reported_mean:.3} mm, max "),
    );
    assert!(
        (reported_mean - mean).abs() < 6e-4 && (reported_max - max).abs() < 6e-4,
        "{out}"
    );
    let nominal_mean = number_after(validation_line, ": nominal mean ");
    assert!((1.0..1.3).contains(&nominal_mean), "{out}");

    // compensate → re-measure (the true geometry at the compensated joints) reaches the
    // nominal targets to the noise floor; before, the true robot misses them by ≈ 1.1 mm.
    let comp = tmp.path().join("comp.csv");
    let out = kincal(&[
        "compensate",
        "--robot",
        s(&cal.join("identified.json")),
        "--nominal",
        s(kr1000()),
        "--targets",
        s(&validation),
        "--out",
        s(&comp),
    ]);
    ok(&out);
    let targets = predict(kr1000(), &validation, "targets.csv");
    // compensate's x, y, z are those targets.
    let written = points_by_id(&comp, 6);
    assert_eq!(
        written.keys().collect::<Vec<_>>(),
        targets.keys().collect::<Vec<_>>()
    );
    assert!(compare(&written, &targets).1 < 1e-9);
    let before = compare(&predict(&true_file, &validation, "before.csv"), &targets);
    let after = compare(&predict(&true_file, &comp, "after.csv"), &targets);
    assert!(before.0 > 0.8, "before compensation {before:?}");
    assert!(
        after.0 < noise_mean && after.1 < 0.1,
        "after compensation {after:?}"
    );
}

/// Nominal KR1000 rows: `id,q1…q6,x,y,z` with exact points, `n` rows, lines 2…n+1.
fn clean_rows(n: usize) -> (String, Vec<String>) {
    let robot = Robot::from_file(kr1000()).unwrap();
    let rows = (0..n)
        .map(|j| {
            let t = j as f64;
            let q = [
                -120.0 + 13.0 * t % 240.0,
                -30.0 + 7.0 * t % 120.0,
                -150.0 + 11.0 * t % 180.0,
                -300.0 + 37.0 * t % 600.0,
                15.0 + 17.0 * t % 90.0,
                -300.0 + 41.0 * t % 600.0,
            ];
            let qr: Vec<f64> = q.iter().map(|v| v.to_radians()).collect();
            let p = robot.point(&qr);
            let qs: Vec<String> = q.iter().map(|v| v.to_string()).collect();
            format!("P{j:02},{},{},{},{}", qs.join(","), p.x, p.y, p.z)
        })
        .collect();
    ("id,q1,q2,q3,q4,q5,q6,x,y,z".to_string(), rows)
}

/// Writes `header` and `rows` to a fresh file, runs `identify` into an empty output
/// directory and returns stderr; asserts failure and that nothing was written.
fn rejected(header: &str, rows: &[String], name: &str) -> String {
    let tmp = tempfile::tempdir().unwrap();
    let data = tmp.path().join(name);
    std::fs::write(&data, format!("{header}\n{}\n", rows.join("\n"))).unwrap();
    let made = tmp.path().join("made");
    std::fs::create_dir(&made).unwrap();
    let fresh = tmp.path().join("fresh");
    for out_dir in [&made, &fresh] {
        let out = kincal(&[
            "identify",
            "--robot",
            s(kr1000()),
            "--data",
            s(&data),
            "--out",
            s(out_dir),
        ]);
        assert!(!out.status.success(), "accepted: {}", stderr(&out));
        assert!(stderr(&out).contains(s(&data)), "{}", stderr(&out));
    }
    assert_eq!(
        std::fs::read_dir(&made).unwrap().count(),
        0,
        "files written"
    );
    assert!(!fresh.exists(), "output directory created");
    stderr(&kincal(&[
        "identify",
        "--robot",
        s(kr1000()),
        "--data",
        s(&data),
        "--out",
        s(&fresh),
    ]))
}

#[test]
fn clean_rows_are_accepted() {
    let (header, rows) = clean_rows(20);
    let tmp = tempfile::tempdir().unwrap();
    let data = tmp.path().join("clean.csv");
    std::fs::write(&data, format!("{header}\n{}\n", rows.join("\n"))).unwrap();
    let out = ok(&kincal(&[
        "identify",
        "--robot",
        s(kr1000()),
        "--data",
        s(&data),
        "--out",
        s(&tmp.path().join("o")),
    ]));
    assert!(out.contains("RMS 0.0000 mm"), "{out}");
}

#[test]
fn missing_column_is_rejected() {
    let (_, rows) = clean_rows(20);
    let rows: Vec<String> = rows
        .iter()
        .map(|r| r.rsplit_once(',').unwrap().0.to_string())
        .collect();
    let err = rejected("id,q1,q2,q3,q4,q5,q6,x,y", &rows, "missing.csv");
    assert!(
        err.contains("missing.csv:1: missing required column \"z\""),
        "{err}"
    );
}

#[test]
fn text_in_a_number_is_rejected() {
    let (header, mut rows) = clean_rows(20);
    let mut f: Vec<String> = rows[4].split(',').map(String::from).collect();
    f[2] = "12..5".into();
    rows[4] = f.join(",");
    let err = rejected(&header, &rows, "text.csv");
    assert!(
        err.contains("text.csv:6: column \"q2\": \"12..5") && err.contains("is not a number"),
        "{err}"
    );
}

#[test]
fn nan_is_rejected() {
    let (header, mut rows) = clean_rows(20);
    let (head, _) = rows[9].rsplit_once(',').unwrap();
    rows[9] = format!("{head},NaN");
    let err = rejected(&header, &rows, "nan.csv");
    assert!(
        err.contains("nan.csv:11: column \"z\": \"NaN\" is not a finite number"),
        "{err}"
    );
}

#[test]
fn ragged_row_is_rejected() {
    let (header, mut rows) = clean_rows(20);
    rows[2] = rows[2].rsplit_once(',').unwrap().0.to_string();
    let err = rejected(&header, &rows, "ragged.csv");
    assert!(
        err.contains("ragged.csv:4: row has 9 field(s) but the header has 10")
            && err.contains("first missing column \"z\""),
        "{err}"
    );
}

#[test]
fn joint_outside_limits_is_rejected() {
    let (header, mut rows) = clean_rows(20);
    let fields: Vec<&str> = rows[7].split(',').collect();
    let mut f: Vec<String> = fields.iter().map(|x| x.to_string()).collect();
    f[1] = "151".into(); // q1 limits ±150°
    rows[7] = f.join(",");
    let err = rejected(&header, &rows, "limits.csv");
    assert!(
        err.contains(
            "limits.csv:9: column \"q1\": joint value 151 deg is outside its limits [-150, 150] deg"
        ),
        "{err}"
    );
}

#[test]
fn fewer_rows_than_free_parameters_need_is_rejected() {
    let (header, rows) = clean_rows(11); // 33 equations < 34 parameters
    let err = rejected(&header, &rows, "few.csv");
    assert!(
        err.contains("few.csv: 11 data row(s), but at least 12 are needed")
            && err.contains("34 free parameters (--params paper) need at least 12 rows"),
        "{err}"
    );
    // The same file suffices for fewer free parameters (11 rows ≥ ⌈27/3⌉ for minimal).
    let tmp = tempfile::tempdir().unwrap();
    let data = tmp.path().join("few.csv");
    std::fs::write(&data, format!("{header}\n{}\n", rows.join("\n"))).unwrap();
    ok(&kincal(&[
        "identify",
        "--robot",
        s(kr1000()),
        "--data",
        s(&data),
        "--params",
        "minimal",
        "--out",
        s(&tmp.path().join("o")),
    ]));
}

#[test]
fn wrong_joint_count_is_rejected() {
    let (_, rows) = clean_rows(20);
    let seven: Vec<String> = rows
        .iter()
        .map(|r| {
            let (id, rest) = r.split_once(',').unwrap();
            let f: Vec<&str> = rest.split(',').collect();
            format!("{id},{},0,{}", f[..6].join(","), f[6..].join(","))
        })
        .collect();
    let err = rejected("id,q1,q2,q3,q4,q5,q6,q7,x,y,z", &seven, "seven.csv");
    assert!(
        err.contains("seven.csv:1: column \"q7\": the header has 7 joint column(s) (q1..q7) but 6 joints are expected"),
        "{err}"
    );
    let five: Vec<String> = rows
        .iter()
        .map(|r| {
            let f: Vec<&str> = r.split(',').collect();
            format!("{},{}", f[..6].join(","), f[7..].join(","))
        })
        .collect();
    let err = rejected("id,q1,q2,q3,q4,q5,x,y,z", &five, "five.csv");
    assert!(
        err.contains("five.csv:1: column \"q6\": the header has 5 joint column(s)"),
        "{err}"
    );
}

#[test]
fn malformed_validation_file_is_rejected_before_anything_is_written() {
    let (header, rows) = clean_rows(20);
    let tmp = tempfile::tempdir().unwrap();
    let data = tmp.path().join("data.csv");
    std::fs::write(&data, format!("{header}\n{}\n", rows.join("\n"))).unwrap();
    let val = tmp.path().join("val.csv");
    std::fs::write(&val, format!("{header}\n{},oops\n", rows[0])).unwrap();
    let out_dir = tmp.path().join("o");
    let out = kincal(&[
        "identify",
        "--robot",
        s(kr1000()),
        "--data",
        s(&data),
        "--validate",
        s(&val),
        "--out",
        s(&out_dir),
    ]);
    assert!(!out.status.success());
    assert!(
        stderr(&out).contains("val.csv:2: row has 11 field(s) but the header has 10"),
        "{}",
        stderr(&out)
    );
    assert!(!out_dir.exists());
}

#[test]
fn crlf_bom_extra_columns_and_comments_are_read() {
    let (_, rows) = clean_rows(20);
    let tmp = tempfile::tempdir().unwrap();
    let plain = tmp.path().join("plain.csv");
    std::fs::write(
        &plain,
        format!("id,q1,q2,q3,q4,q5,q6,x,y,z\n{}\n", rows.join("\n")),
    )
    .unwrap();
    // BOM, CRLF, comments (first line, between rows, indented), blank lines, columns reordered,
    // two extra columns.
    let mut text = String::from("\u{feff}# exported by the tracker software\r\n");
    text.push_str("temp_C, z,y,x,q6,q5,q4,q3,q2,q1,id, note\r\n");
    for (j, r) in rows.iter().enumerate() {
        let f: Vec<&str> = r.split(',').collect();
        text.push_str(&format!(
            "21.{j},{},{},{},{},{},{},{},{},{},{}, ok\r\n",
            f[9], f[8], f[7], f[6], f[5], f[4], f[3], f[2], f[1], f[0]
        ));
        if j == 5 {
            text.push_str("   # a comment between rows\r\n\r\n");
        }
    }
    let fancy = tmp.path().join("fancy.csv");
    std::fs::write(&fancy, text).unwrap();

    // identify reads it (and names the ignored columns).
    let out = kincal(&[
        "identify",
        "--robot",
        s(kr1000()),
        "--data",
        s(&fancy),
        "--validate",
        s(&fancy),
        "--out",
        s(&tmp.path().join("o")),
    ]);
    let stdout = ok(&out);
    assert!(stdout.contains("all 20 rows"), "{stdout}");
    assert!(
        stderr(&out).contains("ignored unknown column \"temp_C\"")
            && stderr(&out).contains("ignored unknown column \"note\""),
        "{}",
        stderr(&out)
    );
    assert!(number_after(&stdout, "calibrated mean ") < 1e-6, "{stdout}");

    // predict and compensate give the same output as for the plain file (ids kept; line 8 of
    // the fancy file is the 6th row's, the comment shifts the rest).
    for cmd in ["predict", "compensate"] {
        let run = |input: &Path, name: &str| {
            let out = tmp.path().join(name);
            let mut args = vec![cmd, "--robot", s(kr1000())];
            if cmd == "predict" {
                args.extend(["--joints", s(input)]);
            } else {
                args.extend(["--nominal", s(kr1000()), "--targets", s(input)]);
            }
            args.extend(["--out", s(&out)]);
            ok(&kincal(&args));
            let text = std::fs::read_to_string(&out).unwrap();
            text.lines()
                .filter(|l| !l.starts_with('#'))
                .map(String::from)
                .collect::<Vec<_>>()
        };
        let a = run(&plain, "a.csv");
        let b = run(&fancy, "b.csv");
        assert_eq!(a.len(), 21, "{cmd}: {a:?}");
        assert_eq!(a, b, "{cmd}");
        assert!(a[1].starts_with("P00,"), "{cmd}: ids kept: {}", a[1]);
    }
}

#[test]
fn outliers_are_reported_and_gross_ones_excluded_by_default() {
    let sim = sim();
    let tmp = tempfile::tempdir().unwrap();
    // Move the measured x of I017 by 1 mm (≈ 30 σ̂₃).
    let text = std::fs::read_to_string(sim.join("identification.csv")).unwrap();
    let bad: Vec<String> = text
        .lines()
        .map(|l| {
            if let Some(rest) = l.strip_prefix("I017,") {
                let mut f: Vec<String> = rest.split(',').map(String::from).collect();
                let x: f64 = f[6].parse().unwrap();
                f[6] = (x + 1.0).to_string();
                format!("I017,{}", f.join(","))
            } else {
                l.to_string()
            }
        })
        .collect();
    let data = tmp.path().join("bad.csv");
    std::fs::write(&data, bad.join("\n")).unwrap();
    let validation = sim.join("validation.csv");
    let run = |extra: &[&str], out: &str| {
        let dir = tmp.path().join(out);
        let mut args = vec![
            "identify",
            "--robot",
            s(kr1000()),
            "--data",
            s(&data),
            "--validate",
            s(&validation),
            "--out",
            s(&dir),
        ];
        args.extend_from_slice(extra);
        let stdout = ok(&kincal(&args));
        let report = std::fs::read_to_string(dir.join("report.md")).unwrap();
        let table: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(dir.join("parameters.json")).unwrap())
                .unwrap();
        (stdout, report, table["rows"].as_u64().unwrap())
    };
    let (kept_out, kept_report, kept_rows) = run(&["--keep-outliers"], "kept");
    assert!(
        kept_out.contains("outliers (‖e‖ > 3 σ̂₃") && kept_out.contains(": 1 — I017 (line 20)"),
        "{kept_out}"
    );
    assert!(kept_out.contains("kept (--reject-outliers to exclude)"));
    assert!(kept_report.contains("| I017 | 20 |"), "{kept_report}");
    assert_eq!(kept_rows, 50);

    // 1 mm on 0.02 mm noise is a gross error: the default robust screen drops it, as
    // `--reject-outliers` (every flagged row) does.
    let (rej_out, rej_report, rej_rows) = run(&[], "rejected");
    assert!(rej_out.contains("excluded, refitted"), "{rej_out}");
    assert!(
        rej_out.contains("robust screen: least trimmed squares on 26 of 50 rows"),
        "{rej_out}"
    );
    assert!(rej_report.contains("1 outliers excluded, 49 rows used"));
    assert_eq!(rej_rows, 49);
    let csv = std::fs::read_to_string(tmp.path().join("rejected/outliers.csv")).unwrap();
    let mut lines = csv.lines();
    assert_eq!(lines.next(), Some("line,id,residual_mm,ratio,status"));
    let row = lines.next().unwrap();
    assert!(
        row.starts_with("20,I017,") && row.ends_with(",excluded"),
        "{csv}"
    );
    let kept_csv = std::fs::read_to_string(tmp.path().join("kept/outliers.csv")).unwrap();
    assert!(
        kept_csv.lines().nth(1).unwrap().ends_with(",kept"),
        "{kept_csv}"
    );
    let (all_out, _, all_rows) = run(&["--reject-outliers"], "all");
    assert_eq!(all_rows, 49);
    assert_eq!(
        number_after(&all_out, "calibrated mean "),
        number_after(&rej_out, "calibrated mean ")
    );
    let kept_mean = number_after(&kept_out, "calibrated mean ");
    let rej_mean = number_after(&rej_out, "calibrated mean ");
    assert!(
        rej_mean < 0.05 && rej_mean < 0.8 * kept_mean,
        "validation mean {kept_mean} kept, {rej_mean} rejected"
    );

    // A tighter k flags more; an invalid k is refused.
    let out = kincal(&[
        "identify",
        "--robot",
        s(kr1000()),
        "--data",
        s(&data),
        "--outlier-k",
        "0",
        "--out",
        s(&tmp.path().join("z")),
    ]);
    assert!(!out.status.success() && stderr(&out).contains("--outlier-k"));
}

#[test]
fn unreachable_targets_fail_unless_allowed() {
    let tmp = tempfile::tempdir().unwrap();
    // The "calibrated" robot: the nominal one with q1 limited to ±10°.
    let mut spec = RobotSpec::from_file(kr1000()).unwrap();
    spec.joints[0].limits_deg = [-10.0, 10.0];
    let limited = tmp.path().join("limited.json");
    std::fs::write(&limited, spec.to_json_string()).unwrap();
    let targets = tmp.path().join("targets.csv");
    std::fs::write(
        &targets,
        "q1,q2,q3,q4,q5,q6\n0,10,-20,30,40,50\n100,10,-20,30,40,50\n5,0,-10,0,30,0\n",
    )
    .unwrap();
    let out_file = tmp.path().join("c.csv");
    let args = [
        "compensate",
        "--robot",
        s(&limited),
        "--nominal",
        s(kr1000()),
        "--targets",
        s(&targets),
        "--out",
        s(&out_file),
    ];
    let out = kincal(&args);
    assert!(!out.status.success());
    let err = stderr(&out);
    assert!(
        err.contains(
            "targets.csv:3: unreachable: beyond a joint limit: the nearest exact solution \
             needs q1 = 100.00° (limits -10.0° … 10.0°)"
        ) && err.contains("1 of 3"),
        "{err}"
    );
    assert!(!out_file.exists());

    let mut allowed = args.to_vec();
    allowed.push("--allow-unreachable");
    let out = kincal(&allowed);
    ok(&out);
    assert!(stderr(&out).contains("targets.csv:3: unreachable"));
    let text = std::fs::read_to_string(&out_file).unwrap();
    let rows: Vec<&str> = text.lines().filter(|l| !l.starts_with('#')).collect();
    assert_eq!(rows[0], "id,q1,q2,q3,q4,q5,q6,x,y,z");
    assert_eq!(rows.len(), 3, "{text}");
    assert!(
        rows[1].starts_with("L2,") && rows[2].starts_with("L4,"),
        "{text}"
    );
}

/// Mean and max 3-D error of the README's independent fit (SciPy MINPACK) on the held-out rows.
const UR10_REFERENCE_MM: (f64, f64) = (0.45, 1.77);

#[test]
fn ur10_real_data_every_15th_row() {
    let data = root().join("data/ur10-ipa/series-b-joint-configurations.csv");
    assert!(data.exists(), "{} is missing", data.display());
    let robot = root().join("scenarios/robots/ur10.json");
    let tmp = tempfile::tempdir().unwrap();
    let cal = tmp.path().join("cal");
    let out = ok(&kincal(&[
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
    assert!(
        out.contains("100 of 1495 rows") && out.contains("35 free parameters"),
        "{out}"
    );
    assert!(out.contains("validation: 1395 poses"), "{out}");
    // The paper set converges: its 10 exactly redundant parameters are held.
    assert!(
        !out.contains("warning: the solver stopped without converging"),
        "{out}"
    );
    assert!(
        line_with(&out, "held at their start values")
            .ends_with("d1, d3, d4, a5, alpha5, theta6, d6, a6, alpha6, base_rz"),
        "{out}"
    );
    let v = line_with(&out, "validation:");
    let nominal_mean = number_after(v, "nominal (registered) mean ");
    let nominal_max = number_after(v, &format!("mean {nominal_mean:.3} mm, max "));
    let mean = number_after(v, "calibrated mean ");
    let max = number_after(v, &format!("calibrated mean {mean:.3} mm, max "));
    let ms = number_after(line_with(&out, "fit:"), "iterations; ");
    println!(
        "UR10: nominal (registered) {nominal_mean} / {nominal_max} mm → calibrated {mean} / \
         {max} mm in {ms} ms"
    );
    let (ref_mean, ref_max) = UR10_REFERENCE_MM;
    assert!(mean <= 1.05 * ref_mean, "calibrated mean {mean} mm");
    assert!(max <= 1.05 * ref_max, "calibrated max {max} mm");
    assert!(nominal_mean > 2.5 && nominal_max > 4.5, "{out}");
    assert!(ms < 1000.0, "identification took {ms} ms");

    // The same figures from predict with identified.json on the held-out rows.
    let pred = tmp.path().join("pred.csv");
    ok(&kincal(&[
        "predict",
        "--robot",
        s(&cal.join("identified.json")),
        "--joints",
        s(&data),
        "--out",
        s(&pred),
    ]));
    let opts = ReadOptions::new(6);
    let measured = read_file(&data, &opts).unwrap().rows;
    let predicted = read_file(&pred, &opts).unwrap().rows;
    assert_eq!(measured.len(), 1495);
    let e: Vec<f64> = measured
        .iter()
        .zip(&predicted)
        .enumerate()
        .filter(|(i, _)| i % 15 != 0)
        .map(|(_, (m, p))| {
            assert_eq!(m.q_deg, p.q_deg);
            (Vector3::from(m.point_mm.unwrap()) - Vector3::from(p.point_mm.unwrap())).norm()
        })
        .collect();
    assert_eq!(e.len(), 1395);
    let p_mean = e.iter().sum::<f64>() / e.len() as f64;
    let p_max = e.iter().copied().fold(0.0, f64::max);
    assert!((p_mean - mean).abs() < 6e-4 && (p_max - max).abs() < 6e-4);

    // The minimal set converges to the same predictions.
    let min = tmp.path().join("min");
    let out = ok(&kincal(&[
        "identify",
        "--robot",
        s(&robot),
        "--data",
        s(&data),
        "--every",
        "15",
        "--params",
        "minimal",
        "--out",
        s(&min),
    ]));
    assert!(
        !out.contains("warning: the solver stopped without converging"),
        "{out}"
    );
    let v = line_with(&out, "validation:");
    let min_mean = number_after(v, "calibrated mean ");
    let min_max = number_after(v, &format!("calibrated mean {min_mean:.3} mm, max "));
    assert!(
        min_mean <= 1.05 * ref_mean && min_max <= 1.05 * ref_max,
        "{out}"
    );

    // The calibrated robot is in the tracker frame: compensation needs the nominal model in
    // that frame (written by identify); the nominal file itself is refused.
    let comp = tmp.path().join("comp.csv");
    let compensate = |nominal: &Path| {
        kincal(&[
            "compensate",
            "--robot",
            s(&min.join("identified.json")),
            "--nominal",
            s(nominal),
            "--targets",
            s(&data),
            "--allow-unreachable",
            "--out",
            s(&comp),
        ])
    };
    let refused = compensate(&robot);
    assert!(!refused.status.success());
    assert!(
        stderr(&refused).contains("not in the same measurement frame")
            && stderr(&refused).contains("registered-nominal.json"),
        "{}",
        stderr(&refused)
    );
    assert!(!comp.exists());
    let out = compensate(&min.join("registered-nominal.json"));
    ok(&out);
    let err = stderr(&out);
    let done = number_after(&err, "compensated ");
    // The rest (fully stretched arm, e.g. line 2, q3 = 0) lie beyond the calibrated reach.
    assert!(done >= 0.99 * 1495.0, "{err}");
    // Issue 29: the row with q5 = 1.2° (line 61) moves q4 and q6 by more than the 2° flag
    // threshold, and is flagged as near the wrist singularity, on stderr and in the file.
    let line61 = err
        .lines()
        .find(|l| l.starts_with("flagged: ") && l.contains("configurations.csv:61: "))
        .unwrap_or_else(|| panic!("line 61 not flagged:\n{err}"));
    assert!(
        line61.contains("q4 +")
            && line61.contains("near the wrist singularity (axes 4 and 6 at 1.0°)"),
        "{line61}"
    );
    let written = std::fs::read_to_string(&comp).unwrap();
    assert!(written.contains("# flagged: ") && written.contains("configurations.csv:61: q4 +"));
    println!("UR10 compensation: {}", err.lines().last().unwrap_or(""));
}

/// `predict` and `compensate` reject malformed joint files by file and line, and write no
/// output file.
#[test]
fn predict_and_compensate_reject_malformed_joint_files() {
    let (header, rows) = clean_rows(5);
    let tmp = tempfile::tempdir().unwrap();
    let cases = [
        ("text.csv", rows[2].replacen(",", ",abc", 2), "text.csv:4"),
        (
            "nan.csv",
            {
                let f: Vec<&str> = rows[1].split(',').collect();
                format!("{},NaN,{}", f[0], f[2..].join(","))
            },
            "nan.csv:3",
        ),
        ("ragged.csv", format!("{},7", rows[0]), "ragged.csv:2"),
    ];
    for (name, bad_row, expect) in cases {
        let mut body = rows.clone();
        let at = expect.rsplit(':').next().unwrap().parse::<usize>().unwrap() - 2;
        body[at] = bad_row;
        let file = tmp.path().join(name);
        std::fs::write(&file, format!("{header}\n{}\n", body.join("\n"))).unwrap();
        let out_file = tmp.path().join(format!("{name}.out.csv"));
        for args in [
            vec!["predict", "--robot", s(kr1000()), "--joints", s(&file)],
            compensate_kr1000(&file),
        ] {
            let mut args = args.clone();
            args.extend(["--out", s(&out_file)]);
            let out = kincal(&args);
            assert!(!out.status.success(), "{args:?} accepted {name}");
            assert!(stderr(&out).contains(expect), "{args:?}: {}", stderr(&out));
            assert!(!out_file.exists(), "{args:?} wrote {}", out_file.display());
        }
    }
}

/// `kincal compensate` of `targets` with the KR1000 as both the calibrated and the nominal
/// robot (the arguments, `--out` to be added).
fn compensate_kr1000(targets: &Path) -> Vec<&str> {
    vec![
        "compensate",
        "--robot",
        s(kr1000()),
        "--nominal",
        s(kr1000()),
        "--targets",
        s(targets),
    ]
}

/// `compensate` with a targets file of no rows (a header only) says so, naming the file,
/// rather than that no target is reachable; nothing is written.
#[test]
fn compensate_with_no_targets_says_the_file_has_no_rows() {
    let (header, _) = clean_rows(1);
    let tmp = tempfile::tempdir().unwrap();
    let file = tmp.path().join("empty-targets.csv");
    std::fs::write(&file, format!("{header}\n")).unwrap();
    let out_file = tmp.path().join("out.csv");
    let mut args = compensate_kr1000(&file);
    args.extend(["--out", s(&out_file)]);
    let out = kincal(&args);
    assert_eq!(out.status.code(), Some(1), "{}", stderr(&out));
    let msg = stderr(&out);
    assert!(
        msg.contains("empty-targets.csv: the targets file has no rows"),
        "{msg}"
    );
    assert!(!msg.contains("reachable"), "{msg}");
    assert!(!out_file.exists());
}

/// `identifiability --json` carries the keys the issue names, computed for the KR1000.
#[test]
fn identifiability_json_has_rank_redundant_condition_and_observability() {
    let out = kincal(&[
        "identifiability",
        "--robot",
        s(kr1000()),
        "--random-poses",
        "50",
        "--json",
    ]);
    let text = ok(&out);
    let v: serde_json::Value = serde_json::from_str(&text).expect("JSON on stdout");
    assert_eq!(v["rank"], 27, "{text}");
    assert_eq!(v["parameter_count"], 34);
    assert_eq!(v["redundant"].as_array().unwrap().len(), 7);
    assert!(v["condition_number"].as_f64().unwrap() > 1.0);
    for k in ["o1", "o2", "o3", "o4", "o5"] {
        assert!(v["observability"][k].as_f64().unwrap() > 0.0, "{k}");
    }
    assert_eq!(v["singular_values"].as_array().unwrap().len(), 34);
}

/// The extended families in `identifiability` (issue 19): on the KR1000 the compliance of
/// the vertical axes 1 and 6 sees no gravity torque, so both are zero columns, reported as
/// redundant and confounded with nothing; the other 43 of 52 are identifiable.
#[test]
fn identifiability_covers_the_extended_families() {
    let out = kincal(&[
        "identifiability",
        "--robot",
        s(kr1000()),
        "--random-poses",
        "50",
        "--params",
        "paper+compliance+gears",
        "--json",
    ]);
    let text = ok(&out);
    let v: serde_json::Value = serde_json::from_str(&text).expect("JSON on stdout");
    assert_eq!(v["parameter_count"], 52, "{text}");
    assert_eq!(v["rank"], 43, "{text}");
    assert_eq!(
        v["zero_columns"],
        serde_json::json!(["compliance_1", "compliance_6"])
    );
    let redundant: Vec<&str> = v["redundant"]
        .as_array()
        .unwrap()
        .iter()
        .map(|r| r.as_str().unwrap())
        .collect();
    assert!(redundant.contains(&"compliance_1") && redundant.contains(&"compliance_6"));
    let identifiable = v["identifiable"].as_array().unwrap();
    assert!(identifiable.contains(&serde_json::json!("compliance_2")));
    assert!(identifiable.contains(&serde_json::json!("gear_6_h1_cos")));
    // A harmonic on a joint the robot does not have is refused by name.
    let bad = kincal(&[
        "identifiability",
        "--robot",
        s(kr1000()),
        "--random-poses",
        "50",
        "--params",
        "paper+gear_7_h1_sin",
    ]);
    assert!(!bad.status.success());
    assert!(
        stderr(&bad).contains("gear_7_h1_sin") && stderr(&bad).contains("joint 7 does not exist"),
        "{}",
        stderr(&bad)
    );
}

/// The extended families in `design`: the minimal set of the extended model (43 of the 52)
/// is designed for, and a bad family member leaves no plan behind.
#[test]
fn design_covers_the_extended_families() {
    let tmp = tempfile::tempdir().unwrap();
    let plan = tmp.path().join("plan.csv");
    let scenario = root().join("scenarios/paper-kr1000.json");
    let args = |params: &'static str| {
        vec![
            "design".to_string(),
            "--robot".into(),
            s(kr1000()).into(),
            "--scenario".into(),
            s(&scenario).into(),
            "--random".into(),
            "200".into(),
            "--poses".into(),
            "20".into(),
            "--params".into(),
            params.into(),
            "--out".into(),
            s(&plan).into(),
        ]
    };
    let out = kincal(
        &args("minimal+compliance+gears")
            .iter()
            .map(String::as_str)
            .collect::<Vec<_>>(),
    );
    let text = ok(&out);
    let set = line_with(&text, "minimal set (43 parameters)");
    assert!(
        set.contains("compliance_2") && set.contains("gear_1_h1_sin"),
        "{text}"
    );
    assert!(
        !set.contains("compliance_1,") && !set.contains("compliance_6"),
        "{text}"
    );
    let rows = read_file(&plan, &ReadOptions::new(6).joints_only())
        .unwrap()
        .rows;
    assert_eq!(rows.len(), 20);
    std::fs::remove_file(&plan).unwrap();
    let bad = kincal(
        &args("minimal+compliance_9")
            .iter()
            .map(String::as_str)
            .collect::<Vec<_>>(),
    );
    assert!(!bad.status.success());
    assert!(stderr(&bad).contains("compliance_9"), "{}", stderr(&bad));
    assert!(!plan.exists());
}

/// Real data with the extended model (issue 19): on the UR10 series B (every 15th row,
/// validated on the 1,395 others), joint compliance lowers the validation mean below the
/// geometric model's; `identified.json` carries the extended section, `predict` on it gives
/// the validation figures `identify` printed, and `urdf export` refuses it by name.
#[test]
fn ur10_with_joint_compliance() {
    let data = root().join("data/ur10-ipa/series-b-joint-configurations.csv");
    let robot = root().join("scenarios/robots/ur10.json");
    let tmp = tempfile::tempdir().unwrap();
    let cal = tmp.path().join("cal");
    let out = ok(&kincal(&[
        "identify",
        "--robot",
        s(&robot),
        "--data",
        s(&data),
        "--every",
        "15",
        "--params",
        "paper+compliance",
        "--out",
        s(&cal),
    ]));
    assert!(out.contains("41 free parameters"), "{out}");
    // Joint 1 is vertical and the probe lies on axis 6: neither sees a gravity torque.
    assert!(
        line_with(&out, "held at their start values")
            .ends_with("base_rz, compliance_1, compliance_6"),
        "{out}"
    );
    let v = line_with(&out, "validation:");
    let mean = number_after(v, "calibrated mean ");
    let (ref_mean, _) = UR10_REFERENCE_MM;
    assert!(
        mean < 0.9 * ref_mean,
        "extended {mean} mm vs geometric {ref_mean} mm"
    );
    let identified = std::fs::read_to_string(cal.join("identified.json")).unwrap();
    assert!(identified.contains("\"extended\"") && identified.contains("compliance_2"));
    let params = std::fs::read_to_string(cal.join("parameters.json")).unwrap();
    assert!(params.contains("urad/Nm"), "{params}");
    // The report says which model was identified.
    let report = std::fs::read_to_string(cal.join("report.md")).unwrap();
    assert!(
        report.contains("- model: geometry (docs/model.md §2–§3) plus the non-geometric joint errors compliance_1, compliance_2"),
        "{report}"
    );
    // predict on identified.json reproduces the validation mean identify printed.
    let pred = tmp.path().join("pred.csv");
    ok(&kincal(&[
        "predict",
        "--robot",
        s(&cal.join("identified.json")),
        "--joints",
        s(&data),
        "--out",
        s(&pred),
    ]));
    let text = std::fs::read_to_string(&pred).unwrap();
    let measured = std::fs::read_to_string(&data).unwrap();
    let rows = |t: &str| -> Vec<Vec<f64>> {
        t.lines()
            .filter(|l| !l.starts_with('#') && !l.starts_with('q'))
            .map(|l| l.split(',').map(|x| x.trim().parse().unwrap()).collect())
            .collect()
    };
    let (p, m) = (rows(&text), rows(&measured));
    let errs: Vec<f64> = p
        .iter()
        .zip(&m)
        .enumerate()
        .filter(|(i, _)| i % 15 != 0)
        .map(|(_, (a, b))| {
            ((a[6] - b[6]).powi(2) + (a[7] - b[7]).powi(2) + (a[8] - b[8]).powi(2)).sqrt()
        })
        .collect();
    let pred_mean = errs.iter().sum::<f64>() / errs.len() as f64;
    assert!(
        (pred_mean - mean).abs() < 0.0006,
        "predict {pred_mean} vs identify {mean}"
    );
    // A URDF cannot carry compliance: export refuses, naming the section.
    let e = kincal(&[
        "urdf",
        "export",
        s(&cal.join("identified.json")),
        "--out",
        s(&tmp.path().join("x.urdf")),
    ]);
    assert!(!e.status.success());
    assert!(stderr(&e).contains("`extended` section"), "{}", stderr(&e));
    assert!(!tmp.path().join("x.urdf").exists());
}

/// A failed write leaves no directory behind and replaces nothing: the outputs of the UR10
/// (every 10th row) rendered, then written under a path whose parent is a file.
#[test]
fn a_failed_write_leaves_no_directory() {
    let request = calibrate::IdentifyRequest {
        split: calibrate::Split::Every {
            every: 10,
            offset: 0,
        },
        ..calibrate::IdentifyRequest::new(
            root().join("scenarios/robots/ur10.json"),
            root().join("data/ur10-ipa/series-b-joint-configurations.csv"),
        )
    };
    let cal = calibrate::run(&request).unwrap();
    let tmp = tempfile::tempdir().unwrap();
    let file = tmp.path().join("a-file");
    std::fs::write(&file, "x").unwrap();
    let e = kincal::identify_cmd::write_outputs(
        &file.join("out"),
        &report::calibration::render(&cal).unwrap(),
    )
    .unwrap_err();
    assert!(e.to_string().contains("a-file"), "{e}");
    assert_eq!(std::fs::read_to_string(&file).unwrap(), "x");
}

/// The command line names the flag of a refused request field (the library names the field):
/// `--offset` not below `--every`, `--select` of too few or too many rows.
#[test]
fn refused_options_are_named_by_their_flags() {
    let data = root().join("data/ur10-ipa/series-b-joint-configurations.csv");
    let robot = root().join("scenarios/robots/ur10.json");
    let tmp = tempfile::tempdir().unwrap();
    let identify = |extra: &[&str]| {
        let mut args = vec!["identify", "--robot", s(&robot), "--data", s(&data)];
        args.extend_from_slice(extra);
        let out_dir = tmp.path().join("o");
        args.extend(["--out", s(&out_dir)]);
        let out = kincal(&args);
        assert!(!out.status.success(), "{extra:?} accepted");
        assert!(!out_dir.exists(), "{extra:?} wrote outputs");
        stderr(&out)
    };
    let e = identify(&["--every", "3", "--offset", "3"]);
    assert!(e.contains("--offset 3"), "{e}");
    for (n, says) in [("5", "need at least"), ("1495", "choose fewer")] {
        let e = identify(&["--select", n, "--criterion", "i"]);
        assert!(
            e.contains(&format!("--select {n}")) && e.contains(says),
            "{e}"
        );
    }
}

/// Issue 29: joints in radians, points in metres and swapped axes make `identify` exit
/// non-zero, write nothing and name the flag that overrides the check; `--joint-units rad
/// --length-units m` read the same file and give the figures of the file in degrees and mm.
#[test]
fn implausible_units_and_frames_are_refused_and_unit_flags_convert() {
    let tmp = tempfile::tempdir().unwrap();
    let text =
        std::fs::read_to_string(root().join("data/ur10-ipa/series-b-joint-configurations.csv"))
            .unwrap();
    let rows: Vec<Vec<f64>> = text
        .lines()
        .skip(1)
        .take(300)
        .map(|l| l.split(',').map(|x| x.parse().unwrap()).collect())
        .collect();
    let write = |name: &str, f: &dyn Fn(&[f64]) -> Vec<f64>| {
        let mut out = String::from("q1,q2,q3,q4,q5,q6,x,y,z\n");
        for r in &rows {
            let v: Vec<String> = f(r).iter().map(|x| format!("{x}")).collect();
            out += &(v.join(",") + "\n");
        }
        let path = tmp.path().join(name);
        std::fs::write(&path, out).unwrap();
        path
    };
    let plain = write("plain.csv", &|r| r.to_vec());
    let rad_m = write("rad-m.csv", &|r| {
        let mut v: Vec<f64> = r[..6].iter().map(|q| q.to_radians()).collect();
        v.extend(r[6..].iter().map(|p| p / 1000.0));
        v
    });
    let metres = write("m.csv", &|r| {
        let mut v = r[..6].to_vec();
        v.extend(r[6..].iter().map(|p| p / 1000.0));
        v
    });
    let swapped = write("zyx.csv", &|r| {
        let mut v = r[..6].to_vec();
        v.extend([r[8], r[7], r[6]]);
        v
    });
    let ur10 = root().join("scenarios/robots/ur10.json");
    let run = |data: &Path, extra: &[&str], out: &str| {
        let dir = tmp.path().join(out);
        let mut args = vec![
            "identify",
            "--robot",
            s(&ur10),
            "--data",
            s(data),
            "--every",
            "3",
            "--out",
            s(&dir),
        ];
        args.extend_from_slice(extra);
        (kincal(&args), dir)
    };
    for (data, allow) in [
        (&rad_m, "joint-units"),
        (&metres, "length-units"),
        (&swapped, "mirror"),
    ] {
        let (out, dir) = run(data, &[], "refused");
        assert!(!out.status.success());
        assert!(!dir.exists(), "nothing written");
        assert!(
            stderr(&out).contains(&format!("--allow {allow}")),
            "{}",
            stderr(&out)
        );
    }
    let converted = ok(&run(
        &rad_m,
        &["--joint-units", "rad", "--length-units", "m"],
        "c",
    )
    .0);
    let reference = ok(&run(&plain, &[], "p").0);
    let mean = |t: &str| number_after(t, "calibrated mean ");
    assert!(
        (mean(&converted) - mean(&reference)).abs() < 0.002,
        "{converted}\n{reference}"
    );
    assert!(
        reference.contains("registration decision: registered"),
        "{reference}"
    );
}

/// Issue 29: one simulated row with q2 written as −0 (a gross error of metres) no longer drags
/// a registration that makes the nominal error worse, and the run is refused instead of giving
/// a robot that validates worse than the nominal when every row is kept (`--keep-outliers`);
/// by default (and with `--reject-outliers`) the row is dropped and the result is that of the
/// clean data.
#[test]
fn a_row_with_a_wrong_joint_neither_drags_the_registration_nor_passes() {
    let sim = sim();
    let tmp = tempfile::tempdir().unwrap();
    let text = std::fs::read_to_string(sim.join("identification.csv")).unwrap();
    let bad: Vec<String> = text
        .lines()
        .map(|l| {
            if let Some(rest) = l.strip_prefix("I027,") {
                let mut f: Vec<&str> = rest.split(',').collect();
                f[1] = "-0";
                format!("I027,{}", f.join(","))
            } else {
                l.to_string()
            }
        })
        .collect();
    let data = tmp.path().join("q2.csv");
    std::fs::write(&data, bad.join("\n")).unwrap();
    let validation = sim.join("validation.csv");
    let run = |extra: &[&str], out: &str| {
        let dir = tmp.path().join(out);
        let mut args = vec![
            "identify",
            "--robot",
            s(kr1000()),
            "--data",
            s(&data),
            "--validate",
            s(&validation),
            "--out",
            s(&dir),
        ];
        args.extend_from_slice(extra);
        (kincal(&args), dir)
    };
    let (out, dir) = run(&["--keep-outliers"], "plain");
    assert!(
        !out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stdout)
    );
    assert!(!dir.exists());
    assert!(stderr(&out).contains("--allow"), "{}", stderr(&out));
    let (out, _) = run(&[], "screened");
    assert!(number_after(&ok(&out), "calibrated mean ") < 0.05);
    let (out, _) = run(&["--reject-outliers"], "rejected");
    let stdout = ok(&out);
    let decision = line_with(&stdout, "registration decision:");
    assert!(
        decision.contains("not registered") || decision.contains("of 50 points"),
        "{decision}"
    );
    assert!(number_after(&stdout, "calibrated mean ") < 0.05, "{stdout}");
}

/// `compensate` of Cartesian targets (a file without joint columns, issue 40) on the UR10's
/// 6-DoF calibration: every target compensated with its orientation, the output the joints
/// and the corrected targets (`x, y, z, qw, qx, qy, qz`); a nominal robot moved far off is
/// still refused, and on a calibration of points the output says the orientation was left
/// to the nominal model. The same targets in metres are refused, naming the override.
#[test]
fn compensate_cartesian_targets_of_the_ur10_6dof_calibration() {
    let tmp = tempfile::tempdir().unwrap();
    let root = root();
    let targets = root.join("data/ur10-ipa/cartesian-targets.csv");
    let ur10 = root.join("scenarios/robots/ur10.json");
    let mut calibrations = Vec::new();
    for (data, name) in [
        ("series-b-6dof.csv", "six"),
        ("series-b-joint-configurations.csv", "pts"),
    ] {
        let dir = tmp.path().join(name);
        ok(&kincal(&[
            "identify",
            "--robot",
            s(&ur10),
            "--data",
            s(&root.join("data/ur10-ipa").join(data)),
            "--every",
            "15",
            "--out",
            s(&dir),
        ]));
        calibrations.push(dir);
    }
    let compensate = |dir: &Path, targets: &Path, extra: &[&str]| {
        let mut args: Vec<String> = vec![
            "compensate".to_string(),
            "--robot".to_string(),
            s(&dir.join("identified.json")).to_string(),
            "--nominal".to_string(),
            s(&dir.join("registered-nominal.json")).to_string(),
            "--targets".to_string(),
            s(targets).to_string(),
            "--start-joints=-166,-129,121,-172,-4,0".to_string(),
        ];
        args.extend(extra.iter().map(|a| a.to_string()));
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        kincal(&args)
    };
    let out = compensate(&calibrations[0], &targets, &[]);
    let csv = ok(&out);
    let msg = stderr(&out);
    assert!(msg.contains("compensated 15 of 15 targets"), "{msg}");
    assert!(!msg.contains("orientation: left"), "{msg}");
    assert!(
        csv.contains("\nid,q1,q2,q3,q4,q5,q6,x,y,z,qw,qx,qy,qz\nc01,"),
        "{csv}"
    );
    let out = compensate(&calibrations[1], &targets, &[]);
    let csv = ok(&out);
    assert!(
        csv.contains("# orientation: left to the nominal model"),
        "{csv}"
    );
    assert!(stderr(&out).contains("orientation: left to the nominal model"));
    // Metres.
    let text = std::fs::read_to_string(&targets).unwrap();
    let metres: String = text
        .lines()
        .map(|l| match l.split(',').collect::<Vec<_>>()[..] {
            [id, x, y, z, ref q @ ..] if id.starts_with('c') => {
                let m = |v: &str| (v.parse::<f64>().unwrap() / 1000.0).to_string();
                format!("{id},{},{},{},{}\n", m(x), m(y), m(z), q.join(","))
            }
            _ => format!("{l}\n"),
        })
        .collect();
    let file = tmp.path().join("metres.csv");
    std::fs::write(&file, metres).unwrap();
    let out = compensate(&calibrations[0], &file, &[]);
    assert_eq!(out.status.code(), Some(1));
    let msg = stderr(&out);
    assert!(
        msg.contains("metres.csv: every target lies within")
            && msg.contains("--allow length-units"),
        "{msg}"
    );
    // Euler columns without a convention, and start joints of the wrong count (the
    // helper's six and three more: a repeated list flag appends).
    let file = tmp.path().join("euler.csv");
    std::fs::write(&file, "id,x,y,z,rx,ry,rz\nc1,100,400,800,0,90,0\n").unwrap();
    let msg = stderr(&compensate(&calibrations[0], &file, &[]));
    assert!(
        msg.contains("--euler") && msg.contains("euler.csv:1: column \"rx\""),
        "{msg}"
    );
    let msg = stderr(&compensate(
        &calibrations[0],
        &targets,
        &["--start-joints=1,2,3"],
    ));
    assert!(
        msg.contains("--start-joints") && msg.contains("9 values for 6 joints"),
        "{msg}"
    );
}
