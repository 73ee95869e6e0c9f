//! The plots and the HTML page of a real-data calibration (`kincal identify`).
//!
//! [`identify_plots`] takes the per-point errors (measured − model, mm) of the start model
//! (the nominal one, registered when the data came in a tracker frame) and of the identified
//! one, on the identification rows and, when there are any, on the validation rows, plus the
//! outlier screen's threshold and flagged rows. It returns the SVGs to write beside
//! `report.md`; [`identify_page`] renders `report.html` from `report.md` and those SVGs.

use crate::fmt;
use crate::html::{self, Picture};
use crate::plot::{
    Figure, HEIGHT, PlotError, RefLine, Scale, Series, Style, cdf_figure, figure_svg, panels_svg,
};
use evaluate::{mean, norms};

/// What [`identify_plots`] draws from. Every error is measured − model, in mm, one per row.
#[derive(Clone, Copy, Debug)]
pub struct IdentifyPlotData<'a> {
    /// The robot's name, for the titles.
    pub robot: &'a str,
    /// Identification rows: error of the start model (nominal, registered).
    pub identification_before_mm: &'a [[f64; 3]],
    /// Identification rows: residual of the identified model.
    pub identification_after_mm: &'a [[f64; 3]],
    /// Validation rows, if any: error of the start model.
    pub validation_before_mm: Option<&'a [[f64; 3]]>,
    /// Validation rows, if any: error of the identified model.
    pub validation_after_mm: Option<&'a [[f64; 3]]>,
    /// The outlier screen's threshold k·σ̂₃ (mm) and k, if screened.
    pub outlier_threshold: Option<(f64, f64)>,
    /// Indices (into the identification rows) of the flagged points.
    pub outliers: &'a [usize],
    /// Empty, or one label per flagged point (e.g. `line 857`), named in the legend (the
    /// first five).
    pub outlier_labels: &'a [String],
}

/// File names of the plots, in the order [`identify_plots`] returns them.
pub const IDENTIFY_PLOT_FILES: [&str; 4] = [
    "pose-errors.svg",
    "error-cdf.svg",
    "residuals-per-axis.svg",
    "outliers.svg",
];

/// Most poses a per-pose plot draws: above it, every k-th pose is drawn (the means and the
/// CDF still use all of them), so a file of 10⁶ rows gives a plot of kilobytes, not 160 MB.
pub const MAX_POSE_POINTS: usize = 2500;

/// Every how many poses a per-pose plot of `n` poses draws one.
fn stride(n: usize) -> usize {
    n.div_ceil(MAX_POSE_POINTS).max(1)
}

/// `(row number from 1, value)` of the drawn poses: all of them, or every k-th.
fn indexed(v: &[f64]) -> Vec<(f64, f64)> {
    v.iter()
        .enumerate()
        .step_by(stride(v.len()))
        .map(|(i, &e)| ((i + 1) as f64, e))
        .collect()
}

/// The x-axis title of a per-pose plot: `rows (row order)`, saying when only every k-th
/// pose is drawn.
fn rows_title(rows: &str, n: usize) -> String {
    match stride(n) {
        1 => format!("{rows} (row order)"),
        k => format!(
            "{rows} (row order; every {}th of {} drawn)",
            fmt::whole(k as f64),
            fmt::whole(n as f64)
        ),
    }
}

fn check_len(what: &str, a: &[[f64; 3]], b: &[[f64; 3]]) -> Result<(), PlotError> {
    if a.is_empty() {
        return Err(PlotError::Empty { what: what.into() });
    }
    if a.len() != b.len() {
        return Err(PlotError::LengthMismatch {
            what: format!("{what} after identification"),
            expected: a.len(),
            got: b.len(),
        });
    }
    Ok(())
}

/// One panel: 3-D error per pose before and after, as points, with the means as lines.
fn before_after_panel(title: &str, rows: &str, before: &[f64], after: &[f64]) -> Figure {
    let mut f = Figure::new(
        title,
        rows_title(rows, before.len()),
        "3-D position error (mm)",
    );
    f.y_from_zero = true;
    f.series.push(Series::new(
        "nominal model (registered)",
        indexed(before),
        Style::Markers,
    ));
    f.series.push(Series::new(
        "identified model",
        indexed(after),
        Style::Markers,
    ));
    f.refs.push(
        RefLine::horizontal(format!("mean {} mm", fmt::mm(mean(before))), mean(before)).colored(0),
    );
    f.refs.push(
        RefLine::horizontal(format!("mean {} mm", fmt::mm(mean(after))), mean(after)).colored(1),
    );
    f
}

/// The identification plots as `(file name, SVG)`, named as [`IDENTIFY_PLOT_FILES`]:
/// - `pose-errors.svg`: 3-D error per pose before/after (identification rows; validation rows
///   in a second panel when given), points with the means as dashed lines;
/// - `error-cdf.svg`: the share of poses whose error is below x, before/after, for the
///   validation rows when given, else the identification rows;
/// - `residuals-per-axis.svg`: the identified model's residual along x, y and z per
///   identification row (three panels, zero line);
/// - `outliers.svg`: ‖e‖ per identification row with the screen's threshold, the flagged rows
///   drawn apart.
///
/// # Errors
/// [`PlotError`] for empty or mismatched inputs, non-finite values, or an outlier index out
/// of range.
pub fn identify_plots(d: &IdentifyPlotData<'_>) -> Result<Vec<(String, String)>, PlotError> {
    check_len(
        "identification errors",
        d.identification_before_mm,
        d.identification_after_mm,
    )?;
    let (ib, ia) = (
        norms(d.identification_before_mm),
        norms(d.identification_after_mm),
    );
    let validation = match (d.validation_before_mm, d.validation_after_mm) {
        (Some(b), Some(a)) => {
            check_len("validation errors", b, a)?;
            Some((norms(b), norms(a)))
        }
        _ => None,
    };
    let mut out = Vec::new();

    // 3-D error per pose.
    let mut panels = vec![before_after_panel(
        &format!("{}: 3-D error per pose", d.robot),
        "identification pose",
        &ib,
        &ia,
    )];
    if let Some((vb, va)) = &validation {
        panels.push(before_after_panel("", "validation pose", vb, va));
    }
    let h = if panels.len() == 1 {
        HEIGHT
    } else {
        2 * HEIGHT - 60
    };
    out.push((IDENTIFY_PLOT_FILES[0].to_string(), panels_svg(&panels, h)?));

    // CDF.
    let (which, b, a) = match &validation {
        Some((vb, va)) => ("validation", vb, va),
        None => ("identification", &ib, &ia),
    };
    let fig = cdf_figure(
        &format!("{}: distribution of the 3-D error ({which} poses)", d.robot),
        &format!("3-D position error on the {which} poses (mm)"),
        &[
            ("nominal model (registered)".to_string(), b.clone()),
            ("identified model".to_string(), a.clone()),
        ],
        Vec::new(),
    )?;
    out.push((IDENTIFY_PLOT_FILES[1].to_string(), figure_svg(&fig)?));

    // Residuals per axis.
    let axes = ["x", "y", "z"];
    let panels: Vec<Figure> = axes
        .iter()
        .enumerate()
        .map(|(k, name)| {
            let title = if k == 0 {
                format!("{}: residual of the identified model per axis", d.robot)
            } else {
                String::new()
            };
            let mut f = Figure::new(
                title,
                rows_title("identification pose", ia.len()),
                format!("{name} residual (mm)"),
            );
            let pts: Vec<f64> = d.identification_after_mm.iter().map(|e| e[k]).collect();
            f.series.push(Series::new(
                format!("{name}: measured − identified"),
                indexed(&pts),
                Style::Markers,
            ));
            f.refs.push(RefLine::horizontal("zero", 0.0));
            f
        })
        .collect();
    out.push((
        IDENTIFY_PLOT_FILES[2].to_string(),
        panels_svg(&panels, 3 * HEIGHT - 300)?,
    ));

    // Outliers.
    if let Some(&bad) = d.outliers.iter().find(|&&i| i >= ia.len()) {
        return Err(PlotError::InvalidValue {
            series: "outlier indices".into(),
            index: bad,
            value: bad as f64,
            reason: "outlier index beyond the identification rows",
        });
    }
    let mut f = Figure::new(
        format!("{}: outlier screen of the identification fit", d.robot),
        rows_title("identification pose", ia.len()),
        "3-D residual ‖e‖ (mm)",
    );
    f.y_from_zero = true;
    // Every flagged row is drawn, whatever the thinning.
    let kept: Vec<(f64, f64)> = (0..ia.len())
        .step_by(stride(ia.len()))
        .filter(|i| !d.outliers.contains(i))
        .map(|i| ((i + 1) as f64, ia[i]))
        .collect();
    f.series
        .push(Series::new("within the threshold", kept, Style::Markers));
    if !d.outliers.is_empty() {
        let flagged = d
            .outliers
            .iter()
            .map(|&i| ((i + 1) as f64, ia[i]))
            .collect();
        let name = if d.outlier_labels.is_empty() {
            "flagged as outliers".to_string()
        } else {
            let more = if d.outlier_labels.len() > 5 {
                ", …"
            } else {
                ""
            };
            format!(
                "flagged as outliers: {}{more}",
                d.outlier_labels[..d.outlier_labels.len().min(5)].join(", ")
            )
        };
        f.series.push(Series::new(name, flagged, Style::Markers));
    }
    if let Some((t, k)) = d.outlier_threshold {
        f.refs.push(RefLine::horizontal(
            format!("threshold {} σ̂₃ = {} mm", fmt::number(k), fmt::mm(t)),
            t,
        ));
    }
    f.y_scale = Scale::Linear;
    out.push((IDENTIFY_PLOT_FILES[3].to_string(), figure_svg(&f)?));
    Ok(out)
}

/// `report.html` of an identification: `report.md` with the plots of [`identify_plots`] in
/// place (per-axis residuals after "Fit residuals", the outlier view after "Outliers", the
/// per-pose errors and the CDF after "Validation…"; a plot whose section is missing goes at
/// the end).
pub fn identify_page(title: &str, report_md: &str, plots: &[(String, String)]) -> String {
    let place = |file: &str| -> (Option<&str>, &str) {
        match file {
            "pose-errors.svg" => (
                Some("Validation"),
                "3-D position error per pose before and after identification: the nominal model (registered in the measurement frame) and the identified model; dashed lines are the means.",
            ),
            "error-cdf.svg" => (
                Some("Validation"),
                "Share of poses whose 3-D error is below a value, before and after: the further left the curve, the better the model.",
            ),
            "residuals-per-axis.svg" => (
                Some("Fit residuals"),
                "Residual of the identified model along each axis per identification pose: structure (trends, steps) is error the model does not contain.",
            ),
            "outliers.svg" => (
                Some("Outliers"),
                "3-D residual per identification pose against the outlier threshold k·σ̂₃.",
            ),
            "orientation-error-cdf.svg" => (
                Some("Validation"),
                "Share of poses whose orientation error (angle of R_modelᵀ·R_measured) is below a value, before and after (degrees).",
            ),
            _ => (None, "plot"),
        }
    };
    let pictures: Vec<Picture> = plots
        .iter()
        .map(|(file, svg)| {
            let (after, caption) = place(file);
            Picture {
                after_heading: after.map(String::from),
                caption: caption.to_string(),
                file: file.clone(),
                svg: svg.clone(),
            }
        })
        .collect();
    html::page(title, report_md, &pictures)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn errors(n: usize, scale: f64) -> Vec<[f64; 3]> {
        (0..n)
            .map(|i| {
                let t = i as f64;
                [
                    scale * (t * 0.7).sin(),
                    scale * (t * 1.3).cos(),
                    scale * 0.5 * (t * 0.4).sin(),
                ]
            })
            .collect()
    }

    /// A million-row recording gives plots of kilobytes: every k-th pose is drawn (and said
    /// so), the CDF keeps at most MAX_CDF_STEPS steps, the flagged row keeps its legend.
    #[test]
    fn large_sets_are_thinned_and_say_so() {
        let n = 200_000;
        let (ib, ia) = (errors(n, 2.5), errors(n, 0.3));
        let small = identify_plots(&IdentifyPlotData {
            robot: "UR10",
            identification_before_mm: &ib[..2000],
            identification_after_mm: &ia[..2000],
            validation_before_mm: None,
            validation_after_mm: None,
            outlier_threshold: None,
            outliers: &[],
            outlier_labels: &[],
        })
        .unwrap();
        let plots = identify_plots(&IdentifyPlotData {
            robot: "UR10",
            identification_before_mm: &ib,
            identification_after_mm: &ia,
            validation_before_mm: None,
            validation_after_mm: None,
            outlier_threshold: Some((0.5, 3.0)),
            outliers: &[12_345],
            outlier_labels: &["line 12347".to_string()],
        })
        .unwrap();
        assert!(small[0].1.contains("identification pose (row order)"));
        assert!(
            plots[0]
                .1
                .contains("identification pose (row order; every 80th of 200,000 drawn)")
        );
        for ((name, svg), (_, small_svg)) in plots.iter().zip(&small) {
            // 2,500 drawn poses against 2,000: of the same order, not 100× larger.
            assert!(
                svg.len() < 3 * small_svg.len(),
                "{name}: {} bytes",
                svg.len()
            );
        }
        assert!(plots[3].1.contains("flagged as outliers: line 12347"));
    }

    #[test]
    fn identify_writes_four_plots_and_a_page_with_them() {
        let (ib, ia) = (errors(100, 2.5), errors(100, 0.3));
        let (vb, va) = (errors(300, 2.8), errors(300, 0.35));
        let d = IdentifyPlotData {
            robot: "UR10",
            identification_before_mm: &ib,
            identification_after_mm: &ia,
            validation_before_mm: Some(&vb),
            validation_after_mm: Some(&va),
            outlier_threshold: Some((0.5, 3.0)),
            outliers: &[7, 42],
            outlier_labels: &["line 9".to_string(), "line 44".to_string()],
        };
        let plots = identify_plots(&d).unwrap();
        let names: Vec<&str> = plots.iter().map(|p| p.0.as_str()).collect();
        assert_eq!(names, IDENTIFY_PLOT_FILES);
        assert!(plots[0].1.contains("validation pose (row order)"));
        assert!(plots[1].1.contains("validation poses (mm)"));
        assert!(plots[3].1.contains("flagged as outliers: line 9, line 44"));
        assert!(plots[3].1.contains("threshold 3 σ̂₃ = 0.500 mm"));
        let md = "# Identification\n\n## Fit residuals\n\n| a | b |\n|---|---|\n| 1 | 2 |\n";
        let html = identify_page("UR10", md, &plots);
        assert_eq!(html.matches("<svg ").count(), 4);
        assert!(html.contains("<table>"));
        // Without validation data: one panel, the CDF of the identification rows.
        let d = IdentifyPlotData {
            validation_before_mm: None,
            validation_after_mm: None,
            ..d
        };
        let plots = identify_plots(&d).unwrap();
        assert!(plots[1].1.contains("identification poses (mm)"));
        // Bad input.
        let d = IdentifyPlotData {
            outliers: &[100],
            outlier_labels: &[],
            ..d
        };
        assert!(identify_plots(&d).is_err());
        let d = IdentifyPlotData {
            identification_after_mm: &ia[..99],
            outliers: &[],
            ..d
        };
        assert!(matches!(
            identify_plots(&d),
            Err(PlotError::LengthMismatch { .. })
        ));
    }
}
