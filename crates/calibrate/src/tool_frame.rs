//! The stages of the calibration pipeline (`crate::pipeline`) for 6-DoF measurements (a
//! tracker probe's orientation, `qw,qx,qy,qz`) and for several targets per pose (`target`
//! column): `docs/model.md` §5 and §6.4. The tool frame (its orientation, the targets'
//! points) is among the unknowns.
//!
//! A pass: register the base from the position rows (one point per pose: the mean of its
//! targets; the registration of every kind) → closed-form start of the tool frame and
//! targets the robot file does not give → choose the identifiable unknowns (the rank
//! decision of [`identify::identifiability`]) → identify ([`identify::frames`]). Outliers are
//! screened pose by pose (the rule of [`identify::outliers`] on each pose's block of rows);
//! validation gives position (mm) and orientation (degrees) errors, separately. The base
//! orientation is refined by the fit (its rotations are among the unknowns).
//!
//! Weights: each row's σ when the file gives them (`sx,sy,sz`, `srx,sry,srz`), else the
//! default ratio [`identify::frames::DEFAULT_MM_PER_DEG`] or the one given in
//! [`Weighting::mm_per_deg`]; the report states which.

use std::cell::Cell;
use std::path::Path;
use std::time::Instant;

use identify::BlockScreen;
use identify::RegistrationReport;
use identify::frames::{
    DEFAULT_MM_PER_DEG, FrameData, FrameFit, FrameFree, FrameModel, FrameRow, closed_form_tool,
    fit_frames, select_free,
};
use kinematics::Robot;
use measurements::{Measurement, MeasurementSet, quaternion_to_matrix};
use nalgebra::Vector3;

use crate::error::{CalibrateError, Refusal, Result, id_err};
use crate::files::{LoadedRobot, file_name};
use crate::pipeline::Common;
use crate::pipeline::{self, Held, Kind, MeasurementKind};
use crate::request::{IdentifyRequest, Weighting};

/// Position and orientation error statistics of a model on a set of poses.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PoseErrors {
    /// Poses.
    pub poses: usize,
    /// Mean and max 3-D position error over the measured points, mm.
    pub position_mm: (f64, f64),
    /// Mean and max orientation error (angle of `R_modelᵀ R_meas`) over the measured
    /// orientations, degrees (0, 0 without orientations).
    pub orientation_deg: (f64, f64),
}

impl PoseErrors {
    /// The errors of `model` on `data`.
    pub fn of(model: &FrameModel, data: &FrameData) -> PoseErrors {
        let errs = model.errors(data);
        let pos: Vec<f64> = errs.iter().map(|(p, _)| p.norm()).collect();
        let ori: Vec<f64> = errs
            .iter()
            .filter_map(|(_, o)| o.map(|o| o.norm()))
            .collect();
        PoseErrors {
            poses: data.n_poses(),
            position_mm: crate::pipeline::mean_max(&pos),
            orientation_deg: crate::pipeline::mean_max(&ori),
        }
    }
}

/// A finished calibration from 6-DoF or multi-target data (a [`crate::Calibration`]).
#[derive(Clone, Debug)]
pub struct ToolFrameCalibration {
    /// What was asked.
    pub request: IdentifyRequest,
    /// The nominal robot file (extended by the request's parameters).
    pub nominal: LoadedRobot,
    /// The identification data's source.
    pub data_source: String,
    /// What the data measure.
    pub kind: MeasurementKind,
    /// The start model (registered nominal, closed-form tool frame and targets).
    pub start: FrameModel,
    /// Whether the tool orientation came from the robot file (else the closed form).
    pub rotation_given: bool,
    /// Targets whose point came from the closed form (names; `tool` for the unnamed one).
    pub targets_estimated: Vec<String>,
    /// The registration, if considered.
    pub registration: Option<RegistrationReport>,
    /// What was decided about registration, and the evidence.
    pub registration_decision: String,
    /// Which poses identified, in words.
    pub selection: String,
    /// The identification data of the final fit.
    pub data: FrameData,
    /// How the rows were weighted, in words.
    pub weighting: String,
    /// Candidates held at their start values as confounded (names).
    pub held: Vec<String>,
    /// The final fit.
    pub fit: FrameFit,
    /// The outlier screen of every identification pose against the final fit (the rule of
    /// [`identify::outliers`] on each pose's block of weighted rows: [`identify::frames::screen_poses`];
    /// `None` without residual degrees of freedom). Its indices are poses of
    /// [`ToolFrameCalibration::screened`].
    pub screen: Option<BlockScreen>,
    /// The identification data screened (every identification pose, outliers included).
    pub screened: FrameData,
    /// The file line of each pose of [`ToolFrameCalibration::screened`] (its first row).
    pub screened_lines: Vec<usize>,
    /// Whether outlier poses were dropped and the model refitted (to a fixed point, as for
    /// points: the poses kept are those the fit on them passes).
    pub rejected: bool,
    /// The robust screen: its scale and the poses excluded (indices into
    /// [`ToolFrameCalibration::screened`]); `None` with `keep_outliers` or without degrees of
    /// freedom.
    pub robust: Option<crate::pipeline::RobustScreen>,
    /// Errors of the start and the identified model on the identification poses.
    pub fit_errors: (PoseErrors, PoseErrors),
    /// Errors on the validation poses (start, identified) and their source, if any.
    pub validation: Option<(String, PoseErrors, PoseErrors)>,
    /// The validation poses, if any (for per-pose plots).
    pub validation_data: Option<FrameData>,
    /// Reader notices.
    pub notices: Vec<String>,
    /// Wall-clock time of the fit alone (ms): registration, start, free set and
    /// identification, summed over the outlier-rejection passes.
    pub elapsed_ms: f64,
    /// Warnings about the data (validation rows that are identification rows), to show
    /// prominently.
    pub warnings: Vec<String>,
    /// The measurements' scale factor identified with `--fit-scale` (`crate::scale`): the
    /// points were divided by it before this calibration; `None` without `--fit-scale` or
    /// when the factor was not significant (the points were left as measured).
    pub measurement_scale: Option<crate::scale::ScaleEvidence>,
    /// The learned residual model's cross-validation and, when it helps, the model
    /// ([`crate::residual`]: position and orientation parts); `None` unless asked for
    /// ([`crate::Calibration::fit_residual_model`]).
    pub residual: Option<crate::residual::ResidualOutcome>,
}

/// The rows of `set` as [`FrameData`] (poses in [`MeasurementSet::poses`] order), weighted
/// as `options` say; returns the weighting in words.
pub fn frame_data(set: &MeasurementSet, options: &Weighting) -> (FrameData, String) {
    let names: Vec<String> = if set.has_targets() {
        set.targets().iter().map(|s| s.to_string()).collect()
    } else {
        vec![String::new()]
    };
    let with_sigma = options.sigma
        && set.rows.iter().all(|r| r.sigma_mm.is_some())
        && set
            .rows
            .iter()
            .all(|r| r.orientation.is_none() || r.sigma_deg.is_some());
    let ratio = options.mm_per_deg.unwrap_or(DEFAULT_MM_PER_DEG);
    let n = set.n_joints;
    let mut poses_rad = Vec::new();
    let mut rows = Vec::new();
    for (j, pose) in set.poses().iter().enumerate() {
        poses_rad.extend(set.rows[pose[0]].q_deg.iter().map(|q| q.to_radians()));
        for &i in pose {
            let r: &Measurement = &set.rows[i];
            let target = r
                .target
                .as_deref()
                .and_then(|t| names.iter().position(|n| n == t))
                .unwrap_or(0);
            let (w_pos, w_rot) = if with_sigma {
                let s = r.sigma_mm.expect("checked");
                let w_rot = r.sigma_deg.map_or(1.0, |d| {
                    let rms = ((d[0] * d[0] + d[1] * d[1] + d[2] * d[2]) / 3.0).sqrt();
                    1.0 / rms.to_radians()
                });
                ([1.0 / s[0], 1.0 / s[1], 1.0 / s[2]], w_rot)
            } else {
                ([1.0; 3], ratio.to_degrees())
            };
            rows.push(FrameRow {
                pose: j,
                target,
                point_mm: Vector3::from(r.point_mm.expect("read with points required")),
                rotation: r.orientation.map(|q| {
                    // Rows then columns.
                    nalgebra::Matrix3::from(quaternion_to_matrix(q)).transpose()
                }),
                w_pos,
                w_rot,
            });
        }
    }
    let words = if with_sigma {
        "each row by its σ (1/σ per position axis; orientation by 1/σ_rot, σ_rot the RMS of \
         the row's three angular σ)"
            .to_string()
    } else {
        format!(
            "position rows 1/mm, orientation rows {ratio} per degree (1° weighs as {ratio} mm{})",
            if options.mm_per_deg.is_some() {
                ", as asked"
            } else if options.sigma {
                "; the default ratio: not every row gives its σ"
            } else {
                "; the default ratio"
            }
        )
    };
    (
        FrameData {
            poses_rad,
            n_joints: n,
            target_names: names,
            rows,
        },
        words,
    )
}

/// Per pose: the joint vector and the point registration uses (target 0's point without
/// named targets, else the mean of the pose's target points).
fn registration_points(data: &FrameData) -> Vec<Vector3<f64>> {
    let mut sum = vec![Vector3::zeros(); data.n_poses()];
    let mut n = vec![0usize; data.n_poses()];
    for r in &data.rows {
        sum[r.pose] += r.point_mm;
        n[r.pose] += 1;
    }
    sum.iter().zip(&n).map(|(s, &k)| s / k as f64).collect()
}

/// The start model: `robot` (registered) with the tool orientation and the targets the
/// robot file gives, the others from [`closed_form_tool`]. Returns it with whether the
/// orientation was given and the names of the estimated targets.
pub fn start_model(robot: &Robot, data: &FrameData) -> (FrameModel, bool, Vec<String>) {
    let given_rot = robot.tool_rotation_rad().map(|_| robot.tool_rotation());
    let known: Vec<Option<Vector3<f64>>> = data
        .target_names
        .iter()
        .map(|name| {
            if name.is_empty() {
                Some(robot.tool_mm())
            } else {
                robot
                    .targets()
                    .and_then(|t| t.iter().find(|(n, _)| n == name).map(|(_, p)| *p))
            }
        })
        .collect();
    let estimated = data
        .target_names
        .iter()
        .zip(&known)
        .filter(|(_, k)| k.is_none())
        .map(|(n, _)| n.clone())
        .collect();
    let model = closed_form_tool(robot, data, given_rot, &known);
    (model, given_rot.is_some(), estimated)
}

/// The identifiable unknowns of `spec` (`minimal`: every geometric parameter is a
/// candidate) on `model` and `data`, with the names of the candidates held as confounded.
fn free_set(
    request: &IdentifyRequest,
    model: &FrameModel,
    data: &FrameData,
) -> Result<(identify::frames::FrameFree, Vec<String>)> {
    let spec_err = |source| CalibrateError::Params {
        spec: request.params.to_string(),
        source,
    };
    let robot = &model.robot;
    let candidates: Vec<usize> = match request.params.listed(robot).map_err(spec_err)? {
        Some(names) => names
            .iter()
            .filter_map(|n| robot.layout().index_of(n).ok())
            .collect(),
        None => (0..robot.n_params()).collect(),
    };
    let (free, dropped) =
        select_free(model, data, &candidates).map_err(id_err("choosing the identifiable set"))?;
    let held = dropped
        .iter()
        .map(|&k| robot.layout().get(k).name.to_string())
        .collect();
    Ok((free, held))
}

/// One registration, start and fit on a pose set.
#[derive(Clone)]
struct Pass {
    start: FrameModel,
    registration: Option<RegistrationReport>,
    decision: String,
    rotation_given: bool,
    targets_estimated: Vec<String>,
    held: Vec<String>,
    fit: FrameFit,
}

/// The file line of each pose of `set` (its first row), in [`MeasurementSet::poses`] order.
pub fn pose_lines(set: &MeasurementSet) -> Vec<usize> {
    set.poses().iter().map(|p| set.rows[p[0]].line).collect()
}

/// The fit of the tool-frame kind: `free` from `data`, starting at `start` (errors naming
/// the robot and the data's source), with the request's solver options (its damping
/// schedule: `--schedule`, `schedule=`) and its prior (`--prior`, `prior=`; by default only
/// where the data leave a robot parameter undetermined, as for points). The one place this
/// kind calls the solver.
pub(crate) fn fit_tool_frame(
    start: &FrameModel,
    data: &FrameData,
    free: &FrameFree,
    (request, prior_file): (&IdentifyRequest, &[(String, f64)]),
    (robot, source): (&str, &str),
) -> Result<FrameFit> {
    let options = request.lm_options();
    let fit = fit_frames(start, data, free, &options)
        .map_err(id_err(format!("identifying {robot} on {source} (6-DoF)")))?;
    crate::prior::refit_frames(
        (&request.prior, prior_file),
        (start, data, free),
        &options,
        fit,
    )
}

/// `model` as `identified.json` gives it back: an extended model's gravity torques were
/// evaluated on the geometry it was extended from, and the file re-extends its own geometry
/// when read (the frame's own tool fields are ignored by the frame model: its targets stand
/// for them); a geometric model as it is.
pub(crate) fn as_written_frame(
    mut model: FrameModel,
    data: &FrameData,
    nominal: &LoadedRobot,
) -> Result<FrameModel> {
    if model.robot.is_extended() {
        let written = model.to_robot(&data.target_names, data.has_orientation());
        model.robot =
            Robot::from_spec(&written.to_spec()).map_err(|source| CalibrateError::Robot {
                what: "identified robot",
                path: nominal.path.clone(),
                source,
            })?;
    }
    Ok(model)
}

/// This kind's stages (`crate::pipeline::Kind`).
struct ToolFrameKind<'a> {
    request: &'a IdentifyRequest,
    nominal: &'a LoadedRobot,
    source: &'a str,
    /// The time of the passes alone, summed over the rejection passes.
    fit_ms: Cell<f64>,
}

/// A validation: its source, the errors of the start and the identified model, the poses.
type PoseValidation = (String, PoseErrors, PoseErrors, FrameData);

impl Kind for ToolFrameKind<'_> {
    const UNIT: &'static str = "pose";
    type Data = FrameData;
    type Pass = Pass;
    type Screen = BlockScreen;
    /// What the poses determine (the unknowns chosen are identifiable: the rank decision is
    /// made before the fit, [`identify::frames::select_free`]).
    type Analysis = crate::excitation::Excitation;
    type Held = FrameData;
    type Validation = PoseValidation;

    fn subset(&self, data: &FrameData, keep: &[usize]) -> FrameData {
        data.subset(keep)
    }

    fn units(&self, data: &FrameData) -> usize {
        data.n_poses()
    }

    /// One pass: register on the position rows, start the tool frame, choose the unknowns
    /// (the one rank decision), fit.
    fn pass(&self, d: &FrameData) -> Result<Pass> {
        let started = Instant::now();
        let robot = &self.nominal.robot;
        let (registered, registration, decision) = crate::pipeline::register(
            robot,
            &d.poses_rad,
            &registration_points(d),
            self.request.registration,
        )
        .map_err(|e| e.context(format!("identification data {}", self.source)))?;
        let (start, rotation_given, targets_estimated) = start_model(&registered, d);
        let (free, held) = free_set(self.request, &start, d)?;
        let mut fit = fit_tool_frame(
            &start,
            d,
            &free,
            (self.request, &self.nominal.prior_sd()),
            (robot.name(), self.source),
        )?;
        // As for points: an extended model's gravity torques were evaluated on the geometry
        // it was extended from; `identified.json` re-extends its own geometry when read, so
        // the model validated and reported is that one (the frame's own tool fields are
        // ignored by the frame model: its targets stand for them).
        fit.model = as_written_frame(fit.model, d, self.nominal)?;
        self.fit_ms
            .set(self.fit_ms.get() + started.elapsed().as_secs_f64() * 1e3);
        Ok(Pass {
            start,
            registration,
            decision,
            rotation_given,
            targets_estimated,
            held,
            fit,
        })
    }

    fn screen(&self, pass: &Pass, data: &FrameData, k: f64) -> Result<Option<BlockScreen>> {
        identify::frames::screen_poses(&pass.fit, data, k).map_err(id_err("screening outliers"))
    }

    fn norms(&self, pass: &Pass, data: &FrameData) -> Vec<(f64, usize)> {
        identify::frames::pose_blocks(&pass.fit.model, data)
    }

    fn start_norms(&self, pass: &Pass, data: &FrameData) -> Vec<(f64, usize)> {
        identify::frames::pose_blocks(&pass.start, data)
    }

    fn sigma_row(pass: &Pass) -> Option<f64> {
        (pass.fit.dof > 0 && pass.fit.sigma_hat.is_finite()).then_some(pass.fit.sigma_hat)
    }

    fn flagged(screen: &BlockScreen) -> Vec<usize> {
        screen.indices()
    }

    fn n_free(pass: &Pass) -> usize {
        pass.fit.free.len()
    }

    fn determines(&self, data: &FrameData, n_free: usize) -> bool {
        data.n_equations() >= n_free
    }

    fn decision(pass: &mut Pass) -> &mut String {
        &mut pass.decision
    }

    fn analyse(&self, pass: &Pass, used: &FrameData) -> Result<Self::Analysis> {
        Ok(crate::excitation::diagnose_frames(
            &pass.start.robot,
            used,
            &pass.fit,
        ))
    }

    /// The parameters check with the evidence of what the poses determine
    /// ([`crate::excitation::parameters`]), as for points.
    fn check_parameters(&self, pass: &Pass, excitation: &Self::Analysis) -> Result<()> {
        crate::excitation::parameters(
            &pass.start.robot,
            &pass.fit.model.robot,
            &pass.fit.free.robot,
            excitation,
        )?;
        Ok(())
    }

    fn moved<'a>(pass: &'a Pass, _: &'a Self::Analysis) -> (&'a Robot, &'a Robot, &'a [usize]) {
        (
            &pass.start.robot,
            &pass.fit.model.robot,
            &pass.fit.free.robot,
        )
    }

    fn validate(&self, pass: &Pass, source: String, d: FrameData) -> Result<PoseValidation> {
        let before = PoseErrors::of(&pass.start, &d);
        let after = PoseErrors::of(&pass.fit.model, &d);
        Ok((source, before, after, d))
    }

    fn validated(v: &PoseValidation) -> (&str, f64, f64) {
        (&v.0, v.1.position_mm.0, v.2.position_mm.0)
    }
}

/// `d` (a validation file's data) with its rows' targets numbered as `id`'s (a file lists
/// its targets in its own order), or the first target `id` does not measure.
fn same_targets(mut d: FrameData, id: &FrameData) -> std::result::Result<FrameData, String> {
    let map: Vec<usize> = d
        .target_names
        .iter()
        .map(|n| id.target_names.iter().position(|m| m == n).ok_or(n.clone()))
        .collect::<std::result::Result<_, _>>()?;
    for r in &mut d.rows {
        r.target = map[r.target];
    }
    d.target_names = id.target_names.clone();
    Ok(d)
}

/// This kind after the split: the pipeline's stages, then the result.
pub(crate) fn calibrate(common: Common<'_>) -> Result<ToolFrameCalibration> {
    let Common {
        request,
        nominal,
        data,
        units: _,
        split,
        kind,
        notices,
        overlap_warning,
    } = common;
    let (all, weighting) = frame_data(&data, &request.weighting);
    let lines = pose_lines(&data);
    let id_data = all.subset(&split.id);
    let id_lines: Vec<usize> = split.id.iter().map(|&j| lines[j]).collect();
    let val = split
        .val
        .map(|(source, held)| -> Result<(String, FrameData)> {
            let d = match held {
                Held::Rest(poses) => all.subset(&poses),
                Held::File(set) => same_targets(frame_data(&set, &request.weighting).0, &all)
                    .map_err(|target| Refusal::ValidationTarget {
                        file: set.source.clone(),
                        target,
                        known: all.target_names.join(", "),
                    })?,
            };
            Ok((source, d))
        })
        .transpose()?;
    let stages = ToolFrameKind {
        request,
        nominal: &nominal,
        source: &data.source,
        fit_ms: Cell::new(0.0),
    };
    let out = pipeline::fit_and_check(&stages, request, &data.source, &id_data, val)?;
    let Pass {
        start,
        registration,
        decision,
        rotation_given,
        targets_estimated,
        held,
        fit,
    } = out.last;
    let fit_errors = (
        PoseErrors::of(&start, &out.used),
        PoseErrors::of(&fit.model, &out.used),
    );
    let (validation, validation_data) = match out.validation {
        Some((source, before, after, d)) => (Some((source, before, after)), Some(d)),
        None => (None, None),
    };
    let elapsed_ms = stages.fit_ms.get();
    Ok(ToolFrameCalibration {
        request: request.clone(),
        data_source: data.source.clone(),
        nominal: nominal.clone(),
        kind,
        start,
        rotation_given,
        targets_estimated,
        registration,
        registration_decision: decision,
        selection: split.text,
        data: out.used,
        weighting,
        held,
        fit,
        screen: out.screen,
        screened: id_data,
        screened_lines: id_lines,
        rejected: out.rejected,
        robust: out.robust,
        fit_errors,
        validation,
        validation_data,
        notices,
        elapsed_ms,
        warnings: overlap_warning
            .into_iter()
            .chain(out.analysis.warning(&request.prior))
            .collect(),
        measurement_scale: None,
        residual: None,
    })
}

/// A flagged pose of [`ToolFrameCalibration::outlier_poses`].
#[derive(Clone, Debug, PartialEq)]
pub struct PoseOutlier {
    /// Index into [`ToolFrameCalibration::screened`].
    pub pose: usize,
    /// Its file line (first row).
    pub line: usize,
    /// `‖e_pose‖ / (√d·σ̂)` of the screen.
    pub ratio: f64,
    /// Its largest position error (over its targets) at the final model, mm.
    pub position_mm: f64,
    /// Its largest orientation error at the final model, degrees (`None` without orientation).
    pub orientation_deg: Option<f64>,
}

impl ToolFrameCalibration {
    /// The flagged poses of the screen (largest ratio first), with their errors at the final
    /// model.
    pub fn outlier_poses(&self) -> Vec<PoseOutlier> {
        let Some(screen) = &self.screen else {
            return Vec::new();
        };
        let errs = self.fit.model.errors(&self.screened);
        screen
            .outliers
            .iter()
            .map(|o| {
                let rows = self
                    .screened
                    .rows
                    .iter()
                    .zip(&errs)
                    .filter(|(r, _)| r.pose == o.index);
                let (mut p, mut a) = (0.0_f64, None::<f64>);
                for (_, (ep, eo)) in rows {
                    p = p.max(ep.norm());
                    if let Some(eo) = eo {
                        a = Some(a.unwrap_or(0.0).max(eo.norm()));
                    }
                }
                PoseOutlier {
                    pose: o.index,
                    line: self.screened_lines[o.index],
                    ratio: o.ratio,
                    position_mm: p,
                    orientation_deg: a,
                }
            })
            .collect()
    }

    /// The calibrated robot as written (`identified.json`): the fit with its tool frame
    /// (`tool_mm`, `tool_rotation_deg` where orientation was measured, `targets` where
    /// named), named after the nominal and the data file.
    pub fn identified_robot(&self) -> Robot {
        let mut r = self
            .fit
            .model
            .to_robot(&self.data.target_names, self.data.has_orientation());
        r.set_name(format!(
            "{}, identified from {}",
            self.nominal.robot.name(),
            file_name(Path::new(&self.data_source))
        ));
        r
    }

    /// Whether the measurement frame was registered onto the robot base.
    pub fn registered(&self) -> bool {
        self.registration.as_ref().is_some_and(|r| r.applied)
    }

    /// The nominal robot in the data's measurement frame with the start tool frame
    /// (`registered-nominal.json`, the targets of compensation): the start model, named
    /// after the data file when registered.
    pub fn registered_robot(&self) -> Robot {
        let mut r = self
            .start
            .to_robot(&self.data.target_names, self.data.has_orientation());
        if self.registered() {
            r.set_name(format!(
                "{}, base registered on {}",
                self.nominal.robot.name(),
                file_name(Path::new(&self.data_source))
            ));
        }
        r
    }
}

#[cfg(test)]
mod tests {
    use std::path::PathBuf;

    use super::*;
    use crate::Split;

    fn request(data: &str) -> IdentifyRequest {
        let root = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../..");
        IdentifyRequest {
            split: Split::Every {
                every: 15,
                offset: 0,
            },
            ..IdentifyRequest::new(
                root.join("scenarios/robots/ur10.json"),
                root.join("data/ur10-ipa").join(data),
            )
        }
    }

    /// The must-show of issue 31: `ur10.json` (no tool orientation) on the 6-DoF series B,
    /// every 15th pose: the 6-DoF fit's held-out position error is no worse than the
    /// point-only fit's on the same poses (0.422 against 0.452 mm when written), and the
    /// identified robot carries the tool orientation.
    #[test]
    fn ur10_6dof_held_out_position_no_worse_than_point_only() {
        let req = request("series-b-6dof.csv");
        let inputs = crate::Inputs::load(&req).unwrap();
        assert_eq!(
            MeasurementKind::of(&inputs.data, false),
            MeasurementKind::SixDof { targets: 1 }
        );
        let six = crate::calibrate(&req, inputs.clone()).unwrap();
        let six = six.tool_frame().unwrap();
        assert!(!six.rotation_given && six.fit.stop.converged());
        let (_, _, after) = six.validation.clone().unwrap();
        assert_eq!(after.poses, 1395);
        let points_only = IdentifyRequest {
            points_only: true,
            ..req.clone()
        };
        let point = crate::calibrate(&points_only, inputs).unwrap();
        let v = point.points().unwrap().validation.clone().unwrap();
        let point_mean = crate::mean_max(&crate::norms(&v.after)).0;
        assert!(
            after.position_mm.0 <= point_mean,
            "6-DoF {} mm, point-only {point_mean} mm",
            after.position_mm.0
        );
        assert!((after.position_mm.0 - 0.422).abs() < 0.005, "{:?}", after);
        assert!(after.orientation_deg.0 < 0.06);
        let robot = six.identified_robot();
        assert!(robot.tool_rotation_rad().is_some());
        // The written file reads back (optional fields) to the same tool frame (degrees in
        // the file: equal to rounding).
        let back = Robot::from_spec(&robot.to_spec()).unwrap();
        let (a, b) = (
            back.tool_rotation_rad().unwrap(),
            robot.tool_rotation_rad().unwrap(),
        );
        assert!(a.iter().zip(b).all(|(x, y)| (x - y).abs() < 1e-12));
    }

    /// The extended model with 6-DoF data: `paper+compliance` identifies the joint
    /// compliances beside the geometry and the tool frame, lowers the held-out position error
    /// below the geometric fit's (0.381 against 0.422 mm when written), and the validated
    /// model is the one `identified.json` gives when read back (to rounding).
    #[test]
    fn extended_model_with_6dof_data_validates_what_is_written() {
        let req = IdentifyRequest {
            params: "paper+compliance".parse().unwrap(),
            ..request("series-b-6dof.csv")
        };
        let inputs = crate::Inputs::load(&req).unwrap();
        let c = crate::calibrate(&req, inputs).unwrap();
        let c = c.tool_frame().unwrap();
        assert!(c.fit.stop.converged());
        let layout = c.fit.model.robot.layout();
        assert!(
            c.fit
                .free
                .robot
                .iter()
                .any(|&k| layout.get(k).name.starts_with("compliance_"))
        );
        let (_, _, after) = c.validation.clone().unwrap();
        assert!(after.position_mm.0 < 0.41, "{after:?}");
        let read_back = Robot::from_spec(
            &kinematics::RobotSpec::from_json_str(
                &c.identified_robot().to_spec().to_json_string(),
                "identified",
            )
            .unwrap(),
        )
        .unwrap();
        assert!(read_back.is_extended());
        let model = FrameModel {
            robot: read_back,
            ..c.fit.model.clone()
        };
        // To rounding: the file's values are decimal degrees and millimetres.
        let back = PoseErrors::of(&model, c.validation_data.as_ref().unwrap());
        assert!((back.position_mm.0 - after.position_mm.0).abs() < 1e-12);
        assert!((back.position_mm.1 - after.position_mm.1).abs() < 1e-12);
        assert!((back.orientation_deg.0 - after.orientation_deg.0).abs() < 1e-12);
    }

    /// Issue 42: the 6-DoF workflow fits with the request's schedule (`--schedule`,
    /// `schedule=`), which it ignored before: the fit reports it and its first iteration
    /// damps with its μ0; two schedules take different paths to the same calibration.
    #[test]
    fn six_dof_fit_honours_the_requested_schedule() {
        let inputs = crate::Inputs::load(&request("series-b-6dof.csv")).unwrap();
        let run = |damping: identify::Damping| {
            let req = IdentifyRequest {
                damping,
                ..request("series-b-6dof.csv")
            };
            crate::calibrate(&req, inputs.clone()).unwrap()
        };
        let nielsen = identify::Damping::Nielsen { tau: 0.5, nu0: 2.0 };
        let (lev, nie) = (run(identify::Damping::levenberg()), run(nielsen));
        let (lev, nie) = (lev.tool_frame().unwrap(), nie.tool_frame().unwrap());
        assert_eq!(
            (lev.fit.damping, nie.fit.damping),
            (identify::Damping::levenberg(), nielsen)
        );
        assert!(lev.fit.stop.converged() && nie.fit.stop.converged());
        assert_eq!(lev.fit.trace[0].mu, 1e-3);
        assert!((nie.fit.trace[0].mu - 0.5).abs() < 1e-12);
        let mus = |c: &ToolFrameCalibration| c.fit.trace.iter().map(|t| t.mu).collect::<Vec<_>>();
        assert_ne!(mus(lev), mus(nie));
        let held_out = |c: &ToolFrameCalibration| c.validation.as_ref().unwrap().2.position_mm.0;
        assert!((held_out(lev) - held_out(nie)).abs() < 1e-4);
    }

    /// A point-only file is calibrated as points.
    #[test]
    fn point_files_stay_on_the_point_path() {
        let req = request("series-b-joint-configurations.csv");
        let inputs = crate::Inputs::load(&req).unwrap();
        assert_eq!(
            MeasurementKind::of(&inputs.data, false),
            MeasurementKind::Points
        );
    }
}
