//! The outputs of a calibration from 6-DoF or multi-target data
//! ([`calibrate::ToolFrameCalibration`]): the files every kind writes (`identified.json`
//! with the identified tool frame, `registered-nominal.json`, `parameters.json`,
//! `report.md`, `report.html` and the plots of [`super::plots::identify_plots`] on the
//! position errors), the orientation error's plot where orientation was measured, and the
//! console summary. Position errors in mm and orientation errors in degrees, reported
//! separately.

use std::fmt::Write as _;

use calibrate::ToolFrameCalibration;
use calibrate::tool_frame::PoseErrors;

use nalgebra::Vector3;

use super::parameters::{ParamRow, ParamTable, columns};
use super::{PARAMETERS_FILE, REPORT_FILE, REPORT_HTML_FILE, ROBOT_FILE, plots};
use crate::fmt::fixed;
use crate::plot::{PlotError, cdf_figure, figure_svg};

fn errors_line(e: &PoseErrors, orientation: bool) -> String {
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
/// frame, weighting, fit, warnings, held parameters, outliers, validation.
pub fn summary(c: &ToolFrameCalibration) -> String {
    let mut out = String::new();
    let ori = c.data.has_orientation();
    let kind = c.kind;
    let _ = writeln!(
        out,
        "{} — {kind}: {} of {} ({} unknowns: {} robot parameters{}{} target coordinates; \
         --params {})",
        c.nominal.robot.name(),
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
    let _ = writeln!(out, "registration decision: {}", c.registration_decision);
    if let Some(e) = &c.measurement_scale {
        let _ = writeln!(out, "measurement scale: {}", e.describe());
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
    for w in &c.warnings {
        let _ = writeln!(out, "warning: {w}");
    }
    if !c.held.is_empty() {
        let _ = writeln!(
            out,
            "held at their start values (confounded with the tool frame or with kept \
             parameters): {}",
            c.held.join(", ")
        );
    }
    let excluded = c
        .robust
        .as_ref()
        .map_or_else(Vec::new, |r| r.excluded.clone());
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
                super::outlier_status(
                    &sc.indices(),
                    &excluded,
                    "pose",
                    "dropped and refitted".to_string()
                )
            );
        }
    }
    if let Some(r) = &c.robust
        && c.rejected
    {
        let labels: Vec<String> = r
            .excluded
            .iter()
            .map(|&i| format!("line {}", c.screened_lines[i]))
            .collect();
        let _ = writeln!(
            out,
            "{}",
            super::robust_sentence(r, "pose", "(weighted rows)", &labels)
        );
    }
    if let Some((source, before, after)) = &c.validation {
        let _ = writeln!(
            out,
            "validation on {source}: nominal {} → identified {}",
            errors_line(before, ori),
            errors_line(after, ori)
        );
    }
    if let Some(r) = &c.residual {
        let _ = writeln!(out, "{}", super::residual::decision(r));
        if let Some(line) = super::residual::validation(r) {
            let _ = writeln!(out, "{line}");
        }
    }
    out
}

/// `report.md`: the summary, the tool frame and every unknown with its standard error.
pub fn markdown(c: &ToolFrameCalibration) -> String {
    let mut out = String::new();
    let _ = writeln!(
        out,
        "# Calibration of {} on {} ({})\n",
        c.nominal.robot.name(),
        c.data_source,
        c.kind
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
    if let Some(r) = &c.residual {
        out.push_str(&super::residual::markdown(r));
    }
    out
}

/// The orientation error plot's file (6-DoF data).
pub const ORIENTATION_CDF_FILE: &str = "orientation-error-cdf.svg";

/// Per row: the position error `measured − model` (mm) and the orientation error (degrees)
/// where measured.
type RowErrors = Vec<(Vector3<f64>, Option<Vector3<f64>>)>;

fn positions(e: &RowErrors) -> Vec<[f64; 3]> {
    e.iter().map(|(p, _)| [p.x, p.y, p.z]).collect()
}

/// The orientation error plot: the distribution of the orientation error (degrees) of the
/// start and the identified model on the validation poses (the identification poses without
/// validation); `None` without orientations.
///
/// # Errors
/// A plot that cannot be drawn.
pub fn orientation_plot(c: &ToolFrameCalibration) -> Result<Option<(String, String)>, PlotError> {
    let (which, d) = match &c.validation_data {
        Some(d) => ("validation", d),
        None => ("identification", &c.data),
    };
    if !d.has_orientation() {
        return Ok(None);
    }
    let ori =
        |e: &RowErrors| -> Vec<f64> { e.iter().filter_map(|(_, o)| o.map(|o| o.norm())).collect() };
    let (before, after) = (c.start.errors(d), c.fit.model.errors(d));
    let fig = cdf_figure(
        &format!(
            "{}: distribution of the orientation error ({which} poses)",
            c.nominal.robot.name()
        ),
        &format!("orientation error on the {which} poses (degrees)"),
        &[
            ("start model (registered)".to_string(), ori(&before)),
            ("identified model".to_string(), ori(&after)),
        ],
        Vec::new(),
    )?;
    Ok(Some((ORIENTATION_CDF_FILE.to_string(), figure_svg(&fig)?)))
}

/// `parameters.json` (format `kincal-parameters/1`, as for points): every robot parameter
/// (the tool point is the first target's), then the tool frame's other unknowns (the tool
/// orientation's rotation vector, the named targets' points; their nominal is their start),
/// with `measurement` naming the kind and `sigma_hat_weighted` the weighted fit's σ̂.
pub fn parameters_json(c: &ToolFrameCalibration) -> String {
    let (start, identified) = (c.registered_robot(), c.identified_robot());
    let nominal = &c.nominal.robot;
    let layout = start.layout();
    let (xn, xs, xi) = (nominal.params(), start.params(), identified.params());
    let estimate = |name: &str| c.fit.estimates.iter().find(|e| e.name == name);
    let mut parameters: Vec<ParamRow<'_>> = layout
        .params()
        .iter()
        .enumerate()
        .map(|(k, info)| {
            let e = estimate(&info.name);
            let free = c.fit.free.robot.contains(&k) || e.is_some();
            let nominal = info.to_display(xn[k]);
            let identified = info.to_display(xi[k]);
            ParamRow {
                name: &info.name,
                unit: info.unit.as_str(),
                free,
                nominal,
                start: info.to_display(xs[k]),
                identified,
                delta: identified - nominal,
                std_error: e.map(|e| e.std_error),
                identifiable: free,
                prior: None,
            }
        })
        .collect();
    for e in &c.fit.estimates {
        if layout.index_of(&e.name).is_err() {
            parameters.push(ParamRow {
                name: &e.name,
                unit: e.unit.as_str(),
                free: true,
                nominal: e.start,
                start: e.start,
                identified: e.value,
                delta: e.value - e.start,
                std_error: Some(e.std_error),
                identifiable: true,
                prior: None,
            });
        }
    }
    let position: Vec<f64> = c
        .fit
        .model
        .errors(&c.data)
        .iter()
        .map(|(p, _)| p.norm_squared())
        .collect();
    let rms_mm = (position.iter().sum::<f64>() / position.len().max(1) as f64).sqrt();
    ParamTable {
        format: "kincal-parameters/1",
        robot_file: ROBOT_FILE,
        nominal_robot: c.nominal.path.display().to_string(),
        data: c.data_source.clone(),
        rows: c.data.rows.len(),
        params: c.request.params.to_string(),
        measurement: Some(c.kind.to_string()),
        free: c.fit.free.len(),
        rank: c.fit.free.len(),
        sigma_hat_mm: None,
        sigma_hat_weighted: Some(c.fit.sigma_hat),
        rms_mm,
        columns: columns(),
        parameters,
    }
    .to_json()
}

/// The files of a 6-DoF or multi-target calibration, the set every kind writes:
/// `identified.json`, `registered-nominal.json`, `parameters.json`, `report.md`,
/// `report.html` (the report with its plots) and the plots as SVG files: those of
/// [`plots::identify_plots`] on the position errors (per measured row; a flagged pose flags
/// its rows) and, where orientation was measured, [`ORIENTATION_CDF_FILE`].
///
/// # Errors
/// A plot that cannot be drawn.
pub fn render(c: &ToolFrameCalibration) -> Result<Vec<(String, String)>, PlotError> {
    let md = markdown(c);
    let (id_before, id_after) = (
        positions(&c.start.errors(&c.screened)),
        positions(&c.fit.model.errors(&c.screened)),
    );
    let validation = c.validation_data.as_ref().map(|d| {
        (
            positions(&c.start.errors(d)),
            positions(&c.fit.model.errors(d)),
        )
    });
    let poses = c.screen.as_ref().map_or_else(Vec::new, |s| s.indices());
    let flagged: Vec<usize> = c
        .screened
        .rows
        .iter()
        .enumerate()
        .filter(|(_, r)| poses.binary_search(&r.pose).is_ok())
        .map(|(i, _)| i)
        .collect();
    let labels: Vec<String> = flagged
        .iter()
        .map(|&i| format!("line {}", c.screened_lines[c.screened.rows[i].pose]))
        .collect();
    let mut pics = plots::identify_plots(&plots::IdentifyPlotData {
        robot: c.nominal.robot.name(),
        identification_before_mm: &id_before,
        identification_after_mm: &id_after,
        validation_before_mm: validation.as_ref().map(|v| v.0.as_slice()),
        validation_after_mm: validation.as_ref().map(|v| v.1.as_slice()),
        outlier_threshold: None,
        outliers: &flagged,
        outlier_labels: &labels,
    })?;
    pics.extend(orientation_plot(c)?);
    let title = format!(
        "Calibration of {} on {} ({})",
        c.nominal.robot.name(),
        calibrate::file_name(std::path::Path::new(&c.data_source)),
        c.kind
    );
    let html = plots::identify_page(&title, &md, &pics);
    let mut files = vec![
        (PARAMETERS_FILE.to_string(), parameters_json(c)),
        (REPORT_FILE.to_string(), md),
        (REPORT_HTML_FILE.to_string(), html),
    ];
    files.extend(pics);
    let excluded = c.robust.as_ref().map_or(&[][..], |r| r.excluded.as_slice());
    let rows: Vec<super::OutlierRow> = c
        .outlier_poses()
        .iter()
        .map(|o| super::OutlierRow {
            line: o.line,
            id: String::new(),
            residual_mm: o.position_mm,
            ratio: o.ratio,
            excluded: excluded.binary_search(&o.pose).is_ok(),
        })
        .collect();
    files.push((super::OUTLIERS_FILE.to_string(), super::outliers_csv(&rows)));
    Ok(files)
}
