//! Everything a real-data calibration shows (`kincal identify`): a [`calibrate::Calibration`]
//! of any kind of measurement rendered as the files of the output directory ([`render`]) and
//! the console summary ([`summary`]). Every kind writes the same set of files (6-DoF data
//! add the orientation error's plot, [`tool_frame::ORIENTATION_CDF_FILE`]); [`points`] and
//! [`tool_frame`] render each kind.
//!
//! | file | what | by |
//! |---|---|---|
//! | [`ROBOT_FILE`] | the calibrated robot | [`calibrate::Calibration::identified_robot`] |
//! | [`REGISTERED_FILE`] | the nominal robot in the data's frame | [`calibrate::Calibration::registered_robot`] |
//! | [`PARAMETERS_FILE`] | the parameter table | [`parameters_json`] |
//! | [`REPORT_FILE`] | the report | [`markdown`] |
//! | [`REPORT_HTML_FILE`] | the report with its plots inline | [`plots::identify_page`] |
//! | [`OUTLIERS_FILE`] | the flagged units, excluded or kept | [`outliers_csv`] |
//! | [`plots::IDENTIFY_PLOT_FILES`] | the plots, as SVG | [`plots::identify_plots`] |
//! | `residual-model.json` | the learned residual model, when kept | [`calibrate::Calibration::written_residual_model`] |
//!
//! Numbers follow [`crate::fmt`]. Where today's files print a signed value with Rust's own
//! fixed notation (a `-0.000` kept, an explicit `+`), the text keeps it: those cells are
//! marked `signed` below.

mod markdown;
mod parameters;
pub mod plots;
pub mod residual;
mod summary;
pub mod tool_frame;

use calibrate::{Calibration, PointCalibration};

use crate::plot::PlotError;

/// File names in the output directory: the calibrated robot.
pub const ROBOT_FILE: &str = "identified.json";
/// The nominal robot in the measurement frame (its base registered on the data).
pub const REGISTERED_FILE: &str = "registered-nominal.json";
/// The parameter table.
pub const PARAMETERS_FILE: &str = "parameters.json";
/// The report.
pub const REPORT_FILE: &str = "report.md";
/// The report as a self-contained HTML page with the plots inline.
pub const REPORT_HTML_FILE: &str = "report.html";
/// The outlier list: every unit the screen flagged, excluded or kept ([`outliers_csv`]).
pub const OUTLIERS_FILE: &str = "outliers.csv";

/// One flagged unit of [`OUTLIERS_FILE`].
pub struct OutlierRow {
    /// Its file line (a pose's first row).
    pub line: usize,
    /// Its id (empty without one).
    pub id: String,
    /// Its largest 3-D position error at the final model, mm.
    pub residual_mm: f64,
    /// Its residual over the screen's scale (`‖e‖/σ̂₃`, or `‖e‖/(√d·σ̂)` for a pose).
    pub ratio: f64,
    /// Whether it was excluded from the final fit.
    pub excluded: bool,
}

/// [`OUTLIERS_FILE`]: a header `line,id,residual_mm,ratio,status` and one row per flagged unit
/// (status `excluded` or `kept`), in the screen's order (largest first); the header alone
/// when nothing was flagged.
pub fn outliers_csv(rows: &[OutlierRow]) -> String {
    let mut out = String::from("line,id,residual_mm,ratio,status\n");
    for r in rows {
        out.push_str(&format!(
            "{},{},{},{},{}\n",
            r.line,
            r.id,
            crate::fmt::mm(r.residual_mm),
            crate::fmt::ratio(r.ratio),
            if r.excluded { "excluded" } else { "kept" }
        ));
    }
    out
}

/// Renders the output files of `cal`, of any kind, in memory, as `(file name, contents)` in
/// writing order: [`ROBOT_FILE`], [`REGISTERED_FILE`], [`PARAMETERS_FILE`], [`REPORT_FILE`],
/// [`REPORT_HTML_FILE`], then the plots ([`plots::IDENTIFY_PLOT_FILES`], and
/// [`tool_frame::ORIENTATION_CDF_FILE`] where orientation was measured), then
/// [`OUTLIERS_FILE`], then the residual model (`calibrate::residual::MODEL_FILE`) when
/// `identify --residual-model` kept one. The caller writes them (all or nothing).
///
/// # Errors
/// [`PlotError`] when an error is not finite (nothing can be drawn).
pub fn render(cal: &Calibration) -> Result<Vec<(String, String)>, PlotError> {
    // The robot files with their provenance (`calibrate::provenance`), then the kind's own.
    let (identified, registered) = cal.written_specs();
    let mut files = vec![
        (ROBOT_FILE.to_string(), identified.to_json_string()),
        (REGISTERED_FILE.to_string(), registered.to_json_string()),
    ];
    files.extend(match cal {
        Calibration::Points(c) => points::render(c),
        Calibration::ToolFrame(c) => tool_frame::render(c),
    }?);
    files.extend(
        cal.written_residual_model()
            .map(|text| (calibrate::residual::MODEL_FILE.to_string(), text)),
    );
    Ok(files)
}

/// What became of the flagged units (indices ascending) given the units `excluded`: `kept
/// (--reject-outliers to exclude)`, `all` (every one excluded: the kind's words, with the
/// refit), or how many were excluded as gross errors and how many kept.
fn outlier_status(flagged: &[usize], excluded: &[usize], unit: &str, all: String) -> String {
    let gross = flagged
        .iter()
        .filter(|i| excluded.binary_search(i).is_ok())
        .count();
    if excluded.is_empty() {
        "kept (--reject-outliers to exclude)".to_string()
    } else if gross == flagged.len() {
        all
    } else {
        format!(
            "{gross} excluded as gross errors (robust screen), {}; the other {} {unit}{} kept \
             (--reject-outliers to exclude)",
            all.trim_start_matches("excluded, "),
            flagged.len() - gross,
            if flagged.len() - gross == 1 { "" } else { "s" }
        )
    }
}

/// The robust screen in one sentence (console and report): the trimmed fit, the robust and
/// the classical scale (`scale_unit`), and the units excluded with their `labels` (up to
/// 10).
fn robust_sentence(
    r: &calibrate::RobustScreen,
    unit: &str,
    scale_unit: &str,
    labels: &[String],
) -> String {
    use crate::fmt::mm;
    let excluded = if r.excluded.is_empty() {
        format!("no {unit} beyond the cut")
    } else {
        format!(
            "excluded {} of {} {unit}s: {}{}",
            r.excluded.len(),
            r.units,
            labels[..labels.len().min(10)].join(", "),
            if labels.len() > 10 { ", …" } else { "" }
        )
    };
    format!(
        "robust screen: least trimmed squares on {} of {} {unit}s (from the {}, {} \
         concentration step{}), robust σ̃ {} {scale_unit} (first fit σ̂ {}); cut {}·√d·σ (σ̃, \
         then σ̂ of the {unit}s kept): {excluded}",
        r.h,
        r.units,
        r.start,
        r.steps,
        if r.steps == 1 { "" } else { "s" },
        mm(r.sigma_robust_row),
        mm(r.sigma_first_row),
        r.cut_k,
    )
}

/// [`robust_sentence`] of a point calibration's robust screen, its rows labelled.
fn robust_points(o: &PointCalibration) -> Option<String> {
    let r = o.robust.as_ref()?;
    let labels: Vec<String> = r
        .excluded
        .iter()
        .map(|&i| calibrate::row_label(&o.screened_rows[i]))
        .collect();
    Some(robust_sentence(r, "row", "mm/axis", &labels))
}

/// The console summary of `cal`, of any kind.
pub fn summary(cal: &Calibration) -> String {
    match cal {
        Calibration::Points(c) => points::summary(c),
        Calibration::ToolFrame(c) => tool_frame::summary(c),
    }
}

/// `report.md` of `cal`, of any kind.
pub fn markdown(cal: &Calibration) -> String {
    match cal {
        Calibration::Points(c) => points::markdown(c),
        Calibration::ToolFrame(c) => tool_frame::markdown(c),
    }
}

/// `parameters.json` of `cal`, of any kind (format `kincal-parameters/1`).
pub fn parameters_json(cal: &Calibration) -> String {
    match cal {
        Calibration::Points(c) => points::parameters_json(c),
        Calibration::ToolFrame(c) => tool_frame::parameters_json(c),
    }
}

/// The outputs of a calibration from points.
pub mod points {
    use calibrate::{PointCalibration, file_name, row_label};

    use super::{
        OUTLIERS_FILE, OutlierRow, PARAMETERS_FILE, REPORT_FILE, REPORT_HTML_FILE, outliers_csv,
        plots,
    };
    use crate::plot::PlotError;

    pub use super::markdown::markdown;
    pub use super::parameters::parameters_json;
    pub use super::summary::summary;

    /// Renders the output files of `cal` in memory, as `(file name, contents)` in writing order
    /// (after [`super::ROBOT_FILE`] and [`super::REGISTERED_FILE`], which [`super::render`]
    /// adds): [`PARAMETERS_FILE`], [`REPORT_FILE`], then
    /// [`REPORT_HTML_FILE`] with the plots of [`plots::identify_plots`] (errors of the start model
    /// and of the identified one on the screened identification rows and on the validation rows;
    /// the outlier screen) inline, and those plots as SVG files. The caller writes them (all or
    /// nothing: `measurements::write_all_atomically`).
    ///
    /// # Errors
    /// [`PlotError`] when an error is not finite (nothing can be drawn).
    pub fn render(cal: &PointCalibration) -> Result<Vec<(String, String)>, PlotError> {
        let nom = &cal.nominal.robot;
        let data = file_name(std::path::Path::new(&cal.data_source));
        let report_md = markdown(cal);
        let (id_before, id_after) = cal.screened_residuals();
        let flagged = cal.screen.as_ref().map_or_else(Vec::new, |s| s.indices());
        let labels: Vec<String> = flagged
            .iter()
            .map(|&i| row_label(&cal.screened_rows[i]))
            .collect();
        let plots = plots::identify_plots(&plots::IdentifyPlotData {
            robot: nom.name(),
            identification_before_mm: &id_before,
            identification_after_mm: &id_after,
            validation_before_mm: cal.validation.as_ref().map(|v| v.before.as_slice()),
            validation_after_mm: cal.validation.as_ref().map(|v| v.after.as_slice()),
            outlier_threshold: cal.screen.as_ref().map(|s| (s.threshold_mm, s.k)),
            outliers: &flagged,
            outlier_labels: &labels,
        })?;
        let html = plots::identify_page(
            &format!("Calibration of {} on {data}", nom.name()),
            &report_md,
            &plots,
        );
        let mut files = vec![
            (PARAMETERS_FILE.to_string(), parameters_json(cal)),
            (REPORT_FILE.to_string(), report_md),
            (REPORT_HTML_FILE.to_string(), html),
        ];
        files.extend(plots);
        let excluded = cal
            .robust
            .as_ref()
            .map_or(&[][..], |r| r.excluded.as_slice());
        let rows: Vec<OutlierRow> = cal.screen.as_ref().map_or_else(Vec::new, |sc| {
            sc.outliers
                .iter()
                .map(|o| {
                    let r = &cal.screened_rows[o.index];
                    OutlierRow {
                        line: r.line,
                        id: r.id.clone().unwrap_or_default(),
                        residual_mm: o.norm_mm,
                        ratio: o.ratio,
                        excluded: excluded.binary_search(&o.index).is_ok(),
                    }
                })
                .collect()
        });
        files.push((OUTLIERS_FILE.to_string(), outliers_csv(&rows)));
        Ok(files)
    }
}

/// `nominal, registered` or `nominal`: the model the fit started from.
fn start_label(cal: &PointCalibration) -> &'static str {
    if cal.registered() {
        "nominal, registered"
    } else {
        "nominal"
    }
}
