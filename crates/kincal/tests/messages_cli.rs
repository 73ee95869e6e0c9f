//! Command-line tests of issue 38, items 3 and 5: every input checked alike (the validation
//! file as the identification data, the robot file's numbers) and messages that name the
//! file, line and column and what was found, in the command line's words. Inputs are the
//! UR10 data of `data/ur10-ipa` (the first 100 rows identify, the next 99 validate), changed
//! and written into a temporary directory.

use std::io::Write as _;
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};

use crate::common::{kincal, ok, root, s, stderr};

fn ur10() -> PathBuf {
    root().join("scenarios/robots/ur10.json")
}

/// The header and data rows `range` of the UR10 data, each row's fields through `edit`.
fn rows(range: std::ops::Range<usize>, edit: impl Fn(usize, &mut Vec<String>)) -> String {
    let text =
        std::fs::read_to_string(root().join("data/ur10-ipa/series-b-joint-configurations.csv"))
            .unwrap();
    let mut lines = text.lines();
    let mut out = format!("{}\n", lines.next().unwrap());
    for (k, line) in lines.enumerate().skip(range.start).take(range.len()) {
        let mut fields: Vec<String> = line.split(',').map(str::to_string).collect();
        edit(k - range.start, &mut fields);
        out.push_str(&fields.join(","));
        out.push('\n');
    }
    out
}

/// Each field of the points (columns 7–9) times `f`, or of the joints (1–6).
fn scaled(cols: std::ops::Range<usize>, f: f64) -> impl Fn(usize, &mut Vec<String>) {
    move |_, fields| {
        for c in cols.clone() {
            fields[c] = format!("{}", fields[c].parse::<f64>().unwrap() * f);
        }
    }
}

/// A fresh scratch directory with the identification rows (`id.csv`) and the validation
/// rows (`val.csv`).
fn scratch(name: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("messages-{name}"));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("id.csv"), rows(0..100, |_, _| {})).unwrap();
    std::fs::write(dir.join("val.csv"), rows(100..199, |_, _| {})).unwrap();
    dir
}

/// `identify --robot ur10 --data DATA [extra…] --out dir/out`.
fn identify(dir: &Path, data: &Path, extra: &[&str]) -> Output {
    identify_with(&ur10(), dir, data, extra)
}

/// `identify --robot ROBOT --data DATA [extra…] --out dir/out`.
fn identify_with(robot: &Path, dir: &Path, data: &Path, extra: &[&str]) -> Output {
    let out = dir.join("out");
    let mut args = vec!["identify", "--robot", s(robot), "--data", s(data)];
    args.extend_from_slice(extra);
    args.extend_from_slice(&["--out", s(&out)]);
    kincal(&args)
}

/// `text` contains `what` (else both in the panic).
#[track_caller]
fn says(text: &str, what: &str) {
    assert!(text.contains(what), "{what:?} not in:\n{text}");
}

/// The stderr of a refused run (exit 1, nothing written).
#[track_caller]
fn refused(dir: &Path, out: &Output) -> String {
    let err = stderr(out);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(!dir.join("out").exists(), "{err}");
    err
}

/// A validation file in metres, or in radians, is refused by the check that refuses such
/// identification data, naming the validation file; `--allow` overrides it as for the data.
/// (Before: accepted, Table 4 of 3019 mm / 1815 mm.)
#[test]
fn a_validation_file_gets_the_checks_of_the_data() {
    let dir = scratch("validate");
    let (id, val_m, val_rad) = (
        dir.join("id.csv"),
        dir.join("val-m.csv"),
        dir.join("val-rad.csv"),
    );
    std::fs::write(&val_m, rows(100..199, scaled(6..9, 1e-3))).unwrap();
    std::fs::write(&val_rad, rows(100..199, scaled(0..6, 1f64.to_radians()))).unwrap();
    let err = refused(&dir, &identify(&dir, &id, &["--validate", s(&val_m)]));
    says(&err, &format!("{}: the measured points spread", s(&val_m)));
    says(&err, "look like metres");
    assert!(
        err.contains("(--length-units m)") && err.contains("(--allow length-units)"),
        "{err}"
    );
    let err = refused(&dir, &identify(&dir, &id, &["--validate", s(&val_rad)]));
    says(
        &err,
        &format!("{}: every joint value is within ±2π", s(&val_rad)),
    );
    assert!(
        err.contains("(--joint-units rad)") && err.contains("(--allow joint-units)"),
        "{err}"
    );
    // Overridden as for the data.
    ok(&identify(
        &dir,
        &id,
        &["--validate", s(&val_m), "--allow", "length-units"],
    ));
    // A good validation file passes.
    let _ = std::fs::remove_dir_all(dir.join("out"));
    let stdout = ok(&identify(
        &dir,
        &id,
        &["--validate", s(&dir.join("val.csv"))],
    ));
    says(&stdout, "validation: 99 poses of");
}

/// A robot file with θ1 = 2⁶⁴ is refused on reading, naming the field and the value in
/// exponent form. (Before: accepted; the fit stalled after one iteration, exit 0.)
#[test]
fn a_robot_file_with_theta1_of_two_to_the_64_is_refused_naming_the_field() {
    let dir = scratch("robot");
    let mut robot: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(ur10()).unwrap()).unwrap();
    robot["joints"][0]["theta_deg"] = 2f64.powi(64).into();
    let file = dir.join("robot.json");
    std::fs::write(&file, robot.to_string()).unwrap();
    let data = dir.join("id.csv");
    let err = refused(&dir, &identify_with(&file, &dir, &data, &[]));
    says(&err, "joints[0].theta_deg = 1.8446744073709552e19°");
    says(&err, "beyond ±360°");
    // A measurement CSV given as the robot says what it is (done earlier, held here).
    let err = refused(&dir, &identify_with(&data, &dir, &data, &[]));
    says(&err, "not a robot model file: it starts with `q1,q2,q3");
}

/// `;`, tab and space separators, decimal commas and upper-case headers: the message names
/// file, line and column and what was found. (Before: `missing required column "q1"`.)
#[test]
fn separators_decimal_commas_and_header_case_are_named() {
    let dir = scratch("format");
    let text = std::fs::read_to_string(dir.join("id.csv")).unwrap();
    let cases = [
        (
            "semicolon.csv",
            text.replace(',', ";"),
            ":1:3: the header is separated by ';' (semicolons)",
        ),
        (
            "tab.csv",
            text.replace(',', "\t"),
            ":1:3: the header is separated by tabs",
        ),
        (
            "space.csv",
            text.replace(',', " "),
            ":1:3: the header is separated by spaces",
        ),
        (
            "european.csv",
            text.replace(',', ";").replace('.', ","),
            "line 2 also writes numbers with a decimal comma (\"-179,999848\")",
        ),
        (
            "decimal-comma.csv",
            text.replace('.', ","),
            ":2:5: \"-179,999848\" is a number with a decimal comma",
        ),
        (
            "upper.csv",
            text.replacen("q1,q2,q3,q4,q5,q6,x,y,z", "Q1,Q2,Q3,Q4,Q5,Q6,X,Y,Z", 1),
            ":1:1: column \"Q1\": column names are lower-case",
        ),
    ];
    for (name, content, said) in cases {
        let file = dir.join(name);
        std::fs::write(&file, content).unwrap();
        let err = refused(&dir, &identify(&dir, &file, &[]));
        assert!(
            err.contains(&format!("{}{said}", s(&file))) || err.contains(said),
            "{name}: {err}"
        );
        assert!(!err.contains("missing required column"), "{name}: {err}");
    }
}

/// A row at 10⁶ mm is named (line, point); a value of 1e300 is printed as `1e300`.
/// (Before: "a different robot or unit" without the row; 301 digits.)
#[test]
fn a_huge_row_is_named_and_huge_numbers_print_short() {
    let dir = scratch("huge");
    // The identification rows with one field of line 40 (data row 38) replaced.
    let with_line_40 = |name: &str, column: usize, value: &str| {
        let file = dir.join(name);
        let edit = |k: usize, f: &mut Vec<String>| {
            if k == 38 {
                f[column] = value.to_string();
            }
        };
        std::fs::write(&file, rows(0..100, edit)).unwrap();
        refused(&dir, &identify(&dir, &file, &[]))
    };
    let err = with_line_40("far.csv", 6, "1000000");
    says(
        &err,
        "one row lies far from all the others: line 40 (x, y, z = 1e6,",
    );
    says(&err, "correct or remove the row");
    let err = with_line_40("huge.csv", 6, "1e300");
    assert!(
        err.contains("line 40 (x, y, z = 1e300,") && err.contains("1e300 mm from"),
        "{err}"
    );
    let err = with_line_40("q.csv", 0, "1e300");
    says(&err, ":40: column \"q1\": joint value 1e300 deg is outside");
    assert!(err.len() < 600, "{err}");
}

/// `--data` and `--validate` read from a pipe (`<(cat file)`, here standard input): the
/// file is read once. (Before: "the file is empty".)
#[test]
fn data_and_validation_read_from_a_pipe() {
    let dir = scratch("pipe");
    let (id, val, out, robot) = (
        dir.join("id.csv"),
        dir.join("val.csv"),
        dir.join("out"),
        ur10(),
    );
    // identify with `data` and `validate`, one of them `/dev/stdin` fed with `input`'s text.
    let run = |data: &Path, validate: &Path, input: &Path| {
        let _ = std::fs::remove_dir_all(&out);
        let mut child = Command::new(env!("CARGO_BIN_EXE_kincal"))
            .args(["identify", "--robot", s(&robot), "--data", s(data)])
            .args(["--validate", s(validate), "--out", s(&out)])
            .current_dir(root())
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        let text = std::fs::read(input).unwrap();
        child.stdin.take().unwrap().write_all(&text).unwrap();
        ok(&child.wait_with_output().unwrap())
    };
    let stdin = Path::new("/dev/stdin");
    let stdout = run(stdin, &val, &id);
    assert!(
        stdout.contains("fit: RMS 0.295 mm") && stdout.contains("100 poses"),
        "{stdout}"
    );
    let stdout = run(&id, stdin, &val);
    says(&stdout, "validation: 99 poses of /dev/stdin");
}

/// The command line's refusals name its options (`--joint-units rad`, `--allow …`), never
/// the library's keywords (`joint_units`). (Before: "declare it (joint_units = rad)".)
#[test]
fn refusals_name_the_command_lines_options() {
    let dir = scratch("flags");
    let rad = dir.join("rad.csv");
    std::fs::write(&rad, rows(0..100, scaled(0..6, 1f64.to_radians()))).unwrap();
    let err = refused(&dir, &identify(&dir, &rad, &[]));
    says(
        &err,
        "declare it (--joint-units rad), or override the check (--allow joint-units)",
    );
    assert!(
        !err.contains("joint_units") && !err.contains("allow="),
        "{err}"
    );
    // Degrees declared radians: declare degrees.
    let err = refused(
        &dir,
        &identify(&dir, &dir.join("id.csv"), &["--joint-units", "rad"]),
    );
    says(&err, "declare degrees (the default) (--joint-units deg)");
    assert!(!err.contains("joint_units"), "{err}");
}

/// Centimetres: points that need ×10 are named centimetres, with `--length-units cm`, which
/// reads them as millimetres would be; points that need ×0.1 are told to divide by 10.
/// (Before: "multiply by 10" for both, and no `cm`.)
#[test]
fn centimetres_are_recognised_both_ways_and_declared_with_cm() {
    let dir = scratch("cm");
    let cm = dir.join("cm.csv");
    std::fs::write(&cm, rows(0..100, scaled(6..9, 0.1))).unwrap();
    let err = refused(&dir, &identify(&dir, &cm, &[]));
    assert!(
        err.contains("ratio 0.1000") && err.contains("look like centimetres"),
        "{err}"
    );
    says(
        &err,
        "multiply them by 10 or declare their unit (--length-units cm)",
    );
    let tenfold = dir.join("tenfold.csv");
    std::fs::write(&tenfold, rows(0..100, scaled(6..9, 10.0))).unwrap();
    let err = refused(&dir, &identify(&dir, &tenfold, &[]));
    says(&err, "divide the points by 10");
    assert!(!err.contains("multiply"), "{err}");
    let val = dir.join("val.csv");
    let val_cm = dir.join("val-cm.csv");
    std::fs::write(&val_cm, rows(100..199, scaled(6..9, 0.1))).unwrap();
    let mm = ok(&identify(
        &dir,
        &dir.join("id.csv"),
        &["--validate", s(&val)],
    ));
    let _ = std::fs::remove_dir_all(dir.join("out"));
    let cm = ok(&identify(
        &dir,
        &cm,
        &["--validate", s(&val_cm), "--length-units", "cm"],
    ));
    let table = |out: &str| {
        out.lines()
            .find(|l| l.starts_with("validation:"))
            .unwrap()
            .split(": ")
            .last()
            .unwrap()
            .to_string()
    };
    assert_eq!(table(&mm), table(&cm), "{mm}\n{cm}");
}

/// The `--params paper --redundant damp` row of docs/calibrating-real-data.md runs as
/// written and gives the figures the doc shows.
#[test]
fn the_docs_redundant_damp_command_runs_as_written() {
    let dir = scratch("damp");
    // The doc's command, with `extra` options.
    let run = |extra: &[&str]| {
        let mut args = vec![
            "identify",
            "--robot",
            "scenarios/robots/ur10.json",
            "--data",
            "data/ur10-ipa/series-b-joint-configurations.csv",
            "--every",
            "15",
            "--params",
            "paper",
            "--redundant",
            "damp",
        ];
        args.extend_from_slice(extra);
        kincal(&args)
    };
    let stdout = ok(&run(&["--out", s(&dir.join("out"))]));
    says(&stdout, "calibrated mean 0.452 mm, max 1.766 mm");
    let doc = std::fs::read_to_string(root().join("docs/calibrating-real-data.md")).unwrap();
    let row = doc
        .lines()
        .find(|l| l.contains("`--params paper --redundant damp`"))
        .unwrap();
    assert!(row.ends_with("| 0.452 | 1.766 |"), "{row}");
    // Without the prior the parameters check refuses it, as the doc says, naming the
    // options that go on (`--prior auto`, `--allow parameters`).
    let out = run(&["--prior", "none", "--out", s(&dir.join("out2"))]);
    let err = stderr(&out);
    assert_eq!(out.status.code(), Some(1), "{err}");
    says(
        &err,
        "(--prior auto), or override the check (--allow parameters)",
    );
    assert!(
        !err.contains("prior=\"") && !err.contains("allow=\""),
        "{err}"
    );
}
