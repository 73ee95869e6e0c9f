//! Controller program text from calibrated targets (issue 40, `docs/controller.md`): the
//! per-axis mapping from the model's joint values to the axis values a controller uses, the
//! configuration data a Cartesian target needs (KUKA Status and Turn, ABB confdata), and
//! writers and readers of target declarations in four formats.
//!
//! # Input and what is written
//!
//! A [`Target`] is what a compensation gives per target: a name, the joints to command
//! (model joint values, degrees) and the corrected Cartesian target for a controller that
//! runs the nominal model (position, mm, and orientation as a unit quaternion `[w, x, y, z]`,
//! scalar first, in the robot's base frame; without one, the nominal model's orientation at
//! the joints is written). [`declare`] applies the robot file's `controller` mapping
//! (`kinematics::ControllerSpec`: `axis = sign · q + offset`, the identity where the file has
//! none) and computes the arm's configuration ([`ArmConfig`]) from the model's geometry;
//! [`write()`] renders the declarations in a [`Format`]; [`read`] parses them back.
//!
//! | format | declarations |
//! |---|---|
//! | `csv` | `target,a1_deg…a6_deg,x_mm,y_mm,z_mm,qw,qx,qy,qz`, one row a target |
//! | `kuka-krl` | a `.dat` (`DEFDAT … ENDDAT`): `DECL E6POS XPk={X …,Y …,Z …,A …,B …,C …,S …,T …,E1 0.0,…,E6 0.0}` and `DECL E6AXIS XAk={A1 …,…,A6 …,E1 0.0,…,E6 0.0}` |
//! | `abb-rapid` | a module: `CONST robtarget pk:=[[x,y,z],[q1,q2,q3,q4],[cf1,cf4,cf6,cfx],[9E+09,…]];`, `CONST jointtarget jk:=[[a1,…,a6],[9E+09,…]];` and `MoveAbsJ jk` in `main` |
//! | `urscript` | `def name():` with `global pk = p[x,y,z,rx,ry,rz]` (m, rotation vector in rad), `global qk = [q1,…,q6]` (rad) and `movej(qk)` |
//!
//! Each target is preceded by a comment line `target <name>` (`;`, `!`, `#`), which the
//! readers use to give the declarations back their name.
//!
//! # Conventions and sources
//!
//! - **KUKA KRL** (E6POS, E6AXIS; KUKA System Software 8 programming manual, "Status and
//!   Turn"; Beckhoff TF5200 "Status & Turn (IS, IT)", which documents KUKA's rule): A, B, C
//!   are the intrinsic ZYX Euler angles in degrees (`R = Rz(A)·Ry(B)·Rx(C)`,
//!   `measurements::EulerConvention::KUKA_ABC`; at B = ±90° C is 0, SciPy's rule). Status
//!   S: bit 0 set when the wrist point has a negative x in the A1 coordinate system (the
//!   overhead area; KUKA's expert programming manual as quoted on robot-forum.com), bit 1 set
//!   when the wrist point is in front of the line through the axes of A2 and A3 (the normal,
//!   elbow-up side: A3 at or beyond its stretched position), bit 2 set when A5 ≤ 0 (KUKA's
//!   rule; Beckhoff writes A5 < 0, which differs at A5 = 0 exactly). Turn T: bit i set when
//!   axis i+1 < 0.
//! - **ABB RAPID** (robtarget, jointtarget, confdata; ABB "Technical reference manual –
//!   RAPID Instructions, Functions and Data types", the `abb_rapid_msgs/RobTarget`
//!   description): the orientation is the quaternion `[q1, q2, q3, q4] = [w, x, y, z]`;
//!   `cf1, cf4, cf6 = ⌊axis/90°⌋` (quadrant 0 is \[0°, 90°), −1 is \[−90°, 0°)); `cfx` of a
//!   serial six-axis arm `= 4·(wrist behind axis 1) + 2·(wrist behind the lower arm) +
//!   (axis 5 < 0)` (ABB's table as recalled, not checked against a copy of the manual);
//!   the external axes are 9E+09 (none).
//! - **URScript** (Universal Robots "The URScript Programming Language", `movej`, `movel`,
//!   pose `p[x, y, z, rx, ry, rz]`): positions in metres, orientation as the rotation vector
//!   (axis · angle, rad; `measurements::quaternion_to_rotvec`, angle in \[0, π\]), joints in
//!   radians.
//!
//! # Number formatting
//!
//! Fixed decimals, so the same targets give the same bytes: millimetres 3 decimals,
//! degrees (axis values, A, B, C) 4, quaternion components 9, metres 6, radians 7; a value
//! that rounds to zero is written without a sign. Reading back recovers every value within
//! half its last printed digit.
//!
//! # What the crate does not do
//!
//! Solve kinematics (the targets come compensated, `calibrate`), know a controller's tool and
//! base data (the Cartesian targets are the tool centre point in the robot's base frame: the
//! controller's TOOL must be the robot file's `tool_mm`/`tool_rotation_deg` and its BASE the
//! robot base), or write files (a front end writes the text).

mod config;
mod csv;
mod error;
mod krl;
mod number;
mod rapid;
mod urscript;

use std::fmt;
use std::str::FromStr;

use kinematics::{AxisMapSpec, ControllerKind, ControllerSpec, Robot};
use nalgebra::Matrix3;

pub use config::{ArmConfig, abb_confdata, kuka_status, kuka_turn};
pub use error::ControllerError;

/// Axes a declaration holds: a six-axis arm.
pub const AXES: usize = 6;

/// One target as a compensation gives it (calibrate's result converts field by field).
#[derive(Clone, Debug, PartialEq)]
pub struct Target {
    /// Name or id (one line without control characters or spaces around it; written in a
    /// comment before the declarations).
    pub name: String,
    /// The joints to command: model joint values, degrees.
    pub joints_deg: Vec<f64>,
    /// The corrected Cartesian target's position in the robot's base frame, mm.
    pub position_mm: [f64; 3],
    /// Its orientation, unit quaternion `[w, x, y, z]`, scalar first; `None`: the nominal
    /// model's at `joints_deg` (a position-only calibration leaves it to the nominal model).
    pub orientation_wxyz: Option<[f64; 4]>,
}

/// A target ready to be written: controller axis values and configuration.
#[derive(Clone, Debug, PartialEq)]
pub struct Declaration {
    /// The target's name.
    pub name: String,
    /// The controller's axis values, degrees (`sign · q + offset` of the mapping).
    pub axes_deg: [f64; AXES],
    /// Position in the robot's base frame, mm.
    pub position_mm: [f64; 3],
    /// Orientation, unit quaternion `[w, x, y, z]` with `w ≥ 0`.
    pub orientation_wxyz: [f64; 4],
    /// The arm's configuration at the joints.
    pub config: ArmConfig,
}

/// One target parsed back from program text: what its declarations held.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ReadTarget {
    /// The name of its `target` comment, else the declared variable's.
    pub name: String,
    /// Axis values, degrees (E6AXIS, jointtarget, URScript joints, CSV).
    pub axes_deg: Option<[f64; AXES]>,
    /// Position, mm.
    pub position_mm: Option<[f64; 3]>,
    /// Orientation, unit quaternion `[w, x, y, z]` (from A, B, C, the quaternion or the
    /// rotation vector).
    pub orientation_wxyz: Option<[f64; 4]>,
    /// KUKA Status and Turn of an E6POS.
    pub kuka_status_turn: Option<(u8, u8)>,
    /// ABB confdata `[cf1, cf4, cf6, cfx]` of a robtarget.
    pub abb_confdata: Option<[i32; 4]>,
}

/// An output format (`kincal compensate --format`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Format {
    /// Comma-separated values (the default).
    Csv,
    /// KUKA KRL `.dat` declarations (E6POS, E6AXIS).
    KukaKrl,
    /// ABB RAPID module (robtarget, jointtarget).
    AbbRapid,
    /// Universal Robots URScript program.
    Urscript,
}

impl Format {
    /// Every format, in the order of the documentation.
    pub const ALL: [Format; 4] = [
        Format::Csv,
        Format::KukaKrl,
        Format::AbbRapid,
        Format::Urscript,
    ];

    /// The name on the command line: `csv`, `kuka-krl`, `abb-rapid`, `urscript`.
    pub fn as_str(self) -> &'static str {
        match self {
            Format::Csv => "csv",
            Format::KukaKrl => "kuka-krl",
            Format::AbbRapid => "abb-rapid",
            Format::Urscript => "urscript",
        }
    }

    /// The file extension a controller expects: `csv`, `dat`, `mod`, `script`.
    pub fn extension(self) -> &'static str {
        match self {
            Format::Csv => "csv",
            Format::KukaKrl => "dat",
            Format::AbbRapid => "mod",
            Format::Urscript => "script",
        }
    }

    /// The format of a controller kind's own language.
    pub fn of_kind(kind: ControllerKind) -> Format {
        match kind {
            ControllerKind::Kuka => Format::KukaKrl,
            ControllerKind::Abb => Format::AbbRapid,
            ControllerKind::Ur => Format::Urscript,
        }
    }
}

impl fmt::Display for Format {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

impl FromStr for Format {
    type Err = ControllerError;
    fn from_str(s: &str) -> Result<Format, ControllerError> {
        Format::ALL
            .into_iter()
            .find(|f| f.as_str() == s)
            .ok_or_else(|| ControllerError::UnknownFormat(s.to_owned()))
    }
}

/// The robot's controller mapping: the robot file's, else the identity (its `kind` then
/// `kuka`, which no writer reads: the format is chosen by the caller).
pub fn mapping(robot: &Robot) -> ControllerSpec {
    robot
        .controller()
        .cloned()
        .unwrap_or_else(|| ControllerSpec {
            kind: ControllerKind::Kuka,
            axes: vec![AxisMapSpec::IDENTITY; robot.n_joints()],
        })
}

/// The tool centre point's pose in the robot's base frame at the model joints `joints_deg`:
/// position (mm) and orientation (`[w, x, y, z]`, `w ≥ 0`) of
/// `T_base⁻¹ · T_flange(q) · (R_tool, tool_mm)`, the nominal forward kinematics a
/// controller running `robot` computes.
pub fn tcp_pose(robot: &Robot, joints_deg: &[f64]) -> ([f64; 3], [f64; 4]) {
    let q: Vec<f64> = joints_deg.iter().map(|v| v.to_radians()).collect();
    let base_inv = robot.base_frame().inverse();
    let flange = base_inv.compose(&robot.flange(&q));
    let p = flange.transform_point(&robot.tool_mm());
    let r: Matrix3<f64> = flange.rot * robot.tool_rotation();
    (p.into(), kinematics::rotation::unit_quaternion(&r))
}

/// The declarations of `targets` on `robot`: each target's axis values (the robot file's
/// `controller` mapping), its orientation (given, else the nominal model's at the joints)
/// and its configuration ([`ArmConfig::of`]).
///
/// # Errors
/// [`ControllerError::UnsupportedRobot`] for a robot without six revolute joints;
/// [`ControllerError::Target`] for a wrong joint count, a non-finite value, a quaternion
/// that is not unit (to [`measurements::QUATERNION_NORM_TOLERANCE`]) or a name that is not
/// one line.
pub fn declare(robot: &Robot, targets: &[Target]) -> Result<Vec<Declaration>, ControllerError> {
    let n = robot.n_joints();
    if n != AXES || (0..n).any(|i| robot.joint_type(i) != kinematics::JointType::Revolute) {
        return Err(ControllerError::UnsupportedRobot(format!(
            "{}: controller declarations are written for six revolute joints, this robot has \
             {n} joints{}",
            robot.name(),
            if robot.has_prismatic() {
                " with a prismatic one (a track is an external axis, not written)"
            } else {
                ""
            }
        )));
    }
    let map = mapping(robot);
    targets
        .iter()
        .enumerate()
        .map(|(index, t)| {
            let bad = |message: String| ControllerError::Target {
                index,
                name: t.name.clone(),
                message,
            };
            if t.name.is_empty() || t.name.chars().any(char::is_control) || t.name.trim() != t.name
            {
                return Err(bad(
                    "a name is one line of text, without control characters \
                     or spaces around it"
                        .into(),
                ));
            }
            if t.joints_deg.len() != n {
                return Err(bad(format!(
                    "{} joint values for a robot of {n} joints",
                    t.joints_deg.len()
                )));
            }
            let finite = |what: &str, v: &[f64]| match v.iter().position(|x| !x.is_finite()) {
                Some(k) => Err(bad(format!("{what}[{k}] = {} is not finite", v[k]))),
                None => Ok(()),
            };
            finite("joints_deg", &t.joints_deg)?;
            finite("position_mm", &t.position_mm)?;
            let orientation = match t.orientation_wxyz {
                Some(q) => {
                    finite("orientation_wxyz", &q)?;
                    let norm = q.iter().map(|v| v * v).sum::<f64>().sqrt();
                    if (norm - 1.0).abs() > measurements::QUATERNION_NORM_TOLERANCE {
                        return Err(bad(format!(
                            "orientation_wxyz has norm {norm}, not a unit quaternion"
                        )));
                    }
                    let q = q.map(|v| v / norm);
                    if q[0] < 0.0 { q.map(|v| -v) } else { q }
                }
                None => tcp_pose(robot, &t.joints_deg).1,
            };
            let axes = map.axes_of(&t.joints_deg);
            let mut axes_deg = [0.0; AXES];
            axes_deg.copy_from_slice(&axes);
            Ok(Declaration {
                name: t.name.clone(),
                axes_deg,
                position_mm: t.position_mm,
                orientation_wxyz: orientation,
                config: ArmConfig::of(robot, &t.joints_deg, &axes_deg),
            })
        })
        .collect()
}

/// The declarations as program text of `format`; `program` names the program (KRL's
/// `DEFDAT`, RAPID's `MODULE`, URScript's `def`; unused by CSV), a letter then letters,
/// digits or `_`, at most 24 characters (KRL's limit). `header` lines are written as
/// comments at the top (provenance: robot, calibration, date-free so the bytes are
/// deterministic).
///
/// # Errors
/// [`ControllerError::ProgramName`] for a name that is not such an identifier.
pub fn write(
    format: Format,
    program: &str,
    header: &[String],
    declarations: &[Declaration],
) -> Result<String, ControllerError> {
    let ok = program.len() <= 24
        && program.starts_with(|c: char| c.is_ascii_alphabetic())
        && program
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || c == '_');
    if !ok {
        return Err(ControllerError::ProgramName {
            name: program.to_owned(),
            message: "a letter, then letters, digits or _, at most 24 characters".into(),
        });
    }
    Ok(match format {
        Format::Csv => csv::write(header, declarations),
        Format::KukaKrl => krl::write(program, header, declarations),
        Format::AbbRapid => rapid::write(program, header, declarations),
        Format::Urscript => urscript::write(program, header, declarations),
    })
}

/// The targets declared in `text` of `format`; `source_name` labels errors.
///
/// # Errors
/// [`ControllerError::Parse`] naming the line and the field that does not parse.
pub fn read(
    format: Format,
    text: &str,
    source_name: &str,
) -> Result<Vec<ReadTarget>, ControllerError> {
    match format {
        Format::Csv => csv::read(text, source_name),
        Format::KukaKrl => krl::read(text, source_name),
        Format::AbbRapid => rapid::read(text, source_name),
        Format::Urscript => urscript::read(text, source_name),
    }
}
