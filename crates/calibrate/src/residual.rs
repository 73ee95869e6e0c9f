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
//! 6-DoF data (one probe per pose, [`ToolFrameCalibration`]): each pose gives a position
//! residual (mm) and an orientation residual, the rotation vector of `R_meas · R_model(q)ᵀ`
//! (degrees, measurement axes). Each fold refits the frame geometry
//! ([`ToolFrameCalibration::refit`]) and both parts are cross-validated on the same folds
//! ([`residual::cross_validate_pose`]). The model is kept when the position part passes the
//! gate; its orientation part is added only when the orientation part passes the same rule
//! on the angles ([`OrientationOutcome::applied`]). `predict` then rotates the predicted
//! orientation by `exp(r_o(q))`, and [`compensate_to`] solves for
//! `(target_p − r_p(q), exp(−r_o(q))·R_target)`. Multi-target data (several reflectors a
//! pose) are refused: calibrate their points with `points_only` for a model of the position
//! residuals.

use std::path::Path;
use std::time::Instant;

use identify::frames::{FrameData, FrameModel};
use identify::{Compensated, CompensationOptions, assess_solution, compensate_nearest_to};
use kinematics::rotation::{exp_so3, log_so3};
use kinematics::{IkTarget, Robot};
use nalgebra::Vector3;

use crate::error::{CalibrateError, Result};
use crate::files::{LoadedRobot, points_mm, poses_rad};
use crate::pipeline::MeasurementKind;
use crate::tool_frame::ToolFrameCalibration;
use crate::workflow::{Calibration, PointCalibration, as_written, fit_points, residuals};

pub use residual::{
    Coverage, CrossValidation, CvOptions, DEFAULT_FOLDS, FoldResult, Gain, GpOptions, HeldOut,
    Hyperparameters, MIN_TRAIN_POSES, MODEL_FILE, OrientationPrediction, PoseCrossValidation,
    Prediction, ResidualError, ResidualModel, cross_validate, cross_validate_pose, evenly_spaced,
    folds, held_out,
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
    /// The orientation part (6-DoF data); `None` for point data.
    pub orientation: Option<OrientationOutcome>,
}

/// The orientation part of [`ResidualOutcome`] (6-DoF data).
#[derive(Clone, Debug)]
pub struct OrientationOutcome {
    /// The cross-validation of the orientation GP on the same folds as the position part:
    /// held-out angle errors (the norms of the orientation residuals) of the geometry and of
    /// the hybrid, and their gains — **degrees** (the `_mm`-named fields of
    /// [`CrossValidation`] hold degrees here).
    pub cv_deg: CrossValidation,
    /// Whether the written model carries the orientation part: the position part was kept
    /// and this part passes the same gate ([`CrossValidation::helps`] of
    /// [`OrientationOutcome::cv_deg`]).
    pub applied: bool,
    /// The applied orientation part on the validation poses, degrees, when there are both.
    pub validation_deg: Option<HeldOut>,
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
            orientation: None,
        });
        Ok(())
    }
}

/// Per pose of `data` (one row a pose: one probe, with its orientation), the residuals of
/// `model`: the position `p_meas − p_model(q)` (mm) and the orientation, the rotation vector
/// of `R_meas · R_model(q)ᵀ` (degrees, measurement axes; `R_model` the flange rotation times
/// the tool rotation). Rows without an orientation give a zero orientation residual (the
/// caller refuses such identification data and leaves the orientation of such validation
/// data unscored).
pub fn pose_residuals(model: &FrameModel, data: &FrameData) -> (Vec<[f64; 3]>, Vec<[f64; 3]>) {
    let mut position = Vec::with_capacity(data.rows.len());
    let mut orientation = Vec::with_capacity(data.rows.len());
    for r in &data.rows {
        let f = model.robot.flange(data.pose(r.pose));
        let p = f.rot * model.targets_mm[r.target] + f.pos_mm;
        let e = r.point_mm - p;
        position.push([e.x, e.y, e.z]);
        let o = r.rotation.map_or_else(Vector3::zeros, |m| {
            log_so3(&(m * (f.rot * model.tool_rotation).transpose())).map(f64::to_degrees)
        });
        orientation.push([o.x, o.y, o.z]);
    }
    (position, orientation)
}

impl ToolFrameCalibration {
    /// The frame geometry refitted on the poses `keep` (indices into
    /// [`ToolFrameCalibration::data`]): the calibration's start (the registered nominal with
    /// its start tool frame), free set, weighting, solver options and prior — as
    /// [`PointCalibration::refit`] for points (registration and the outlier screen are the
    /// whole calibration's, not redone per fold).
    ///
    /// # Errors
    /// The identification's errors, naming the robot and the data.
    pub fn refit(&self, keep: &[usize]) -> Result<FrameModel> {
        let data = self.data.subset(keep);
        let fit = crate::tool_frame::fit_tool_frame(
            &self.start,
            &data,
            &self.fit.free,
            (&self.request, &self.nominal.prior_sd()),
            (self.nominal.robot.name(), &self.data_source),
        )?;
        crate::tool_frame::as_written_frame(fit.model, &data, &self.nominal)
    }

    /// The residual model of 6-DoF data ([`Calibration::fit_residual_model`]): both parts
    /// cross-validated on the same folds (each fold refits the frame geometry,
    /// [`ToolFrameCalibration::refit`]); the model is kept when the position part passes
    /// the gate, and carries the orientation part when that passes it too.
    ///
    /// # Errors
    /// [`CalibrateError::ResidualMismatch`] for multi-target data or poses without an
    /// orientation; [`CalibrateError::Residual`]; a fold's geometric fit's error.
    pub fn fit_residual_model(&mut self, options: &CvOptions) -> Result<()> {
        let single = matches!(self.kind, MeasurementKind::SixDof { targets: 1 });
        // One row a pose, in pose order: the folds index poses and rows alike.
        let in_order = |d: &FrameData| {
            d.rows.len() == d.n_poses() && d.rows.iter().enumerate().all(|(i, r)| r.pose == i)
        };
        if !single || !in_order(&self.data) {
            return Err(CalibrateError::ResidualMismatch(format!(
                "a residual model is fitted on point data or on 6-DoF data of one probe a \
                 pose; {} has {} data (several targets a pose: their residuals are not \
                 modelled): calibrate its points alone (points_only) for a model of the \
                 position residuals",
                self.data_source, self.kind
            )));
        }
        if let Some(row) = self.data.rows.iter().position(|r| r.rotation.is_none()) {
            return Err(CalibrateError::ResidualMismatch(format!(
                "a residual model of 6-DoF data needs an orientation at every pose; pose {row} \
                 of {} has none",
                self.data_source
            )));
        }
        let started = Instant::now();
        let joints: Vec<Vec<f64>> = (0..self.data.n_poses())
            .map(|j| self.data.pose(j).iter().map(|v| v.to_degrees()).collect())
            .collect();
        let context = format!(
            "cross-validating the residual model on the {} identification poses of {}",
            joints.len(),
            self.data_source
        );
        let cv = residual::cross_validate_pose(&joints, options, |train| {
            let model = self.refit(train).map_err(Box::new)?;
            Ok(pose_residuals(&model, &self.data))
        })
        .map_err(gp_err(context))?;
        let fit_err = || {
            gp_err(format!(
                "fitting the residual model on the identification poses of {}",
                self.data_source
            ))
        };
        let applied = cv.position_mm.helps() && cv.orientation_deg.helps();
        let model = if cv.position_mm.helps() {
            let (rp, ro) = pose_residuals(&self.fit.model, &self.data);
            let mut m = ResidualModel::fit(&joints, &rp, &options.gp).map_err(fit_err())?;
            if applied {
                m.fit_orientation(&joints, &ro, &options.gp)
                    .map_err(fit_err())?;
            }
            Some(m)
        } else {
            None
        };
        let (validation, validation_deg) = match (&model, &self.validation_data) {
            // Validation poses in order, each with its orientation (else the position part
            // alone is scored there).
            (Some(m), Some(v)) if in_order(v) => {
                let q: Vec<Vec<f64>> = (0..v.n_poses())
                    .map(|j| v.pose(j).iter().map(|x| x.to_degrees()).collect())
                    .collect();
                let (rp, ro) = pose_residuals(&self.fit.model, v);
                let err = || {
                    gp_err(format!(
                        "predicting the residual model on the validation poses of {}",
                        self.validation.as_ref().map_or("", |v| v.0.as_str())
                    ))
                };
                let position = held_out(m, &q, &rp).map_err(err())?;
                let orientation = if v.rows.iter().all(|r| r.rotation.is_some()) {
                    m.predict_orientation(&q)
                        .map_err(err())?
                        .map(|pred| held_out_deg(&pred, &ro))
                } else {
                    None
                };
                (Some(position), orientation)
            }
            _ => (None, None),
        };
        self.residual = Some(ResidualOutcome {
            options: options.clone(),
            cv: cv.position_mm,
            model,
            validation,
            elapsed_ms: started.elapsed().as_secs_f64() * 1e3,
            orientation: Some(OrientationOutcome {
                cv_deg: cv.orientation_deg,
                applied,
                validation_deg,
            }),
        });
        Ok(())
    }
}

/// [`held_out`] of the orientation part: the geometry's and the hybrid's angle errors
/// (degrees) at poses whose orientation residuals are `residuals_deg`, and the coverage of
/// the part's sd.
fn held_out_deg(pred: &[OrientationPrediction], residuals_deg: &[[f64; 3]]) -> HeldOut {
    residual::held_out_predicted(pred.iter().map(|p| (p.mean_deg, p.sd_deg)), residuals_deg)
}

impl Calibration {
    /// [`PointCalibration::fit_residual_model`] of a point calibration,
    /// [`ToolFrameCalibration::fit_residual_model`] of 6-DoF data.
    ///
    /// # Errors
    /// [`CalibrateError::ResidualMismatch`] for multi-target data (several reflectors a
    /// pose); the calibration's errors.
    pub fn fit_residual_model(&mut self, options: &CvOptions) -> Result<()> {
        match self {
            Calibration::Points(c) => c.fit_residual_model(options),
            Calibration::ToolFrame(c) => c.fit_residual_model(options),
        }
    }

    /// The residual model's outcome, if one was asked for.
    pub fn residual(&self) -> Option<&ResidualOutcome> {
        match self {
            Calibration::Points(c) => c.residual.as_ref(),
            Calibration::ToolFrame(c) => c.residual.as_ref(),
        }
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

/// With an orientation part (6-DoF data), the fixed point also waits until the part's mean
/// moves by less than this between two steps, degrees [5e-9: a tenth of the IK's orientation
/// tolerance (1e-9 rad = 5.7e-8°); the orientation mean varies by hundredths of a degree
/// over radians of joint travel, so each step shrinks its change many thousandfold too].
pub const FIXED_POINT_TOL_DEG: f64 = 5e-9;

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
    /// With the model's orientation part: its mean at the joints found, `r_o(q)` (degrees,
    /// measurement axes): the geometric model reaches `exp(−r_o(q))·R_target` there.
    pub orientation_correction_deg: Option<Vector3<f64>>,
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
    /// With the model's orientation part: the largest angle `|r_o(q)|` of its correction,
    /// degrees.
    pub max_orientation_correction_deg: Option<f64>,
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
            max_orientation_correction_deg: fixed
                .iter()
                .filter_map(|f| f.orientation_correction_deg.map(|o| o.norm()))
                .reduce(f64::max),
        }
    }

    /// The output header's line: that the model was applied, its file, how, and the size of
    /// its correction.
    pub(crate) fn header_line(&self) -> String {
        let orientation = self
            .max_orientation_correction_deg
            .map_or(String::new(), |d| {
                format!(
                    "; with its orientation part: the orientation solves exp(r_o(q))·R(q) = \
                 R_target (until r_o changes by < {FIXED_POINT_TOL_DEG:e}°), |r_o| max {}°",
                    measurements::number(d, 5)
                )
            });
        format!(
            "\nresidual model: applied ({}, docs/residual-model.md): the joints solve \
             FK(q) + r(q) = target, r(q) the model's mean (what predict adds), by a fixed point \
             around the IK (until r changes by < {FIXED_POINT_TOL_MM:e} mm; at most {} steps \
             here); |r| mean {} mm, max {} mm{orientation}",
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

/// The model's mean at the joints `q_rad` (radians): the position part, mm, and the
/// orientation part's, degrees, if it has one.
fn mean_at(
    model: &ResidualModel,
    q_rad: &[f64],
) -> std::result::Result<(Vector3<f64>, Option<Vector3<f64>>), String> {
    let q = vec![q_rad.iter().map(|v| v.to_degrees()).collect::<Vec<f64>>()];
    let err = |e: ResidualError| format!("the residual model cannot be evaluated there: {e}");
    let p = model.predict(&q).map_err(err)?;
    let o = model.predict_orientation(&q).map_err(err)?;
    Ok((
        Vector3::from(p[0].mean_mm),
        o.map(|o| Vector3::from(o[0].mean_deg)),
    ))
}

/// `target` shifted by the model's correction: the position by `−r`, and with an
/// orientation part the flange orientation by `exp(−r_o)` on the left (the measured frame's
/// orientation is `exp(r_o)·R_flange·R_tool`, so the geometric model must reach
/// `exp(−r_o)·R_target`).
fn shifted_target(target: &IkTarget, r: Vector3<f64>, ro: Option<Vector3<f64>>) -> IkTarget {
    IkTarget {
        position_mm: target.position_mm - r,
        rotation: match ro {
            Some(o) => exp_so3(&(-o.map(f64::to_radians))) * target.rotation,
            None => target.rotation,
        },
        ..*target
    }
}

/// The joints of `identified` for `target`, nearest the start `q_rad` (the nominal
/// controller's joints; overwritten with the solution): without a model the geometric
/// solution ([`compensate_nearest_to`], as it is); with one, the joints at which the
/// calibrated robot's point `FK_geom(q) + r(q)` (`r` the model's mean, as `predict` adds it)
/// is the target. From the geometric solution `q₀`, each step solves
/// `q_{k+1} = IK_geom(target − r(q_k))` by damped Newton from `q_k` (the orientation of
/// `target` held for a model of the position alone; with an orientation part, 6-DoF data,
/// the orientation solved is `exp(−r_o(q_k))·R_target`, so that `exp(r_o(q))·R(q)`, what
/// `predict` writes, is the target's), until `r` changes by less than
/// [`FIXED_POINT_TOL_MM`] (and `r_o` by less than [`FIXED_POINT_TOL_DEG`]), in at most [`FIXED_POINT_MAX_STEPS`] steps; the solution is
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
/// with the result on success): `q_{k+1} = IK_geom(target − r(q_k))` (with an orientation
/// part, orientation `exp(−r_o(q_k))·R_target`) by the damped Newton solve `ik` from `q_k`,
/// until `r` changes by less than [`FIXED_POINT_TOL_MM`] (and `r_o` by less than
/// [`FIXED_POINT_TOL_DEG`]), in at most
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
    let (mut r, mut ro) = mean_at(model, &q)?;
    let (mut change, mut change_deg) = (f64::INFINITY, 0.0);
    for step in 1..=FIXED_POINT_MAX_STEPS {
        let shifted = shifted_target(target, r, ro);
        let report = identified.solve_ik(&shifted, &mut q, ik).map_err(|e| {
            format!(
                "with the residual model's correction ({} mm) at step {step}: {e}",
                measurements::number(r.norm(), 4)
            )
        })?;
        let (next, next_o) = mean_at(model, &q)?;
        change = (next - r).norm();
        change_deg = match (next_o, ro) {
            (Some(a), Some(b)) => (a - b).norm(),
            _ => 0.0,
        };
        r = next;
        ro = next_o;
        if change < FIXED_POINT_TOL_MM && change_deg < FIXED_POINT_TOL_DEG {
            q_rad.copy_from_slice(&q);
            let fixed = FixedPoint {
                steps: step,
                correction_mm: r,
                last_change_mm: change,
                orientation_correction_deg: ro,
            };
            return Ok((shifted, report, fixed));
        }
    }
    let orientation = if ro.is_some() {
        format!(
            ", its orientation part by {}° (tolerance {FIXED_POINT_TOL_DEG:e}°)",
            measurements::number(change_deg, 4)
        )
    } else {
        String::new()
    };
    Err(format!(
        "the residual model's fixed point did not converge in {FIXED_POINT_MAX_STEPS} steps \
         (the model's mean still moved by {} mm in the last, tolerance {FIXED_POINT_TOL_MM:e} \
         mm{orientation}): compensate it with the geometry alone (--geometry-only) or leave it \
         out",
        measurements::number(change, 4)
    ))
}
