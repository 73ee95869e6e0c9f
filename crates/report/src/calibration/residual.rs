//! The learned residual model's section of a calibration's report and its console line
//! (`identify --residual-model gp`, `docs/residual-model.md`): the cross-validation table
//! (geometry vs hybrid, per fold), the gate's decision with its numbers, the coverage of the
//! predicted standard deviation and the model's hyperparameters; for 6-DoF data also the
//! orientation part's (degrees) and whether it is applied.

use std::fmt::Write as _;

use calibrate::residual::{Gain, OrientationOutcome, ResidualOutcome};

use crate::fmt::{mm, ms, pct};

/// `Δ̄ ± s_Δ` of a gain, mm.
fn gain(g: &Gain) -> String {
    format!("{} ± {} mm", mm(g.mean_mm), mm(g.scatter_mm))
}

/// `Δ̄ ± s_Δ` of a gain of the orientation part, degrees.
fn gain_deg(g: &Gain) -> String {
    format!("{} ± {}°", deg(g.mean_mm), deg(g.scatter_mm))
}

/// Degrees to 4 decimals (the orientation residuals are hundredths of a degree).
fn deg(v: f64) -> String {
    format!("{v:.4}")
}

/// The gate's decision in one sentence (console and report); for 6-DoF data a second
/// sentence on the orientation part.
pub fn decision(o: &ResidualOutcome) -> String {
    let position = position_decision(o);
    match &o.orientation {
        Some(or) => format!("{position}\n{}", orientation_decision(o, or)),
        None => position,
    }
}

/// The orientation part's decision in one sentence: its held-out angle errors, gains and
/// whether it is applied.
fn orientation_decision(o: &ResidualOutcome, or: &OrientationOutcome) -> String {
    let cv = &or.cv_deg;
    let numbers = format!(
        "held-out angle mean {}° → {}° (gain {}), p95 {}° → {}° (gain {})",
        deg(cv.geometry.mean_mm),
        deg(cv.hybrid.mean_mm),
        gain_deg(&cv.mean_gain),
        deg(cv.geometry.p95_mm),
        deg(cv.hybrid.p95_mm),
        gain_deg(&cv.p95_gain),
    );
    if or.applied {
        format!(
            "residual model (gp), orientation part: applied — {numbers}; both gains exceed \
             their fold-to-fold scatter"
        )
    } else if !cv.helps() {
        let which: Vec<&str> = [
            (!cv.mean_gain.significant()).then_some("mean"),
            (!cv.p95_gain.significant()).then_some("p95"),
        ]
        .into_iter()
        .flatten()
        .collect();
        let kept = if o.model.is_some() {
            "the position part alone is written"
        } else {
            "no model is written"
        };
        format!(
            "residual model (gp), orientation part: declined, {kept} — {numbers}; the {} gain \
             does not exceed its fold-to-fold scatter",
            which.join(" and ")
        )
    } else {
        format!(
            "residual model (gp), orientation part: not applied — {numbers} (it passes the \
             gate, but the position part does not, and no model is written)"
        )
    }
}

fn position_decision(o: &ResidualOutcome) -> String {
    let cv = &o.cv;
    let (g, h) = (&cv.geometry, &cv.hybrid);
    let numbers = format!(
        "held-out mean {} → {} mm (gain {}), p95 {} → {} mm (gain {}), {}-fold \
         cross-validation",
        mm(g.mean_mm),
        mm(h.mean_mm),
        gain(&cv.mean_gain),
        mm(g.p95_mm),
        mm(h.p95_mm),
        gain(&cv.p95_gain),
        cv.folds.len()
    );
    if cv.helps() {
        format!(
            "residual model (gp): used — {numbers}; both gains exceed their fold-to-fold \
             scatter"
        )
    } else {
        let which: Vec<&str> = [
            (!cv.mean_gain.significant()).then_some("mean"),
            (!cv.p95_gain.significant()).then_some("p95"),
        ]
        .into_iter()
        .flatten()
        .collect();
        format!(
            "residual model (gp): not used, the geometric robot is written alone — {numbers}; \
             the {} gain does not exceed its fold-to-fold scatter",
            which.join(" and ")
        )
    }
}

/// The kept model on the validation rows in one line (console and report): the geometry's
/// and the hybrid's mean, p95 and max, and the coverage; `None` without validation rows or
/// without a kept model.
pub fn validation(o: &ResidualOutcome) -> Option<String> {
    let mut line = position_validation(o)?;
    if let Some(v) = o
        .orientation
        .as_ref()
        .and_then(|or| or.validation_deg.as_ref())
    {
        let g = evaluate::AxisStats::from_values(&v.geometry_mm).ok()?;
        let h = evaluate::AxisStats::from_values(&v.hybrid_mm).ok()?;
        let c = v.coverage();
        let _ = write!(
            line,
            "; orientation: angle mean {}° → {}°, p95 {}° → {}°, max {}° → {}°; {} % within 1 \
             sd, {} % within 2 sd",
            deg(g.mean_mm),
            deg(h.mean_mm),
            deg(g.p95_mm),
            deg(h.p95_mm),
            deg(g.max_mm),
            deg(h.max_mm),
            pct(100.0 * c.within_1sd),
            pct(100.0 * c.within_2sd)
        );
    }
    Some(line)
}

fn position_validation(o: &ResidualOutcome) -> Option<String> {
    let v = o.validation.as_ref()?;
    let g = evaluate::AxisStats::from_values(&v.geometry_mm).ok()?;
    let h = evaluate::AxisStats::from_values(&v.hybrid_mm).ok()?;
    let c = v.coverage();
    Some(format!(
        "residual model on the {} validation rows (never used to fit the geometry or the \
         model): mean {} → {} mm, p95 {} → {} mm, max {} → {} mm (geometry → hybrid); {} % \
         within 1 sd, {} % within 2 sd",
        v.geometry_mm.len(),
        mm(g.mean_mm),
        mm(h.mean_mm),
        mm(g.p95_mm),
        mm(h.p95_mm),
        mm(g.max_mm),
        mm(h.max_mm),
        pct(100.0 * c.within_1sd),
        pct(100.0 * c.within_2sd)
    ))
}

/// The report's section.
pub fn markdown(o: &ResidualOutcome) -> String {
    let mut s = String::from("\n## Learned residual model\n\n");
    let cv = &o.cv;
    let _ = writeln!(
        s,
        "A Gaussian process on the position residual (measured − geometry) as a function of \
         the joints, cross-validated against the geometry alone on the identification rows \
         ({} interleaved folds: fold f holds out rows f, f+{k}, f+2·{k}, …; each fold \
         refits the geometry and the GP on the other folds; at most {} training poses a \
         GP). The hybrid is used only if both the mean and the p95 of the held-out 3-D \
         error improve by more than their fold-to-fold scatter (`docs/residual-model.md`).\n",
        cv.folds.len(),
        o.options.gp.max_train_poses,
        k = cv.folds.len(),
    );
    s.push_str(
        "| fold | training poses | held out | geometry mean | hybrid mean | geometry p95 | \
         hybrid p95 | geometry max | hybrid max |\n|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n",
    );
    for f in &cv.folds {
        let _ = writeln!(
            s,
            "| {} | {} | {} | {} | {} | {} | {} | {} | {} |",
            f.fold,
            f.train_poses,
            f.held_out_poses,
            mm(f.geometry.mean_mm),
            mm(f.hybrid.mean_mm),
            mm(f.geometry.p95_mm),
            mm(f.hybrid.p95_mm),
            mm(f.geometry.max_mm),
            mm(f.hybrid.max_mm)
        );
    }
    let held: usize = cv.folds.iter().map(|f| f.held_out_poses).sum();
    let _ = writeln!(
        s,
        "| all | | {held} | {} | {} | {} | {} | {} | {} |\n",
        mm(cv.geometry.mean_mm),
        mm(cv.hybrid.mean_mm),
        mm(cv.geometry.p95_mm),
        mm(cv.hybrid.p95_mm),
        mm(cv.geometry.max_mm),
        mm(cv.hybrid.max_mm)
    );
    if let Some(or) = &o.orientation {
        let cv = &or.cv_deg;
        s.push_str(
            "Orientation part (6-DoF data: the rotation vector of R_measured · R_geometryᵀ, \
             degrees; the same folds and geometric refits):\n\n| fold | geometry mean | \
             hybrid mean | geometry p95 | hybrid p95 |\n|---:|---:|---:|---:|---:|\n",
        );
        for f in &cv.folds {
            let _ = writeln!(
                s,
                "| {} | {}° | {}° | {}° | {}° |",
                f.fold,
                deg(f.geometry.mean_mm),
                deg(f.hybrid.mean_mm),
                deg(f.geometry.p95_mm),
                deg(f.hybrid.p95_mm)
            );
        }
        let _ = writeln!(
            s,
            "| all | {}° | {}° | {}° | {}° |\n",
            deg(cv.geometry.mean_mm),
            deg(cv.hybrid.mean_mm),
            deg(cv.geometry.p95_mm),
            deg(cv.hybrid.p95_mm)
        );
    }
    let _ = writeln!(s, "**Decision.** {}.\n", decision(o).replace('\n', ".\n\n"));
    let _ = writeln!(
        s,
        "**Coverage** of the hybrid's predicted standard deviation on the held-out rows \
         ({} axis values): {} % within 1 sd, {} % within 2 sd (a calibrated Gaussian: 68.3 %, \
         95.4 %).\n",
        cv.coverage.values,
        pct(100.0 * cv.coverage.within_1sd),
        pct(100.0 * cv.coverage.within_2sd)
    );
    if let Some(line) = validation(o) {
        let _ = writeln!(s, "**Validation.** The {line}.\n");
    }
    match &o.model {
        Some(m) => {
            let h = m.hyperparameters();
            let ls: Vec<String> = h
                .length_scales_rad
                .iter()
                .map(|l| format!("{:.3}", l.to_degrees()))
                .collect();
            let noise = m.noise_sd_mm();
            let _ = writeln!(
                s,
                "The model written ({}, named with its SHA-256 in {}'s provenance): fitted on \
                 {} of {} identification rows; length scales {}° (q1…); signal variance {:.4}, \
                 noise variance {:.4} (normalised); learnt noise {} / {} / {} mm (x / y / z); \
                 log marginal likelihood {:.2} after {} iterations. `kincal predict` adds its \
                 mean; `--with-sd` writes its standard deviation. Cross-validation and fit: {} \
                 ms.",
                calibrate::residual::MODEL_FILE,
                super::ROBOT_FILE,
                m.training_poses(),
                m.training_poses_given(),
                ls.join(", "),
                h.signal_variance,
                h.noise_variance,
                mm(noise[0]),
                mm(noise[1]),
                mm(noise[2]),
                m.log_marginal_likelihood(),
                m.optimiser().iterations,
                ms(o.elapsed_ms)
            );
            if let (Some(h), Some(noise)) = (
                m.orientation_hyperparameters(),
                m.orientation_noise_sd_deg(),
            ) {
                let ls: Vec<String> = h
                    .length_scales_rad
                    .iter()
                    .map(|l| format!("{:.3}", l.to_degrees()))
                    .collect();
                let _ = writeln!(
                    s,
                    "\nIts orientation part (`kincal-residual-model/2`): length scales {}° \
                     (q1…); signal variance {:.4}, noise variance {:.4} (normalised); learnt \
                     noise {}° / {}° / {}°. `kincal predict` rotates the orientation by \
                     exp(r_o(q)); `compensate` solves for exp(−r_o(q))·R_target.",
                    ls.join(", "),
                    h.signal_variance,
                    h.noise_variance,
                    deg(noise[0]),
                    deg(noise[1]),
                    deg(noise[2]),
                );
            }
        }
        None => {
            let _ = writeln!(
                s,
                "No residual model is written: {} is the geometric robot alone. \
                 Cross-validation: {} ms.",
                super::ROBOT_FILE,
                ms(o.elapsed_ms)
            );
        }
    }
    s
}
