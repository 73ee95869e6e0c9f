//! Compensation of Cartesian targets (`kincal compensate --targets` with a file of poses and
//! no joint columns) and the corrected targets a controller takes ([`CorrectedTarget`]).
//!
//! Each target (a TCP position, mm, and optionally an orientation) is first solved on the
//! nominal model, as the robot's controller would ([`kinematics::Robot::solve_ik_nearest`]
//! from the previous target's solution, the first from the start joints), then on the
//! calibrated model from there ([`identify::compensate_nearest_to`]): the exact solution
//! nearest the nominal controller's, flagged like a joint target when it moves a joint by
//! more than the flag threshold. With a calibration of points only (no `tool_rotation_deg`)
//! the orientation is left to the nominal model: the calibrated solve holds the nominal
//! solution's flange orientation, as joint targets do. The corrected target of each row is
//! the nominal model's forward kinematics at the joints to command, in the robot's base frame
//! (the nominal robot file's `base`, the controller's frame): sent to a controller that runs
//! the nominal model, its IK gives back those joints.

use std::fmt;
use std::path::Path;
use std::str::FromStr;

use identify::{CompensationOptions, FlagReason, compensation_target};
use kinematics::rotation::unit_quaternion;
use kinematics::{Frame, IkTarget, Robot};
use measurements::{EulerConvention, MeasurementSet, ReadOptions, quaternion_to_matrix, read_str};
use nalgebra::{Matrix3, Vector3};

use crate::checks::refuse;
use crate::error::{CalibrateError, Refusal, Result};
use crate::files::{LoadedRobot, file_name};
use crate::joints::{
    Compensation, Rows, check_compensation_inputs, check_same_frame, check_same_layout,
};
use crate::request::Check;

/// One compensated target as a controller takes it: the joints to command, or the corrected
/// Cartesian target for a controller that runs the nominal model (its forward kinematics at
/// those joints). Plain values, degrees and millimetres, for the program writers.
#[derive(Clone, Debug, PartialEq)]
pub struct CorrectedTarget {
    /// The target's id (`L<line>`, its line in the targets file, when it has none).
    pub id: String,
    /// The joints to command, degrees (millimetres for a prismatic joint), in the model's
    /// joint convention (`q1…qN` of `docs/model.md` §2).
    pub joints_deg: Vec<f64>,
    /// The nominal controller's joints for the target, degrees: the commanded joints of a
    /// joint target, the nominal model's IK solution of a Cartesian one.
    pub nominal_joints_deg: Vec<f64>,
    /// The corrected target's position: the nominal model's TCP at `joints_deg`, mm, in the
    /// robot's base frame (the nominal robot file's `base`: the controller's frame).
    pub position_mm: [f64; 3],
    /// The corrected target's orientation (the TCP frame's: flange rotation times the tool
    /// rotation) in that frame, unit quaternion `[w, x, y, z]`, `w ≥ 0`.
    pub orientation_wxyz: [f64; 4],
    /// Largest joint change from `nominal_joints_deg`, degrees.
    pub max_change_deg: f64,
    /// Why the row is flagged (it moves a joint by more than the flag threshold), nearest
    /// reason first; empty when it is not.
    pub flags: Vec<FlagReason>,
}

/// Where the orientation of compensated targets comes from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum OrientationSource {
    /// Joint targets: the nominal flange orientation at the commanded joints, held.
    Held,
    /// Cartesian targets on a calibration with orientation (`tool_rotation_deg`, 6-DoF): the
    /// target orientation is reached on the calibrated model.
    Calibrated,
    /// Cartesian targets on a calibration of points only: the orientation is left to the
    /// nominal model (the calibrated solve holds the nominal solution's flange orientation).
    LeftToNominal,
}

/// The frame the positions and orientations of a Cartesian targets file are given in.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum TargetFrame {
    /// The robot's base frame (the nominal robot file's `base`: the controller's frame), the
    /// default.
    #[default]
    Base,
    /// The calibration's measurement frame (the tracker's, where `identify` registered).
    Measurement,
}

impl FromStr for TargetFrame {
    type Err = String;

    fn from_str(s: &str) -> std::result::Result<Self, Self::Err> {
        match s {
            "base" => Ok(TargetFrame::Base),
            "measurement" => Ok(TargetFrame::Measurement),
            _ => Err(format!("unknown frame `{s}` (one of base, measurement)")),
        }
    }
}

impl fmt::Display for TargetFrame {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            TargetFrame::Base => "base",
            TargetFrame::Measurement => "measurement",
        })
    }
}

/// How the columns `rx, ry, rz` of a Cartesian targets file are read.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum OrientationColumns {
    /// Euler angles in this convention, degrees ([`EulerConvention`]; `kuka` is KUKA's
    /// A, B, C: intrinsic `ZYX`, [`EulerConvention::KUKA_ABC`]).
    Euler(EulerConvention),
    /// A rotation vector, radians (a UR controller's `rx, ry, rz`; `rotvec`).
    RotationVector,
}

impl FromStr for OrientationColumns {
    type Err = String;

    /// `kuka`, `rotvec`, or three axis letters (`XYZ` … `zyz`).
    fn from_str(s: &str) -> std::result::Result<Self, Self::Err> {
        match s {
            "kuka" => Ok(OrientationColumns::Euler(EulerConvention::KUKA_ABC)),
            "rotvec" => Ok(OrientationColumns::RotationVector),
            _ => s.parse().map(OrientationColumns::Euler).map_err(|e| {
                format!("{e} (or `kuka` for A, B, C = ZYX, `rotvec` for a rotation vector)")
            }),
        }
    }
}

/// The tool centre point the targets are for: a point and an orientation in the flange
/// frame (the robot file's `tool_mm` and `tool_rotation_deg`, `R_tool = Rz·Ry·Rx`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Tcp {
    /// The TCP in the flange frame, mm.
    pub tool_mm: [f64; 3],
    /// Its orientation `[rx, ry, rz]`, degrees (`None`: the flange's).
    pub tool_rotation_deg: Option<[f64; 3]>,
}

impl fmt::Display for Tcp {
    /// `[x, y, z] mm` and `rotation [rx, ry, rz] deg` when it has one, shortest round-trip
    /// numbers.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let [x, y, z] = self.tool_mm;
        write!(f, "[{x}, {y}, {z}] mm")?;
        if let Some([a, b, c]) = self.tool_rotation_deg {
            write!(f, ", rotation [{a}, {b}, {c}] deg")?;
        }
        Ok(())
    }
}

impl Tcp {
    /// The TCP of `robot`: its `tool_mm` and `tool_rotation_deg`.
    pub fn of(robot: &Robot) -> Tcp {
        let t = robot.tool_mm();
        Tcp {
            tool_mm: [t.x, t.y, t.z],
            tool_rotation_deg: robot.tool_rotation_rad().map(|r| r.map(f64::to_degrees)),
        }
    }

    /// `robot` with this TCP as its tool.
    fn on(&self, robot: &Robot) -> Robot {
        let mut r = robot.clone();
        r.set_tool_mm(Vector3::from(self.tool_mm));
        r.set_tool_rotation_rad(self.tool_rotation_deg.map(|d| d.map(f64::to_radians)));
        r
    }
}

/// The corrected target of `nominal` (its tool is the TCP) at the joints `q_deg` (degrees,
/// as written): the TCP's position (mm) and orientation (`[w, x, y, z]`, `w ≥ 0`) in the
/// robot's base frame, `T_base⁻¹ · T_flange(q) · (R_tool, tool_mm)` — the forward kinematics
/// a controller running `nominal` computes.
pub(crate) fn corrected_pose(nominal: &Robot, q_deg: &[f64]) -> ([f64; 3], [f64; 4]) {
    let q: Vec<f64> = q_deg.iter().map(|v| v.to_radians()).collect();
    let f = nominal.base_frame().inverse().compose(&nominal.flange(&q));
    let p = f.transform_point(&nominal.tool_mm());
    (
        [p.x, p.y, p.z],
        unit_quaternion(&(f.rot * nominal.tool_rotation())),
    )
}

/// What [`compensate_cartesian`] needs besides the robots and the targets.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct CartesianOptions {
    /// The frame of the targets \[[`TargetFrame::Base`]\].
    pub frame: TargetFrame,
    /// How columns `rx, ry, rz` are read (refused without) \[none\].
    pub orientation_columns: Option<OrientationColumns>,
    /// The TCP of both models \[each model's own, from the calibration's files: the
    /// calibrated robot's `tool_mm` and `tool_rotation_deg` (the identified tool), the nominal
    /// robot's (the controller's TCP as the calibration registered it; without a
    /// `tool_rotation_deg` it takes the calibrated robot's)\].
    pub tcp: Option<Tcp>,
    /// The joints the nominal controller starts from, degrees: the first target's nominal IK
    /// is the solution nearest them, each next one the nearest the previous target's \[each
    /// joint's 0 clamped to its limits\]. Targets without an orientation keep the TCP
    /// orientation of the nominal model at these joints.
    pub start_deg: Option<Vec<f64>>,
    /// Take targets that all lie within [`METRES_FRACTION`] of the robot's size from its
    /// base as millimetres anyway (the `length-units` check) \[false\].
    pub allow_length_units: bool,
}

/// Targets that all lie within this fraction of the robot's size (`Σ(|a_i| + |d_i|) +
/// |tool|`) from its base origin are refused as metres [0.01: a UR10's targets in metres lie
/// within 1.8 of the origin, its size is 1,800 mm; no useful target lies within 18 mm of
/// the base].
pub const METRES_FRACTION: f64 = 0.01;

/// Whether the targets text has joint columns (`q1`): a joint targets file; otherwise a
/// file of Cartesian targets. Looks at the header (the first line that is neither blank nor
/// a comment).
pub fn has_joint_columns(text: &str) -> bool {
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    text.lines()
        .map(str::trim)
        .find(|l| !l.is_empty() && !l.starts_with('#'))
        .is_some_and(|h| h.split(',').any(|f| f.trim() == "q1"))
}

/// Reads a Cartesian targets file's text (`docs/model.md` §5 without joint columns: `x, y,
/// z`, optionally `id` and an orientation), named `source`.
pub fn read_cartesian(
    text: &str,
    source: &str,
    columns: Option<OrientationColumns>,
) -> Result<MeasurementSet> {
    let mut opts = ReadOptions::new(0);
    match columns {
        Some(OrientationColumns::Euler(c)) => opts = opts.with_euler(c),
        Some(OrientationColumns::RotationVector) => opts = opts.with_rotation_vector(),
        None => {}
    }
    read_str(text, source, &opts).map_err(|source_err| CalibrateError::Read {
        context: format!("reading the Cartesian targets file {source}"),
        source: source_err,
    })
}

/// [`compensate_poses`] of the Cartesian targets file `targets`.
pub fn compensate_cartesian(
    calibrated: &LoadedRobot,
    nominal: &LoadedRobot,
    targets: &Path,
    allow_unreachable: bool,
    (options, cartesian): (&CompensationOptions, &CartesianOptions),
    out_label: &str,
) -> Result<Compensation> {
    let text = nominal.read_text(targets, "Cartesian targets file")?;
    let set = read_cartesian(
        &text,
        &targets.display().to_string(),
        cartesian.orientation_columns,
    )?;
    compensate_poses(
        calibrated,
        nominal,
        set,
        allow_unreachable,
        (options, cartesian),
        out_label,
    )
}

/// The start joints of the nominal IK, radians: `start_deg` checked (one per joint, within
/// the limits) or each joint's 0 clamped to its limits.
fn start_rad(nominal: &LoadedRobot, start_deg: Option<&[f64]>) -> Result<Vec<f64>> {
    let robot = &nominal.robot;
    let n = robot.n_joints();
    let Some(deg) = start_deg else {
        return Ok((0..n)
            .map(|i| {
                let [lo, hi] = robot.limits_rad(i);
                0.0_f64.clamp(lo, hi)
            })
            .collect());
    };
    let limits = nominal.limits_deg();
    let bad = (deg.len() != n).then(|| format!("{} values for {n} joints", deg.len()));
    let bad = bad.or_else(|| {
        deg.iter().zip(&limits).enumerate().find_map(|(i, (v, l))| {
            (!(l[0]..=l[1]).contains(v)).then(|| {
                format!(
                    "q{} = {v}° is outside its limits [{}, {}]°",
                    i + 1,
                    l[0],
                    l[1]
                )
            })
        })
    });
    if let Some(reason) = bad {
        return Err(Refusal::StartJoints {
            robot: nominal.path.clone(),
            reason,
        }
        .into());
    }
    Ok(deg.iter().map(|d| d.to_radians()).collect())
}

/// Refuses targets that all lie within [`METRES_FRACTION`] of the robot's size from its
/// base origin (positions in the measurement frame): metres read as millimetres.
fn check_target_lengths(
    nominal: &Robot,
    set: &MeasurementSet,
    positions: &[Vector3<f64>],
) -> Result<()> {
    let origin = nominal.base_frame().pos_mm;
    let size = crate::joints::robot_size_mm(nominal);
    let farthest = positions
        .iter()
        .map(|p| (p - origin).norm())
        .fold(0.0_f64, f64::max);
    if farthest < METRES_FRACTION * size {
        return Err(refuse(
            Check::LengthUnits,
            format!(
                "{}: every target lies within {} mm of the robot's base origin, where the \
                 robot ({}) is {} mm in size (Σ|a|+|d|+|tool|): the positions look like \
                 metres",
                set.source,
                measurements::number(farthest, 4),
                nominal.name(),
                measurements::number(size, 1)
            ),
            "write the targets in millimetres (multiply by 1000)",
        )
        .into());
    }
    Ok(())
}

/// For each Cartesian target of `set` (read by [`read_cartesian`]; frame, orientation
/// columns, TCP and start joints in `cartesian`), the joints that bring the calibrated
/// robot's TCP onto it, nearest the nominal controller's solution, and the corrected target
/// ([`Compensation::corrected`]). Unreachable targets (for the nominal model or the
/// calibrated one) are an error listing them unless `allow_unreachable`; rows moving a joint
/// from the nominal solution by more than `options.flag_change_deg` are flagged as joint
/// targets are. The CSV is `id, q1…qN, x, y, z, qw, qx, qy, qz`: the joints to command and
/// the corrected target.
pub fn compensate_poses(
    calibrated: &LoadedRobot,
    nominal: &LoadedRobot,
    set: MeasurementSet,
    allow_unreachable: bool,
    (options, cartesian): (&CompensationOptions, &CartesianOptions),
    out_label: &str,
) -> Result<Compensation> {
    compensate_poses_with(
        (calibrated, None),
        nominal,
        set,
        allow_unreachable,
        (options, cartesian),
        out_label,
    )
}

/// [`compensate_poses`] with the learned residual model of `calibrated`, if given, as
/// [`crate::compensate_rows_with`] applies it: the calibrated solve brings `FK(q) + r(q)`
/// onto each target's position; with the model's orientation part (6-DoF data) the
/// orientation solved is `exp(−r_o(q))·R_target`, so that `exp(r_o(q))·R(q)` (what `predict`
/// writes) is the target's (without it, the orientation as without the model). With a TCP other than the calibrated robot's (`--tcp`), the model's
/// correction of the measured point is applied to it as is. Without a model the result is
/// [`compensate_poses`]'s.
///
/// # Errors
/// As [`compensate_poses`].
pub fn compensate_poses_with(
    (calibrated, model): (&LoadedRobot, Option<&residual::ResidualModel>),
    nominal: &LoadedRobot,
    set: MeasurementSet,
    allow_unreachable: bool,
    (options, cartesian): (&CompensationOptions, &CartesianOptions),
    out_label: &str,
) -> Result<Compensation> {
    check_compensation_inputs((calibrated, model), nominal, &set)?;
    let (tcp_cal, tcp) = cartesian.tcp.map_or_else(
        || {
            let (cal, mut nom) = (Tcp::of(&calibrated.robot), Tcp::of(&nominal.robot));
            nom.tool_rotation_deg = nom.tool_rotation_deg.or(cal.tool_rotation_deg);
            (cal, nom)
        },
        |t| (t, t),
    );
    let (cal, nom) = (tcp_cal.on(&calibrated.robot), tcp.on(&nominal.robot));
    let (r_tool, r_tool_cal) = (nom.tool_rotation(), cal.tool_rotation());
    let to_measurement = match cartesian.frame {
        TargetFrame::Base => nom.base_frame(),
        TargetFrame::Measurement => Frame::identity(),
    };
    let positions: Vec<Vector3<f64>> = set
        .rows
        .iter()
        .map(|r| {
            to_measurement.transform_point(&Vector3::from(r.point_mm.expect("read with points")))
        })
        .collect();
    if !cartesian.allow_length_units {
        check_target_lengths(&nom, &set, &positions)?;
    }
    let start = start_rad(nominal, cartesian.start_deg.as_deref())?;
    let held = nom.flange(&start).rot * r_tool;
    let six_dof = calibrated.robot.tool_rotation_rad().is_some();
    let quaternion = |q: [f64; 4]| {
        let m = quaternion_to_matrix(q);
        Matrix3::from_fn(|i, j| m[i][j])
    };
    // The nominal controller's solutions, each from the previous one.
    let mut solutions = Vec::with_capacity(set.rows.len());
    let mut q = start.clone();
    for (r, p) in set.rows.iter().zip(&positions) {
        let rot = r
            .orientation
            .map_or(held, |o| to_measurement.rot * quaternion(o));
        let target = IkTarget {
            point_in_flange_mm: Vector3::from(tcp.tool_mm),
            position_mm: *p,
            rotation: rot * r_tool.transpose(),
        };
        let mut q_nom = q.clone();
        let solved = nom.solve_ik_nearest(&target, &mut q_nom, &options.ik, &options.search);
        if solved.is_ok() {
            q.clone_from(&q_nom);
        }
        solutions.push(solved.map(|_| (target, q_nom)));
    }
    let solved_poses: Vec<f64> = solutions
        .iter()
        .flatten()
        .flat_map(|(_, q)| q.iter().copied())
        .collect();
    check_same_frame(calibrated, nominal, &solved_poses)?;
    let mut rows = Rows::new(&set.source, options, model);
    for (r, solution) in set.rows.iter().zip(solutions) {
        let (target, q_nom) = match solution {
            Ok(s) => s,
            Err(e) => {
                rows.unreachable(r, " for the nominal model", e);
                continue;
            }
        };
        let target = if six_dof {
            IkTarget {
                point_in_flange_mm: Vector3::from(tcp_cal.tool_mm),
                position_mm: target.position_mm,
                rotation: target.rotation * r_tool * r_tool_cal.transpose(),
            }
        } else {
            compensation_target(&nom, &cal, &q_nom)
        };
        let mut q = q_nom.clone();
        let nominal_deg: Vec<f64> = q_nom.iter().map(|v| v.to_degrees()).collect();
        rows.compensate(r, (&cal, &target), (&nominal_deg, &mut q), None, &nom);
    }
    let mut header = format!(
        "kincal compensate: joints (degrees) to command so that {} ({}; TCP {}) reaches the \
         Cartesian targets of {} (in the robot's {} frame), each solved from the nominal \
         controller's solution on {} ({}; TCP {})\nx y z qw qx qy qz: the corrected target \
         for a controller running the nominal model with its TCP (its forward kinematics at \
         these joints), mm and unit quaternion (scalar first, qw >= 0), in the robot's base \
         frame",
        calibrated.robot.name(),
        file_name(&calibrated.path),
        tcp_cal,
        file_name(Path::new(&set.source)),
        cartesian.frame,
        nominal.robot.name(),
        file_name(&nominal.path),
        tcp,
    );
    let orientation = if six_dof {
        OrientationSource::Calibrated
    } else {
        header.push_str(
            "\norientation: left to the nominal model (the calibration has no orientation: \
             the calibrated solve holds the nominal solution's flange orientation)",
        );
        OrientationSource::LeftToNominal
    };
    rows.finish(
        &mut header,
        (calibrated, &set, out_label),
        allow_unreachable,
        orientation,
    )
}

/// Compensates the targets file `targets`, read once (a pipe reads as a file does), of
/// either kind: joint targets when its header has joint columns (as
/// [`crate::compensate_targets`]; `cartesian` is not used), Cartesian targets otherwise (as
/// [`compensate_cartesian`]). [`Compensation::orientation`] tells which
/// ([`OrientationSource::Held`] for joint targets). With a residual model `model` (that of
/// `calibrated`, [`crate::residual::load_model`]) both kinds apply it
/// ([`crate::compensate_rows_with`], [`compensate_poses_with`]); with `None` the geometry
/// alone.
pub fn compensate_file(
    (calibrated, model): (&LoadedRobot, Option<&residual::ResidualModel>),
    nominal: &LoadedRobot,
    targets: &Path,
    allow_unreachable: bool,
    (options, cartesian): (&CompensationOptions, &CartesianOptions),
    out_label: &str,
) -> Result<Compensation> {
    check_same_layout(calibrated, nominal)?;
    let text = nominal.read_text(targets, "targets file")?;
    let source = targets.display().to_string();
    if has_joint_columns(&text) {
        let what = "target joint file";
        let set =
            nominal.read_text_with(&text, &source, false, (0, None), what, (1.0, 1.0), None)?;
        crate::compensate_rows_with(
            (calibrated, model),
            nominal,
            set,
            allow_unreachable,
            options,
            out_label,
        )
    } else {
        let set = read_cartesian(&text, &source, cartesian.orientation_columns)?;
        compensate_poses_with(
            (calibrated, model),
            nominal,
            set,
            allow_unreachable,
            (options, cartesian),
            out_label,
        )
    }
}

#[cfg(test)]
mod tests {
    use kinematics::rotation::log_so3;
    use measurements::{EulerConvention, Measurement, quaternion_to_rotvec};

    use super::*;

    /// The KR1000 with a base away from the origin (a registered nominal), and a calibrated
    /// robot: every parameter moved by up to ±0.5 mm or ±0.03°, with a tool orientation
    /// (6-DoF) or without (points).
    fn robots(six_dof: bool) -> (LoadedRobot, LoadedRobot) {
        let path =
            Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenarios/robots/kr1000-titan.json");
        let mut spec = kinematics::RobotSpec::from_file(&path).unwrap();
        spec.tool_mm = [60.0, 20.0, 150.0];
        spec.base = kinematics::BaseSpec::from_values([1.0, -2.0, 30.0, 2500.0, -800.0, 300.0]);
        let nominal = LoadedRobot::from_spec(spec, "nominal.json", "nominal").unwrap();
        let mut robot = nominal.robot.clone();
        let p: Vec<f64> = robot
            .params()
            .iter()
            .enumerate()
            .map(|(k, v)| {
                let s = ((k as f64) * 1.7).sin();
                if robot.layout().get(k).unit == kinematics::Unit::Deg {
                    v + 0.03_f64.to_radians() * s
                } else {
                    v + 0.5 * s
                }
            })
            .collect();
        robot.set_params(&p).unwrap();
        if six_dof {
            robot.set_tool_rotation_rad(Some([0.002, -0.001, 0.003]));
        }
        let calibrated = LoadedRobot::from_spec(robot.to_spec(), "identified.json", "c").unwrap();
        (calibrated, nominal)
    }

    /// Commanded joints of the KR1000 away from singularities, degrees.
    fn joints() -> Vec<Vec<f64>> {
        (0..12)
            .map(|k| {
                let t = k as f64;
                vec![
                    40.0 * (0.7 * t).sin(),
                    20.0 + 15.0 * (1.1 * t).cos(),
                    -20.0 + 15.0 * (0.9 * t).sin(),
                    30.0 * (1.3 * t).cos(),
                    60.0 + 20.0 * (0.5 * t).sin(),
                    20.0 * t.sin(),
                ]
            })
            .collect()
    }

    /// The nominal TCP poses at `joints` in the robot's base frame (TCP = `nominal`'s tool
    /// with `tool_rotation`), as a file of Cartesian targets in memory.
    fn targets(nominal: &Robot, tool_rotation: Matrix3<f64>, q_deg: &[Vec<f64>]) -> MeasurementSet {
        let base_inv = nominal.base_frame().inverse();
        let rows = q_deg
            .iter()
            .enumerate()
            .map(|(k, q)| {
                let q: Vec<f64> = q.iter().map(|d| d.to_radians()).collect();
                let f = base_inv.compose(&nominal.flange(&q));
                let p = f.transform_point(&nominal.tool_mm());
                Measurement {
                    line: k + 2,
                    id: Some(format!("t{k}")),
                    point_mm: Some([p.x, p.y, p.z]),
                    orientation: Some(unit_quaternion(&(f.rot * tool_rotation))),
                    ..Default::default()
                }
            })
            .collect();
        MeasurementSet::new("targets.csv", 0, rows)
    }

    fn start(q: &[Vec<f64>]) -> CartesianOptions {
        CartesianOptions {
            start_deg: Some(q[0].clone()),
            ..Default::default()
        }
    }

    /// A 6-DoF calibration: the calibrated model at the joints to command puts its TCP on
    /// each target (position and orientation, to the IK's tolerance); the nominal
    /// controller's solutions are the joints the targets came from; a nominal controller
    /// given the corrected targets finds the joints to command again; quaternion, KUKA A, B,
    /// C and rotation-vector columns give the same joints.
    #[test]
    fn six_dof_targets_are_reached_on_the_calibrated_model() {
        let (cal, nom) = robots(true);
        let q = joints();
        let r_tool = cal.robot.tool_rotation();
        let set = targets(&nom.robot, r_tool, &q);
        let opts = CompensationOptions::default();
        let c =
            compensate_poses(&cal, &nom, set.clone(), false, (&opts, &start(&q)), "out").unwrap();
        assert_eq!(c.orientation, OrientationSource::Calibrated);
        assert_eq!(c.compensated, q.len());
        let base = nom.robot.base_frame();
        for (ct, (row, q_cmd)) in c.corrected.iter().zip(set.rows.iter().zip(&q)) {
            for (a, b) in ct.nominal_joints_deg.iter().zip(q_cmd) {
                assert!((a - b).abs() < 1e-6, "{}: {a} vs {b}", ct.id);
            }
            let qc: Vec<f64> = ct.joints_deg.iter().map(|d| d.to_radians()).collect();
            let f = base.inverse().compose(&cal.robot.flange(&qc));
            let p = f.transform_point(&cal.robot.tool_mm());
            let target = Vector3::from(row.point_mm.unwrap());
            assert!((p - target).norm() < 1e-6, "{}", (p - target).norm());
            let m = quaternion_to_matrix(row.orientation.unwrap());
            let rt = Matrix3::from_fn(|i, j| m[i][j]);
            let angle = log_so3(&(rt.transpose() * f.rot * r_tool)).norm();
            assert!(angle < 1e-8, "{angle:e} rad");
            // The compensation is a calibration's: a tenth of a degree at most.
            assert!(ct.max_change_deg < 0.5 && ct.flags.is_empty(), "{ct:?}");
            // A nominal controller given the corrected target: the joints to command.
            let cm = quaternion_to_matrix(ct.orientation_wxyz);
            let target = IkTarget {
                point_in_flange_mm: nom.robot.tool_mm(),
                position_mm: base.transform_point(&Vector3::from(ct.position_mm)),
                rotation: base.rot * Matrix3::from_fn(|i, j| cm[i][j]) * r_tool.transpose(),
            };
            let mut qn: Vec<f64> = ct
                .nominal_joints_deg
                .iter()
                .map(|d| d.to_radians())
                .collect();
            let nom_tcp = Tcp {
                tool_rotation_deg: cal
                    .robot
                    .tool_rotation_rad()
                    .map(|r| r.map(f64::to_degrees)),
                ..Tcp::of(&nom.robot)
            };
            nom_tcp
                .on(&nom.robot)
                .solve_ik_nearest(&target, &mut qn, &opts.ik, &opts.search)
                .unwrap();
            for (a, b) in qn.iter().zip(&qc) {
                assert!((a - b).abs() < 1e-9, "{}: {a} vs {b}", ct.id);
            }
        }
        // The same targets as text: quaternions, KUKA A, B, C, a rotation vector (radians).
        let kuka = EulerConvention::KUKA_ABC;
        let text = |f: &dyn Fn([f64; 4]) -> [f64; 3], header: &str| {
            let mut s = format!("id,x,y,z,{header}\n");
            for r in &set.rows {
                let [x, y, z] = r.point_mm.unwrap();
                let [a, b, c] = f(r.orientation.unwrap());
                s.push_str(&format!(
                    "{},{x},{y},{z},{a},{b},{c}\n",
                    r.id.as_ref().unwrap()
                ));
            }
            s
        };
        let by_euler = text(&|o| kuka.angles_deg(o), "rx,ry,rz");
        let by_rotvec = text(&quaternion_to_rotvec, "rx,ry,rz");
        for (text, columns) in [
            (by_euler, "kuka".parse().unwrap()),
            (by_rotvec, OrientationColumns::RotationVector),
        ] {
            let set = read_cartesian(&text, "t.csv", Some(columns)).unwrap();
            let d = compensate_poses(&cal, &nom, set, false, (&opts, &start(&q)), "out").unwrap();
            for (a, b) in d
                .joints_deg
                .iter()
                .flatten()
                .zip(c.joints_deg.iter().flatten())
            {
                assert!((a - b).abs() < 1e-7, "{columns:?}: {a} vs {b}");
            }
        }
    }

    /// A calibration of points: the orientation is left to the nominal model, and
    /// Cartesian targets made from joint targets give the joint targets' compensation;
    /// targets in the measurement frame give the same joints as in the base frame; a file
    /// in metres, bad start joints and an unreachable target are refused, naming them.
    #[test]
    fn point_calibration_leaves_the_orientation_to_the_nominal_model() {
        let (cal, nom) = robots(false);
        let q = joints();
        let set = targets(&nom.robot, Matrix3::identity(), &q);
        let opts = CompensationOptions::default();
        let c =
            compensate_poses(&cal, &nom, set.clone(), false, (&opts, &start(&q)), "out").unwrap();
        assert_eq!(c.orientation, OrientationSource::LeftToNominal);
        assert!(
            c.csv.contains("orientation: left to the nominal model"),
            "{}",
            c.csv
        );
        assert!(
            c.csv.contains("\nid,q1,q2,q3,q4,q5,q6,x,y,z,qw,qx,qy,qz\n"),
            "{}",
            c.csv
        );
        let joint_rows = q
            .iter()
            .enumerate()
            .map(|(k, q)| Measurement::new(q.clone(), None).with_id(format!("t{k}")))
            .collect();
        let j = crate::compensate_rows(
            &cal,
            &nom,
            MeasurementSet::new("joints.csv", 6, joint_rows),
            false,
            &opts,
            "out",
        )
        .unwrap();
        for (a, b) in c
            .joints_deg
            .iter()
            .flatten()
            .zip(j.joints_deg.iter().flatten())
        {
            assert!((a - b).abs() < 1e-6, "{a} vs {b}");
        }
        // The measurement frame: the same targets moved by the nominal's base.
        let base = nom.robot.base_frame();
        let mut moved = set.clone();
        for r in &mut moved.rows {
            let p = base.transform_point(&Vector3::from(r.point_mm.unwrap()));
            r.point_mm = Some([p.x, p.y, p.z]);
            let m = quaternion_to_matrix(r.orientation.unwrap());
            r.orientation = Some(unit_quaternion(
                &(base.rot * Matrix3::from_fn(|i, j| m[i][j])),
            ));
        }
        let in_measurement = CartesianOptions {
            frame: TargetFrame::Measurement,
            ..start(&q)
        };
        let m = compensate_poses(&cal, &nom, moved, false, (&opts, &in_measurement), "o").unwrap();
        for (a, b) in m
            .joints_deg
            .iter()
            .flatten()
            .zip(c.joints_deg.iter().flatten())
        {
            assert!((a - b).abs() < 1e-7, "{a} vs {b}");
        }
        // Metres.
        let mut metres = set.clone();
        for r in &mut metres.rows {
            r.point_mm = r.point_mm.map(|p| p.map(|v| v / 1000.0));
        }
        let e = compensate_poses(&cal, &nom, metres, false, (&opts, &start(&q)), "o")
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("targets.csv: every target lies within") && e.contains("metres"),
            "{e}"
        );
        assert!(e.contains("length-units"), "{e}");
        // Start joints.
        let bad = CartesianOptions {
            start_deg: Some(vec![0.0; 5]),
            ..Default::default()
        };
        let e = compensate_poses(&cal, &nom, set.clone(), false, (&opts, &bad), "o")
            .unwrap_err()
            .to_string();
        assert!(e.contains("5 values for 6 joints"), "{e}");
        // A target 10 m away: unreachable for the nominal model, named with its line.
        let mut far = set;
        far.rows[3].point_mm = Some([10_000.0, 0.0, 0.0]);
        let e = compensate_poses(&cal, &nom, far.clone(), false, (&opts, &start(&q)), "o")
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("targets.csv:5: t3: unreachable for the nominal model"),
            "{e}"
        );
        let d = compensate_poses(&cal, &nom, far, true, (&opts, &start(&q)), "o").unwrap();
        assert_eq!((d.compensated, d.unreachable.len()), (q.len() - 1, 1));
    }

    #[test]
    fn the_kind_of_a_targets_file_is_its_header() {
        assert!(has_joint_columns("\u{feff}# c\n\nid, q1,q2\n"));
        assert!(!has_joint_columns("# q1\nid,x,y,z\n1,2,3,4\n"));
        assert_eq!(
            "kuka".parse(),
            Ok(OrientationColumns::Euler(EulerConvention::KUKA_ABC))
        );
        assert!(
            "abc"
                .parse::<OrientationColumns>()
                .unwrap_err()
                .contains("rotvec")
        );
        assert_eq!("measurement".parse(), Ok(TargetFrame::Measurement));
    }
}
