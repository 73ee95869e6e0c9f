//! The Markdown report of one trial (`trial-<k>.md`): Table 4, the ISO 9283 table and the
//! parameter recovery of the lowest-index successful trial of a campaign.
//!
//! Numbers follow the formatting rules of `report::fmt`: lengths (mm) with a fixed 3
//! decimals in the tables (so that a column of before/after errors stays aligned whatever
//! its magnitude), percentages with 1, parameter values (mm or deg) with 4, z-scores with 2;
//! a value that rounds to zero is printed unsigned; an undefined improvement (zero
//! baseline) is printed as `n/a`.

use std::fmt::Write as _;

use evaluate::{
    AxisStats, ErrorStats, IsoReport, ParameterRecovery, PointStats, Table4, improvement_pct,
    summarize_z,
};
use report::fmt;
use serde::{Deserialize, Serialize};

use crate::outputs::summary::{PAPER, is_paper};
use crate::scenario::Scenario;
use crate::trial::TrialResult;

/// Everything [`TrialReport::to_markdown`] prints for one trial.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TrialReport {
    /// Report title (first-level heading).
    pub title: String,
    /// Scenario name.
    pub scenario: String,
    /// Before/after validation error statistics (the paper's Table 4).
    pub table4: Table4,
    /// Print the paper's reference numbers under Table 4 (mean 1.122 → 0.340 mm,
    /// max 2.557 → 0.973 mm, 69.7 %; [`PAPER`]).
    #[serde(default)]
    pub show_paper_reference: bool,
    /// ISO 9283 results on P1…P5, if measured.
    #[serde(default)]
    pub iso: Option<IsoReport>,
    /// Parameter recovery table, if the truth is known (simulation).
    #[serde(default)]
    pub recovery: Option<Vec<ParameterRecovery>>,
    /// Free-form lines printed as a bullet list at the end.
    #[serde(default)]
    pub notes: Vec<String>,
}

/// A length in a table, mm: `report::fmt`'s before/after column rule.
fn mm(v: f64) -> String {
    fmt::mm_col(v)
}

/// An improvement, %, or `n/a` when it is undefined.
fn pct(v: Option<f64>) -> String {
    v.map_or_else(|| "n/a".to_string(), fmt::pct)
}

/// A parameter value (mm or deg): 4 decimals.
fn param(v: f64) -> String {
    fmt::param(v, 4)
}

impl TrialReport {
    /// The report of trial `t` of a campaign of `scenario`: Table 4 (with the paper's
    /// reference for the paper's scenarios), the ISO table and recovery when the trial has
    /// them, and notes on the identification.
    pub fn new(scenario: &Scenario, t: &TrialResult) -> TrialReport {
        let recovery = (!t.recovery.is_empty()).then(|| t.recovery.clone());
        let f = &t.fit;
        TrialReport {
            title: format!("Trial {} of `{}`", t.trial, scenario.name),
            scenario: scenario.name.clone(),
            table4: t.table4,
            show_paper_reference: is_paper(&scenario.name),
            iso: t.iso,
            recovery,
            notes: vec![
                format!(
                    "Seed {}, trial {}: identification on {} poses ({} free parameters, rank {}), validation on {} poses.",
                    scenario.seed,
                    t.trial,
                    scenario.poses.identification.len(),
                    f.free,
                    f.rank
                        .map_or_else(|| "unknown".to_string(), |r| r.to_string()),
                    scenario.poses.validation.len()
                ),
                format!(
                    "LM: {} iterations, stopped on {}; fit RMS residual {} mm.",
                    f.iterations,
                    f.stop,
                    param(f.rms_mm)
                ),
                format!(
                    "Geometry error of the identified model on the validation poses: {} mm; compensation failures: {}; unmeasurable poses: {}.",
                    param(t.predicted_error_mm),
                    t.compensation_failures,
                    t.unmeasurable
                ),
            ],
        }
    }

    /// Renders the report as Markdown, deterministically (same report ⇒ same bytes).
    ///
    /// Sections, in order: title and scenario; Table 4 with rows `statistic × axis`
    /// (mean, max, RMS, p95 × `|x|`, `|y|`, `|z|`, 3-D) and columns before (mm), after
    /// (mm), improvement `100·(before − after)/before` (%), followed by the paper's
    /// reference numbers if [`TrialReport::show_paper_reference`] is set; the ISO 9283
    /// table (P1…P5: `AP_p`, `AP_x`, `AP_y`, `AP_z`, `RP_l` before/after, plus mean `AP_p`
    /// and its improvement) if present; the recovery table (name, unit, truth, estimate,
    /// error, std error, z, plus a z summary when there are ≥ 2 rows) if present; the notes
    /// as a bullet list if any. Formats: see the module doc.
    pub fn to_markdown(&self) -> String {
        let mut out = String::new();
        let _ = writeln!(out, "# {}\n", self.title);
        let _ = writeln!(out, "Scenario: `{}`\n", self.scenario);
        table4_section(&mut out, &self.table4, self.show_paper_reference);
        if let Some(iso) = &self.iso {
            iso_section(&mut out, iso);
        }
        if let Some(rec) = &self.recovery {
            recovery_section(&mut out, rec);
        }
        if !self.notes.is_empty() {
            out.push_str("\n## Notes\n\n");
            for line in &self.notes {
                let _ = writeln!(out, "- {line}");
            }
        }
        out
    }
}

fn table4_section(out: &mut String, t: &Table4, show_paper_reference: bool) {
    out.push_str("## Table 4: validation error before and after compensation\n\n");
    if t.before.count == t.after.count {
        let _ = writeln!(out, "Validation poses: {}.\n", t.before.count);
    } else {
        let _ = writeln!(
            out,
            "Validation poses: {} before, {} after.\n",
            t.before.count, t.after.count
        );
    }
    out.push_str("| Statistic | Before (mm) | After (mm) | Improvement (%) |\n");
    out.push_str("|---|---:|---:|---:|\n");
    type Pick = fn(&AxisStats) -> f64;
    let statistics: [(&str, Pick); 4] = [
        ("mean", |a| a.mean_mm),
        ("max", |a| a.max_mm),
        ("RMS", |a| a.rms_mm),
        ("p95", |a| a.p95_mm),
    ];
    type Axis = fn(&ErrorStats) -> &AxisStats;
    let axes: [(&str, Axis); 4] = [
        ("\\|x\\|", |s| &s.x),
        ("\\|y\\|", |s| &s.y),
        ("\\|z\\|", |s| &s.z),
        ("3-D", |s| &s.norm),
    ];
    for (stat_name, pick) in statistics {
        for (axis_name, axis) in axes {
            let b = pick(axis(&t.before));
            let a = pick(axis(&t.after));
            let _ = writeln!(
                out,
                "| {stat_name} {axis_name} | {} | {} | {} |",
                mm(b),
                mm(a),
                pct(improvement_pct(b, a))
            );
        }
    }
    if show_paper_reference {
        let _ = writeln!(
            out,
            "\nPaper reference (Li et al. 2023, Table 4, KUKA KR1000 Titan): \
             mean 3-D {} → {} mm, max 3-D {} → {} mm, improvement {} %.",
            mm(PAPER.before_mean_mm),
            mm(PAPER.after_mean_mm),
            mm(PAPER.before_max_mm),
            mm(PAPER.after_max_mm),
            fmt::pct(PAPER.improvement_pct)
        );
    }
}

fn iso_section(out: &mut String, iso: &IsoReport) {
    out.push_str("\n## ISO 9283 position accuracy and repeatability\n\n");
    if let Some(c) = iso.cube {
        let _ = writeln!(
            out,
            "Cube: centre ({}, {}, {}) mm, edge {} mm; measuring plane C1-C2-C7-C8.",
            mm(c.center_mm[0]),
            mm(c.center_mm[1]),
            mm(c.center_mm[2]),
            mm(c.edge_mm)
        );
    }
    let cycles: Vec<usize> = iso
        .points
        .iter()
        .flat_map(|p| [p.before.cycles, p.after.cycles])
        .collect();
    if cycles.iter().all(|&c| c == cycles[0]) {
        let _ = writeln!(out, "Cycles per point: {}.", cycles[0]);
    }
    out.push('\n');
    out.push_str(
        "| Point | AP_p before (mm) | AP_p after (mm) | AP_x before (mm) | AP_x after (mm) \
         | AP_y before (mm) | AP_y after (mm) | AP_z before (mm) | AP_z after (mm) \
         | RP_l before (mm) | RP_l after (mm) |\n",
    );
    out.push_str("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n");
    type Pick = fn(&PointStats) -> f64;
    let columns: [Pick; 5] = [
        |p| p.ap_p_mm,
        |p| p.ap_x_mm,
        |p| p.ap_y_mm,
        |p| p.ap_z_mm,
        |p| p.rp_l_mm,
    ];
    for (i, row) in iso.points.iter().enumerate() {
        let _ = write!(out, "| P{} |", i + 1);
        for pick in columns {
            let _ = write!(
                out,
                " {} | {} |",
                mm(pick(&row.before)),
                mm(pick(&row.after))
            );
        }
        out.push('\n');
    }
    let _ = writeln!(
        out,
        "\nMean AP_p: {} → {} mm (improvement {} %).",
        mm(iso.mean_ap_p_before_mm()),
        mm(iso.mean_ap_p_after_mm()),
        pct(iso.ap_p_improvement_pct())
    );
    let _ = writeln!(
        out,
        "Mean RP_l: {} → {} mm.",
        mm(iso.mean_rp_l_before_mm()),
        mm(iso.mean_rp_l_after_mm())
    );
}

fn recovery_section(out: &mut String, rec: &[ParameterRecovery]) {
    out.push_str("\n## Parameter recovery\n\n");
    out.push_str("| Parameter | Unit | Truth | Estimate | Error | Std error | z |\n");
    out.push_str("|---|---|---:|---:|---:|---:|---:|\n");
    for r in rec {
        let _ = writeln!(
            out,
            "| {} | {} | {} | {} | {} | {} | {} |",
            r.name,
            r.unit,
            param(r.truth),
            param(r.estimate),
            param(r.error),
            param(r.std_error),
            fmt::z(r.z)
        );
    }
    let z: Vec<f64> = rec.iter().map(|r| r.z).collect();
    if let Ok(s) = summarize_z(&z) {
        let _ = writeln!(
            out,
            "\nz-scores: n = {}, mean {}, sd {}, max \\|z\\| {}.",
            s.count,
            fmt::z(s.mean),
            fmt::z(s.sd),
            fmt::z(s.max_abs)
        );
    }
}

#[cfg(test)]
mod tests {
    use std::path::PathBuf;

    use evaluate::{IsoCube, score_recovery};

    use super::*;

    fn minimal(show: bool) -> TrialReport {
        TrialReport {
            title: "T".into(),
            scenario: "s".into(),
            table4: Table4::from_errors(
                &[[1.0, 0.0, 0.0], [0.0, 0.0, 3.0]],
                &[[0.5, 0.0, 0.0], [0.0, 0.0, -0.0001]],
            )
            .unwrap(),
            show_paper_reference: show,
            iso: None,
            recovery: None,
            notes: vec![],
        }
    }

    #[test]
    fn fixed_normalises_negative_zero() {
        assert_eq!(fmt::fixed(-0.0001, 3), "0.000");
        assert_eq!(fmt::fixed(-0.0, 1), "0.0");
        assert_eq!(fmt::fixed(-0.0006, 3), "-0.001");
        assert_eq!(fmt::fixed(12.34567, 3), "12.346");
        assert_eq!(pct(None), "n/a");
        assert_eq!(pct(Some(69.69697)), "69.7");
    }

    #[test]
    fn paper_reference_only_on_request() {
        let without = minimal(false).to_markdown();
        let with = minimal(true).to_markdown();
        assert!(!without.contains("Paper reference"));
        assert!(
            with.contains(
                "mean 3-D 1.122 → 0.340 mm, max 3-D 2.557 → 0.973 mm, improvement 69.7 %"
            )
        );
        // Optional sections absent.
        assert!(!without.contains("ISO 9283"));
        assert!(!without.contains("Parameter recovery"));
        assert!(!without.contains("## Notes"));
    }

    #[test]
    fn table4_rows_and_undefined_improvement() {
        let md = minimal(false).to_markdown();
        // 16 statistic rows + header + separator.
        assert_eq!(md.lines().filter(|l| l.starts_with("| ")).count(), 17);
        // norm before 1, 3 → mean 2; after 0.5, 0.0001 → mean 0.25005 → 87.5 %.
        assert!(md.contains("| mean 3-D | 2.000 | 0.250 | 87.5 |"), "{md}");
        // |y| is zero before: undefined improvement.
        assert!(
            md.contains("| mean \\|y\\| | 0.000 | 0.000 | n/a |"),
            "{md}"
        );
        assert!(md.contains("Validation poses: 2."));
    }

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

    /// Golden file of a fixed report, `tests/golden/trial_report.md`; `UPDATE_GOLDEN=1`
    /// rewrites it after an intended change of the layout (then review the diff).
    #[test]
    fn trial_report_matches_golden_file() {
        let rendered = fixed_report().to_markdown();
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
        let a = report.to_markdown();
        let json = serde_json::to_string(&report).unwrap();
        let back: TrialReport = serde_json::from_str(&json).unwrap();
        assert_eq!(back, report);
        assert_eq!(back.to_markdown(), a);
    }
}
