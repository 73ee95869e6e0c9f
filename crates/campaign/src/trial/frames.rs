//! The identification of a trial whose scenario measures frames (a 6-DoF probe) or several
//! reflectors per pose (`measurement`, [`crate::scenario::MeasurementConfig`]): the virtual
//! robot reads the tool ([`World::measure_tool`]), `identify::frames` identifies the robot
//! with the tool frame (orientation and/or targets) from the nominal model, and the trial
//! goes on with the identified robot (its tool point is target 0) as for a point fit.
//!
//! Rows are weighted as `identify::frames` weighs data without σ: position 1/mm,
//! orientation [`DEFAULT_MM_PER_DEG`] per degree (the virtual tracker's σ ratio, 0.02 mm
//! against 0.005°, is 4 mm/°: close to it). The candidates are every robot parameter (for
//! `paper` and `minimal`; a list of names: those), of which [`select_free`] keeps the
//! identifiable ones.

use identify::frames::{
    DEFAULT_MM_PER_DEG, FrameData, FrameModel, FrameRow, fit_frames, residual_jacobian, select_free,
};
use identify::{Observability, ParamSet};
use kinematics::Robot;
use nalgebra::DMatrix;
use virtual_robot::World;

use super::context::Context;
use super::result::FitSummary;
use crate::error::CampaignError;

/// What the frame identification of a trial gives the rest of the trial.
pub(super) struct FrameIdentification {
    /// The identified robot (tool point = target 0, tool orientation for frames).
    pub robot: Robot,
    /// The fit's figures.
    pub summary: FitSummary,
    /// O1–O5 of the frame rows at the nominal model on the identified unknowns.
    pub observability: Option<Observability>,
    /// Identification poses that could not be measured.
    pub unmeasurable: usize,
}

/// Measures `poses_rad` (flat) with the scenario's measurement and identifies.
pub(super) fn identify_frames(
    ctx: &Context,
    world: &mut World,
    poses_rad: &[f64],
    trial: u64,
) -> Result<FrameIdentification, CampaignError> {
    let nominal = ctx.nominal();
    let scenario = &ctx.loaded.scenario;
    let m = &scenario.measurement;
    let n = nominal.n_joints();
    let ident = |source| CampaignError::Identify { trial, source };
    let offsets = m.offsets_mm();
    let names = m.target_names();
    let orientation = m.kind == design::Measure::Frame;
    let w_rot = DEFAULT_MM_PER_DEG.to_degrees();
    let mut rows = Vec::new();
    let mut measured = Vec::with_capacity(poses_rad.len());
    let mut unmeasurable = 0;
    for q in poses_rad.chunks_exact(n) {
        let Ok((points, rot)) = world.measure_tool(q, &offsets, orientation) else {
            unmeasurable += 1;
            continue;
        };
        let pose = measured.len() / n;
        measured.extend_from_slice(q);
        for (k, p) in points.into_iter().enumerate() {
            rows.push(FrameRow {
                pose,
                target: k,
                point_mm: p,
                rotation: if k == 0 { rot } else { None },
                w_pos: [1.0; 3],
                w_rot,
            });
        }
    }
    let data = FrameData {
        poses_rad: measured,
        n_joints: n,
        target_names: names.clone(),
        rows,
    };
    let start = FrameModel {
        robot: nominal.clone(),
        tool_rotation: nominal.tool_rotation(),
        targets_mm: offsets.iter().map(|o| nominal.tool_mm() + o).collect(),
    };
    let candidates: Vec<usize> = match &scenario.identification.params {
        ParamSet::Names(list) => list
            .iter()
            .filter_map(|s| nominal.layout().index_of(s).ok())
            .collect(),
        _ => (0..nominal.n_params()).collect(),
    };
    let (free, _) = select_free(&start, &data, &candidates).map_err(ident)?;
    // The scenario's solver options (the one solver of points and frames); redundant
    // unknowns were held by `select_free`.
    let options = identify::LmOptions {
        redundant: identify::Redundant::Hold,
        ..ctx.id_options.lm
    };
    let fit = fit_frames(&start, &data, &free, &options).map_err(ident)?;
    // Figures of the fit: position RMS per axis.
    let errors = fit.model.errors(&data);
    let rms_mm = (errors.iter().map(|(p, _)| p.norm_squared()).sum::<f64>()
        / (3 * errors.len()).max(1) as f64)
        .sqrt();
    // O1–O5 on the nominal model's rows (unit-norm columns: the weights' scale cancels).
    let mut jac = DMatrix::zeros(0, 0);
    residual_jacobian(&start, &data, &free, Some(&mut jac));
    let observability = design::observability(&(jac.transpose() * &jac), data.n_poses());
    Ok(FrameIdentification {
        robot: fit.model.to_robot(&names, orientation),
        summary: FitSummary {
            iterations: fit.iterations,
            stop: fit.stop,
            converged: fit.stop.converged(),
            rms_mm,
            free: free.len(),
            rank: Some(free.len()),
            gradient_cosine: fit.gradient_cosine,
        },
        observability,
        unmeasurable,
    })
}
