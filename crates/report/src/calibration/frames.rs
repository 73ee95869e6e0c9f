//! The outputs of a 6-DoF / multi-target calibration ([`calibrate::frames`]):
//! `identified.json` (with the identified tool frame) and `report.md`, and the console
//! summary. Position errors in mm and orientation errors in degrees, reported separately.

use std::fmt::Write as _;

use calibrate::frames::{FrameCalibration, FrameErrors};

use nalgebra::Vector3;

use super::{REPORT_FILE, REPORT_HTML_FILE, ROBOT_FILE};
use crate::fmt::fixed;
use crate::html::{self, Picture};
use crate::plot::{PlotError, cdf_figure, figure_svg};

fn errors_line(e: &FrameErrors, orientation: bool) -> String {
    let mut s = format!(
        "position mean {} mm, max {} mm",
        fixed(e.position_mm.0, 3),
        fixed(e.position_mm.1, 3)
    );
    if orientation {
        let _ = write!(
            s,
            "; orientation mean {}°, max {}°",
            fixed(e.orientation_deg.0, 4),
            fixed(e.orientation_deg.1, 4)
        );
    }
    s
}

/// The console summary, one line each: what was fitted, registration, start of the tool
/// frame, weighting, fit, held parameters, outliers, validation.
pub fn summary(c: &FrameCalibration) -> String {
    let mut out = String::new();
    let ori = c.data.has_orientation();
    let kind = match (ori, c.data.target_names.len()) {
        (true, 1) => "6-DoF (point and orientation per pose)".to_string(),
        (true, k) => format!("6-DoF with {k} targets per pose"),
        (false, k) => format!("{k} targets per pose"),
    };
    let _ = writeln!(
        out,
        "{} — {kind}: {} of {} ({} unknowns: {} robot parameters{}{} target coordinates; \
         --params {})",
        c.nominal_name,
        c.selection,
        c.request.data.display(),
        c.fit.free.len(),
        c.fit.free.robot.len(),
        if c.fit.free.rotation {
            ", 3 tool-orientation, "
        } else {
            ", "
        },
        3 * c.fit.free.n_targets,
        c.request.params,
    );
    if let Some(r) = c.registration.as_ref().filter(|r| r.applied) {
        let _ = writeln!(
            out,
            "registration (position rows): nominal mean error {} mm → {} mm; the base \
             orientation is refined by the fit",
            fixed(r.mean_error_before_mm, 3),
            fixed(r.mean_error_after_mm, 3)
        );
    }
    if ori {
        let _ = writeln!(
            out,
            "tool orientation: {}",
            if c.rotation_given {
                "from the robot file"
            } else {
                "not in the robot file: started from the closed-form estimate (chordal mean \
                 of R_flangeᵀ·R_measured over the registered data)"
            }
        );
    }
    if !c.targets_estimated.is_empty() {
        let _ = writeln!(
            out,
            "targets started from the closed-form estimate (mean of R_flangeᵀ·(p − o)): {}",
            c.targets_estimated.join(", ")
        );
    }
    let _ = writeln!(out, "weighting: {}", c.weighting);
    let _ = writeln!(
        out,
        "fit: {} on {} poses ({} equations); σ̂ {} (weighted); condition {}; {} after {} \
         iterations; {} ms",
        errors_line(&c.fit_errors.1, ori),
        c.data.n_poses(),
        c.fit.n_equations,
        fixed(c.fit.sigma_hat, 3),
        fixed(c.fit.condition_number, 1),
        if c.fit.stop.converged() {
            "converged".to_string()
        } else {
            format!("not converged ({})", c.fit.stop)
        },
        c.fit.iterations,
        fixed(c.elapsed_ms, 1)
    );
    if !c.held.is_empty() {
        let _ = writeln!(
            out,
            "held at their start values (confounded with the tool frame or with kept \
             parameters): {}",
            c.held.join(", ")
        );
    }
    if let Some(sc) = &c.screen {
        let ol = c.outlier_poses();
        let rule = format!(
            "outliers (pose residual ‖e‖ > {}·√d·σ̂, d its rows, σ̂ {})",
            sc.k,
            fixed(sc.sigma_row, 3)
        );
        if ol.is_empty() {
            let _ = writeln!(out, "{rule}: none");
        } else {
            let list: Vec<String> = ol
                .iter()
                .take(10)
                .map(|o| {
                    let mut t = format!("line {} {} mm", o.line, fixed(o.position_mm, 3));
                    if let Some(a) = o.orientation_deg {
                        let _ = write!(t, " {}°", fixed(a, 4));
                    }
                    let _ = write!(t, " ({}×)", fixed(o.ratio, 1));
                    t
                })
                .collect();
            let _ = writeln!(
                out,
                "{rule}: {} pose{} — {}{}; {}",
                ol.len(),
                if ol.len() == 1 { "" } else { "s" },
                list.join(", "),
                if ol.len() > 10 { ", …" } else { "" },
                if c.rejected {
                    "dropped and refitted"
                } else {
                    "kept (--reject-outliers to exclude)"
                }
            );
        }
    }
    if let Some((source, before, after)) = &c.validation {
        let _ = writeln!(
            out,
            "validation on {source}: nominal {} → identified {}",
            errors_line(before, ori),
            errors_line(after, ori)
        );
    }
    out
}

/// `report.md`: the summary, the tool frame and every unknown with its standard error.
pub fn markdown(c: &FrameCalibration) -> String {
    let mut out = String::new();
    let _ = writeln!(
        out,
        "# Calibration of {} on {} (6-DoF / multi-target)\n",
        c.nominal_name,
        c.request.data.display()
    );
    out.push_str("```text\n");
    out.push_str(&summary(c));
    out.push_str("```\n\n");
    let r = c.identified_robot();
    let t = r.tool_mm();
    let _ = writeln!(
        out,
        "## Tool frame\n\nTool point (flange frame): {} mm, {} mm, {} mm.",
        fixed(t.x, 3),
        fixed(t.y, 3),
        fixed(t.z, 3)
    );
    if let Some(rot) = r.tool_rotation_rad() {
        let _ = writeln!(
            out,
            "Tool orientation (`R = Rz·Ry·Rx`): rx {}°, ry {}°, rz {}°.",
            fixed(rot[0].to_degrees(), 4),
            fixed(rot[1].to_degrees(), 4),
            fixed(rot[2].to_degrees(), 4)
        );
    }
    if let Some(ts) = r.targets() {
        for (name, p) in ts {
            let _ = writeln!(
                out,
                "Target {name}: {} mm, {} mm, {} mm.",
                fixed(p.x, 3),
                fixed(p.y, 3),
                fixed(p.z, 3)
            );
        }
    }
    out.push_str(
        "\n## Unknowns\n\n`tool_rx, tool_ry, tool_rz` are the rotation vector from the start \
         orientation, about the tool axes. Standard errors σ̂·√((JᵀJ)⁻¹)_kk.\n\n\
         | name | unit | start | identified | std error |\n|---|---|---|---|---|\n",
    );
    for e in &c.fit.estimates {
        let _ = writeln!(
            out,
            "| {} | {} | {} | {} | {} |",
            e.name,
            e.unit.as_str(),
            fixed(e.start, 5),
            fixed(e.value, 5),
            fixed(e.std_error, 5)
        );
    }
    out
}

/// The position error plot's file.
pub const POSITION_CDF_FILE: &str = "error-cdf.svg";
/// The orientation error plot's file.
pub const ORIENTATION_CDF_FILE: &str = "orientation-error-cdf.svg";

/// The plots: distributions of the position error (mm) and, where measured, of the
/// orientation error (degrees), start and identified model, on the validation poses (the
/// identification poses without validation), one value per measured row.
///
/// # Errors
/// A plot that cannot be drawn.
pub fn pictures(c: &FrameCalibration) -> Result<Vec<Picture>, PlotError> {
    let (which, d) = match &c.validation_data {
        Some(d) => ("validation", d),
        None => ("identification", &c.data),
    };
    let (before, after) = (c.start.errors(d), c.fit.model.errors(d));
    let pos = |e: &[(Vector3<f64>, Option<Vector3<f64>>)]| -> Vec<f64> {
        e.iter().map(|(p, _)| p.norm()).collect()
    };
    let ori = |e: &[(Vector3<f64>, Option<Vector3<f64>>)]| -> Vec<f64> {
        e.iter().filter_map(|(_, o)| o.map(|o| o.norm())).collect()
    };
    let mut out = Vec::new();
    let mut add = |title: String, x: String, b: Vec<f64>, a: Vec<f64>, file: &str, cap: String| {
        cdf_figure(
            &title,
            &x,
            &[
                ("start model (registered)".to_string(), b),
                ("identified model".to_string(), a),
            ],
            Vec::new(),
        )
        .and_then(|f| figure_svg(&f))
        .map(|svg| {
            out.push(Picture {
                after_heading: None,
                caption: cap,
                file: file.to_string(),
                svg,
            })
        })
    };
    add(
        format!(
            "{}: distribution of the position error ({which} poses)",
            c.nominal_name
        ),
        format!("3-D position error on the {which} poses (mm)"),
        pos(&before),
        pos(&after),
        POSITION_CDF_FILE,
        format!("Share of the {which} points whose 3-D position error is below a value (mm)."),
    )?;
    if d.has_orientation() {
        add(
            format!(
                "{}: distribution of the orientation error ({which} poses)",
                c.nominal_name
            ),
            format!("orientation error on the {which} poses (degrees)"),
            ori(&before),
            ori(&after),
            ORIENTATION_CDF_FILE,
            format!(
                "Share of the {which} orientations whose error (angle of R_modelᵀ·R_measured) is \
                 below a value (degrees)."
            ),
        )?;
    }
    Ok(out)
}

/// The files of a 6-DoF calibration: `identified.json`, `report.md`, `report.html` (the
/// report with its plots: position error in mm and orientation error in degrees, separately)
/// and the plots as SVG files.
///
/// # Errors
/// A plot that cannot be drawn.
pub fn render(c: &FrameCalibration) -> Result<Vec<(String, String)>, PlotError> {
    let md = markdown(c);
    let pics = pictures(c)?;
    let title = format!("Calibration of {} (6-DoF / multi-target)", c.nominal_name);
    let mut files = vec![
        (
            ROBOT_FILE.to_string(),
            c.identified_robot().to_spec().to_json_string(),
        ),
        (REPORT_FILE.to_string(), md.clone()),
        (REPORT_HTML_FILE.to_string(), html::page(&title, &md, &pics)),
    ];
    files.extend(pics.into_iter().map(|p| (p.file, p.svg)));
    Ok(files)
}
