//! The learned residual model of a point calibration (`docs/residual-model.md`, the
//! `residual` crate): `identify --residual-model gp` cross-validates the hybrid (the
//! calibrated geometry + a Gaussian process on what it leaves) against the geometry alone on
//! the identification rows, and writes the model beside `identified.json` only when the
//! gate says it helps ([`residual::CrossValidation::helps`]).
//!
//! Each fold refits the geometry on its training rows ([`PointCalibration::refit`]: the same
//! start — the registered nominal —, free set, solver options and prior as the calibration;
//! the registration and the outlier screen are those of the whole calibration, not redone
//! per fold), so the geometry's held-out error is a held-out error too.
//!
//! The written pair: `identified.json`'s provenance names the model file and its SHA-256
//! ([`kinematics::ResidualModelRef`]); the model names the calibration run it corrects
//! (`fitted_for`, the provenance's `run`). [`load_model`] reads it back for `predict`,
//! refusing a file whose digest or run differs.
//!
//! Point data only: a 6-DoF or multi-target calibration is refused (its orientation
//! residuals are not modelled; calibrate its points with `points_only` for a model of the
//! position residuals).

use std::path::Path;
use std::time::Instant;

use kinematics::Robot;
use residual::ResidualError;

use crate::error::{CalibrateError, Result};
use crate::files::{LoadedRobot, points_mm, poses_rad};
use crate::workflow::{Calibration, PointCalibration, as_written, fit_points, residuals};

pub use residual::{
    Coverage, CrossValidation, CvOptions, DEFAULT_FOLDS, FoldResult, Gain, GpOptions, HeldOut,
    Hyperparameters, MODEL_FILE, Prediction, ResidualModel, cross_validate, evenly_spaced, folds,
    held_out,
};

/// What `identify --residual-model gp` found.
#[derive(Clone, Debug)]
pub struct ResidualOutcome {
    /// The options it ran with.
    pub options: CvOptions,
    /// The cross-validation on the identification rows (the final fit's).
    pub cv: CrossValidation,
    /// The model fitted on every identification row, when the gate says the hybrid helps
    /// (it is then written, [`MODEL_FILE`]); `None` when it does not (the geometric robot
    /// is written alone).
    pub model: Option<ResidualModel>,
    /// The kept model on the validation rows (`--validate`, `--every`), when there are
    /// both: the geometry's and the hybrid's errors there, and the coverage of its sd.
    pub validation: Option<HeldOut>,
    /// Wall-clock time of the cross-validation and the final fit, ms.
    pub elapsed_ms: f64,
}

fn gp_err(context: impl Into<String>) -> impl FnOnce(ResidualError) -> CalibrateError {
    move |source| CalibrateError::Residual {
        context: context.into(),
        source,
    }
}

impl PointCalibration {
    /// The geometry refitted on the rows `keep` (indices into [`PointCalibration::used`]):
    /// the calibration's start (the registered nominal), free set, solver options and prior.
    ///
    /// # Errors
    /// The identification's errors, naming the robot and the data.
    pub fn refit(&self, keep: &[usize]) -> Result<Robot> {
        let rows: Vec<_> = keep.iter().map(|&i| self.used[i].clone()).collect();
        let options = identify::IdentifyOptions {
            lm: self.request.lm_options(),
            registration: identify::RegistrationPolicy::Never,
            ..identify::IdentifyOptions::default()
        };
        let fit = fit_points(
            &self.start,
            (&poses_rad(&rows), &points_mm(&rows)),
            self.free.clone(),
            &options,
            (&self.request.prior, &self.nominal.prior_sd()),
            (self.nominal.robot.name(), &self.data_source),
        )?;
        as_written(fit.robot, &self.nominal)
    }

    /// Cross-validates the residual model on the identification rows and, when the gate
    /// says the hybrid helps, fits it on all of them (residuals of the final fit); the
    /// outcome is kept in [`PointCalibration::residual`].
    ///
    /// # Errors
    /// [`CalibrateError::Residual`] (too few rows for the folds, a model that cannot be
    /// fitted); a fold's geometric fit's error.
    pub fn fit_residual_model(&mut self, options: &CvOptions) -> Result<()> {
        let started = Instant::now();
        let joints: Vec<Vec<f64>> = self.used.iter().map(|r| r.q_deg.clone()).collect();
        let context = format!(
            "cross-validating the residual model on the {} identification rows of {}",
            self.used.len(),
            self.data_source
        );
        let cv = residual::cross_validate(&joints, options, |train| {
            let robot = self.refit(train).map_err(Box::new)?;
            Ok(residuals(&robot, &self.used))
        })
        .map_err(gp_err(context))?;
        let model = if cv.helps() {
            let r = residuals(&self.fit.robot, &self.used);
            Some(
                ResidualModel::fit(&joints, &r, &options.gp).map_err(gp_err(format!(
                    "fitting the residual model on the identification rows of {}",
                    self.data_source
                )))?,
            )
        } else {
            None
        };
        let validation = match (&model, &self.validation) {
            (Some(m), Some(v)) => {
                let q: Vec<Vec<f64>> = v.rows.iter().map(|r| r.q_deg.clone()).collect();
                Some(held_out(m, &q, &v.after).map_err(gp_err(format!(
                    "predicting the residual model on the validation rows of {}",
                    v.source
                )))?)
            }
            _ => None,
        };
        self.residual = Some(ResidualOutcome {
            options: options.clone(),
            cv,
            model,
            validation,
            elapsed_ms: started.elapsed().as_secs_f64() * 1e3,
        });
        Ok(())
    }
}

impl Calibration {
    /// [`PointCalibration::fit_residual_model`] of a point calibration.
    ///
    /// # Errors
    /// [`CalibrateError::ResidualMismatch`] for 6-DoF or multi-target data (orientation
    /// residuals are not modelled); the point calibration's errors.
    pub fn fit_residual_model(&mut self, options: &CvOptions) -> Result<()> {
        match self {
            Calibration::Points(c) => c.fit_residual_model(options),
            Calibration::ToolFrame(c) => Err(CalibrateError::ResidualMismatch(format!(
                "a residual model is fitted on point data; {} has {} data (orientation \
                 residuals are not modelled): calibrate its points alone (points_only) for a \
                 model of the position residuals",
                c.data_source, c.kind
            ))),
        }
    }

    /// The residual model's outcome, if one was asked for.
    pub fn residual(&self) -> Option<&ResidualOutcome> {
        self.points().and_then(|c| c.residual.as_ref())
    }
}

/// The residual model `robot` names in its provenance ([`kinematics::ResidualModelRef`]),
/// read from its directory; `None` when it names none.
///
/// # Errors
/// [`CalibrateError::ResidualMismatch`] when the file's SHA-256 is not the one named, or
/// the model was fitted for another calibration run; [`CalibrateError::Residual`] for a file
/// that cannot be read or parsed (naming it).
pub fn load_model(robot: &LoadedRobot) -> Result<Option<ResidualModel>> {
    let Some(p) = robot.spec.provenance.as_ref() else {
        return Ok(None);
    };
    let Some(r) = p.residual_model.as_ref() else {
        return Ok(None);
    };
    let dir = robot.path.parent().unwrap_or(Path::new("."));
    let path = dir.join(&r.file);
    let shown = path.display().to_string();
    let bytes = std::fs::read(&path).map_err(|e| {
        CalibrateError::ResidualMismatch(format!(
            "{} names its residual model {} (beside it), which cannot be read: {e}",
            robot.path.display(),
            shown
        ))
    })?;
    let sha = crate::provenance::sha256_hex(&bytes);
    if sha != r.sha256 {
        return Err(CalibrateError::ResidualMismatch(format!(
            "{shown} is not the residual model {} names: its SHA-256 is {sha}, the robot file \
             names {}",
            robot.path.display(),
            r.sha256
        )));
    }
    let text = String::from_utf8_lossy(&bytes);
    let model = ResidualModel::from_json_str(&text, &shown)
        .map_err(gp_err(format!("reading the residual model {shown}")))?;
    if model.fitted_for() != Some(p.run.as_str()) {
        return Err(CalibrateError::ResidualMismatch(format!(
            "{shown} was fitted for calibration run {}, {} is run {}",
            model.fitted_for().unwrap_or("(none)"),
            robot.path.display(),
            p.run
        )));
    }
    Ok(Some(model))
}
