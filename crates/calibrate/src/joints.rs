//! Prediction and compensation of joint files: what `kincal predict` and `kincal compensate`
//! compute, rendered as measurement files (`docs/model.md` §5).

use std::path::Path;

use identify::{CompensationOptions, compensate_nearest, kabsch};
use kinematics::Robot;
use measurements::{Measurement, MeasurementSet, to_csv_string};
use nalgebra::Vector3;

use crate::error::{CalibrateError, Refusal, Result};
use crate::files::{LoadedRobot, file_name, poses_rad};

/// The predicted points of a robot at the rows of a joint file.
#[derive(Clone, Debug)]
pub struct Prediction {
    /// `id` (if the input has ids), `q1…qN` as read, predicted `x, y, z` (mm, the robot's
    /// measurement frame), with a comment header.
    pub csv: String,
    /// Rows predicted.
    pub rows: usize,
    /// When every input row has a point: mean and max of |file − predicted| (mm).
    pub file_error_mm: Option<(f64, f64)>,
    /// Reader notices (ignored columns).
    pub notices: Vec<String>,
}

/// Predicts the measured point of `robot` at each row of the joint file `joints`; `out_label`
/// names the output in the CSV (a path or `stdout`).
pub fn predict(robot: &LoadedRobot, joints: &Path, out_label: &str) -> Result<Prediction> {
    let set = robot.read_set(joints, false, (1, None), "joint file")?;
    let mut rows = Vec::with_capacity(set.rows.len());
    let mut errors = Vec::new();
    let mut q = vec![0.0; robot.robot.n_joints()];
    for r in &set.rows {
        for (qr, d) in q.iter_mut().zip(&r.q_deg) {
            *qr = d.to_radians();
        }
        let p = robot.robot.point(&q);
        if let Some(m) = r.point_mm {
            errors.push((Vector3::from(m) - p).norm());
        }
        rows.push(Measurement {
            line: 0,
            id: r.id.clone(),
            q_deg: r.q_deg.clone(),
            point_mm: Some([p.x, p.y, p.z]),
            ..Default::default()
        });
    }
    let n = rows.len();
    let out_set = MeasurementSet::new(out_label, robot.robot.n_joints(), rows);
    let header = format!(
        "kincal predict: points of {} ({}) at the joints of {}\nq in degrees as read; x y z \
         predicted, mm, in the robot's measurement frame",
        robot.robot.name(),
        file_name(&robot.path),
        file_name(joints)
    );
    let csv = to_csv_string(&out_set, Some(&header)).map_err(|source| CalibrateError::Read {
        context: "formatting the predictions".into(),
        source,
    })?;
    let file_error_mm = (n > 0 && errors.len() == n).then(|| {
        let mean = errors.iter().sum::<f64>() / n as f64;
        (mean, errors.iter().copied().fold(0.0, f64::max))
    });
    Ok(Prediction {
        csv,
        rows: n,
        file_error_mm,
        notices: set.notices,
    })
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
    /// rows. Rows without an id get `L<line>` (their line in the targets file).
    pub csv: String,
    /// The joints to command (degrees), one row per compensated target, in the order of the
    /// targets (the rows of `csv`).
    pub joints_deg: Vec<Vec<f64>>,
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
}

/// The size of a robot for [`SAME_FRAME_FRACTION`]: `Σ(|a_i| + |d_i|) + |t|`, mm.
fn robot_size_mm(robot: &Robot) -> f64 {
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
fn check_same_frame(calibrated: &LoadedRobot, nominal: &LoadedRobot, poses: &[f64]) -> Result<()> {
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
/// commanded joints ([`compensate_nearest`]); rows moving a joint by more than
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

/// Refuses two robots with different parameter layouts, up to the Hayati β parameters:
/// those follow the twists (β_i is a parameter where |α_i| < 1°, `docs/model.md` §3), and a
/// calibration may move a nominal α = 0 past 1° (the `parameters` check allows 5°), so that
/// `identified.json` read back has one β fewer than `identify`'s own
/// `registered-nominal.json`. Both still carry every joint's β, which is all compensation
/// (forward kinematics and IK) uses.
fn check_same_layout(calibrated: &LoadedRobot, nominal: &LoadedRobot) -> Result<()> {
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
    check_same_layout(calibrated, nominal)?;
    if set.rows.is_empty() {
        return Err(Refusal::NoTargets {
            file: set.source.clone(),
        }
        .into());
    }
    let (id_r, nom_r): (&Robot, &Robot) = (&calibrated.robot, &nominal.robot);
    let n = nom_r.n_joints();
    check_same_frame(calibrated, nominal, &poses_rad(&set.rows))?;
    let mut rows = Vec::with_capacity(set.rows.len());
    let mut unreachable = Vec::new();
    let mut flagged = Vec::new();
    let mut flag_reasons: std::collections::BTreeMap<&'static str, usize> = Default::default();
    let mut q = vec![0.0; n];
    let mut cmd = vec![0.0; n];
    let (mut max_dq_deg, mut max_err_mm) = (0.0_f64, 0.0_f64);
    for r in &set.rows {
        for (qr, d) in q.iter_mut().zip(&r.q_deg) {
            *qr = d.to_radians();
        }
        cmd.copy_from_slice(&q);
        let id_label = r.id.as_ref().map_or(String::new(), |id| format!("{id}: "));
        match compensate_nearest(nom_r, id_r, &mut q, options) {
            Ok(c) => {
                let target = nom_r.point(&cmd);
                let q_deg: Vec<f64> = q.iter().map(|v| v.to_degrees()).collect();
                for (a, b) in q_deg.iter().zip(&r.q_deg) {
                    max_dq_deg = max_dq_deg.max((a - b).abs());
                }
                max_err_mm = max_err_mm.max(c.report.pos_err_mm);
                if let Some(first) = c.flags.first() {
                    *flag_reasons.entry(first.key()).or_default() += 1;
                    let changes: Vec<String> = q_deg
                        .iter()
                        .zip(&r.q_deg)
                        .enumerate()
                        .filter(|(_, (a, b))| (*a - *b).abs() > options.flag_change_deg)
                        .map(|(i, (a, b))| format!("q{} {:+.2}°", i + 1, a - b))
                        .collect();
                    flagged.push(format!(
                        "{}:{}: {id_label}{}: {}",
                        set.source,
                        r.line,
                        changes.join(", "),
                        c.flags
                            .iter()
                            .map(|f| f.to_string())
                            .collect::<Vec<_>>()
                            .join("; ")
                    ));
                }
                rows.push(Measurement {
                    line: 0,
                    id: Some(r.id.clone().unwrap_or_else(|| format!("L{}", r.line))),
                    q_deg,
                    point_mm: Some([target.x, target.y, target.z]),
                    ..Default::default()
                });
            }
            Err(e) => unreachable.push(format!(
                "{}:{}: {id_label}unreachable: {e}",
                set.source, r.line
            )),
        }
    }
    if !unreachable.is_empty() && !allow_unreachable {
        return Err(Refusal::Unreachable {
            unreachable,
            targets: set.rows.len(),
            file: set.source.clone(),
            robot: id_r.name().to_string(),
        }
        .into());
    }
    if rows.is_empty() {
        return Err(Refusal::NoneReachable {
            unreachable,
            file: set.source.clone(),
        }
        .into());
    }
    let compensated = rows.len();
    let joints_deg = rows.iter().map(|r| r.q_deg.clone()).collect();
    let out_set = MeasurementSet::new(out_label, n, rows);
    let mut header = format!(
        "kincal compensate: joints (degrees) to command so that {} ({}) reaches the points of \
         {} ({}) at the commanded joints of {}\nx y z: that target point, mm",
        id_r.name(),
        file_name(&calibrated.path),
        nom_r.name(),
        file_name(&nominal.path),
        file_name(Path::new(&set.source))
    );
    if !flagged.is_empty() {
        header.push_str(&format!(
            "\nflagged: {} rows move a joint by more than {}° (the nearest exact solution):",
            flagged.len(),
            options.flag_change_deg
        ));
        for f in &flagged {
            header.push_str(&format!("\n  {f}"));
        }
    }
    let csv = to_csv_string(&out_set, Some(&header)).map_err(|source| CalibrateError::Read {
        context: "formatting the joints".into(),
        source,
    })?;
    Ok(Compensation {
        csv,
        joints_deg,
        compensated,
        targets: set.rows.len(),
        unreachable,
        flagged,
        flag_change_deg: options.flag_change_deg,
        flag_reasons: flag_reasons.into_iter().collect(),
        max_joint_change_deg: max_dq_deg,
        max_ik_error_mm: max_err_mm,
        notices: set.notices,
    })
}
