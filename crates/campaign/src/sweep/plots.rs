//! A sweep's output files: `sweep.json`, `sweep.csv`, `sweep.md`, one figure per plot of the
//! sweep file (drawn through the `report` crate's plotting layer, legends and axis titles in
//! words) and `report.html`.

use report::fmt::{self, number};
use report::html::{self, Picture};
use report::plot;
use report::{Figure, RefLine, Scale, Series, Style};

use super::spec::{PlotSpec, SweepPoint, SweepResult};
use crate::error::{CampaignError, SweepPlotError};
use crate::outputs::summary::{PAPER, is_paper};
use crate::run::aggregate::Summary;

/// Renders every output file of a sweep in memory: `sweep.json`, `sweep.csv`, `sweep.md`,
/// the plots and `report.html`, as (file name, bytes).
pub fn render_sweep_outputs(result: &SweepResult) -> Result<Vec<(String, Vec<u8>)>, CampaignError> {
    let mut json =
        serde_json::to_string_pretty(result).map_err(|source| CampaignError::Serialise {
            path: "sweep.json".into(),
            source,
        })?;
    json.push('\n');
    let mut files: Vec<(String, Vec<u8>)> = vec![
        ("sweep.json".into(), json.into_bytes()),
        ("sweep.csv".into(), result.to_csv().into_bytes()),
        ("sweep.md".into(), result.to_markdown().into_bytes()),
    ];
    files.extend(sweep_outputs(result)?);
    Ok(files)
}

/// A scenario path in words, for axis titles (the path itself if unknown).
pub fn path_in_words(path: &str) -> String {
    match path {
        "identification.lm.damping.mu0" => "μ0 (initial Levenberg–Marquardt damping)".into(),
        "identification.lm.damping.tau" => "τ (Nielsen's initial damping factor)".into(),
        "identification.lm.damping" | "identification.lm.damping.kind" => "damping schedule".into(),
        "identification.lm.column_scaling" => "Jacobian columns".into(),
        "poses.identification" => "identification poses".into(),
        "poses.validation" => "validation poses".into(),
        "tracker.noise_scale" => "tracker noise (× AT960)".into(),
        "unmodelled.compliance.scale" => "injected joint compliance (× the paper budget)".into(),
        "unmodelled.gears.scale" => "injected gear errors (× the paper budget)".into(),
        "identification.extended" => "identified model".into(),
        "trials" => "trials".into(),
        other => other.into(),
    }
}

/// A metric in words with its unit, for axis titles.
pub fn metric_in_words(metric: &str) -> String {
    match metric {
        "after_mean_mm" => "validation error after compensation (mm)".into(),
        "after_max_mm" => "max validation error after compensation (mm)".into(),
        "before_mean_mm" => "validation error before calibration (mm)".into(),
        "improvement_pct" => "improvement of the mean error (%)".into(),
        "predicted_error_mm" => "geometry error of the identified model (mm)".into(),
        "fit_rms_mm" => "RMS residual of the fit (mm)".into(),
        "lm_iterations" => "Levenberg–Marquardt iterations".into(),
        "compensation_failures" => "unreachable validation targets per trial".into(),
        "geometry_after_mean_mm" => "validation error, geometry alone (mm)".into(),
        "hybrid_after_mean_mm" => "validation error, geometry + residual model (mm)".into(),
        "residual_used" => "share of trials whose gate kept the residual model".into(),
        other => other.into(),
    }
}

/// One sweep value in words, for legends (`{"kind": "nielsen"}` → `Nielsen`, `false` on the
/// column-scaling axis → `unscaled (JᵀJ + μI)`).
pub fn value_in_words(path: &str, v: &serde_json::Value) -> String {
    use serde_json::Value;
    let schedule = |s: &str| match s {
        "levenberg" => "Levenberg".to_string(),
        "marquardt" => "Marquardt".to_string(),
        "nielsen" => "Nielsen".to_string(),
        o => o.to_string(),
    };
    match (path, v) {
        ("identification.lm.column_scaling", Value::Bool(true)) => "column-scaled".into(),
        ("identification.lm.column_scaling", Value::Bool(false)) => "unscaled (JᵀJ + μI)".into(),
        ("identification.extended", Value::Array(a)) if a.is_empty() => "geometric model".into(),
        ("identification.extended", Value::Array(a)) => format!(
            "geometric + {}",
            a.iter()
                .map(|x| x.as_str().map_or_else(|| x.to_string(), String::from))
                .collect::<Vec<_>>()
                .join(" + ")
        ),
        (_, Value::String(s)) => schedule(s),
        (_, Value::Object(m)) => {
            let mut parts: Vec<String> = Vec::new();
            if let Some(Value::String(k)) = m.get("kind") {
                parts.push(schedule(k));
            }
            for (k, x) in m {
                if k != "kind" {
                    parts.push(format!("{k} {}", value_in_words(k, x)));
                }
            }
            parts.join(", ")
        }
        (_, Value::Number(n)) => n.as_f64().map_or_else(|| n.to_string(), number),
        (p, Value::Bool(b)) => format!("{}: {}", path_in_words(p), if *b { "yes" } else { "no" }),
        (_, other) => other.to_string(),
    }
}

fn summary_of<'a>(p: &'a SweepPoint, metric: &str) -> Option<&'a Summary> {
    p.metrics.get(metric).and_then(|m| m.as_ref())
}

/// The figure of one sweep plot: `plot.y` (mean ± 1 sd over trials) against the x axis, one
/// curve per combination of the other axes, legends in words, the x axis logarithmic for
/// log-spaced values ([`Scale::auto`]) with a tick at every swept value, markers dodged so
/// that equal curves stay visible, and the paper's value as a line where it has one.
pub fn sweep_figure(result: &SweepResult, plot: &PlotSpec) -> Result<Figure, SweepPlotError> {
    let spec = &result.spec;
    let xi = result.x_axis(plot)?;
    let x_axis = &spec.axes[xi];
    let xs: Vec<f64> = x_axis
        .values
        .iter()
        .map(|v| {
            v.as_f64().ok_or_else(|| SweepPlotError::NotNumeric {
                axis: x_axis.path.clone(),
            })
        })
        .collect::<Result<_, _>>()?;
    let x_scale = Scale::auto(xs.iter().copied());
    let mut curves: Vec<Series> = Vec::new();
    for p in &result.points {
        let x = p.values[xi].as_f64().expect("checked above");
        let name: Vec<String> = spec
            .axes
            .iter()
            .zip(&p.values)
            .enumerate()
            .filter(|(i, _)| *i != xi)
            .map(|(_, (a, v))| value_in_words(&a.path, v))
            .collect();
        let name = if name.is_empty() {
            "mean over trials ± 1 sd".to_string()
        } else {
            name.join(", ")
        };
        let k = match curves.iter().position(|s| s.name == name) {
            Some(k) => k,
            None => {
                curves.push(Series::new(name, Vec::new(), Style::LineMarkers));
                curves.len() - 1
            }
        };
        match summary_of(p, &plot.y) {
            Some(s) if !plot.log_y || s.mean > 0.0 => {
                curves[k].points.push((x, s.mean));
                curves[k].bars.push((s.mean - s.sd, s.mean + s.sd));
            }
            _ => {}
        }
    }
    curves.retain(|s| !s.points.is_empty());
    let single = curves.len() == 1;
    let x_words = path_in_words(&x_axis.path);
    let y_words = metric_in_words(&plot.y);
    let mut f = Figure::new(
        format!(
            "{}: {} against {}",
            spec.name,
            short(&y_words),
            short(&x_words)
        ),
        if x_scale == Scale::Log {
            format!("{x_words}, log scale")
        } else {
            x_words
        },
        y_words,
    );
    f.x_scale = x_scale;
    f.series = curves;
    // A log y axis, if the sweep asks for one, only where the values span a decade or more.
    let log_y = plot.log_y && {
        let ys = f.series.iter().flat_map(|s| s.points.iter().map(|p| p.1));
        let (lo, hi) = ys.fold((f64::INFINITY, 0.0f64), |(a, b), y| (a.min(y), b.max(y)));
        lo > 0.0 && hi >= 10.0 * lo
    };
    f.y_scale = if log_y { Scale::Log } else { Scale::Linear };
    f.y_from_zero = !log_y;
    if log_y {
        f.y_title = format!("{}, log scale", f.y_title);
    }
    f.x_ticks = Some(xs);
    f.dodge = true;
    if single {
        f.series[0].name = "mean over trials ± 1 sd".into();
    }
    if is_paper_base(result) {
        let paper = match plot.y.as_str() {
            "after_mean_mm" => Some(PAPER.after_mean_mm),
            "after_max_mm" => Some(PAPER.after_max_mm),
            "before_mean_mm" => Some(PAPER.before_mean_mm),
            "improvement_pct" => Some(PAPER.improvement_pct),
            _ => None,
        };
        if let Some(v) = paper {
            let text = if plot.y.ends_with("_pct") {
                format!("{} %", fmt::pct(v))
            } else {
                format!("{} mm", fmt::mm(v))
            };
            f.refs
                .push(RefLine::horizontal(format!("paper (Table 4): {text}"), v));
        }
    }
    Ok(f)
}

/// A metric's title without its unit and qualifiers, for figure titles.
fn short(words: &str) -> String {
    words
        .split([',', '('])
        .next()
        .unwrap_or(words)
        .trim()
        .to_string()
}

fn is_paper_base(result: &SweepResult) -> bool {
    result
        .spec
        .scenario
        .file_stem()
        .is_some_and(|s| is_paper(&s.to_string_lossy()))
}

/// The SVG of one sweep plot ([`sweep_figure`]).
pub fn sweep_svg(result: &SweepResult, plot: &PlotSpec) -> Result<String, SweepPlotError> {
    let f = sweep_figure(result, plot)?;
    Ok(plot::figure_svg(&f)?)
}

/// The file name of sweep plot `k` (0-based): `<metric>-<k+1>.svg`.
pub fn sweep_plot_file(plot: &PlotSpec, k: usize) -> String {
    format!("{}-{}.svg", plot.y, k + 1)
}

/// `report.html` of a sweep: `sweep.md` with every plot after the table.
pub fn sweep_page(result: &SweepResult, svgs: &[(String, String)]) -> String {
    let pictures: Vec<Picture> = svgs
        .iter()
        .zip(&result.spec.plots)
        .map(|((file, svg), plot)| Picture {
            after_heading: None,
            caption: format!(
                "{} against {}: mean over {} trials per point, bars ± 1 sd; curves that coincide are shifted sideways by a few pixels.",
                metric_in_words(&plot.y),
                path_in_words(plot.x.as_deref().unwrap_or(&result.spec.axes[0].path)),
                result.spec.trials
            ),
            file: file.clone(),
            svg: svg.clone(),
        })
        .collect();
    html::page(
        &format!("Sweep {}", result.spec.name),
        &result.to_markdown(),
        &pictures,
    )
}

/// A sweep's figures and its `report.html`, as (file name, bytes): one SVG per plot of the
/// sweep file ([`sweep_plot_file`]) and the page.
///
/// # Errors
/// A plot whose x axis is not a numeric axis, or that cannot be drawn (message names the
/// plot).
pub fn sweep_outputs(result: &SweepResult) -> Result<Vec<(String, Vec<u8>)>, CampaignError> {
    let mut svgs = Vec::new();
    for (k, plot) in result.spec.plots.iter().enumerate() {
        let svg = sweep_svg(result, plot).map_err(|source| CampaignError::SweepPlot {
            plot: k + 1,
            source,
        })?;
        svgs.push((sweep_plot_file(plot, k), svg));
    }
    let mut files = vec![(
        "report.html".to_string(),
        sweep_page(result, &svgs).into_bytes(),
    )];
    files.extend(svgs.into_iter().map(|(n, s)| (n, s.into_bytes())));
    Ok(files)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn values_in_words() {
        let v = |s: &str| serde_json::from_str::<serde_json::Value>(s).unwrap();
        assert_eq!(
            value_in_words("identification.lm.damping", &v(r#"{"kind":"nielsen"}"#)),
            "Nielsen"
        );
        assert_eq!(
            value_in_words("identification.lm.damping.kind", &v(r#""levenberg""#)),
            "Levenberg"
        );
        assert_eq!(
            value_in_words("identification.lm.column_scaling", &v("false")),
            "unscaled (JᵀJ + μI)"
        );
        assert_eq!(
            value_in_words("identification.lm.damping.mu0", &v("1000000")),
            "1e6"
        );
        assert_eq!(value_in_words("x", &v("1e-9")), "1e-9");
    }
}
