//! Prediction and compensation of joint files: what `kincal predict` and `kincal compensate`
//! compute, rendered as measurement files (`docs/model.md` §5).

use std::path::Path;

use identify::{Compensated, CompensationOptions, compensation_target, kabsch};
use kinematics::rotation::{exp_so3, log_so3, unit_quaternion};
use kinematics::{IkTarget, Robot};
use measurements::{Measurement, MeasurementSet, quaternion_to_matrix, to_csv_string};
use nalgebra::{Matrix3, Vector3};

use crate::cartesian::{CorrectedTarget, OrientationSource, corrected_pose};
use crate::error::{CalibrateError, Refusal, Result};
use crate::files::{LoadedRobot, file_name, poses_rad};
use crate::residual::{FixedPoint, ResidualApplied, compensate_to};

/// The predicted points of a robot at the rows of a joint file.
#[derive(Clone, Debug)]
pub struct Prediction {
    /// `id` (if the input has ids), `q1…qN` as read, predicted `x, y, z` (mm, the robot's
    /// measurement frame) and, when the robot has a tool orientation, the measured frame's
    /// orientation `qw, qx, qy, qz` ([`orientation_wxyz`]), with a comment header.
    pub csv: String,
    /// Rows predicted.
    pub rows: usize,
    /// When every input row has a point: mean and max of |file − predicted| (mm).
    pub file_error_mm: Option<(f64, f64)>,
    /// Whether the output has the orientation columns `qw, qx, qy, qz` (the robot has a
    /// tool orientation, `tool_rotation_deg`).
    pub orientation: bool,
    /// When the output has them and every input row has an orientation: mean and max of
    /// the angle between the file's and the predicted orientation (degrees).
    pub file_error_deg: Option<(f64, f64)>,
    /// Reader notices (ignored columns).
    pub notices: Vec<String>,
    /// Whether `x, y, z` include a learned residual model's mean ([`predict_with`]).
    pub residual_model: bool,
}

/// The orientation of the measured frame of `robot` at the joints `q_rad`, when the robot
/// has a tool orientation (`tool_rotation_deg`; `None` otherwise): the flange rotation times
/// the tool rotation `R_tool = Rz·Ry·Rx` (`docs/model.md` §5), the frame model that 6-DoF
/// identification fits, as a unit quaternion `[w, x, y, z]`, scalar first, `w ≥ 0` — the
/// orientation columns `qw, qx, qy, qz` of a measurement file.
pub fn orientation_wxyz(robot: &Robot, q_rad: &[f64]) -> Option<[f64; 4]> {
    robot
        .tool_rotation_rad()
        .map(|_| unit_quaternion(&(robot.flange(q_rad).rot * robot.tool_rotation())))
}

/// [`orientation_wxyz`] with a residual model's orientation mean applied: the measured
/// frame `exp(r_o)·R_flange·R_tool`, `rotation_deg` the mean `r_o` (a rotation vector in the
/// measurement axes, degrees; `docs/residual-model.md`, "6-DoF data"); `None` without one.
pub fn orientation_wxyz_with(
    robot: &Robot,
    q_rad: &[f64],
    rotation_deg: Option<[f64; 3]>,
) -> Option<[f64; 4]> {
    match rotation_deg {
        Some(r) if robot.tool_rotation_rad().is_some() => Some(unit_quaternion(
            &(exp_so3(&Vector3::from(r).map(f64::to_radians))
                * robot.flange(q_rad).rot
                * robot.tool_rotation()),
        )),
        _ => orientation_wxyz(robot, q_rad),
    }
}

/// Predicts the measured point of `robot` at each row of the joint file `joints`, and the
/// measured frame's orientation when the robot has a tool orientation
/// ([`orientation_wxyz`]); `out_label` names the output in the CSV (a path or `stdout`).
pub fn predict(robot: &LoadedRobot, joints: &Path, out_label: &str) -> Result<Prediction> {
    predict_with(robot, None, joints, out_label)
}

/// [`predict`] with a learned residual model (`crate::residual::load_model`): its mean is
/// added to each predicted point, and with `with_sd` its predictive standard deviation is
/// written as the `sx, sy, sz` columns (mm). A model with an orientation part (6-DoF data)
/// on a robot with a tool orientation also rotates the predicted orientation by
/// `exp(r_o(q))` (measurement axes), and with `with_sd` writes that part's standard
/// deviation as the `srx, sry, srz` columns (degrees).
///
/// # Errors
/// As [`predict`]; the residual model's errors (a joint count it was not trained on).
pub fn predict_with(
    robot: &LoadedRobot,
    residual: Option<(&residual::ResidualModel, bool)>,
    joints: &Path,
    out_label: &str,
) -> Result<Prediction> {
    let set = robot.read_set(joints, false, (1, None), "joint file")?;
    let corrections = residual
        .map(|(m, _)| {
            let q: Vec<Vec<f64>> = set.rows.iter().map(|r| r.q_deg.clone()).collect();
            m.predict(&q).map_err(|source| CalibrateError::Residual {
                context: format!(
                    "predicting the residual model at the joints of {}",
                    joints.display()
                ),
                source,
            })
        })
        .transpose()?;
    let orientation = robot.robot.tool_rotation_rad().is_some();
    let rotations = residual
        .filter(|_| orientation)
        .map(|(m, _)| {
            let q: Vec<Vec<f64>> = set.rows.iter().map(|r| r.q_deg.clone()).collect();
            m.predict_orientation(&q)
                .map_err(|source| CalibrateError::Residual {
                    context: format!(
                        "predicting the residual model's orientation part at the joints of {}",
                        joints.display()
                    ),
                    source,
                })
        })
        .transpose()?
        .flatten();
    let with_sd = residual.is_some_and(|(_, sd)| sd);
    let mut rows = Vec::with_capacity(set.rows.len());
    let mut errors = Vec::new();
    let mut angles = Vec::new();
    let mut q = vec![0.0; robot.robot.n_joints()];
    for (k, r) in set.rows.iter().enumerate() {
        for (qr, d) in q.iter_mut().zip(&r.q_deg) {
            *qr = d.to_radians();
        }
        let correction = corrections.as_ref().map(|c| c[k]);
        let p = robot.robot.point(&q)
            + correction.map_or_else(Vector3::zeros, |c| Vector3::from(c.mean_mm));
        if let Some(m) = r.point_mm {
            errors.push((Vector3::from(m) - p).norm());
        }
        let rotation = rotations.as_ref().map(|c| c[k]);
        let o = orientation_wxyz_with(&robot.robot, &q, rotation.map(|c| c.mean_deg));
        if let (Some(o), Some(m)) = (o, r.orientation) {
            angles.push(angle_deg(o, m));
        }
        rows.push(Measurement {
            line: 0,
            id: r.id.clone(),
            q_deg: r.q_deg.clone(),
            point_mm: Some([p.x, p.y, p.z]),
            orientation: o,
            sigma_mm: correction.filter(|_| with_sd).map(|c| c.sd_mm),
            sigma_deg: rotation.filter(|_| with_sd).map(|c| c.sd_deg),
            ..Default::default()
        });
    }
    let n = rows.len();
    let out_set = MeasurementSet::new(out_label, robot.robot.n_joints(), rows);
    let mut header = format!(
        "kincal predict: points of {} ({}) at the joints of {}\nq in degrees as read; x y z \
         predicted, mm, in the robot's measurement frame",
        robot.robot.name(),
        file_name(&robot.path),
        file_name(joints)
    );
    if orientation {
        header.push_str(
            "; qw qx qy qz the measured frame's orientation (flange rotation times the \
             robot's tool_rotation_deg) in that frame, unit quaternion, scalar first, qw >= 0",
        );
    }
    if corrections.is_some() {
        header.push_str(
            "; x y z include the learned residual model's mean (residual-model.json, \
             docs/residual-model.md)",
        );
    }
    if rotations.is_some() {
        header.push_str(
            "; qw qx qy qz include the residual model's orientation part (rotated by \
             exp(r_o(q)), measurement axes)",
        );
    }
    if with_sd {
        header.push_str(
            "; sx sy sz the residual model's predictive standard deviation of the point, mm",
        );
        if rotations.is_some() {
            header.push_str(
                "; srx sry srz that of the orientation, degrees about the measurement axes",
            );
        }
    }
    let csv = to_csv_string(&out_set, Some(&header)).map_err(|source| CalibrateError::Read {
        context: "formatting the predictions".into(),
        source,
    })?;
    let file_error_mm = (n > 0 && errors.len() == n).then(|| {
        let mean = errors.iter().sum::<f64>() / n as f64;
        (mean, errors.iter().copied().fold(0.0, f64::max))
    });
    let file_error_deg = (n > 0 && angles.len() == n).then(|| {
        let mean = angles.iter().sum::<f64>() / n as f64;
        (mean, angles.iter().copied().fold(0.0, f64::max))
    });
    Ok(Prediction {
        csv,
        rows: n,
        file_error_mm,
        orientation,
        file_error_deg,
        notices: set.notices,
        residual_model: corrections.is_some(),
    })
}

/// The angle (degrees) of the rotation between two orientations given as quaternions
/// `[w, x, y, z]` (the second normalised first, as the reader accepts it).
fn angle_deg(a: [f64; 4], b: [f64; 4]) -> f64 {
    let m = |q: [f64; 4]| Matrix3::from_fn(|i, j| quaternion_to_matrix(q)[i][j]);
    log_so3(&(m(a).transpose() * m(b))).norm().to_degrees()
}

/// Smallest mean shift (mm) of the rigid transform between the nominal and the calibrated
/// robot's points that [`compensate_targets`] treats as another measurement frame, for a
/// small robot [10 mm, the threshold above which `identify` registers: geometric errors are
/// millimetres, another frame is metres]. For a larger robot the bound is
/// [`SAME_FRAME_FRACTION`] of its size, whichever is larger.
pub const SAME_FRAME_MM: f64 = 10.0;

/// The bound on the mean shift as a fraction of the robot's size `Σ(|a_i| + |d_i|) + |t|`
/// [0.01: a calibration rotates the base by a few tenths of a degree at most (0.01 rad =
/// 0.57°), which moves points by that fraction of the arm's size; 49 mm for the KR1000,
/// 18 mm for the UR10; another frame is metres or tens of degrees away].
pub const SAME_FRAME_FRACTION: f64 = 0.01;

/// Largest rotation (degrees) of that transform accepted as the same frame [2°: several
/// times what a calibration's base correction rotates; a tracker frame is tens of degrees
/// away, or exactly aligned].
pub const SAME_FRAME_DEG: f64 = 2.0;

/// The joints to command for each target, and what was left out.
#[derive(Clone, Debug)]
pub struct Compensation {
    /// `id, q1…qN, x, y, z`: the joints to command (degrees) and the target point they
    /// reach on the calibrated model (mm), with a comment header that lists the flagged
    /// rows. Rows without an id get `L<line>` (their line in the targets file). For Cartesian
    /// targets (`crate::compensate_poses`) `id, q1…qN, x, y, z, qw, qx, qy, qz`: the joints
    /// to command and the corrected target ([`CorrectedTarget`]).
    pub csv: String,
    /// The joints to command (degrees), one row per compensated target, in the order of the
    /// targets (the rows of `csv`).
    pub joints_deg: Vec<Vec<f64>>,
    /// Each compensated target as a controller takes it (the joints to command and the
    /// corrected Cartesian target), in the order of the rows of `csv`.
    pub corrected: Vec<CorrectedTarget>,
    /// Where the orientation of the targets came from.
    pub orientation: OrientationSource,
    /// Targets compensated.
    pub compensated: usize,
    /// Targets read.
    pub targets: usize,
    /// `file:line: id: unreachable: why`, one per target left out.
    pub unreachable: Vec<String>,
    /// `file:line: id: q4 +14.97°: reason`, one per compensated row that moves a joint by
    /// more than the flag threshold.
    pub flagged: Vec<String>,
    /// The flag threshold used, degrees.
    pub flag_change_deg: f64,
    /// Flagged rows by their first reason ([`identify::FlagReason::key`]), in key order.
    pub flag_reasons: Vec<(&'static str, usize)>,
    /// Largest change of a joint (degrees).
    pub max_joint_change_deg: f64,
    /// Largest IK position error (mm).
    pub max_ik_error_mm: f64,
    /// Reader notices (ignored columns).
    pub notices: Vec<String>,
    /// When a learned residual model was applied (`compensate_rows_with`, …): its file and
    /// what its fixed point did; `None` with the geometry alone.
    pub residual_model: Option<ResidualApplied>,
}

/// The size of a robot for [`SAME_FRAME_FRACTION`]: `Σ(|a_i| + |d_i|) + |t|`, mm.
pub(crate) fn robot_size_mm(robot: &Robot) -> f64 {
    let spec = robot.to_spec();
    spec.joints
        .iter()
        .map(|j| j.a_mm.abs() + j.d_mm.abs())
        .sum::<f64>()
        + robot.tool_mm().norm()
}

/// Refuses a nominal model that is not in the calibrated robot's measurement frame: the
/// rigid transform best mapping the nominal model's points onto the calibrated robot's at the
/// target poses must rotate by at most [`SAME_FRAME_DEG`] and move the points by at most
/// [`SAME_FRAME_MM`] or [`SAME_FRAME_FRACTION`] of the robot's size on average, whichever is
/// larger: what a calibration's base correction can do; a model in another frame (the robot
/// file itself when `identify` registered a tracker frame) is metres or tens of degrees away.
/// (Base parameters alone cannot tell: with redundant parameters the identified base trades
/// against θ1 and d1.) Skipped when the targets do not determine a rotation (fewer than
/// three, or collinear).
pub(crate) fn check_same_frame(
    calibrated: &LoadedRobot,
    nominal: &LoadedRobot,
    poses: &[f64],
) -> Result<()> {
    let (pn, pi) = (nominal.robot.points(poses), calibrated.robot.points(poses));
    let Ok(t) = kabsch(&pn, &pi) else {
        return Ok(());
    };
    let shift = pn.iter().map(|p| (t.apply(p) - p).norm()).sum::<f64>() / pn.len() as f64;
    let bound_mm = SAME_FRAME_MM.max(SAME_FRAME_FRACTION * robot_size_mm(&nominal.robot));
    if shift > bound_mm || t.angle_deg() > SAME_FRAME_DEG {
        return Err(Refusal::DifferentFrames {
            calibrated: calibrated.path.clone(),
            nominal: nominal.path.clone(),
            angle_deg: t.angle_deg(),
            translation_mm: t.translation_mm.norm(),
            shift_mm: shift,
            bound_mm,
        }
        .into());
    }
    Ok(())
}

/// For each commanded pose of `targets`, the joints that bring `calibrated`'s point onto
/// `nominal`'s (flange orientation held), by IK of the calibrated model. Unreachable targets
/// are an error listing them ([`Refusal::Unreachable`]) unless `allow_unreachable`, which
/// leaves them out; `out_label` names the output. Each row is the exact solution nearest the
/// commanded joints ([`identify::compensate_nearest`]); rows moving a joint by more than
/// `options.flag_change_deg` are written, and listed with their reason
/// ([`Compensation::flagged`], and in the output's comment header).
pub fn compensate_targets(
    calibrated: &LoadedRobot,
    nominal: &LoadedRobot,
    targets: &Path,
    allow_unreachable: bool,
    options: &CompensationOptions,
    out_label: &str,
) -> Result<Compensation> {
    check_same_layout(calibrated, nominal)?;
    // No minimum here: a file of no rows is refused by `compensate_rows`, saying so.
    let set = nominal.read_set(targets, false, (0, None), "target joint file")?;
    compensate_rows(
        calibrated,
        nominal,
        set,
        allow_unreachable,
        options,
        out_label,
    )
}

/// The checks every compensation makes before solving, for joint and Cartesian targets
/// alike: the same parameter layout ([`check_same_layout`]), at least one target
/// ([`Refusal::NoTargets`]) and a residual model for the calibrated robot's joints.
pub(crate) fn check_compensation_inputs(
    (calibrated, model): (&LoadedRobot, Option<&residual::ResidualModel>),
    nominal: &LoadedRobot,
    set: &MeasurementSet,
) -> Result<()> {
    check_same_layout(calibrated, nominal)?;
    if set.rows.is_empty() {
        return Err(Refusal::NoTargets {
            file: set.source.clone(),
        }
        .into());
    }
    crate::residual::check_joints(calibrated, model)?;
    Ok(())
}

/// Refuses two robots with different parameter layouts, up to the Hayati β parameters:
/// those follow the twists (β_i is a parameter where |α_i| < 1°, `docs/model.md` §3), and a
/// calibration may move a nominal α = 0 past 1° (the `parameters` check allows 5°), so that
/// `identified.json` read back has one β fewer than `identify`'s own
/// `registered-nominal.json`. Both still carry every joint's β, which is all compensation
/// (forward kinematics and IK) uses.
pub(crate) fn check_same_layout(calibrated: &LoadedRobot, nominal: &LoadedRobot) -> Result<()> {
    let (id_r, nom_r): (&Robot, &Robot) = (&calibrated.robot, &nominal.robot);
    let without_beta = |r: &Robot| -> Vec<kinematics::ParamKind> {
        r.layout()
            .params()
            .iter()
            .map(|p| p.kind)
            .filter(|k| !matches!(k, kinematics::ParamKind::Beta(_)))
            .collect()
    };
    if id_r.n_joints() != nom_r.n_joints() || without_beta(id_r) != without_beta(nom_r) {
        return Err(Refusal::DifferentRobots {
            calibrated: calibrated.path.clone(),
            calibrated_joints: id_r.n_joints(),
            calibrated_params: id_r.n_params(),
            nominal: nominal.path.clone(),
            nominal_joints: nom_r.n_joints(),
            nominal_params: nom_r.n_params(),
        }
        .into());
    }
    Ok(())
}

/// [`compensate_targets`] on target rows already read (joints checked against `nominal`'s
/// limits, as [`LoadedRobot::read_set`] or [`LoadedRobot::check_set`] do).
///
/// # Errors
/// As [`compensate_targets`], without the reading errors.
pub fn compensate_rows(
    calibrated: &LoadedRobot,
    nominal: &LoadedRobot,
    set: MeasurementSet,
    allow_unreachable: bool,
    options: &CompensationOptions,
    out_label: &str,
) -> Result<Compensation> {
    compensate_rows_with(
        (calibrated, None),
        nominal,
        set,
        allow_unreachable,
        options,
        out_label,
    )
}

/// [`compensate_rows`] with the learned residual model of `calibrated`, if given
/// ([`crate::residual::load_model`]): the joints bring the calibrated robot's point with the
/// model's mean, `FK(q) + r(q)`, onto each target ([`crate::residual::FIXED_POINT_TOL_MM`];
/// a target whose fixed point does not converge is left out as unreachable, naming it), and
/// the output's header says so ([`Compensation::residual_model`]). Without a model the
/// result is [`compensate_rows`]'s.
///
/// # Errors
/// As [`compensate_rows`].
pub fn compensate_rows_with(
    (calibrated, model): (&LoadedRobot, Option<&residual::ResidualModel>),
    nominal: &LoadedRobot,
    set: MeasurementSet,
    allow_unreachable: bool,
    options: &CompensationOptions,
    out_label: &str,
) -> Result<Compensation> {
    check_compensation_inputs((calibrated, model), nominal, &set)?;
    let (id_r, nom_r): (&Robot, &Robot) = (&calibrated.robot, &nominal.robot);
    let n = nom_r.n_joints();
    check_same_frame(calibrated, nominal, &poses_rad(&set.rows))?;
    let mut rows = Rows::new(&set.source, options, model);
    let mut q = vec![0.0; n];
    for r in &set.rows {
        for (qr, d) in q.iter_mut().zip(&r.q_deg) {
            *qr = d.to_radians();
        }
        let p = nom_r.point(&q);
        let target = compensation_target(nom_r, id_r, &q);
        rows.compensate(
            r,
            (id_r, &target),
            (&r.q_deg, &mut q),
            Some([p.x, p.y, p.z]),
            nom_r,
        );
    }
    let mut header = format!(
        "kincal compensate: joints (degrees) to command so that {} ({}) reaches the points of \
         {} ({}) at the commanded joints of {}\nx y z: that target point, mm",
        id_r.name(),
        file_name(&calibrated.path),
        nom_r.name(),
        file_name(&nominal.path),
        file_name(Path::new(&set.source))
    );
    rows.finish(
        &mut header,
        (calibrated, &set, out_label),
        allow_unreachable,
        OrientationSource::Held,
    )
}

/// The rows of a compensation as they are solved, and what is said of them: one per target
/// of either kind (joint or Cartesian), so that both are flagged, listed and summed alike.
pub(crate) struct Rows<'a> {
    source: &'a str,
    options: &'a CompensationOptions,
    model: Option<&'a residual::ResidualModel>,
    fixed: Vec<FixedPoint>,
    rows: Vec<Measurement>,
    corrected: Vec<CorrectedTarget>,
    unreachable: Vec<String>,
    flagged: Vec<String>,
    flag_reasons: std::collections::BTreeMap<&'static str, usize>,
    max_dq_deg: f64,
    max_err_mm: f64,
}

impl<'a> Rows<'a> {
    pub(crate) fn new(
        source: &'a str,
        options: &'a CompensationOptions,
        model: Option<&'a residual::ResidualModel>,
    ) -> Self {
        Rows {
            source,
            options,
            model,
            fixed: Vec::new(),
            rows: Vec::new(),
            corrected: Vec::new(),
            unreachable: Vec::new(),
            flagged: Vec::new(),
            flag_reasons: Default::default(),
            max_dq_deg: 0.0,
            max_err_mm: 0.0,
        }
    }

    fn id_label(r: &Measurement) -> String {
        r.id.as_ref().map_or(String::new(), |id| format!("{id}: "))
    }

    /// Target `r` left out: `file:line: id: unreachable{what}: why`.
    pub(crate) fn unreachable(&mut self, r: &Measurement, what: &str, e: impl std::fmt::Display) {
        self.unreachable.push(format!(
            "{}:{}: {}unreachable{what}: {e}",
            self.source,
            r.line,
            Self::id_label(r)
        ));
    }

    /// Target `r` solved for `target` on `identified` ([`compensate_to`], with the residual
    /// model if there is one) from the joints `q_rad` (the nominal controller's, `start_deg`
    /// in degrees; overwritten with the solution) and recorded ([`Rows::record`]), or left out
    /// with the reason.
    pub(crate) fn compensate(
        &mut self,
        r: &Measurement,
        (identified, target): (&Robot, &IkTarget),
        (start_deg, q_rad): (&[f64], &mut [f64]),
        point: Option<[f64; 3]>,
        nominal: &Robot,
    ) {
        match compensate_to(identified, target, q_rad, self.options, self.model) {
            Ok((c, fixed)) => {
                self.record(r, start_deg, q_rad, &c, point, nominal);
                self.fixed.extend(fixed);
            }
            Err(e) => self.unreachable(r, "", e),
        }
    }

    /// Target `r` compensated by `c` at joints `q_rad` from the nominal controller's joints
    /// `start_deg`; its corrected target is `nominal`'s ([`corrected_pose`]: the tool of
    /// `nominal` is the TCP). The row written is the joints and `point` (joint targets: the
    /// target point), or without one the corrected target (Cartesian targets).
    fn record(
        &mut self,
        r: &Measurement,
        start_deg: &[f64],
        q_rad: &[f64],
        c: &Compensated,
        point: Option<[f64; 3]>,
        nominal: &Robot,
    ) {
        let q_deg: Vec<f64> = q_rad.iter().map(|v| v.to_degrees()).collect();
        let (position_mm, orientation_wxyz) = corrected_pose(nominal, &q_deg);
        for (a, b) in q_deg.iter().zip(start_deg) {
            self.max_dq_deg = self.max_dq_deg.max((a - b).abs());
        }
        self.max_err_mm = self.max_err_mm.max(c.report.pos_err_mm);
        if let Some(first) = c.flags.first() {
            *self.flag_reasons.entry(first.key()).or_default() += 1;
            let changes: Vec<String> = q_deg
                .iter()
                .zip(start_deg)
                .enumerate()
                .filter(|(_, (a, b))| (*a - *b).abs() > self.options.flag_change_deg)
                .map(|(i, (a, b))| format!("q{} {:+.2}°", i + 1, a - b))
                .collect();
            self.flagged.push(format!(
                "{}:{}: {}{}: {}",
                self.source,
                r.line,
                Self::id_label(r),
                changes.join(", "),
                c.flags
                    .iter()
                    .map(|f| f.to_string())
                    .collect::<Vec<_>>()
                    .join("; ")
            ));
        }
        let id = r.id.clone().unwrap_or_else(|| format!("L{}", r.line));
        self.corrected.push(CorrectedTarget {
            id: id.clone(),
            joints_deg: q_deg.clone(),
            nominal_joints_deg: start_deg.to_vec(),
            position_mm,
            orientation_wxyz,
            max_change_deg: c.max_change_deg,
            flags: c.flags.clone(),
        });
        self.rows.push(Measurement {
            line: 0,
            id: Some(id),
            q_deg,
            point_mm: Some(point.unwrap_or(position_mm)),
            orientation: point.is_none().then_some(orientation_wxyz),
            ..Default::default()
        });
    }

    /// The [`Compensation`] of the rows recorded for the targets `set` of `calibrated`, with
    /// the output's comment `header` (the flagged rows are appended to it), or the refusal
    /// of unreachable targets (unless allowed) or of none reachable.
    pub(crate) fn finish(
        self,
        header: &mut String,
        (calibrated, set, out_label): (&LoadedRobot, &MeasurementSet, &str),
        allow_unreachable: bool,
        orientation: OrientationSource,
    ) -> Result<Compensation> {
        if !self.unreachable.is_empty() && !allow_unreachable {
            return Err(Refusal::Unreachable {
                unreachable: self.unreachable,
                targets: set.rows.len(),
                file: set.source.clone(),
                robot: calibrated.robot.name().to_string(),
            }
            .into());
        }
        if self.rows.is_empty() {
            return Err(Refusal::NoneReachable {
                unreachable: self.unreachable,
                file: set.source.clone(),
            }
            .into());
        }
        let compensated = self.rows.len();
        let joints_deg = self.rows.iter().map(|r| r.q_deg.clone()).collect();
        let out_set = MeasurementSet::new(out_label, calibrated.robot.n_joints(), self.rows);
        let residual_model = self
            .model
            .map(|_| ResidualApplied::of(calibrated, &self.fixed));
        if let Some(applied) = &residual_model {
            header.push_str(&applied.header_line());
        }
        if !self.flagged.is_empty() {
            header.push_str(&format!(
                "\nflagged: {} rows move a joint by more than {}° (the nearest exact solution):",
                self.flagged.len(),
                self.options.flag_change_deg
            ));
            for f in &self.flagged {
                header.push_str(&format!("\n  {f}"));
            }
        }
        let csv = to_csv_string(&out_set, Some(header)).map_err(|source| CalibrateError::Read {
            context: "formatting the joints".into(),
            source,
        })?;
        Ok(Compensation {
            csv,
            joints_deg,
            corrected: self.corrected,
            orientation,
            compensated,
            targets: set.rows.len(),
            unreachable: self.unreachable,
            flagged: self.flagged,
            flag_change_deg: self.options.flag_change_deg,
            flag_reasons: self.flag_reasons.into_iter().collect(),
            max_joint_change_deg: self.max_dq_deg,
            max_ik_error_mm: self.max_err_mm,
            notices: set.notices.clone(),
            residual_model,
        })
    }
}

#[cfg(test)]
mod tests {
    use identify::frames::{FrameData, FrameModel, FrameRow};
    use kinematics::rotation::exp_so3;

    use super::*;

    /// The orientation `predict` writes is the frame model's of 6-DoF identification
    /// (`identify::frames`): a robot written by [`FrameModel::to_robot`] predicts, at any
    /// joints, the quaternion whose rotation the model sees with no error (to 1e-12 rad),
    /// unit and with w ≥ 0; a robot without a tool orientation predicts none.
    #[test]
    fn predicted_orientation_is_the_frame_models() {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenarios/robots/ur10.json");
        let mut robot = Robot::from_file(&path).unwrap();
        assert_eq!(orientation_wxyz(&robot, &[0.1; 6]), None);
        let p: Vec<f64> = robot
            .params()
            .iter()
            .enumerate()
            .map(|(k, v)| v + 1e-3 * ((k as f64) * 0.7).sin())
            .collect();
        robot.set_params(&p).unwrap();
        for v in [
            Vector3::new(0.2, -0.1, 0.4),
            Vector3::new(-1.4, 2.1, 0.3),
            Vector3::new(0.0, 3.1, 0.0),
        ] {
            let model = FrameModel {
                robot: robot.clone(),
                tool_rotation: exp_so3(&v),
                targets_mm: vec![Vector3::new(10.0, -20.0, 150.0)],
            };
            let written = model.to_robot(&[String::new()], true);
            let poses: Vec<Vec<f64>> = (0..20)
                .map(|j| {
                    (0..6)
                        .map(|i| ((j * 6 + i) as f64 * 1.3).sin() * 3.0)
                        .collect()
                })
                .collect();
            let rows = poses
                .iter()
                .enumerate()
                .map(|(j, q)| {
                    let o = orientation_wxyz(&written, q).unwrap();
                    let n = o.iter().map(|x| x * x).sum::<f64>().sqrt();
                    assert!((n - 1.0).abs() < 1e-15 && o[0] >= 0.0, "{o:?}");
                    let m = quaternion_to_matrix(o);
                    FrameRow {
                        pose: j,
                        target: 0,
                        point_mm: written.point(q),
                        rotation: Some(Matrix3::from_fn(|r, c| m[r][c])),
                        w_pos: [1.0; 3],
                        w_rot: 1.0,
                    }
                })
                .collect();
            let data = FrameData {
                poses_rad: poses.concat(),
                n_joints: 6,
                target_names: vec![String::new()],
                rows,
            };
            for (dp, dr) in model.errors(&data) {
                assert!(dp.norm() < 1e-9, "{dp}");
                let angle_rad = dr.unwrap().norm().to_radians();
                assert!(angle_rad < 1e-12, "{v}: {angle_rad:e} rad");
            }
        }
    }
}
