//! Command-line tests of `check` (issue 6): a regression is reported by figure name with a
//! non-zero exit, and malformed check files and missing baselines are clear errors.

mod common;

use common::{root, xtask};
use std::path::{Path, PathBuf};
use std::process::Output;

fn text(out: &Output) -> String {
    format!(
        "{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    )
}

fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("kincal-check-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// A one-check file (8 trials of the paper scenario) next to the committed scenarios.
fn check_file(dir: &Path, tolerances: &str) -> PathBuf {
    let scenario = root().join("scenarios/paper-kr1000.json");
    let path = dir.join("checks.json");
    std::fs::write(
        &path,
        format!(
            r#"{{ "tolerances": {tolerances},
  "checks": [ {{ "name": "small", "scenario": "{}", "trials": 8,
                "overrides": {{ "iso.enabled": false }} }} ] }}"#,
            scenario.display()
        ),
    )
    .unwrap();
    path
}

const TOL: &str = r#"{ "rel_mm": 0.03, "abs_pct": 1.0, "rel_abs_error": 0.1, "abs_z_sd": 0.15,
  "rel_observability": 0.01, "abs_iterations": 1.0 }"#;

#[test]
fn bless_then_pass_then_a_tampered_baseline_fails_by_name() {
    let dir = scratch("tamper");
    let checks = check_file(&dir, TOL);
    let base = dir.join("baselines");
    let args = |extra: &[&str]| -> Vec<String> {
        let mut v = vec![
            "check".to_string(),
            "--checks".into(),
            checks.display().to_string(),
            "--baselines".into(),
            base.display().to_string(),
        ];
        v.extend(extra.iter().map(|s| s.to_string()));
        v
    };
    let run = |extra: &[&str]| {
        let a = args(extra);
        xtask(&a.iter().map(String::as_str).collect::<Vec<_>>())
    };
    let out = run(&["--bless"]);
    assert!(out.status.success(), "{}", text(&out));
    let out = run(&[]);
    assert!(out.status.success(), "{}", text(&out));
    assert!(text(&out).contains("0 outside tolerance"), "{}", text(&out));

    // Pretend the baseline had rank 26 and a better improvement: both must be named.
    let file = base.join("small.json");
    let mut v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&file).unwrap()).unwrap();
    let f = &mut v["figures"];
    f["rank"] = serde_json::json!({ "026": 8 });
    let imp = f["improvement_pct"].as_f64().unwrap();
    f["improvement_pct"] = (imp + 5.0).into();
    std::fs::write(&file, serde_json::to_string(&v).unwrap()).unwrap();
    let out = run(&[]);
    assert!(!out.status.success());
    let t = text(&out);
    assert!(t.contains("REGRESSION rank"), "{t}");
    assert!(t.contains("REGRESSION improvement_pct"), "{t}");
    assert!(t.contains("2 figure(s) regressed"), "{t}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn bad_tolerance_and_missing_baseline_are_clear_errors() {
    let dir = scratch("bad");
    let checks = check_file(&dir, &TOL.replace("\"abs_pct\": 1.0", "\"abs_pct\": -1"));
    let out = xtask(&["check", "--checks", checks.to_str().unwrap()]);
    assert!(!out.status.success());
    assert!(
        text(&out).contains("tolerances.abs_pct = -1"),
        "{}",
        text(&out)
    );

    let checks = check_file(&dir, TOL);
    let missing = dir.join("none");
    let out = xtask(&[
        "check",
        "--checks",
        checks.to_str().unwrap(),
        "--baselines",
        missing.to_str().unwrap(),
    ]);
    assert!(!out.status.success());
    let t = text(&out);
    assert!(t.contains("small.json") && t.contains("--bless"), "{t}");
    let _ = std::fs::remove_dir_all(&dir);
}
