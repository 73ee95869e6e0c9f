//! Golden-file test of the Markdown trial report.
//!
//! Compares the rendering of a fixed [`TrialReport`] with
//! `tests/golden/trial_report.md`. Run with `UPDATE_GOLDEN=1` to rewrite the file
//! after an intended change of the layout, then review the diff.

use std::path::PathBuf;

use evaluate::{IsoCube, IsoReport, Table4, TrialReport, render_trial_markdown, score_recovery};

/// A tiny deterministic generator (64-bit LCG, Knuth's MMIX constants) giving values
/// in [−1, 1): enough to make varied but fixed data.
struct Lcg(u64);

impl Lcg {
    fn next(&mut self) -> f64 {
        self.0 = self
            .0
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        ((self.0 >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
    }
    fn vec3(&mut self, scale: f64) -> [f64; 3] {
        [
            scale * self.next(),
            scale * self.next(),
            scale * self.next(),
        ]
    }
}

fn refs(v: &[Vec<[f64; 3]>]) -> [&[[f64; 3]]; 5] {
    [&v[0], &v[1], &v[2], &v[3], &v[4]]
}

fn fixed_report() -> TrialReport {
    let mut g = Lcg(20_231_122);
    let before: Vec<[f64; 3]> = (0..50).map(|_| g.vec3(1.2)).collect();
    let after: Vec<[f64; 3]> = (0..50).map(|_| g.vec3(0.35)).collect();
    let table4 = Table4::from_errors(&before, &after).unwrap();

    let cube = IsoCube::new([2000.0, 0.0, 1600.0], 800.0).unwrap();
    let targets = cube.test_points_mm();
    let mut series = |bias: [f64; 3], scatter: f64| -> Vec<Vec<[f64; 3]>> {
        targets
            .iter()
            .map(|t| {
                (0..30)
                    .map(|_| {
                        let d = g.vec3(scatter);
                        [
                            t[0] + bias[0] + d[0],
                            t[1] + bias[1] + d[1],
                            t[2] + bias[2] + d[2],
                        ]
                    })
                    .collect()
            })
            .collect()
    };
    let iso_before = series([0.6, -0.5, 0.4], 0.05);
    let iso_after = series([0.05, 0.04, -0.06], 0.05);
    let iso = IsoReport::from_attained(cube, refs(&iso_before), refs(&iso_after)).unwrap();

    let recovery = score_recovery(
        &["a_2", "alpha_2", "beta_2", "dx", "tz"],
        &["mm", "deg", "deg", "mm", "mm"],
        &[1400.4312, 0.0121, -0.0087, 0.2514, 150.0931],
        &[1400.4000, 0.0100, -0.0090, 0.2700, 150.1000],
        &[0.0150, 0.0011, 0.0006, 0.0120, 0.0080],
    )
    .unwrap();

    TrialReport {
        title: "Trial 7: KR1000 Titan, geometric errors + compliance".into(),
        scenario: "kr1000-paper".into(),
        table4,
        show_paper_reference: true,
        iso: Some(iso),
        recovery: Some(recovery),
        notes: vec![
            "Identification on 50 poses, validation on 50 other poses.".into(),
            "Stop reason: small relative cost change after 7 iterations.".into(),
        ],
    }
}

#[test]
fn trial_report_matches_golden_file() {
    let rendered = render_trial_markdown(&fixed_report());
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/golden/trial_report.md");
    if std::env::var_os("UPDATE_GOLDEN").is_some_and(|v| v == "1") {
        std::fs::write(&path, &rendered).unwrap();
        return;
    }
    let expected = std::fs::read_to_string(&path).unwrap_or_else(|e| {
        panic!(
            "cannot read {}: {e}; run with UPDATE_GOLDEN=1 to create it",
            path.display()
        )
    });
    assert!(
        rendered == expected,
        "rendered report differs from {}; rerun with UPDATE_GOLDEN=1 if the change is \
         intended.\n--- rendered ---\n{rendered}",
        path.display()
    );
}

#[test]
fn rendering_is_deterministic_and_serde_stable() {
    let report = fixed_report();
    let a = render_trial_markdown(&report);
    let json = serde_json::to_string(&report).unwrap();
    let back: TrialReport = serde_json::from_str(&json).unwrap();
    assert_eq!(back, report);
    assert_eq!(render_trial_markdown(&back), a);
}
