//! Conversion of option arguments: strings and lists into the library's option types, each
//! parsed by the library's `FromStr` (the names the command line accepts), an error naming
//! the argument.

use std::path::{Path, PathBuf};
use std::str::FromStr;

use pyo3::prelude::*;

use crate::errors::refuse;

/// `value` parsed by the library's `FromStr`; an error is `{name}: {the library's text}`.
pub(crate) fn parse_arg<T>(name: &str, value: &str) -> PyResult<T>
where
    T: FromStr,
    T::Err: std::fmt::Display,
{
    value.parse().map_err(|e| refuse(format!("{name}: {e}")))
}

/// The checks an `allow` argument names: `None`, a check's name or a sequence of names.
pub(crate) fn allow_arg(allow: Option<&Bound<'_, PyAny>>) -> PyResult<Vec<calibrate::Check>> {
    let Some(a) = allow else {
        return Ok(Vec::new());
    };
    a.extract::<String>()
        .map(|s| vec![s])
        .or_else(|_| a.extract::<Vec<String>>())
        .map_err(|_| refuse("allow: expected a check's name or a list of names"))?
        .iter()
        .map(|name| parse_arg("allow", name))
        .collect()
}

/// A spec given as a string or a sequence of names (joined by commas).
pub(crate) fn params_arg(params: &Bound<'_, PyAny>) -> PyResult<identify::ParamSpec> {
    let text = match params.extract::<String>() {
        Ok(s) => s,
        Err(_) => params
            .extract::<Vec<String>>()
            .map_err(|_| {
                refuse(
                    "params: expected a spec string (\"paper\", \"minimal\", \
                     \"paper+compliance\", \"theta2,d3\") or a list of parameter names",
                )
            })?
            .join(","),
    };
    Ok(text.parse().expect("a parameter spec always parses"))
}

/// The options `identify` and `identify_frames` share: the flags of `kincal identify`.
pub(crate) struct Shared<'a, 'py> {
    pub params: Option<Bound<'py, PyAny>>,
    pub reject_outliers: bool,
    pub keep_outliers: bool,
    pub every: Option<usize>,
    pub offset: usize,
    pub select: Option<usize>,
    pub criterion: &'a str,
    pub schedule: &'a str,
    pub redundant: &'a str,
    pub registration: &'a str,
    pub outlier_k: f64,
    pub worst: usize,
    pub joint_units: &'a str,
    pub length_units: &'a str,
    pub allow: Option<Bound<'py, PyAny>>,
    /// `--prior`: `auto`, `none`, `tolerance` or `tolerance,NAME=SD,…`.
    pub prior: &'a str,
    /// `--fit-scale`.
    pub fit_scale: bool,
}

/// The request `kincal identify` builds from its flags, for the robot `robot`, the data
/// named `data` and the validation set named `validate`.
pub(crate) fn identify_request(
    robot: &Path,
    data: &str,
    validate: Option<&str>,
    o: Shared<'_, '_>,
) -> PyResult<calibrate::IdentifyRequest> {
    let Shared {
        params,
        reject_outliers,
        keep_outliers,
        every,
        offset,
        select,
        criterion,
        schedule,
        redundant,
        registration,
        outlier_k,
        worst,
        joint_units,
        length_units,
        allow,
        prior,
        fit_scale,
    } = o;
    // Parsed whether or not `select` is given (by the library's `FromStr`, as `kincal
    // identify --criterion` is), so a misspelt criterion is never accepted silently.
    let criterion: design::Criterion = parse_arg("criterion", criterion)?;
    if select.is_none() && criterion != design::Criterion::D {
        return Err(refuse(format!(
            "criterion={:?}: only with select (it chooses the rows select identifies on)",
            criterion.as_str()
        )));
    }
    let split = match (every, select) {
        (Some(_), Some(_)) => {
            return Err(refuse(
                "every and select: give one split of the data, not both",
            ));
        }
        (Some(every), None) => calibrate::Split::Every { every, offset },
        (None, Some(poses)) => calibrate::Split::Select { poses, criterion },
        (None, None) => calibrate::Split::All,
    };
    if offset != 0 && every.is_none() {
        return Err(refuse("offset: only with every"));
    }
    // In the order the arguments are checked (the first error is raised).
    let damping = parse_arg("schedule", schedule)?;
    let redundant = parse_arg("redundant", redundant)?;
    let registration = parse_arg("registration", registration)?;
    let params = match &params {
        Some(p) => params_arg(p)?,
        None => identify::ParamSpec::default(),
    };
    Ok(calibrate::IdentifyRequest {
        validate: validate.map(PathBuf::from),
        split,
        params,
        damping,
        redundant,
        registration,
        reject_outliers,
        keep_outliers,
        outlier_k,
        worst,
        joint_units: parse_arg("joint_units", joint_units)?,
        length_units: parse_arg("length_units", length_units)?,
        allow: allow_arg(allow.as_ref())?,
        prior: parse_arg("prior", prior)?,
        fit_scale,
        ..calibrate::IdentifyRequest::new(robot, data)
    })
}
