//! `report.md`: the report of a calibration, for people (`docs/calibrating-real-data.md`).

use std::fmt::Write as _;

use calibrate::{PointCalibration, mean_max, norms};
use evaluate::{AxisStats, ErrorStats, Table4, improvement_pct};
use identify::RegistrationPolicy;
use measurements::Measurement;

use super::start_label;
use crate::fmt::{deg_coarse, mm, mm_col, number, param, plus, ratio, setting, signed};
use crate::identifiability::{confounded_with, indices};

fn stats_row(out: &mut String, name: &str, before: f64, after: f64) {
    // An improvement of -0.04 % prints `-0.0`.
    let pct = improvement_pct(before, after).map_or_else(|| "n/a".into(), |p| signed(p, 1));
    let _ = writeln!(
        out,
        "| {name} | {} | {} | {pct} |",
        mm_col(before),
        mm_col(after)
    );
}

fn table4_md(out: &mut String, t: &Table4, before: &str) {
    let _ = writeln!(
        out,
        "| statistic | {before} (mm) | calibrated (mm) | improvement (%) |"
    );
    out.push_str("|---|---:|---:|---:|\n");
    type Pick = fn(&AxisStats) -> f64;
    type Axis = fn(&ErrorStats) -> &AxisStats;
    let stats: [(&str, Pick); 4] = [
        ("mean", |a| a.mean_mm),
        ("max", |a| a.max_mm),
        ("RMS", |a| a.rms_mm),
        ("p95", |a| a.p95_mm),
    ];
    let axes: [(&str, Axis); 4] = [
        ("\\|x\\|", |s| &s.x),
        ("\\|y\\|", |s| &s.y),
        ("\\|z\\|", |s| &s.z),
        ("3-D", |s| &s.norm),
    ];
    for (sn, pick) in stats {
        for (an, axis) in axes {
            stats_row(
                out,
                &format!("{sn} {an}"),
                pick(axis(&t.before)),
                pick(axis(&t.after)),
            );
        }
    }
}

fn worst_md(out: &mut String, rows: &[Measurement], errors: &[[f64; 3]], n: usize) {
    let mut idx: Vec<usize> = (0..rows.len()).collect();
    let nrm = norms(errors);
    idx.sort_by(|&a, &b| nrm[b].total_cmp(&nrm[a]).then(a.cmp(&b)));
    out.push_str("| point | line | ‖e‖ (mm) | e_x | e_y | e_z |\n|---|---:|---:|---:|---:|---:|\n");
    for &i in idx.iter().take(n) {
        let e = errors[i];
        let _ = writeln!(
            out,
            "| {} | {} | {} | {} | {} | {} |",
            rows[i].id.as_deref().unwrap_or("–"),
            rows[i].line,
            mm_col(nrm[i]),
            signed(e[0], 3),
            signed(e[1], 3),
            signed(e[2], 3)
        );
    }
}

/// The prior's section: per solved parameter its prior and posterior standard deviations,
/// the share of the prior's variance the data removed, and whether the prior rather than the
/// data determine it.
fn prior_md(s: &mut String, post: &identify::Posterior) {
    s.push_str("\n## Prior\n\n");
    let _ = writeln!(
        s,
        "Identified with a Gaussian prior (maximum a posteriori, `--prior`): each parameter \
         about its start value with its prior standard deviation, weighed against the data \
         with σ̂ = {} mm of the fit without it. Information = 1 − posterior variance / prior \
         variance, the share of the prior's uncertainty the data removed; a posterior \
         standard deviation above {} × the prior's means the prior rather than the data \
         determine the value.\n",
        mm(post.sigma_e),
        identify::HELD_BY_PRIOR
    );
    s.push_str(
        "| parameter | unit | prior sd | posterior sd | information | determined by |\n\
         |---|---|---:|---:|---:|---|\n",
    );
    for p in &post.params {
        let _ = writeln!(
            s,
            "| {} | {} | {} | {} | {} | {} |",
            p.name,
            p.unit.as_str(),
            p.prior_sd.map_or_else(|| "–".into(), |v| param(v, 5)),
            param(p.posterior_sd, 5),
            p.information
                .map_or_else(|| "–".into(), |v| format!("{:.1} %", 100.0 * v)),
            if p.held_by_prior {
                "**the prior**"
            } else {
                "the data"
            }
        );
    }
}

/// `report.md` of a calibration: what was fitted and how (files, rows, free and held
/// parameters, solver, registration, model), the fit residuals, identifiability at the
/// solution, the parameter table, the prior (when one was used), correlations above 0.9, the
/// outliers, the worst points, and the validation (Table 4 before and after, the worst
/// validation points).
pub fn markdown(o: &PointCalibration) -> String {
    let a = &o.request;
    let nom = &o.nominal.robot;
    let mut s = String::new();
    let _ = writeln!(s, "# Calibration of {}\n", nom.name());
    let _ = writeln!(
        s,
        "- nominal robot: `{}` ({} joints, {} parameters)",
        o.nominal.path.display(),
        nom.n_joints(),
        nom.n_params()
    );
    let _ = writeln!(
        s,
        "- identification data: `{}`, {}{}",
        o.data_source,
        o.selection,
        if o.rejected {
            format!(
                "; {} outliers excluded, {} rows used",
                o.screened_rows.len() - o.used.len(),
                o.used.len()
            )
        } else {
            String::new()
        }
    );
    let _ = writeln!(
        s,
        "- free parameters: {} (`--params {}`): {}",
        o.free.len(),
        a.params,
        o.fit.free.join(", ")
    );
    if !o.fit.held.is_empty() {
        let _ = writeln!(
            s,
            "- held at their start values (exactly redundant there, `--redundant hold`): {}",
            o.fit.held.join(", ")
        );
    }
    let _ = writeln!(
        s,
        "- solver: {} damping, column scaling {}; stopped after {} iterations ({} accepted): {}",
        a.damping.name(),
        if o.fit.column_scaling { "on" } else { "off" },
        o.fit.iterations,
        o.fit.accepted_steps,
        o.fit.stop
    );
    if !o.fit.stop.converged() {
        s.push_str(
            "- **not converged**: the solver hit a cap. With (nearly) redundant free parameters \
             the cost is flat along their null-space directions, so their values drift while \
             the predictions stay put; trust the identifiable values only, or use \
             `--params minimal`.\n",
        );
    }
    match &o.registration {
        Some(r) if r.applied => {
            let _ = writeln!(
                s,
                "- registration: applied — mean point error of the nominal model {} mm → {} mm \
                 after a rigid fit (rotation {}°, translation ({}, {}, {}) mm); base \
                 (rx, ry, rz °; dx, dy, dz mm) = ({}, {}, {}; {}, {}, {})",
                mm_col(r.mean_error_before_mm),
                mm_col(r.mean_error_after_mm),
                deg_coarse(r.rotation_deg),
                signed(r.translation_mm[0], 3),
                signed(r.translation_mm[1], 3),
                signed(r.translation_mm[2], 3),
                signed(r.base_after[0], 4),
                signed(r.base_after[1], 4),
                signed(r.base_after[2], 4),
                signed(r.base_after[3], 3),
                signed(r.base_after[4], 3),
                signed(r.base_after[5], 3)
            );
        }
        Some(r) => {
            let threshold = match a.registration {
                RegistrationPolicy::Auto { threshold_mm } => number(threshold_mm),
                _ => "the threshold".into(),
            };
            let _ = writeln!(
                s,
                "- registration: not needed (nominal mean point error {} mm ≤ {threshold} mm)",
                mm_col(r.mean_error_before_mm)
            );
        }
        None => s.push_str("- registration: off (`--registration never`)\n"),
    }
    let _ = writeln!(s, "- registration decision: {}", o.registration_decision);
    if let Some(e) = &o.measurement_scale {
        let _ = writeln!(s, "- measurement scale: {}", e.describe());
    }
    for w in &o.warnings {
        let _ = writeln!(s, "- **warning**: {w}");
    }
    match o.fit.robot.extended() {
        None => s.push_str(
            "- model: geometry only (docs/model.md §2–§3). Compliance, gear errors and other \
             non-geometric effects are not identified; they stay in the residuals.\n",
        ),
        Some(model) => {
            let names: Vec<String> = model.kinds().iter().map(|k| k.name()).collect();
            let _ = writeln!(
                s,
                "- model: geometry (docs/model.md §2–§3) plus the non-geometric joint errors {} \
                 (docs/extended-model.md: gravity torques from the robot file's mass model on \
                 the start geometry). Other non-geometric effects stay in the residuals.",
                names.join(", ")
            );
        }
    }

    s.push_str("\n## Fit residuals\n\n");
    s.push_str("| model | poses | RMS 3-D (mm) | mean 3-D (mm) | max 3-D (mm) |\n|---|---:|---:|---:|---:|\n");
    let (start_res, fit_res) = o.fit_residuals();
    let (start_n, fit_n) = (norms(&start_res), norms(&fit_res));
    for (name, v) in [(start_label(o), &start_n), ("identified", &fit_n)] {
        let (mean, max) = mean_max(v);
        let rms = (v.iter().map(|x| x * x).sum::<f64>() / v.len() as f64).sqrt();
        let _ = writeln!(
            s,
            "| {name} | {} | {} | {} | {} |",
            v.len(),
            mm(rms),
            mm(mean),
            mm(max)
        );
    }
    match o.fit.sigma_hat {
        Some(sh) => {
            let _ = writeln!(
                s,
                "\nσ̂ = √(RSS / dof) = {} mm per axis (dof = {}).",
                mm(sh),
                o.fit.dof
            );
        }
        None => s.push_str("\nNo degrees of freedom left: σ̂ undefined.\n"),
    }

    let an = &o.analysis;
    s.push_str("\n## Identifiability at the solution\n\n");
    let _ = writeln!(
        s,
        "Rank {} of {} free parameters ({}; σ_i > {}·σ_max).",
        an.rank,
        an.parameter_count,
        an.scaling,
        number(an.rank_rtol)
    );
    if let Some(c) = an.condition_number {
        let _ = writeln!(
            s,
            "Condition number of the identifiable part: {}.",
            ratio(c)
        );
    }
    if let Some(ob) = &an.observability {
        let _ = writeln!(
            s,
            "\nObservability (singular values of the column-scaled Jacobian, m = {}): {}.",
            an.n_poses,
            indices(ob, ", ")
        );
    }
    if an.redundancies.is_empty() {
        s.push_str("\nRedundant set: none.\n");
    } else {
        let _ = writeln!(
            s,
            "\nRedundant set ({}; values arbitrary, no standard error):\n",
            an.redundant.len()
        );
        for r in &an.redundancies {
            let with = confounded_with(r, "nothing: it does not move the point");
            let _ = writeln!(s, "- `{}` confounded with {with}", r.name);
        }
    }

    let held_not_redundant: Vec<&str> = o
        .fit
        .held
        .iter()
        .filter(|h| !an.redundant.iter().any(|r| r == *h))
        .map(|h| h.as_str())
        .collect();
    if !held_not_redundant.is_empty() {
        let _ = writeln!(
            s,
            "\nHeld at their start values but not in the redundant set at the solution: {} — \
             they were exactly redundant at the start model, so the solver held them; the \
             analysis at the solution, where the other parameters moved, ranks them \
             identifiable only numerically. They were not fitted and have no standard error.",
            held_not_redundant.join(", ")
        );
    }

    s.push_str("\n## Parameters\n\n");
    s.push_str(
        "Nominal = robot file; identified = `identified.json`; Δ = identified − nominal (for \
         the base this includes the registration).\n\n",
    );
    s.push_str("| parameter | unit | nominal | identified | Δ | std error | identifiable |\n|---|---|---:|---:|---:|---:|---|\n");
    let layout = o.start.layout();
    let xn = nom.params();
    let cov = o.fit.covariance.as_ref();
    for (k, info) in layout.params().iter().enumerate() {
        let (n, v) = (info.to_display(xn[k]), info.to_display(o.fit.params[k]));
        let se = cov.and_then(|c| c.std_error(&info.name));
        let ident = if !o.free.contains(&k) {
            "fixed"
        } else if o.fit.held.contains(&info.name) {
            "held (exactly redundant at the start: not fitted, no standard error)"
        } else if se.is_none() && an.identifiable.iter().any(|n| *n == info.name) {
            "yes at the solution, no standard error: outside the fit's covariance (redundant \
             at the start)"
        } else if se.is_some() || an.identifiable.iter().any(|n| *n == info.name) {
            "yes"
        } else {
            "no"
        };
        let _ = writeln!(
            s,
            "| {} | {} | {} | {} | {} | {} | {ident} |",
            info.name,
            info.unit.as_str(),
            signed(n, 5),
            signed(v, 5),
            signed(v - n, 5),
            se.map_or_else(|| "–".into(), |e| param(e, 5))
        );
    }

    if let Some(post) = &o.fit.posterior {
        prior_md(&mut s, post);
    }

    s.push_str("\n## Correlations above 0.9\n\n");
    match cov {
        Some(c) if !c.high_correlations.is_empty() => {
            s.push_str("| a | b | ρ |\n|---|---|---:|\n");
            for p in &c.high_correlations {
                let _ = writeln!(s, "| {} | {} | {} |", p.a, p.b, plus(p.rho, 4));
            }
        }
        Some(_) => s.push_str("None.\n"),
        None => s.push_str("No covariance (no degrees of freedom).\n"),
    }

    s.push_str("\n## Outliers\n\n");
    match &o.screen {
        Some(sc) => {
            let _ = writeln!(
                s,
                "Screened against the final fit: ‖e‖ > k·σ̂₃ = {} × {} = {} mm (σ̂₃ = √3·σ̂, \
                 first-fit RMS {} mm).",
                setting(sc.k),
                mm(sc.sigma_3d_mm),
                mm(sc.threshold_mm),
                mm(o.first.rms_mm)
            );
            match super::robust_points(o) {
                Some(sentence) => {
                    let _ = writeln!(s, "\n{sentence}.");
                }
                None => s.push_str("\nRobust screen off (`--keep-outliers`): every row kept.\n"),
            }
            if sc.outliers.is_empty() {
                s.push_str("\nNone.\n");
            } else {
                let excluded = o
                    .robust
                    .as_ref()
                    .map_or_else(Vec::new, |r| r.excluded.clone());
                let _ = writeln!(
                    s,
                    "\n{} point(s) — {}:\n",
                    sc.outliers.len(),
                    super::outlier_status(
                        &sc.indices(),
                        &excluded,
                        "row",
                        format!(
                            "excluded, refitted (RMS {} → {} mm)",
                            mm(o.first.rms_mm),
                            mm(o.fit.rms_mm)
                        )
                    )
                );
                s.push_str("| point | line | ‖e‖ (mm) | ‖e‖/σ̂₃ |\n|---|---:|---:|---:|\n");
                for ol in &sc.outliers {
                    let r = &o.screened_rows[ol.index];
                    let _ = writeln!(
                        s,
                        "| {} | {} | {} | {} |",
                        r.id.as_deref().unwrap_or("–"),
                        r.line,
                        mm(ol.norm_mm),
                        ratio(ol.ratio)
                    );
                }
            }
        }
        None => s.push_str("Not screened (no degrees of freedom).\n"),
    }

    let _ = writeln!(s, "\n## Worst identification points (identified model)\n");
    worst_md(&mut s, &o.used, &fit_res, a.worst);

    if let Some(v) = &o.validation {
        let _ = writeln!(s, "\n## Validation on {}\n", v.source);
        let _ = writeln!(
            s,
            "{} poses never used to identify. Before: the nominal model (after registration, \
             if any: the model the fit started from) vs measured; after: the identified \
             model's prediction vs measured. e = measured − predicted.\n",
            v.rows.len()
        );
        table4_md(&mut s, &v.table, start_label(o));
        if let Some((mean, max)) = v.self_registered {
            let _ = writeln!(
                s,
                "\nFor reference, the nominal model rigidly registered on these validation \
                 points themselves (the best any frame alone can do): mean {} mm, max {} mm.",
                mm_col(mean),
                mm_col(max)
            );
        }
        s.push_str("\n### Worst validation points (identified model)\n\n");
        worst_md(&mut s, &v.rows, &v.after, a.worst);
    } else {
        s.push_str("\n## Validation\n\nNo validation data (`--validate FILE` or `--every K`).\n");
    }
    if let Some(r) = &o.residual {
        s.push_str(&super::residual::markdown(r));
    }
    s
}
