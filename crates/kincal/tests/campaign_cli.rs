//! Command-line tests of `campaign`: `--no-iso` switches the scenario's ISO 9283 test off,
//! `--no-budget` its residual budget.

use crate::common::{kincal, root};

#[test]
fn no_iso_drops_the_iso_rows_of_the_summary() {
    let dir = std::env::temp_dir().join(format!("kincal-campaign-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let scenario = root().join("scenarios/paper-kr1000.json");
    let run = |name: &str, extra: &[&str]| -> String {
        let out_dir = dir.join(name);
        let mut args = vec![
            "campaign",
            scenario.to_str().unwrap(),
            "--trials",
            "3",
            "--quiet",
            "--out",
            out_dir.to_str().unwrap(),
        ];
        args.extend_from_slice(extra);
        let out = kincal(&args);
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        std::fs::read_to_string(out_dir.join("summary.md")).unwrap()
    };
    let with = run("with", &[]);
    let without = run("without", &["--no-iso"]);
    assert!(with.contains("AP_p"), "{with}");
    assert!(!without.contains("AP_p"), "{without}");
    // Everything else is the same trials' figures.
    let table4 = |s: &str| {
        s.lines()
            .find(|l| l.contains("mean 3-D before"))
            .map(String::from)
    };
    assert_eq!(table4(&with), table4(&without));
    assert!(table4(&with).is_some(), "{with}");
    // `--no-budget` drops the residual budget the scenario asks for, and nothing else.
    let no_budget = run("no-budget", &["--no-budget"]);
    assert!(with.contains("## Residual budget"), "{with}");
    assert!(!no_budget.contains("Residual budget"), "{no_budget}");
    assert_eq!(table4(&with), table4(&no_budget));
    let _ = std::fs::remove_dir_all(&dir);
}
