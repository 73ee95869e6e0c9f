//! The console summary of a calibration (what `kincal identify` prints).

use std::fmt::Write as _;

use calibrate::{PointCalibration, mean_max, norms, row_label};
use nalgebra::Vector3;

use super::start_label;
use crate::fmt::{deg_coarse, mm, mm_coarse, mm_col, ms};

/// The console summary of a calibration, one line each: what was fitted, the registration,
/// the fit, the held parameters, a warning when the solver did not converge, the outliers,
/// the validation.
pub fn summary(o: &PointCalibration) -> String {
    let mut out = String::new();
    let a = &o.request;
    let nom = &o.nominal.robot;
    let _ = writeln!(
        out,
        "{} — {} of {} ({} free parameters, --params {}, {} damping)",
        nom.name(),
        o.selection,
        o.data_source,
        o.free.len(),
        a.params,
        a.damping.name()
    );
    if let Some(r) = &o.registration
        && r.applied
    {
        let _ = writeln!(
            out,
            "registration: nominal mean error {} mm → {} mm (rotation {}°, translation {} mm)",
            mm_col(r.mean_error_before_mm),
            mm_col(r.mean_error_after_mm),
            deg_coarse(r.rotation_deg),
            mm_coarse(Vector3::from(r.translation_mm).norm())
        );
    }
    let _ = writeln!(out, "registration decision: {}", o.registration_decision);
    let (_, fit_max) = mean_max(&norms(&o.fit_residuals().1));
    let _ = writeln!(
        out,
        "fit: RMS {} mm, max {} mm on {} poses; σ̂ {} mm/axis; rank {} of {}; {} after {} \
         iterations; {} ms",
        mm(o.fit.rms_mm),
        mm(fit_max),
        o.used.len(),
        o.fit.sigma_hat.map_or_else(|| "n/a".into(), mm),
        o.analysis.rank,
        o.free.len(),
        o.fit.stop,
        o.fit.iterations,
        ms(o.elapsed_ms)
    );
    for w in &o.warnings {
        let _ = writeln!(out, "warning: {w}");
    }
    if !o.fit.held.is_empty() {
        let _ = writeln!(
            out,
            "held at their start values (exactly redundant there; --redundant damp keeps them \
             in the damped system): {}",
            o.fit.held.join(", ")
        );
    }
    if !o.fit.stop.converged() {
        let _ = writeln!(
            out,
            "warning: the solver stopped without converging ({}): some free parameters are \
             (nearly) redundant and drift along a flat valley; predictions are unaffected, \
             but only the identifiable values mean anything — try --params minimal",
            o.fit.stop
        );
    }
    // k as given (`{}`: the shortest text that reads back as the value).
    let excluded = o
        .robust
        .as_ref()
        .map_or_else(Vec::new, |r| r.excluded.clone());
    if let Some(sc) = &o.screen {
        if sc.outliers.is_empty() {
            let _ = writeln!(
                out,
                "outliers (‖e‖ > {} σ̂₃ = {} mm): none",
                sc.k,
                mm(sc.threshold_mm)
            );
        } else {
            let list: Vec<String> = sc
                .outliers
                .iter()
                .take(10)
                .map(|ol| {
                    format!(
                        "{} {} mm",
                        row_label(&o.screened_rows[ol.index]),
                        mm(ol.norm_mm)
                    )
                })
                .collect();
            let _ = writeln!(
                out,
                "outliers (‖e‖ > {} σ̂₃ = {} mm): {} — {}{}; {}",
                sc.k,
                mm(sc.threshold_mm),
                sc.outliers.len(),
                list.join(", "),
                if sc.outliers.len() > 10 { ", …" } else { "" },
                super::outlier_status(
                    &sc.indices(),
                    &excluded,
                    "row",
                    format!(
                        "excluded, refitted: RMS {} → {} mm",
                        mm(o.first.rms_mm),
                        mm(o.fit.rms_mm)
                    )
                )
            );
        }
    }
    if o.rejected
        && let Some(sentence) = super::robust_points(o)
    {
        let _ = writeln!(out, "{sentence}");
    }
    if let Some(v) = &o.validation {
        let (b, af) = (&v.table.before.norm, &v.table.after.norm);
        let _ = writeln!(
            out,
            "validation: {} poses of {}: {} mean {} mm, max {} mm → calibrated mean {} mm, \
             max {} mm",
            v.rows.len(),
            v.source,
            if start_label(o) == "nominal" {
                "nominal"
            } else {
                "nominal (registered)"
            },
            mm_col(b.mean_mm),
            mm_col(b.max_mm),
            mm_col(af.mean_mm),
            mm_col(af.max_mm)
        );
    }
    if let Some(r) = &o.residual {
        let _ = writeln!(out, "{}", super::residual::decision(r));
        if let Some(line) = super::residual::validation(r) {
            let _ = writeln!(out, "{line}");
        }
    }
    out
}
