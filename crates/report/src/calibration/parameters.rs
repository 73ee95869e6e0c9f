//! `parameters.json`: the parameter table of a calibration, for programs.

use std::collections::BTreeMap;

use calibrate::Calibration;
use serde::Serialize;

use super::ROBOT_FILE;

/// One row of `parameters.json`.
#[derive(Serialize)]
struct ParamRow<'a> {
    name: &'a str,
    unit: &'static str,
    free: bool,
    nominal: f64,
    start: f64,
    identified: f64,
    delta: f64,
    std_error: Option<f64>,
    identifiable: bool,
    #[serde(skip_serializing_if = "Option::is_none")]
    prior: Option<PriorCols>,
}

/// The prior's columns of a row (with `--prior`, solved parameters only).
#[derive(Serialize)]
struct PriorCols {
    prior_sd: Option<f64>,
    posterior_sd: f64,
    information: Option<f64>,
    held_by_prior: bool,
}

/// `parameters.json`.
#[derive(Serialize)]
struct ParamTable<'a> {
    format: &'static str,
    robot_file: &'static str,
    nominal_robot: String,
    data: String,
    rows: usize,
    params: String,
    free: usize,
    rank: usize,
    sigma_hat_mm: Option<f64>,
    rms_mm: f64,
    columns: BTreeMap<&'static str, &'static str>,
    parameters: Vec<ParamRow<'a>>,
}

/// `parameters.json` (format `kincal-parameters/1`): for every parameter of the robot its
/// unit, whether it was free, its nominal, start and identified values (display units), Δ,
/// standard error and identifiability, under a header naming the files, the spec, the rank
/// and the fit's σ̂ and RMS.
pub fn parameters_json(o: &Calibration) -> String {
    let layout = o.start.layout();
    let (xn, xs) = (o.nominal.robot.params(), o.start.params());
    let cov = o.fit.covariance.as_ref();
    let parameters = layout
        .params()
        .iter()
        .enumerate()
        .map(|(k, info)| {
            let nominal = info.to_display(xn[k]);
            let identified = info.to_display(o.fit.params[k]);
            ParamRow {
                name: &info.name,
                unit: info.unit.as_str(),
                free: o.free.contains(&k),
                nominal,
                start: info.to_display(xs[k]),
                identified,
                delta: identified - nominal,
                std_error: cov.and_then(|c| c.std_error(&info.name)),
                identifiable: match cov {
                    Some(c) => c.parameters.contains(&info.name),
                    None => o.analysis.identifiable.contains(&info.name),
                },
                prior: o.fit.posterior.as_ref().and_then(|post| {
                    post.params
                        .iter()
                        .find(|p| p.name == info.name)
                        .map(|p| PriorCols {
                            prior_sd: p.prior_sd,
                            posterior_sd: p.posterior_sd,
                            information: p.information,
                            held_by_prior: p.held_by_prior,
                        })
                }),
            }
        })
        .collect();
    let columns = BTreeMap::from([
        ("nominal", "value in the nominal robot file"),
        (
            "start",
            "value the fit started from (the nominal model after base registration)",
        ),
        (
            "identified",
            "value of the calibrated robot (identified.json)",
        ),
        ("delta", "identified − nominal"),
        (
            "std_error",
            "standard error, for identifiable parameters (null otherwise)",
        ),
        (
            "prior",
            "with a prior (--prior): prior_sd and posterior_sd (display units), information \
             (1 − posterior variance / prior variance) and held_by_prior (posterior sd above \
             half the prior's: the prior rather than the data determine the value); solved \
             parameters only",
        ),
        (
            "identifiable",
            "in the identifiable (minimal) subset at the solution; the values of the others \
             are arbitrary along their null-space directions",
        ),
    ]);
    let table = ParamTable {
        format: "kincal-parameters/1",
        robot_file: ROBOT_FILE,
        nominal_robot: o.nominal.path.display().to_string(),
        data: o.data_source.clone(),
        rows: o.used.len(),
        params: o.request.params.to_string(),
        free: o.free.len(),
        rank: o.analysis.rank,
        sigma_hat_mm: o.fit.sigma_hat,
        rms_mm: o.fit.rms_mm,
        columns,
        parameters,
    };
    let mut s = serde_json::to_string_pretty(&table).expect("the table serialises");
    s.push('\n');
    s
}
