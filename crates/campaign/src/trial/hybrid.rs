//! The learned residual model of a trial (scenario `residual_model`,
//! `docs/residual-model.md`, "In campaigns"): what `kincal identify --residual-model gp`
//! does on real data, on the trial's identification poses.
//!
//! 1. **Cross-validation and gate** ([`fit`]): `k` interleaved folds of the measured
//!    identification poses; each fold refits the geometry on its training poses (the
//!    trial's start model, free set and identification options) and the Gaussian process
//!    on their residuals, and predicts the held-out poses
//!    ([`calibrate::residual::cross_validate`]). The gate keeps the model when the mean
//!    and the p95 gains both exceed their fold-to-fold scatter.
//! 2. **The model** fitted on every identification pose's residual of the trial's fit —
//!    always, so that the trial reports what the hybrid gives even where the gate declines
//!    it.
//! 3. **Validation** ([`Hybrid::validate`], through the trial's own compensate-and-measure
//!    loop): each validation target is compensated by the hybrid, `FK_fit(q) + r(q) =
//!    target` — the geometric IK from the commanded joints, then the fixed point of
//!    [`calibrate::residual::fixed_point`] — and measured by the virtual robot; the
//!    coverage of the model's sd is scored on the validation poses' measured residuals
//!    before compensation.
//!
//! The trial's `after` is the hybrid's when the gate keeps the model and the geometry's
//! otherwise, so a campaign's Table 4 is what a user following the gate would get.

use calibrate::residual::{CrossValidation, ResidualModel, cross_validate, held_out};
use evaluate::AxisStats;
use identify::Problem;
use kinematics::{IkOptions, PoseTrig, Robot};
use nalgebra::Vector3;
use virtual_robot::World;

use super::context::Context;
use super::points::PointIdentification;
use super::result::ResidualTrial;
use crate::error::CampaignError;

/// The residual model of a trial and its cross-validation.
pub(super) struct Hybrid {
    /// The cross-validation on the identification poses.
    pub cv: CrossValidation,
    /// The model fitted on every identification pose.
    pub model: ResidualModel,
}

pub(super) fn to_deg(q_rad: &[f64]) -> Vec<f64> {
    q_rad.iter().map(|v| v.to_degrees()).collect()
}

/// `measured − robot(q)` of every pose, mm.
fn residuals(robot: &Robot, poses_rad: &[f64], points_mm: &[Vector3<f64>]) -> Vec<[f64; 3]> {
    robot
        .points(poses_rad)
        .iter()
        .zip(points_mm)
        .map(|(g, p)| (p - g).into())
        .collect()
}

/// Cross-validates the residual model on the trial's identification poses and fits it on
/// all of them (module doc, steps 1 and 2).
///
/// # Errors
/// [`CampaignError::Residual`]: a fold without enough poses, a GP fit that fails, or a
/// fold's geometric refit that fails (its identification error inside); the trial then
/// fails as a whole and is counted among the failed trials, with that message.
pub(super) fn fit(
    ctx: &Context,
    id: &PointIdentification,
    trial: u64,
) -> Result<Hybrid, CampaignError> {
    let options = ctx.loaded.scenario.residual_model.cv_options();
    let n = ctx.nominal().n_joints();
    let joints: Vec<Vec<f64>> = id.poses_rad.chunks_exact(n).map(to_deg).collect();
    let gp = |source| CampaignError::Residual { trial, source };
    let cv = cross_validate(&joints, &options, |train| {
        let q: Vec<f64> = train
            .iter()
            .flat_map(|&i| id.poses_rad[i * n..(i + 1) * n].iter().copied())
            .collect();
        let p: Vec<Vector3<f64>> = train.iter().map(|&i| id.points_mm[i]).collect();
        let problem = Problem::new(&ctx.id_nominal, &q, &p, id.free.clone())?;
        let refit = identify::identify(&problem, &ctx.id_options)?;
        Ok(residuals(&refit.robot, &id.poses_rad, &id.points_mm))
    })
    .map_err(gp)?;
    let r = residuals(&id.fit.robot, &id.poses_rad, &id.points_mm);
    let model = ResidualModel::fit(&joints, &r, &options.gp).map_err(gp)?;
    Ok(Hybrid { cv, model })
}

/// Hybrid compensation of one target: the geometric IK from the commanded joints `q_rad`
/// (overwritten with the solution), then the fixed point `FK_fit(q) + r(q) = target`.
/// `false` when either fails (`q_rad` then holds no solution).
pub(super) fn compensate(
    fit_robot: &Robot,
    model: &ResidualModel,
    target: &kinematics::IkTarget,
    q_rad: &mut [f64],
    ik: &IkOptions,
) -> bool {
    fit_robot.solve_ik(target, q_rad, ik).is_ok()
        && calibrate::residual::fixed_point(fit_robot, target, q_rad, ik, model).is_ok()
}

/// The validation poses the tracker measured: the trial's validation poses and, for each
/// measured one, its index and measured point (mm).
#[derive(Clone, Copy)]
pub(super) struct MeasuredValidation<'a> {
    /// The validation poses, flat, rad.
    pub poses_rad: &'a [f64],
    /// Joints a pose.
    pub n_joints: usize,
    /// The measured poses' indices and points, mm.
    pub measured: &'a [(usize, Vector3<f64>)],
}

impl<'a> MeasuredValidation<'a> {
    /// How many poses were measured.
    pub fn len(&self) -> usize {
        self.measured.len()
    }

    /// Each measured pose: its index, commanded joints (rad) and measured point (mm).
    pub fn iter(&self) -> impl Iterator<Item = (usize, &'a [f64], Vector3<f64>)> + 'a {
        let (poses, n) = (self.poses_rad, self.n_joints);
        self.measured
            .iter()
            .map(move |&(j, p)| (j, &poses[j * n..(j + 1) * n], p))
    }
}

/// What the hybrid's validation gives the trial.
pub(super) struct HybridValidation {
    /// The trial's outcome of the residual model.
    pub outcome: ResidualTrial,
    /// The hybrid's compensated errors, mm (one a reached and measured target).
    pub after_mm: Vec<[f64; 3]>,
    /// Hybrid targets the tracker could not measure.
    pub unmeasurable: usize,
}

impl Hybrid {
    /// Whether the gate keeps the model.
    pub fn used(&self) -> bool {
        self.cv.helps()
    }

    /// The model's validation (module doc, step 3): the measured validation poses
    /// `measured`, the geometry's compensated errors `geometry_after_mm` (for the
    /// outcome's statistics).
    ///
    /// # Errors
    /// [`CampaignError::Residual`] when the model cannot be evaluated at a validation pose;
    /// [`CampaignError::Evaluate`] for statistics of non-finite errors.
    pub fn validate(
        &self,
        ctx: &Context,
        world: &mut World,
        (fit_robot, val_trig): (&Robot, &PoseTrig),
        measured: MeasuredValidation<'_>,
        geometry_after_mm: &[[f64; 3]],
        trial: u64,
    ) -> Result<HybridValidation, CampaignError> {
        let eval = |source| CampaignError::Evaluate { trial, source };
        let gp = |source| CampaignError::Residual { trial, source };
        // Coverage of the sd on the validation poses' residuals before compensation.
        let q_deg: Vec<Vec<f64>> = measured.iter().map(|(_, q, _)| to_deg(q)).collect();
        let e: Vec<[f64; 3]> = measured
            .iter()
            .map(|(j, _, p)| (p - fit_robot.point_trig(val_trig.pose(j))).into())
            .collect();
        let coverage = held_out(&self.model, &q_deg, &e).map_err(gp)?.coverage();
        let (after_mm, failures, unmeasurable) = super::compensated_errors(
            ctx,
            world,
            (fit_robot, val_trig),
            measured,
            Some(&self.model),
            trial,
        )?;
        let hybrid_after = if after_mm.is_empty() {
            None
        } else {
            Some(AxisStats::from_values(&evaluate::norms(&after_mm)).map_err(eval)?)
        };
        let outcome = ResidualTrial {
            used: self.used(),
            cv_mean_gain: self.cv.mean_gain.into(),
            cv_p95_gain: self.cv.p95_gain.into(),
            geometry_after: AxisStats::from_values(&evaluate::norms(geometry_after_mm))
                .map_err(eval)?,
            hybrid_after,
            hybrid_compensation_failures: failures,
            coverage_1sd: coverage.within_1sd,
            coverage_2sd: coverage.within_2sd,
        };
        Ok(HybridValidation {
            outcome,
            after_mm,
            unmeasurable,
        })
    }
}
