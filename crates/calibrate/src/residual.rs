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
//! [`compensate_to`] is what `compensate` solves with a model: the joints `q` with
//! `FK_geom(q) + r(q) = target` (`r` the model's mean), by a fixed point around the
//! geometric IK.
//!
//! Point data only: a 6-DoF or multi-target calibration is refused (its orientation
//! residuals are not modelled; calibrate its points with `points_only` for a model of the
//! position residuals).

use std::path::Path;
use std::time::Instant;

use identify::{Compensated, CompensationOptions, assess_solution, compensate_nearest_to};
use kinematics::{IkTarget, Robot};
use nalgebra::Vector3;

use crate::error::{CalibrateError, Result};
use crate::files::{LoadedRobot, points_mm, poses_rad};
use crate::workflow::{Calibration, PointCalibration, as_written, fit_points, residuals};

pub use residual::{
    Coverage, CrossValidation, CvOptions, DEFAULT_FOLDS, FoldResult, Gain, GpOptions, HeldOut,
    Hyperparameters, MIN_TRAIN_POSES, MODEL_FILE, Prediction, ResidualError, ResidualModel,
    cross_validate, evenly_spaced, folds, held_out,
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

/// The fixed point of [`compensate_to`] stops when the model's mean moves by less than this
/// between two steps, mm [1e-7: a tenth of the IK's position tolerance (1e-6 mm), so that
/// `FK_geom(q) + r(q)` meets the target to the IK's tolerance; the mean is smooth and its
/// slope against the point is ~1e-4 (tenths of a mm over a metre), so each step shrinks the
/// change ~10⁴-fold and two or three steps reach it away from singularities (on the UR10
/// recording at most four, and six at its first pose, singular three ways at once)].
pub const FIXED_POINT_TOL_MM: f64 = 1e-7;

/// Most steps of the fixed point of [`compensate_to`] after the geometric solution [10: it
/// takes two or three, six at a pose singular three ways; a target that needs more is
/// refused, naming it].
pub const FIXED_POINT_MAX_STEPS: usize = 10;

/// What the fixed point of [`compensate_to`] did for one target.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FixedPoint {
    /// Steps after the geometric solution (each one IK solve).
    pub steps: usize,
    /// The model's mean at the joints found, `r(q)`, mm: the geometric model reaches
    /// `target − r(q)` there.
    pub correction_mm: Vector3<f64>,
    /// The change of `r` in the last step, mm (below [`FIXED_POINT_TOL_MM`]).
    pub last_change_mm: f64,
}

/// What a compensation with a residual model did ([`crate::Compensation::residual_model`]).
#[derive(Clone, Debug, PartialEq)]
pub struct ResidualApplied {
    /// The model's file as the calibrated robot names it (beside it; `(given)` for a model
    /// passed to a robot that names none).
    pub file: String,
    /// Most fixed-point steps a target took.
    pub max_steps: usize,
    /// Mean over the compensated targets of `|r(q)|`, the model's correction, mm.
    pub mean_correction_mm: f64,
    /// Largest `|r(q)|`, mm.
    pub max_correction_mm: f64,
}

impl ResidualApplied {
    /// The summary of the fixed points of the compensated targets of `robot`.
    pub(crate) fn of(robot: &LoadedRobot, fixed: &[FixedPoint]) -> ResidualApplied {
        let file = robot
            .spec
            .provenance
            .as_ref()
            .and_then(|p| p.residual_model.as_ref())
            .map_or_else(|| "(given)".to_string(), |r| r.file.clone());
        let norms = fixed.iter().map(|f| f.correction_mm.norm());
        ResidualApplied {
            file,
            max_steps: fixed.iter().map(|f| f.steps).max().unwrap_or(0),
            mean_correction_mm: norms.clone().sum::<f64>() / fixed.len().max(1) as f64,
            max_correction_mm: norms.fold(0.0, f64::max),
        }
    }

    /// The output header's line: that the model was applied, its file, how, and the size of
    /// its correction.
    pub(crate) fn header_line(&self) -> String {
        format!(
            "\nresidual model: applied ({}, docs/residual-model.md): the joints solve \
             FK(q) + r(q) = target, r(q) the model's mean (what predict adds), by a fixed point \
             around the IK (until r changes by < {FIXED_POINT_TOL_MM:e} mm; at most {} steps \
             here); |r| mean {} mm, max {} mm",
            self.file,
            self.max_steps,
            measurements::number(self.mean_correction_mm, 4),
            measurements::number(self.max_correction_mm, 4)
        )
    }
}

/// Refuses a residual model trained on another number of joints than `robot` has.
///
/// # Errors
/// [`CalibrateError::ResidualMismatch`], naming the robot.
pub(crate) fn check_joints(robot: &LoadedRobot, model: Option<&ResidualModel>) -> Result<()> {
    match model {
        Some(m) if m.n_joints() != robot.robot.n_joints() => {
            Err(CalibrateError::ResidualMismatch(format!(
                "the residual model has {} joints, {} has {}",
                m.n_joints(),
                robot.path.display(),
                robot.robot.n_joints()
            )))
        }
        _ => Ok(()),
    }
}

/// The model's mean at the joints `q_rad` (radians), mm.
fn mean_at(model: &ResidualModel, q_rad: &[f64]) -> std::result::Result<Vector3<f64>, String> {
    let q: Vec<f64> = q_rad.iter().map(|v| v.to_degrees()).collect();
    model
        .predict(&[q])
        .map(|p| Vector3::from(p[0].mean_mm))
        .map_err(|e| format!("the residual model cannot be evaluated there: {e}"))
}

/// The joints of `identified` for `target`, nearest the start `q_rad` (the nominal
/// controller's joints; overwritten with the solution): without a model the geometric
/// solution ([`compensate_nearest_to`], as it is); with one, the joints at which the
/// calibrated robot's point `FK_geom(q) + r(q)` (`r` the model's mean, as `predict` adds it)
/// is the target. From the geometric solution `q₀`, each step solves
/// `q_{k+1} = IK_geom(target − r(q_k))` by damped Newton from `q_k` (the orientation of
/// `target` held: the model is position-only), until `r` changes by less than
/// [`FIXED_POINT_TOL_MM`], in at most [`FIXED_POINT_MAX_STEPS`] steps; the solution is
/// flagged as the geometric one is ([`assess_solution`], from the start). The same for joint
/// and Cartesian targets.
///
/// # Errors
/// Why the target is left out, in words (unreachable, or a fixed point that does not
/// converge, with its last change); `q_rad` is restored.
pub fn compensate_to(
    identified: &Robot,
    target: &IkTarget,
    q_rad: &mut [f64],
    options: &CompensationOptions,
    model: Option<&ResidualModel>,
) -> std::result::Result<(Compensated, Option<FixedPoint>), String> {
    let start = q_rad.to_vec();
    let geometric =
        compensate_nearest_to(identified, target, q_rad, options).map_err(|e| e.to_string())?;
    let Some(model) = model else {
        return Ok((geometric, None));
    };
    let result = fixed_point(identified, target, q_rad, &options.ik, model);
    match result {
        Ok((shifted, report, fixed)) => {
            let (max_change_rad, joint) =
                q_rad
                    .iter()
                    .zip(&start)
                    .enumerate()
                    .fold((0.0, 0), |(m, k), (i, (a, b))| {
                        let d = (a - b).abs();
                        if d > m { (d, i) } else { (m, k) }
                    });
            let c = assess_solution(
                identified,
                &shifted,
                &start,
                (report, max_change_rad, joint),
                options,
            );
            Ok((c, Some(fixed)))
        }
        Err(e) => {
            q_rad.copy_from_slice(&start);
            Err(e)
        }
    }
}

/// The fixed point of [`compensate_to`] from the geometric solution `q_rad` (overwritten
/// with the result on success): `q_{k+1} = IK_geom(target − r(q_k))` by the damped Newton
/// solve `ik` from `q_k`, until `r` changes by less than [`FIXED_POINT_TOL_MM`], in at most
/// [`FIXED_POINT_MAX_STEPS`] steps. Returns the last target solved, its IK report, and the
/// steps. Campaign trials call it from their own geometric solution (the compensation of a
/// simulated trial is a plain IK from the commanded joints, not the nearest-solution search
/// of [`compensate_to`]).
///
/// # Errors
/// Why there is no solution, in words (an IK failure at a step, a model that cannot be
/// evaluated, or no convergence); `q_rad` is then left as it was.
pub fn fixed_point(
    identified: &Robot,
    target: &IkTarget,
    q_rad: &mut [f64],
    ik: &kinematics::IkOptions,
    model: &ResidualModel,
) -> std::result::Result<(IkTarget, kinematics::IkReport, FixedPoint), String> {
    let mut q = q_rad.to_vec();
    let mut r = mean_at(model, &q)?;
    let mut change = f64::INFINITY;
    for step in 1..=FIXED_POINT_MAX_STEPS {
        let shifted = IkTarget {
            position_mm: target.position_mm - r,
            ..*target
        };
        let report = identified.solve_ik(&shifted, &mut q, ik).map_err(|e| {
            format!(
                "with the residual model's correction ({} mm) at step {step}: {e}",
                measurements::number(r.norm(), 4)
            )
        })?;
        let next = mean_at(model, &q)?;
        change = (next - r).norm();
        r = next;
        if change < FIXED_POINT_TOL_MM {
            q_rad.copy_from_slice(&q);
            let fixed = FixedPoint {
                steps: step,
                correction_mm: r,
                last_change_mm: change,
            };
            return Ok((shifted, report, fixed));
        }
    }
    Err(format!(
        "the residual model's fixed point did not converge in {FIXED_POINT_MAX_STEPS} steps \
         (the model's mean still moved by {} mm in the last, tolerance {FIXED_POINT_TOL_MM:e} \
         mm): compensate it with the geometry alone (--geometry-only) or leave it out",
        measurements::number(change, 4)
    ))
}
