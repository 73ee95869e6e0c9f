//! The prior of a calibration (`identify::prior`): which one ([`PriorSpec`]), built on the
//! start model, and the maximum a posteriori refit.
//!
//! The prior (`tolerance`; by default `auto`: only when the data leave a parameter
//! undetermined) centres each geometric parameter on the start model's value (the robot
//! file's, after registration) with the standard deviation of its manufacturing tolerance,
//! the one the parameters check uses ([`crate::tolerance::tolerance`]: 20 mm for a and d, 5° for
//! θ, α and β, 250 mm for the tool); the base (the measurement frame) and the parameters
//! beyond geometry have none. The residual rows' noise σ_e that weighs it against the data is
//! σ̂ of the fit without the prior: the prior fit is a second solve, from the same start.

use identify::frames::{FrameData, FrameFit, FrameFree, FrameModel, fit_frames_with_prior};
use identify::{Fit, IdentifyOptions, LmOptions, Prior, Problem, identify};
use kinematics::Robot;

use crate::error::{Result, id_err};
use crate::tolerance::tolerance;

/// Which prior identifies.
#[derive(Clone, Debug, PartialEq)]
pub enum PriorSpec {
    /// No prior: the least-squares fit (`--prior none`).
    None,
    /// The prior of [`PriorSpec::Tolerance`] when the data leave a free parameter
    /// undetermined (its standard error from the data alone above
    /// [`crate::tolerance::UNDETERMINED_FRACTION`] × its tolerance), else none: well-excited
    /// data give the least-squares fit to the bit (`--prior auto`, the default).
    Auto,
    /// The manufacturing tolerances of [`crate::tolerance::tolerance`], with the standard
    /// deviations (display units: mm, °) of the named parameters replaced.
    Tolerance {
        /// `(name, sd)` replacements, in the order given.
        sd: Vec<(String, f64)>,
    },
}

impl Default for PriorSpec {
    /// [`PriorSpec::Auto`].
    fn default() -> Self {
        PriorSpec::Auto
    }
}

impl std::fmt::Display for PriorSpec {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            PriorSpec::None => write!(f, "none"),
            PriorSpec::Auto => write!(f, "auto"),
            PriorSpec::Tolerance { sd } => {
                write!(f, "tolerance")?;
                for (name, v) in sd {
                    write!(f, ",{name}={v}")?;
                }
                Ok(())
            }
        }
    }
}

impl std::str::FromStr for PriorSpec {
    type Err = String;

    /// `none`, `auto`, `tolerance`, or `tolerance,NAME=SD,…` (`NAME=SD,…` alone implies
    /// `tolerance`); SD in the parameter's display unit (mm or °), finite and positive.
    fn from_str(s: &str) -> std::result::Result<Self, Self::Err> {
        let s = s.trim();
        match s {
            "none" => return Ok(PriorSpec::None),
            "auto" => return Ok(PriorSpec::Auto),
            _ => {}
        }
        let mut sd = Vec::new();
        for (i, item) in s.split(',').map(str::trim).enumerate() {
            if i == 0 && item == "tolerance" {
                continue;
            }
            let (name, value) = item.split_once('=').ok_or_else(|| {
                format!("`{item}`: expected none, auto, tolerance or NAME=SD (e.g. a6=0.5)")
            })?;
            let v: f64 = value
                .trim()
                .parse()
                .map_err(|_| format!("`{item}`: the standard deviation is not a number"))?;
            if !(v.is_finite() && v > 0.0) {
                return Err(format!(
                    "`{item}`: a prior's standard deviation must be finite and positive"
                ));
            }
            sd.push((name.trim().to_string(), v));
        }
        Ok(PriorSpec::Tolerance { sd })
    }
}

impl PriorSpec {
    /// The prior on `start` (centred on its values), `None` for [`PriorSpec::None`]: the
    /// manufacturing tolerances, replaced by the robot file's `prior_sd` (`file`: name → sd,
    /// display units), replaced in turn by the request's (`--prior tolerance,NAME=SD`).
    ///
    /// # Errors
    /// A replaced parameter the robot does not have.
    pub fn on(&self, start: &Robot, file: &[(String, f64)]) -> Result<Option<Prior>> {
        let given: &[(String, f64)] = match self {
            PriorSpec::None => return Ok(None),
            PriorSpec::Auto => &[],
            PriorSpec::Tolerance { sd } => sd,
        };
        let replaced = file.iter().chain(given);
        let layout = start.layout();
        let mut sd: Vec<Option<f64>> = layout
            .params()
            .iter()
            .map(|p| tolerance(p.kind).map(|t| t / p.to_display(1.0).abs()))
            .collect();
        for (name, v) in replaced {
            let k = layout.index_of(name).map_err(|e| {
                id_err(format!("the prior of {name}"))(identify::IdentifyError::from(e))
            })?;
            sd[k] = Some(v / layout.get(k).to_display(1.0).abs());
        }
        Prior::centred_on(start, sd)
            .map(Some)
            .map_err(id_err("building the prior"))
    }
}

/// The fit of `problem` with the prior of `spec` (maximum a posteriori), weighed with σ̂ of
/// `fit` (the fit without it, which is returned as it is for [`PriorSpec::None`], for
/// [`PriorSpec::Auto`] when the data determine every free parameter, or when σ̂ is unknown:
/// no degrees of freedom).
///
/// # Errors
/// As [`PriorSpec::on`]; the solver's.
pub(crate) fn refit(
    spec: &PriorSpec,
    file: &[(String, f64)],
    problem: &Problem,
    options: &IdentifyOptions,
    fit: Fit,
) -> Result<Fit> {
    if *spec == PriorSpec::Auto && !crate::tolerance::leaves_undetermined(problem.robot(), &fit) {
        return Ok(fit);
    }
    let (Some(prior), Some(sigma)) = (spec.on(problem.robot(), file)?, fit.sigma_hat) else {
        return Ok(fit);
    };
    if !(sigma.is_finite() && sigma > 0.0) {
        return Ok(fit);
    }
    let term = prior.term(sigma);
    let with = problem
        .clone()
        .with_prior(&term)
        .map_err(id_err("the prior"))?;
    identify(&with, options).map_err(id_err("identifying with the prior"))
}

/// [`refit`] for the 6-DoF / multi-target kind: the fit of `free` on `data` from `start` with
/// the prior of `spec` on the robot parameters (the tool frame and the targets have none),
/// weighed with σ̂ of `fit` (the fit without it, returned as it is for [`PriorSpec::None`],
/// for [`PriorSpec::Auto`] when the data determine every free robot parameter
/// ([`crate::excitation::diagnose_frames`]), or when σ̂ is unknown).
///
/// # Errors
/// As [`PriorSpec::on`]; the solver's.
pub(crate) fn refit_frames(
    (spec, file): (&PriorSpec, &[(String, f64)]),
    (start, data, free): (&FrameModel, &FrameData, &FrameFree),
    options: &LmOptions,
    fit: FrameFit,
) -> Result<FrameFit> {
    if *spec == PriorSpec::Auto
        && crate::excitation::diagnose_frames(&start.robot, data, &fit)
            .undetermined
            .is_empty()
    {
        return Ok(fit);
    }
    let (Some(prior), sigma) = (spec.on(&start.robot, file)?, fit.sigma_hat) else {
        return Ok(fit);
    };
    if !(sigma.is_finite() && sigma > 0.0) {
        return Ok(fit);
    }
    let term = prior.term(sigma);
    fit_frames_with_prior(start, data, free, options, Some(&term))
        .map_err(id_err("identifying with the prior (6-DoF)"))
}
