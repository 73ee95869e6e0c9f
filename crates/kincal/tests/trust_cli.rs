//! Issue 29 ("a wrong robot never leaves kincal with exit 0"), the rows of its table that the
//! library tests (`crates/calibrate/tests/workflow.rs`) and `calibrate_cli.rs` do not cover
//! on the command line: the KR1000 with swapped axes, an outlier factor of 0.5, joints in
//! degrees declared radians, the q2 = −0 row's registration and compensation of its own
//! outputs, a URDF in millimetres, a robot file in metres (identify and scenario), and a
//! campaign of another robot than the paper's (its masses, its pose counts, no paper column).

use crate::common::{kincal, kr1000, ok, root, s, sim, stderr};
use std::path::Path;
use std::process::Output;

/// `file` with every data row passed through `f` (fields split at commas; the comment lines
/// and the header kept).
fn rewrite(file: &Path, out: &Path, f: &dyn Fn(&mut Vec<String>)) {
    let text = std::fs::read_to_string(file).unwrap();
    let mut o = String::new();
    let mut header = true;
    for l in text.lines() {
        if header || l.starts_with('#') {
            header &= l.starts_with('#');
            o += &format!("{l}\n");
            continue;
        }
        let mut v: Vec<String> = l.split(',').map(String::from).collect();
        f(&mut v);
        o += &(v.join(",") + "\n");
    }
    std::fs::write(out, o).unwrap();
}

/// `identify` on the KR1000 with `data` (validated on the simulation's validation file)
/// and `extra` arguments, into `dir`.
fn identify(data: &Path, extra: &[&str], dir: &Path) -> Output {
    let robot = kr1000();
    let validation = sim().join("validation.csv");
    let mut args = vec![
        "identify",
        "--robot",
        s(robot),
        "--data",
        s(data),
        "--validate",
        s(&validation),
        "--out",
        s(dir),
    ];
    args.extend_from_slice(extra);
    kincal(&args)
}

/// A refusal: exit non-zero, nothing written, the overriding flag named.
fn assert_refused(out: &Output, dir: &Path, flag: &str) -> String {
    let err = stderr(out);
    assert!(
        !out.status.success(),
        "accepted:\n{}",
        String::from_utf8_lossy(&out.stdout)
    );
    assert!(!dir.exists(), "{} written", dir.display());
    assert!(err.contains(flag), "{flag} not named: {err}");
    err
}

/// Table rows "axes swapped (x,y,z written as z,y,x: a left-handed frame)" on the KR1000 and
/// "`--outlier-k 0.5`": both refused, nothing written, the override named.
#[test]
fn kr1000_swapped_axes_and_a_tiny_outlier_factor_are_refused() {
    let tmp = tempfile::tempdir().unwrap();
    let id = sim().join("identification.csv");
    let zyx = tmp.path().join("zyx.csv");
    // id, q1…q6, x, y, z: columns 7 and 9 swapped.
    rewrite(&id, &zyx, &|v| v.swap(7, 9));
    let dir = tmp.path().join("zyx");
    let err = assert_refused(&identify(&zyx, &[], &dir), &dir, "--allow mirror");
    assert!(err.contains("left-handed"), "{err}");
    let dir = tmp.path().join("k");
    let err = assert_refused(
        &identify(&id, &["--reject-outliers", "--outlier-k", "0.5"], &dir),
        &dir,
        "--allow outliers",
    );
    assert!(err.contains("below 2"), "{err}");
    // The clean file passes.
    ok(&identify(&id, &[], &tmp.path().join("clean")));
}

/// The reverse units case: joints in degrees declared radians (`--joint-units rad`) are
/// refused with the evidence (values beyond one turn that are within the limits as
/// degrees), not as the first row beyond a joint limit.
#[test]
fn degrees_declared_radians_are_refused_with_the_evidence() {
    let tmp = tempfile::tempdir().unwrap();
    let id = sim().join("identification.csv");
    let dir = tmp.path().join("o");
    let err = assert_refused(
        &identify(&id, &["--joint-units", "rad"], &dir),
        &dir,
        "--allow joint-units",
    );
    assert!(
        err.contains("declared radians") && err.contains("look like degrees"),
        "{err}"
    );
    // Overridden, the reader's own error stands (a joint beyond its limit in radians).
    let out = identify(
        &id,
        &["--joint-units", "rad", "--allow", "joint-units"],
        &dir,
    );
    assert!(!out.status.success() && !dir.exists());
    assert!(
        !stderr(&out).contains("look like degrees"),
        "{}",
        stderr(&out)
    );
}

/// Table row "simulated data where one row has q2 = −0": the registration on all rows does
/// not make the nominal error worse (it was 10.2 → 19.6 mm) and says on what evidence it was
/// decided; with every row kept (`--keep-outliers`) the run is refused (it validated at
/// 28.55 mm against 1.117) — by default the robust screen drops the row (issue 38);
/// overridden, it is written, and `compensate` accepts `identify`'s own `registered-nominal.json` (it refused
/// it: the fit moved α2 past 1°, so `identified.json` has no β2 parameter).
#[test]
fn a_q2_minus_zero_row_registers_on_evidence_and_compensates_its_own_outputs() {
    let tmp = tempfile::tempdir().unwrap();
    let id = sim().join("identification.csv");
    let bad = tmp.path().join("q2.csv");
    rewrite(&id, &bad, &|v| {
        if v[0] == "I027" {
            v[2] = "-0".into();
        }
    });
    let dir = tmp.path().join("plain");
    assert_refused(&identify(&bad, &["--keep-outliers"], &dir), &dir, "--allow");
    let dir = tmp.path().join("screened");
    let screened = ok(&identify(&bad, &[], &dir));
    assert!(
        screened.contains("robust screen: ") && screened.contains("I027"),
        "{screened}"
    );
    let dir = tmp.path().join("forced");
    let out = identify(
        &bad,
        &[
            "--keep-outliers",
            "--allow",
            "parameters",
            "--allow",
            "validation",
        ],
        &dir,
    );
    let stdout = ok(&out);
    let decision = stdout
        .lines()
        .find(|l| l.starts_with("registration decision:"))
        .unwrap_or_else(|| panic!("{stdout}"));
    // "…, mean A mm → B mm; …": the registration used never raises the mean error.
    if let Some(rest) = decision.split(", mean ").nth(1) {
        let num = |t: &str| {
            t.trim()
                .trim_end_matches("mm")
                .trim()
                .parse::<f64>()
                .unwrap()
        };
        let (a, b) = rest.split_once('→').unwrap();
        let b = b.split(';').next().unwrap();
        assert!(num(b) <= num(a), "{decision}");
    } else {
        assert!(decision.contains("not registered"), "{decision}");
    }
    let comp = tmp.path().join("comp.csv");
    let out = kincal(&[
        "compensate",
        "--robot",
        s(&dir.join("identified.json")),
        "--nominal",
        s(&dir.join("registered-nominal.json")),
        "--targets",
        s(&sim().join("validation.csv")),
        "--allow-unreachable",
        "--out",
        s(&comp),
    ]);
    assert!(
        !stderr(&out).contains("not the same kind of robot"),
        "{}",
        stderr(&out)
    );
}

/// Scales every `<origin xyz="…">` of a URDF by `k` (a description written in millimetres).
fn scale_origins(text: &str, k: f64) -> String {
    let mut out = String::new();
    let mut rest = text;
    while let Some(i) = rest.find("<origin") {
        out += &rest[..i];
        rest = &rest[i..];
        let end = rest.find('>').unwrap();
        let tag = &rest[..end];
        let scaled = match tag.find("xyz=\"") {
            Some(j) => {
                let start = j + 5;
                let stop = start + tag[start..].find('"').unwrap();
                let v: Vec<String> = tag[start..stop]
                    .split_whitespace()
                    .map(|x| format!("{}", x.parse::<f64>().unwrap() * k))
                    .collect();
                format!("{}{}{}", &tag[..start], v.join(" "), &tag[stop..])
            }
            None => tag.to_string(),
        };
        out += &scaled;
        rest = &rest[end..];
    }
    out + rest
}

/// A URDF in millimetres (lengths 1000× too large: a reach of kilometres) is refused at
/// import with the size and the override; a robot file in metres is refused by `identify`
/// (against the UR10 data in mm) and at scenario load.
#[test]
fn lengths_in_the_wrong_unit_are_refused_at_import_identify_and_scenario_load() {
    let tmp = tempfile::tempdir().unwrap();
    let text =
        std::fs::read_to_string(root().join("crates/urdf/tests/fixtures/ur10.urdf")).unwrap();
    let mm = tmp.path().join("ur10-mm.urdf");
    std::fs::write(&mm, scale_origins(&text, 1000.0)).unwrap();
    let robot = tmp.path().join("r.json");
    let import = |extra: &[&str]| {
        let mut args = vec![
            "urdf",
            "import",
            s(&mm),
            "--base",
            "base_link",
            "--tip",
            "tool0",
            "--out",
            s(&robot),
        ];
        args.extend_from_slice(extra);
        kincal(&args)
    };
    let out = import(&[]);
    assert!(!out.status.success() && !robot.exists());
    let err = stderr(&out);
    assert!(
        err.contains("--allow length-units") && err.contains("look like millimetres"),
        "{err}"
    );
    ok(&import(&["--allow", "length-units"]));
    assert!(robot.exists());

    // The UR10 robot file in metres.
    let mut spec: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(root().join("scenarios/robots/ur10.json")).unwrap(),
    )
    .unwrap();
    for j in spec["joints"].as_array_mut().unwrap() {
        for k in ["a_mm", "d_mm"] {
            j[k] = (j[k].as_f64().unwrap() / 1000.0).into();
        }
    }
    for t in spec["tool_mm"].as_array_mut().unwrap() {
        *t = (t.as_f64().unwrap() / 1000.0).into();
    }
    let metres = tmp.path().join("ur10-m.json");
    std::fs::write(&metres, serde_json::to_string_pretty(&spec).unwrap()).unwrap();
    let dir = tmp.path().join("id");
    let out = kincal(&[
        "identify",
        "--robot",
        s(&metres),
        "--data",
        s(&root().join("data/ur10-ipa/series-b-joint-configurations.csv")),
        "--every",
        "15",
        "--out",
        s(&dir),
    ]);
    let err = assert_refused(&out, &dir, "--allow length-units");
    assert!(err.contains("robot file's lengths are metres"), "{err}");

    let mut scenario: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(root().join("scenarios/noise-floor.json")).unwrap(),
    )
    .unwrap();
    scenario["robot"] = s(&metres).into();
    scenario["tool_mm"] = serde_json::json!([0.0, 0.0, 0.109]);
    let file = tmp.path().join("metres.json");
    std::fs::write(&file, scenario.to_string()).unwrap();
    let dir = tmp.path().join("campaign");
    let out = kincal(&[
        "campaign",
        s(&file),
        "--trials",
        "1",
        "--quiet",
        "--out",
        s(&dir),
    ]);
    let err = stderr(&out);
    assert!(!out.status.success() && !dir.exists(), "{err}");
    assert!(
        err.contains("look") && err.contains("metres") && err.contains("length-units"),
        "{err}"
    );
}

/// Table rows "`paper-kr1000` copied with `"robot": "ur10.json"`" and "a scenario copy with
/// 20 identification poses": the summary says what was run (the UR10 file, its own link
/// masses, 20 identification poses) and shows no "paper" column (the paper's figures are
/// the KR1000's); `summary.json` has no `paper` key.
#[test]
fn a_campaign_of_another_robot_says_what_was_run_without_the_paper_column() {
    let tmp = tempfile::tempdir().unwrap();
    let mut scenario: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(root().join("scenarios/paper-kr1000.json")).unwrap(),
    )
    .unwrap();
    scenario["robot"] = s(&root().join("scenarios/robots/ur10.json")).into();
    scenario["poses"]["identification"] = 20.into();
    let file = tmp.path().join("ur10-copy.json");
    std::fs::write(&file, scenario.to_string()).unwrap();
    let dir = tmp.path().join("out");
    ok(&kincal(&[
        "campaign",
        s(&file),
        "--trials",
        "2",
        "--no-iso",
        "--no-budget",
        "--quiet",
        "--out",
        s(&dir),
    ]));
    let md = std::fs::read_to_string(dir.join("summary.md")).unwrap();
    assert!(md.contains("ur10.json"), "{md}");
    assert!(md.contains("per trial 20 identification poses"), "{md}");
    assert!(
        md.contains("link masses 7.1, 12.7, 4.27, 2, 2, 0.365 kg"),
        "{md}"
    );
    assert!(
        !md.contains("| paper |") && !md.contains("beside the paper"),
        "{md}"
    );
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("summary.json")).unwrap()).unwrap();
    assert!(json.get("paper").is_none(), "{json}");
    // The paper's own scenario keeps its column (`results/paper-kr1000/summary.md`).
    let committed =
        std::fs::read_to_string(root().join("results/paper-kr1000/summary.md")).unwrap();
    assert!(committed.contains("| metric | kincal | paper |"));
}

/// Table row "UR10 README example, `report.md`": the held, redundant and identifiable sets
/// agree — every parameter the console lists as held is in the report's redundant set or
/// named as held outside it with the reason, its table row says "held", and every row that
/// says "yes" (identifiable) has a standard error.
#[test]
fn ur10_report_held_redundant_and_identifiable_sets_agree() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("cal");
    let out = ok(&kincal(&[
        "identify",
        "--robot",
        s(&root().join("scenarios/robots/ur10.json")),
        "--data",
        s(&root().join("data/ur10-ipa/series-b-joint-configurations.csv")),
        "--every",
        "15",
        "--out",
        s(&dir),
    ]));
    let list =
        |line: &str| -> Vec<String> { line.split(", ").map(|n| n.trim().to_string()).collect() };
    let held = list(
        out.lines()
            .find_map(|l| l.strip_prefix("held at their start values"))
            .and_then(|l| l.split_once("): ").map(|(_, r)| r))
            .unwrap_or_else(|| panic!("{out}")),
    );
    assert_eq!(held.len(), 10, "{held:?}");
    let report = std::fs::read_to_string(dir.join("report.md")).unwrap();
    let redundant: Vec<&str> = report
        .lines()
        .filter_map(|l| l.strip_prefix("- `"))
        .filter_map(|l| l.split_once('`').map(|(n, _)| n))
        .collect();
    let outside: Vec<String> = report
        .lines()
        .find_map(|l| {
            l.strip_prefix(
                "Held at their start values but not in the redundant set at the solution: ",
            )
        })
        .map(|l| list(l.split(" — ").next().unwrap()))
        .unwrap_or_default();
    for h in &held {
        assert!(
            redundant.contains(&h.as_str()) != outside.contains(h),
            "{h}: redundant {redundant:?}, held outside it {outside:?}"
        );
        let row = report
            .lines()
            .find(|l| l.starts_with(&format!("| {h} |")))
            .unwrap_or_else(|| panic!("no row {h}"));
        assert!(
            row.ends_with(
                "| held (exactly redundant at the start: not fitted, no standard error) |"
            ),
            "{row}"
        );
    }
    let mut rows = 0;
    for l in report.lines().filter(|l| l.ends_with("| yes |")) {
        let cells: Vec<&str> = l.split('|').map(str::trim).collect();
        // | name | unit | nominal | identified | Δ | std error | identifiable |
        assert!(
            cells[6].parse::<f64>().is_ok(),
            "identifiable without SE: {l}"
        );
        rows += 1;
    }
    assert_eq!(rows, 35 - 10, "{report}");
}

/// "A simulated campaign uses the robot file's own mass model, or refuses when the
/// scenario's unmodelled errors need one it lacks": a `paper-kr1000` copy (compliance on)
/// with a UR10 file stripped of its `mass_model` is refused at load, naming the field.
#[test]
fn a_campaign_needing_a_mass_model_the_robot_lacks_is_refused() {
    let tmp = tempfile::tempdir().unwrap();
    let mut spec: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(root().join("scenarios/robots/ur10.json")).unwrap(),
    )
    .unwrap();
    spec.as_object_mut().unwrap().remove("mass_model").unwrap();
    let robot = tmp.path().join("ur10-bare.json");
    std::fs::write(&robot, spec.to_string()).unwrap();
    let mut scenario: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(root().join("scenarios/paper-kr1000.json")).unwrap(),
    )
    .unwrap();
    scenario["robot"] = s(&robot).into();
    let file = tmp.path().join("bare.json");
    std::fs::write(&file, scenario.to_string()).unwrap();
    let dir = tmp.path().join("out");
    let out = kincal(&[
        "campaign",
        s(&file),
        "--trials",
        "1",
        "--quiet",
        "--out",
        s(&dir),
    ]);
    let err = stderr(&out);
    assert!(!out.status.success() && !dir.exists(), "{err}");
    assert!(
        err.contains("unmodelled.compliance.links") && err.contains("mass_model"),
        "{err}"
    );
}

/// Issue 38, item 4: the robot files `identify` writes say what they are and which run and
/// data they come from, and `compensate` refuses the pair swapped (which wrote the
/// anti-compensation with exit 0) or from two runs, naming both files; `--allow provenance`
/// takes them as given.
#[test]
fn compensate_refuses_a_swapped_pair_or_two_runs() {
    let tmp = tempfile::tempdir().unwrap();
    let data = root().join("data/ur10-ipa/series-b-joint-configurations.csv");
    let run = |offset: &str| {
        let dir = tmp.path().join(format!("cal-{offset}"));
        ok(&kincal(&[
            "identify",
            "--robot",
            "scenarios/robots/ur10.json",
            "--data",
            s(&data),
            "--every",
            "15",
            "--offset",
            offset,
            "--out",
            s(&dir),
        ]));
        dir
    };
    let (a, b) = (run("0"), run("7"));
    let spec = |p: &Path| -> serde_json::Value {
        serde_json::from_str(&std::fs::read_to_string(p).unwrap()).unwrap()
    };
    let (id_a, reg_a) = (
        spec(&a.join("identified.json")),
        spec(&a.join("registered-nominal.json")),
    );
    assert_eq!(id_a["provenance"]["role"], "identified");
    assert_eq!(reg_a["provenance"]["role"], "registered-nominal");
    assert_eq!(id_a["provenance"]["run"], reg_a["provenance"]["run"]);
    assert_eq!(
        id_a["provenance"]["data_sha256"].as_str().unwrap().len(),
        64
    );
    let id_b = spec(&b.join("identified.json"));
    assert_ne!(id_a["provenance"]["run"], id_b["provenance"]["run"]);
    // A few commanded joints.
    let targets = tmp.path().join("targets.csv");
    let text = std::fs::read_to_string(&data).unwrap();
    let head: Vec<&str> = text.lines().take(12).collect();
    std::fs::write(&targets, head.join("\n") + "\n").unwrap();
    let out = tmp.path().join("commands.csv");
    let compensate = |robot: &Path, nominal: &Path, allow: bool| {
        let mut args = vec![
            "compensate",
            "--robot",
            s(robot),
            "--nominal",
            s(nominal),
            "--targets",
            s(&targets),
            "--allow-unreachable",
            "--out",
            s(&out),
        ];
        if allow {
            args.extend(["--allow", "provenance"]);
        }
        kincal(&args)
    };
    let refused = |o: Output, says: &str| {
        let e = stderr(&o);
        assert!(!o.status.success(), "{e}");
        assert!(
            e.contains(says) && e.contains("--allow provenance") && e.contains("nothing written"),
            "{e}"
        );
        assert!(!out.exists());
        e
    };
    let (ida, rega, regb) = (
        a.join("identified.json"),
        a.join("registered-nominal.json"),
        b.join("registered-nominal.json"),
    );
    let e = refused(compensate(&rega, &ida, false), "swapped");
    assert!(e.contains(s(&rega)) && e.contains(s(&ida)), "{e}");
    let e = refused(compensate(&ida, &regb, false), "different calibration runs");
    assert!(e.contains(s(&ida)) && e.contains(s(&regb)), "{e}");
    ok(&compensate(&ida, &regb, true));
    std::fs::remove_file(&out).unwrap();
    ok(&compensate(&ida, &rega, false));
    assert!(out.exists());
}
