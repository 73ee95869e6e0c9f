//! `parameters.json`: the parameter table of a calibration, for programs.

use std::collections::BTreeMap;

use calibrate::PointCalibration;
use serde::Serialize;

use super::ROBOT_FILE;

/// One row of `parameters.json`.
#[derive(Serialize)]
pub(super) struct ParamRow<'a> {
    pub name: &'a str,
    pub unit: &'static str,
    pub free: bool,
    pub nominal: f64,
    pub start: f64,
    pub identified: f64,
    pub delta: f64,
    pub std_error: Option<f64>,
    pub identifiable: bool,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub prior: Option<PriorCols>,
}

/// The prior's columns of a row (with `--prior`, solved parameters only).
#[derive(Serialize)]
pub(super) struct PriorCols {
    pub prior_sd: Option<f64>,
    pub posterior_sd: f64,
    pub information: Option<f64>,
    pub held_by_prior: bool,
}

/// `parameters.json`.
#[derive(Serialize)]
pub(super) struct ParamTable<'a> {
    pub format: &'static str,
    pub robot_file: &'static str,
    pub nominal_robot: String,
    pub data: String,
    pub rows: usize,
    pub params: String,
    /// What the data measure, where not points.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub measurement: Option<String>,
    pub free: usize,
    pub rank: usize,
    pub sigma_hat_mm: Option<f64>,
    /// σ̂ of a weighted fit (6-DoF and multi-target data), in the units of the weighting.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub sigma_hat_weighted: Option<f64>,
    pub rms_mm: f64,
    pub columns: BTreeMap<&'static str, &'static str>,
    pub parameters: Vec<ParamRow<'a>>,
}

impl ParamTable<'_> {
    /// The table as written: pretty JSON and a final newline.
    pub(super) fn to_json(&self) -> String {
        let mut s = serde_json::to_string_pretty(self).expect("the table serialises");
        s.push('\n');
        s
    }
}

/// `parameters.json` (format `kincal-parameters/1`): for every parameter of the robot its
/// unit, whether it was free, its nominal, start and identified values (display units), Δ,
/// standard error and identifiability, under a header naming the files, the spec, the rank
/// and the fit's σ̂ and RMS.
pub fn parameters_json(o: &PointCalibration) -> String {
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
                    None => o.analysis.identifiable.iter().any(|n| *n == info.name),
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
    let columns = columns();
    let table = ParamTable {
        format: "kincal-parameters/1",
        robot_file: ROBOT_FILE,
        nominal_robot: o.nominal.path.display().to_string(),
        data: o.data_source.clone(),
        rows: o.used.len(),
        params: o.request.params.to_string(),
        measurement: None,
        free: o.free.len(),
        rank: o.analysis.rank,
        sigma_hat_mm: o.fit.sigma_hat,
        sigma_hat_weighted: None,
        rms_mm: o.fit.rms_mm,
        columns,
        parameters,
    };
    table.to_json()
}

/// The `columns` header: what each column of a row means.
pub(super) fn columns() -> BTreeMap<&'static str, &'static str> {
    BTreeMap::from([
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
    ])
}
