//! Deterministic Markdown report of one trial.
//!
//! Number formats are fixed: lengths (mm) with 3 decimals, percentages with 1,
//! parameter values (mm or deg) with 4, z-scores with 2; `-0.000` is printed as
//! `0.000`; an undefined improvement (zero baseline) is printed as `n/a`.

use std::fmt::Write as _;

use serde::{Deserialize, Serialize};

use crate::iso9283::{IsoReport, PointStats};
use crate::recovery::{ParameterRecovery, summarize_z};
use crate::stats::{AxisStats, ErrorStats, Table4, improvement_pct};

/// The paper's Table 4 reference numbers (Li et al. 2023, KUKA KR1000 Titan):
/// mean 3-D error before/after (mm), max 3-D error before/after (mm), and the
/// improvement of the mean (%).
pub const PAPER_TABLE4_REFERENCE: PaperReference = PaperReference {
    mean_before_mm: 1.122,
    mean_after_mm: 0.340,
    max_before_mm: 2.557,
    max_after_mm: 0.973,
    mean_improvement_pct: 69.7,
};

/// Reference numbers quoted from the paper (see [`PAPER_TABLE4_REFERENCE`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PaperReference {
    /// Mean 3-D error before compensation (mm).
    pub mean_before_mm: f64,
    /// Mean 3-D error after compensation (mm).
    pub mean_after_mm: f64,
    /// Max 3-D error before compensation (mm).
    pub max_before_mm: f64,
    /// Max 3-D error after compensation (mm).
    pub max_after_mm: f64,
    /// Improvement of the mean, `100·(before − after)/before` (%).
    pub mean_improvement_pct: f64,
}

/// Everything [`render_trial_markdown`] prints for one trial.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TrialReport {
    /// Report title (first-level heading).
    pub title: String,
    /// Scenario name.
    pub scenario: String,
    /// Before/after validation error statistics (the paper's Table 4).
    pub table4: Table4,
    /// Print the paper's reference numbers under Table 4 (mean 1.122 → 0.340 mm,
    /// max 2.557 → 0.973 mm, 69.7 %).
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

/// Fixed-point formatting with `decimals` digits; negative zero is printed unsigned.
fn fixed(v: f64, decimals: usize) -> String {
    let s = format!("{v:.decimals$}");
    if s.starts_with('-') && s[1..].chars().all(|c| c == '0' || c == '.') {
        s[1..].to_string()
    } else {
        s
    }
}

fn mm(v: f64) -> String {
    fixed(v, 3)
}

fn pct(v: Option<f64>) -> String {
    v.map_or_else(|| "n/a".to_string(), |p| fixed(p, 1))
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
        let r = PAPER_TABLE4_REFERENCE;
        let _ = writeln!(
            out,
            "\nPaper reference (Li et al. 2023, Table 4, KUKA KR1000 Titan): \
             mean 3-D {} → {} mm, max 3-D {} → {} mm, improvement {} %.",
            mm(r.mean_before_mm),
            mm(r.mean_after_mm),
            mm(r.max_before_mm),
            mm(r.max_after_mm),
            fixed(r.mean_improvement_pct, 1)
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
            fixed(r.truth, 4),
            fixed(r.estimate, 4),
            fixed(r.error, 4),
            fixed(r.std_error, 4),
            fixed(r.z, 2)
        );
    }
    let z: Vec<f64> = rec.iter().map(|r| r.z).collect();
    if let Ok(s) = summarize_z(&z) {
        let _ = writeln!(
            out,
            "\nz-scores: n = {}, mean {}, sd {}, max \\|z\\| {}.",
            s.count,
            fixed(s.mean, 2),
            fixed(s.sd, 2),
            fixed(s.max_abs, 2)
        );
    }
}

/// Renders one trial as Markdown, deterministically (same report ⇒ same bytes).
///
/// Sections, in order: title and scenario; Table 4 with rows `statistic × axis`
/// (mean, max, RMS, p95 × `|x|`, `|y|`, `|z|`, 3-D) and columns before (mm), after (mm),
/// improvement `100·(before − after)/before` (%), followed by the paper's reference
/// numbers if [`TrialReport::show_paper_reference`] is set; the ISO 9283 table (P1…P5:
/// `AP_p`, `AP_x`, `AP_y`, `AP_z`, `RP_l` before/after, plus mean `AP_p` and its
/// improvement) if present; the recovery table (name, unit, truth, estimate, error,
/// std error, z, plus a z summary when there are ≥ 2 rows) if present; the notes as a
/// bullet list if any. Formats: see the module doc.
pub fn render_trial_markdown(report: &TrialReport) -> String {
    let mut out = String::new();
    let _ = writeln!(out, "# {}\n", report.title);
    let _ = writeln!(out, "Scenario: `{}`\n", report.scenario);
    table4_section(&mut out, &report.table4, report.show_paper_reference);
    if let Some(iso) = &report.iso {
        iso_section(&mut out, iso);
    }
    if let Some(rec) = &report.recovery {
        recovery_section(&mut out, rec);
    }
    if !report.notes.is_empty() {
        out.push_str("\n## Notes\n\n");
        for line in &report.notes {
            let _ = writeln!(out, "- {line}");
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::stats::Table4;

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
        assert_eq!(fixed(-0.0001, 3), "0.000");
        assert_eq!(fixed(-0.0, 1), "0.0");
        assert_eq!(fixed(-0.0006, 3), "-0.001");
        assert_eq!(fixed(12.34567, 3), "12.346");
        assert_eq!(pct(None), "n/a");
        assert_eq!(pct(Some(69.69697)), "69.7");
    }

    #[test]
    fn paper_reference_only_on_request() {
        let without = render_trial_markdown(&minimal(false));
        let with = render_trial_markdown(&minimal(true));
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
        let md = render_trial_markdown(&minimal(false));
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
}
