//! The robot model file (JSON) and its validation.
//!
//! ```json
//! {
//!   "name": "KUKA KR1000 Titan",
//!   "joints": [
//!     { "theta_deg": 0, "d_mm": 1100, "a_mm": 600, "alpha_deg": -90, "beta_deg": 0,
//!       "limits_deg": [-150, 150] }
//!   ],
//!   "base": { "rx_deg": 0, "ry_deg": 0, "rz_deg": 0, "dx_mm": 0, "dy_mm": 0, "dz_mm": 0 },
//!   "tool_mm": [60, 20, 150]
//! }
//! ```
//!
//! Every field is required and unknown fields are errors, except the optional `mass_model`
//! section (see [`MassModelSpec`] and `docs/extended-model.md`): link masses and centres of
//! mass plus a payload, for the gravity-torque (joint compliance) parameter families:
//!
//! ```json
//!   "mass_model": {
//!     "gravity_m_per_s2": 9.80665,
//!     "links": [ { "mass_kg": 1650, "com_mm": [-350, 400, 0] } ],
//!     "payload_kg": 0, "payload_com_mm": [0, 0, 250]
//!   }
//! ```
//!
//! Values are in the interface units (degrees, millimetres, kilograms); [`crate::Robot`]
//! converts to radians inside.

use std::fmt;
use std::path::Path;

use serde::de::{self, MapAccess, Visitor};
use serde::{Deserialize, Deserializer, Serialize};

use crate::error::ModelError;
use crate::frame::Frame;

/// Largest number of joints a chain may have (frames live in fixed-size arrays on the stack).
pub const MAX_JOINTS: usize = 16;

/// Largest |angle| a robot file may give, degrees (θ, α, base and tool rotations) [360: one
/// turn; a larger offset is the same angle written wrongly, or a corrupted file].
pub const MAX_ANGLE_DEG: f64 = 360.0;

/// Largest |length| a robot file may give, mm (a, d, base translation, tool, targets, a
/// prismatic joint's limits) [100 m: the largest robots and gantries reach a few metres, a
/// tracker stands within tens of metres; beyond it the file is in other units or corrupted].
pub const MAX_LENGTH_MM: f64 = 100_000.0;

/// A number for a message: shortest form, exponent notation from 10⁶ up (`1.8446744073709552e19`,
/// not twenty digits).
fn short(v: f64) -> String {
    if v.is_finite() && v.abs() >= 1e6 {
        format!("{v:e}")
    } else {
        format!("{v}")
    }
}

/// What a joint's variable moves (`docs/model.md` §2): a rotation about the previous z axis
/// (the default) or a translation along it. The robot file's `type` field; absent means
/// revolute, so files without it read and write as before.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum JointType {
    /// `q` (degrees outside) adds to θ.
    #[default]
    Revolute,
    /// `q` (millimetres outside) adds to d, times the axis scale.
    Prismatic,
}

impl JointType {
    /// True for [`JointType::Revolute`] (serde's `skip_serializing_if`).
    pub fn is_revolute(&self) -> bool {
        *self == JointType::Revolute
    }

    /// `"revolute"` or `"prismatic"`.
    pub fn as_str(self) -> &'static str {
        match self {
            JointType::Revolute => "revolute",
            JointType::Prismatic => "prismatic",
        }
    }

    /// The interface unit of the joint variable and its limits: `"deg"` or `"mm"`.
    pub fn unit(self) -> &'static str {
        match self {
            JointType::Revolute => "deg",
            JointType::Prismatic => "mm",
        }
    }
}

/// One joint in the Hayati-modified standard DH convention (`docs/model.md` §2):
/// revolute `T_i = Rz(θ_i + q_i) · Tz(d_i) · Tx(a_i) · Rx(α_i) · Ry(β_i)`, prismatic
/// `T_i = Rz(θ_i) · Tz(d_i + s_i·q_i) · Tx(a_i) · Rx(α_i) · Ry(β_i)` (s_i the axis scale).
///
/// In the file a prismatic joint has `"type": "prismatic"`, its limits as `limits_mm` and
/// optionally `scale_mm_per_mm` (default 1); a revolute joint has neither of the two and
/// its limits as `limits_deg`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "JointRepr", into = "JointRepr")]
pub struct JointSpec {
    /// Revolute (the default) or prismatic.
    pub joint_type: JointType,
    /// Constant joint-angle offset θ_i, degrees.
    pub theta_deg: f64,
    /// Link offset d_i along the previous z axis, mm (a prismatic joint's offset: the
    /// joint's d at q = 0).
    pub d_mm: f64,
    /// Link length a_i along the new x axis, mm.
    pub a_mm: f64,
    /// Link twist α_i about the new x axis, degrees.
    pub alpha_deg: f64,
    /// Hayati's β_i about the new y axis, degrees (a parameter only where the axis is
    /// parallel to the next one, see [`crate::ParamLayout`]).
    pub beta_deg: f64,
    /// Joint limits `[min, max]` of the joint variable q_i in the joint's interface unit
    /// ([`JointType::unit`]): degrees for a revolute joint (the file's `limits_deg`),
    /// millimetres for a prismatic one (the file's `limits_mm`). Every joint vector at an
    /// interface (measurement files, plans, reports) uses the same per-joint units.
    pub limits_deg: [f64; 2],
    /// The axis scale s_i of a prismatic joint (the encoder's mm per mm, nominally 1): the
    /// joint moves `s_i · q_i` along z. 1 and unused for a revolute joint.
    pub scale_mm_per_mm: f64,
}

impl JointSpec {
    /// A revolute joint (the common case) with these values.
    pub fn revolute(
        theta_deg: f64,
        d_mm: f64,
        a_mm: f64,
        alpha_deg: f64,
        beta_deg: f64,
        limits_deg: [f64; 2],
    ) -> JointSpec {
        JointSpec {
            joint_type: JointType::Revolute,
            theta_deg,
            d_mm,
            a_mm,
            alpha_deg,
            beta_deg,
            limits_deg,
            scale_mm_per_mm: 1.0,
        }
    }

    /// True for a prismatic joint.
    pub fn is_prismatic(&self) -> bool {
        self.joint_type == JointType::Prismatic
    }
}

/// The file form of [`JointSpec`]: `limits_deg` or `limits_mm` by the joint's type.
#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct JointRepr {
    #[serde(rename = "type", default, skip_serializing_if = "Option::is_none")]
    joint_type: Option<JointType>,
    theta_deg: f64,
    d_mm: f64,
    a_mm: f64,
    alpha_deg: f64,
    beta_deg: f64,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    limits_deg: Option<[f64; 2]>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    limits_mm: Option<[f64; 2]>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    scale_mm_per_mm: Option<f64>,
}

impl TryFrom<JointRepr> for JointSpec {
    type Error = String;
    fn try_from(r: JointRepr) -> Result<JointSpec, String> {
        let joint_type = r.joint_type.unwrap_or_default();
        let limits_deg = match (joint_type, r.limits_deg, r.limits_mm) {
            (JointType::Revolute, Some(l), None) | (JointType::Prismatic, None, Some(l)) => l,
            (JointType::Revolute, None, None) => return Err("missing field `limits_deg`".into()),
            (JointType::Prismatic, None, None) => return Err("missing field `limits_mm`".into()),
            (JointType::Revolute, _, Some(_)) => {
                return Err(
                    "`limits_mm` is for a prismatic joint (`\"type\": \"prismatic\"`); \
                            a revolute joint gives `limits_deg`"
                        .into(),
                );
            }
            (JointType::Prismatic, Some(_), _) => {
                return Err(
                    "a prismatic joint gives its limits in millimetres, `limits_mm`, \
                            not `limits_deg`"
                        .into(),
                );
            }
        };
        if joint_type == JointType::Revolute && r.scale_mm_per_mm.is_some() {
            return Err(
                "`scale_mm_per_mm` is for a prismatic joint (`\"type\": \"prismatic\"`)".into(),
            );
        }
        Ok(JointSpec {
            joint_type,
            theta_deg: r.theta_deg,
            d_mm: r.d_mm,
            a_mm: r.a_mm,
            alpha_deg: r.alpha_deg,
            beta_deg: r.beta_deg,
            limits_deg,
            scale_mm_per_mm: r.scale_mm_per_mm.unwrap_or(1.0),
        })
    }
}

impl From<JointSpec> for JointRepr {
    fn from(j: JointSpec) -> JointRepr {
        let prismatic = j.is_prismatic();
        JointRepr {
            joint_type: prismatic.then_some(j.joint_type),
            theta_deg: j.theta_deg,
            d_mm: j.d_mm,
            a_mm: j.a_mm,
            alpha_deg: j.alpha_deg,
            beta_deg: j.beta_deg,
            limits_deg: (!prismatic).then_some(j.limits_deg),
            limits_mm: prismatic.then_some(j.limits_deg),
            scale_mm_per_mm: prismatic.then_some(j.scale_mm_per_mm),
        }
    }
}

/// A base pose `T = Trans(dx, dy, dz) · Rz(rz) · Ry(ry) · Rx(rx)` in interface units: the
/// robot file's `base` (the robot base in the measurement frame; all six fields required)
/// and the scenario's `tracker.base_residual` (the error of the base frame built from the
/// tracker; omitted fields are zero, [`BaseSpec::deserialize_omitted_zero`]). The one
/// base-frame type of the workspace; [`BaseSpec::frame`] is its transform.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BaseSpec {
    /// Rotation about x, degrees.
    pub rx_deg: f64,
    /// Rotation about y, degrees.
    pub ry_deg: f64,
    /// Rotation about z, degrees.
    pub rz_deg: f64,
    /// Translation along x, mm.
    pub dx_mm: f64,
    /// Translation along y, mm.
    pub dy_mm: f64,
    /// Translation along z, mm.
    pub dz_mm: f64,
}

impl BaseSpec {
    /// The field names, in the order of [`BaseSpec::values`].
    pub const FIELDS: [&'static str; 6] = ["rx_deg", "ry_deg", "rz_deg", "dx_mm", "dy_mm", "dz_mm"];

    /// The six values in the order rx, ry, rz (deg), dx, dy, dz (mm).
    pub fn values(&self) -> [f64; 6] {
        [
            self.rx_deg,
            self.ry_deg,
            self.rz_deg,
            self.dx_mm,
            self.dy_mm,
            self.dz_mm,
        ]
    }

    /// The base pose with these six values (order of [`BaseSpec::values`]).
    pub fn from_values([rx_deg, ry_deg, rz_deg, dx_mm, dy_mm, dz_mm]: [f64; 6]) -> BaseSpec {
        BaseSpec {
            rx_deg,
            ry_deg,
            rz_deg,
            dx_mm,
            dy_mm,
            dz_mm,
        }
    }

    /// The first field (name and value) that is not a finite number: what both the robot
    /// file's and the scenario's validation refuse, each naming it by its own path.
    pub fn first_non_finite(&self) -> Option<(&'static str, f64)> {
        Self::FIELDS
            .into_iter()
            .zip(self.values())
            .find(|(_, v)| !v.is_finite())
    }

    /// True if all six values are zero.
    pub fn is_zero(&self) -> bool {
        self.values().iter().all(|v| *v == 0.0)
    }

    /// The rotations (rx, ry, rz) in radians.
    pub fn rotations_rad(&self) -> [f64; 3] {
        [
            self.rx_deg.to_radians(),
            self.ry_deg.to_radians(),
            self.rz_deg.to_radians(),
        ]
    }

    /// The translation (dx, dy, dz) in mm.
    pub fn translation_mm(&self) -> [f64; 3] {
        [self.dx_mm, self.dy_mm, self.dz_mm]
    }

    /// The base pose of rotations in radians and a translation in mm (the inverse of
    /// [`BaseSpec::rotations_rad`] and [`BaseSpec::translation_mm`]).
    pub fn from_internal(r_rad: [f64; 3], d_mm: [f64; 3]) -> BaseSpec {
        let [rx, ry, rz] = r_rad;
        let [dx_mm, dy_mm, dz_mm] = d_mm;
        BaseSpec {
            rx_deg: rx.to_degrees(),
            ry_deg: ry.to_degrees(),
            rz_deg: rz.to_degrees(),
            dx_mm,
            dy_mm,
            dz_mm,
        }
    }

    /// `T = Trans(dx, dy, dz) · Rz(rz) · Ry(ry) · Rx(rx)` ([`Frame::from_base_pose`]).
    pub fn frame(&self) -> Frame {
        Frame::from_base_pose(self.rotations_rad(), self.translation_mm())
    }

    /// Deserializes a base pose whose omitted fields are zero, for a serde field
    /// `#[serde(deserialize_with = "BaseSpec::deserialize_omitted_zero")]` (the scenario's
    /// `tracker.base_residual`). Unknown and repeated fields are errors, as in the robot
    /// file, whose `base` (the derived `Deserialize`) requires all six.
    pub fn deserialize_omitted_zero<'de, D: Deserializer<'de>>(d: D) -> Result<BaseSpec, D::Error> {
        struct OmittedZero;
        impl<'de> Visitor<'de> for OmittedZero {
            type Value = BaseSpec;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("a base pose (rx_deg, ry_deg, rz_deg, dx_mm, dy_mm, dz_mm)")
            }
            fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<BaseSpec, A::Error> {
                let mut values = [0.0; 6];
                let mut seen = [false; 6];
                while let Some(key) = map.next_key::<String>()? {
                    let Some(k) = BaseSpec::FIELDS.iter().position(|f| *f == key) else {
                        return Err(de::Error::unknown_field(&key, &BaseSpec::FIELDS));
                    };
                    if seen[k] {
                        return Err(de::Error::duplicate_field(BaseSpec::FIELDS[k]));
                    }
                    seen[k] = true;
                    values[k] = map.next_value()?;
                }
                Ok(BaseSpec::from_values(values))
            }
        }
        d.deserialize_struct("BaseSpec", &Self::FIELDS, OmittedZero)
    }
}

/// Mass and centre of mass of one link (the body moved by joint i), in the link frame after
/// joint i (frame i of the chain, the frame [`JointSpec`] i ends in).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LinkMassSpec {
    /// Link mass, kg (≥ 0).
    pub mass_kg: f64,
    /// Centre of mass in the link frame, mm.
    pub com_mm: [f64; 3],
}

fn default_gravity() -> f64 {
    9.80665
}

fn default_payload_com() -> [f64; 3] {
    [0.0, 0.0, 250.0]
}

/// Optional mass model of the robot file: what the gravity torque τ_j(q) about every joint
/// is computed from (joint compliance families). Gravity points along −z of the robot base.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MassModelSpec {
    /// Gravitational acceleration, m/s² (default 9.80665).
    #[serde(default = "default_gravity")]
    pub gravity_m_per_s2: f64,
    /// One entry per joint, base to flange.
    pub links: Vec<LinkMassSpec>,
    /// Payload mass, kg (default 0).
    #[serde(default)]
    pub payload_kg: f64,
    /// Payload centre of mass in the flange frame, mm (default (0, 0, 250)).
    #[serde(default = "default_payload_com")]
    pub payload_com_mm: [f64; 3],
}

/// The robot model file.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RobotSpec {
    /// Human-readable name.
    pub name: String,
    /// Joints from base to flange.
    pub joints: Vec<JointSpec>,
    /// Base pose in the measurement frame.
    pub base: BaseSpec,
    /// Measured point (tracker ball, probe) in the flange frame, mm.
    pub tool_mm: [f64; 3],
    /// Optional names of the joints, base to flange (e.g. a URDF's joint names, kept
    /// through calibration so that `urdf export` writes them back). Absent from files that
    /// have none, so those read and write as before.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub joint_names: Option<Vec<String>>,
    /// Optional mass model (link masses, centres of mass, payload) for the gravity-torque
    /// parameter families; absent from files and output when not given.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub mass_model: Option<MassModelSpec>,
    /// Optional non-geometric joint-error parameters with their values (an extended robot,
    /// e.g. an `identified.json` of `--params paper+compliance`; `docs/extended-model.md`);
    /// absent from files and output when not given.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub extended: Option<Vec<ExtendedParamSpec>>,
    /// Optional orientation of the measured frame (a 6-DoF probe's, e.g. a T-Mac's) in the
    /// flange frame, degrees: `[rx, ry, rz]` with `R_tool = Rz(rz)·Ry(ry)·Rx(rx)`, the base's
    /// convention; its origin is `tool_mm`. Absent from files and output when not given (a
    /// 6-DoF calibration then starts from a closed-form estimate, `docs/model.md` §5).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tool_rotation_deg: Option<[f64; 3]>,
    /// Optional named targets (reflectors) on the tool, each a point in the flange frame
    /// (mm), for measurement files with a `target` column; absent when not given (a
    /// calibration then starts each from a closed-form estimate).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub targets: Option<Vec<TargetSpec>>,
    /// Optional standard deviations of the identification's Gaussian prior, by parameter
    /// name, in the parameter's display unit (mm, °, mm/mm): e.g. `{"a2": 0.5, "theta6":
    /// 0.2}` for a robot whose tolerances are known better (or worse) than the manufacturing
    /// tolerances the prior takes by default (`docs/model.md` §7). A `--prior` on the command
    /// line replaces these in turn. Absent from files and output when not given.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub prior_sd: Option<std::collections::BTreeMap<String, f64>>,
    /// Optional mapping from the model's joint values to the axis values a controller
    /// displays and reads (`docs/controller.md`): per joint `axis = sign · q + offset`. Kept
    /// through calibration (`identified.json` carries it); absent from files and output when
    /// not given.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub controller: Option<ControllerSpec>,
    /// What the file is and where it came from, for the files a calibration writes
    /// (`identified.json`, `registered-nominal.json`): readers such as `compensate` refuse a
    /// swapped pair or a pair from different runs. Absent from a robot file written by hand.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub provenance: Option<Provenance>,
}

/// Which controller a robot file's [`ControllerSpec`] describes: the vendor whose axis
/// values, configuration data and program text the robot's controller uses (the default
/// output format of `docs/controller.md` follows it).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ControllerKind {
    /// A KUKA KR C controller (KRL; axes A1…A6).
    Kuka,
    /// An ABB IRC controller (RAPID; axes 1…6).
    Abb,
    /// A Universal Robots controller (URScript; joints base … wrist 3).
    Ur,
}

impl ControllerKind {
    /// `"kuka"`, `"abb"` or `"ur"`, as the robot file writes it.
    pub fn as_str(self) -> &'static str {
        match self {
            ControllerKind::Kuka => "kuka",
            ControllerKind::Abb => "abb",
            ControllerKind::Ur => "ur",
        }
    }
}

/// One controller axis of a [`ControllerSpec`]: the controller's axis value is
/// `sign · q + offset_deg`, with q the model's joint value (the robot file's joint variable,
/// degrees; millimetres, and the offset too, for a prismatic joint).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AxisMapSpec {
    /// Added after the sign, degrees (mm for a prismatic joint); finite, within
    /// ±[`MAX_ANGLE_DEG`].
    pub offset_deg: f64,
    /// +1 where the controller's positive direction is the model's, −1 where it is opposite.
    pub sign: i8,
}

impl AxisMapSpec {
    /// The identity mapping of one axis (offset 0, sign +1).
    pub const IDENTITY: AxisMapSpec = AxisMapSpec {
        offset_deg: 0.0,
        sign: 1,
    };
}

/// The robot file's optional `controller` section: how the controller's axis values relate
/// to the model's joint values, one entry per joint, base to flange.
///
/// ```json
///   "controller": { "kind": "kuka", "axes": [ { "offset_deg": 0, "sign": -1 }, … ] }
/// ```
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ControllerSpec {
    /// The controller's vendor.
    pub kind: ControllerKind,
    /// One mapping per joint: `axis = sign · q + offset_deg`.
    pub axes: Vec<AxisMapSpec>,
}

impl ControllerSpec {
    /// The controller's axis values of the model joint values `joints` (interface units):
    /// `axis_i = sign_i · q_i + offset_i`. Extra values beyond the mapping's axes are copied.
    pub fn axes_of(&self, joints: &[f64]) -> Vec<f64> {
        let id = AxisMapSpec::IDENTITY;
        joints
            .iter()
            .enumerate()
            .map(|(i, q)| {
                let m = self.axes.get(i).unwrap_or(&id);
                f64::from(m.sign) * q + m.offset_deg
            })
            .collect()
    }

    /// The model joint values of controller axis values, the inverse of
    /// [`ControllerSpec::axes_of`]: `q_i = sign_i · (axis_i − offset_i)` (sign is ±1).
    pub fn joints_of(&self, axes: &[f64]) -> Vec<f64> {
        let id = AxisMapSpec::IDENTITY;
        axes.iter()
            .enumerate()
            .map(|(i, a)| {
                let m = self.axes.get(i).unwrap_or(&id);
                f64::from(m.sign) * (a - m.offset_deg)
            })
            .collect()
    }
}

/// What a robot file written by a calibration is ([`RobotSpec::provenance`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum FileRole {
    /// The calibrated robot (`identified.json`).
    Identified,
    /// The nominal robot in the data's measurement frame (`registered-nominal.json`): the
    /// targets of compensation.
    RegisteredNominal,
}

impl std::fmt::Display for FileRole {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            FileRole::Identified => "the identified (calibrated) robot",
            FileRole::RegisteredNominal => "the registered nominal robot",
        })
    }
}

/// Where a robot file written by a calibration came from.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Provenance {
    /// What the file is.
    pub role: FileRole,
    /// The run that wrote it: one digest shared by the files of one calibration (SHA-256 of
    /// the data's digest and both robots, hex, 16 bytes).
    pub run: String,
    /// The identification data, as named to the calibration.
    pub data: String,
    /// SHA-256 of the data (hex): the file's bytes (`sha256sum` gives the same), or of the
    /// rows for data given in memory.
    pub data_sha256: String,
}

/// One named target (reflector) of a robot file's `targets` section.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TargetSpec {
    /// The name the measurement file's `target` column uses.
    pub name: String,
    /// The target's centre in the flange frame, mm.
    pub point_mm: [f64; 3],
}

/// One non-geometric parameter of a robot file's `extended` section.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ExtendedParamSpec {
    /// Stable name: `compliance_J`, `gear_J_hK_sin`, `gear_J_hK_cos`.
    pub name: String,
    /// Value in display units: µrad/(N·m) for compliance, arcseconds for gear terms.
    pub value: f64,
}

impl RobotSpec {
    /// Parses and validates a model from JSON text; `source_name` labels errors. A leading
    /// byte-order mark (as some Windows editors write) is skipped, as the measurement reader
    /// skips it.
    pub fn from_json_str(text: &str, source_name: &str) -> Result<Self, ModelError> {
        let text = text.strip_prefix('\u{feff}').unwrap_or(text);
        // Not a JSON object at all (a measurement CSV given as the robot, say): say what the
        // file starts with rather than serde's "expected value at line 1 column 1".
        let body = text.trim_start();
        if !body.starts_with('{') {
            let start: String = body.lines().next().unwrap_or("").chars().take(40).collect();
            return Err(ModelError::Parse {
                source_name: source_name.to_string(),
                field: ".".to_string(),
                message: if body.is_empty() {
                    "the file is empty; a robot model file is a JSON object (docs/model.md §4)"
                        .to_string()
                } else {
                    format!(
                        "not a robot model file: it starts with `{start}`, where a robot model \
                         file is a JSON object `{{ \"name\": …, \"joints\": [...] }}` \
                         (docs/model.md §4); a measurement or joint CSV goes to --data, \
                         --joints or --targets"
                    )
                },
            });
        }
        let de = &mut serde_json::Deserializer::from_str(text);
        let spec: RobotSpec = serde_path_to_error::deserialize(&mut *de).map_err(|e| {
            let field = e.path().to_string();
            ModelError::Parse {
                source_name: source_name.to_string(),
                field,
                message: e.into_inner().to_string(),
            }
        })?;
        de.end().map_err(|e| ModelError::Parse {
            source_name: source_name.to_string(),
            field: ".".to_string(),
            message: e.to_string(),
        })?;
        spec.validate(source_name)?;
        spec.check_plausible(source_name)?;
        Ok(spec)
    }

    /// Checks that a robot file's numbers are a robot's (finite ones assumed,
    /// [`RobotSpec::validate`]): every angle within ±[`MAX_ANGLE_DEG`] (θ, α, the base's and the
    /// tool's rotations) and every length within ±[`MAX_LENGTH_MM`] (a, d, the base's
    /// translation, the tool and the targets, a prismatic joint's limits). A file with
    /// θ1 = 2⁶⁴ parses as a number but is no robot: the fit on it stalls after one iteration.
    /// Checked where a file is read ([`RobotSpec::from_json_str`]), not on every model built
    /// in memory (an identification may wander further before its checks refuse it).
    ///
    /// # Errors
    /// [`ModelError::Invalid`] naming the field (`joints[0].theta_deg`) and its value, in
    /// exponent form when it is huge.
    pub fn check_plausible(&self, source_name: &str) -> Result<(), ModelError> {
        let check = |field: String, v: f64, bound: f64, unit: &str, what: &str| {
            if v.abs() <= bound {
                return Ok(());
            }
            Err(ModelError::Invalid {
                source_name: source_name.to_string(),
                field: field.clone(),
                message: format!(
                    "{field} = {}{unit} is beyond ±{}{unit}, the bound of {what} \
                     (docs/model.md §4): is the file in other units, or corrupted?",
                    short(v),
                    short(bound)
                ),
            })
        };
        let angle =
            |field: String, v: f64| check(field, v, MAX_ANGLE_DEG, "°", "an angle (one turn)");
        let length = |field: String, v: f64| {
            check(field, v, MAX_LENGTH_MM, " mm", "a robot's lengths (100 m)")
        };
        for (i, j) in self.joints.iter().enumerate() {
            let f = |name: &str| format!("joints[{i}].{name}");
            angle(f("theta_deg"), j.theta_deg)?;
            length(f("d_mm"), j.d_mm)?;
            length(f("a_mm"), j.a_mm)?;
            angle(f("alpha_deg"), j.alpha_deg)?;
            if j.is_prismatic() {
                length(f("limits_mm[0]"), j.limits_deg[0])?;
                length(f("limits_mm[1]"), j.limits_deg[1])?;
            }
        }
        for (name, v) in BaseSpec::FIELDS.iter().zip(self.base.values()) {
            let field = format!("base.{name}");
            if name.ends_with("_deg") {
                angle(field, v)?;
            } else {
                length(field, v)?;
            }
        }
        for (k, v) in self.tool_mm.iter().enumerate() {
            length(format!("tool_mm[{k}]"), *v)?;
        }
        for (k, v) in self.tool_rotation_deg.iter().flatten().enumerate() {
            angle(format!("tool_rotation_deg[{k}]"), *v)?;
        }
        for (k, t) in self.targets.iter().flatten().enumerate() {
            for (c, v) in t.point_mm.iter().enumerate() {
                length(format!("targets[{k}].point_mm[{c}]"), *v)?;
            }
        }
        Ok(())
    }

    /// Reads and validates a model file.
    pub fn from_file(path: &Path) -> Result<Self, ModelError> {
        let text = std::fs::read_to_string(path).map_err(|source| ModelError::Io {
            file: path.to_path_buf(),
            source,
        })?;
        Self::from_json_str(&text, &path.display().to_string())
    }

    /// Pretty JSON of the model, deterministic for the same values.
    pub fn to_json_string(&self) -> String {
        let mut s = serde_json::to_string_pretty(self).expect("a RobotSpec always serialises");
        s.push('\n');
        s
    }

    /// Checks every value: finite numbers, `min < max` limits, 1 ≤ joints ≤ [`MAX_JOINTS`].
    pub fn validate(&self, source_name: &str) -> Result<(), ModelError> {
        let invalid = |field: String, message: String| ModelError::Invalid {
            source_name: source_name.to_string(),
            field,
            message,
        };
        for (name, sd) in self.prior_sd.iter().flatten() {
            if !(sd.is_finite() && *sd > 0.0) {
                return Err(invalid(
                    format!("prior_sd.{name}"),
                    format!("{sd} is not a standard deviation (finite and positive)"),
                ));
            }
        }
        if self.joints.is_empty() || self.joints.len() > MAX_JOINTS {
            return Err(invalid(
                "joints".into(),
                format!(
                    "a chain needs 1 to {MAX_JOINTS} joints, this one has {}",
                    self.joints.len()
                ),
            ));
        }
        let finite = |field: String, v: f64| {
            if v.is_finite() {
                Ok(())
            } else {
                Err(invalid(field, format!("{v} is not a finite number")))
            }
        };
        for (i, j) in self.joints.iter().enumerate() {
            let f = |name: &str| format!("joints[{i}].{name}");
            finite(f("theta_deg"), j.theta_deg)?;
            finite(f("d_mm"), j.d_mm)?;
            finite(f("a_mm"), j.a_mm)?;
            finite(f("alpha_deg"), j.alpha_deg)?;
            finite(f("beta_deg"), j.beta_deg)?;
            let limits = if j.is_prismatic() {
                "limits_mm"
            } else {
                "limits_deg"
            };
            finite(f(&format!("{limits}[0]")), j.limits_deg[0])?;
            finite(f(&format!("{limits}[1]")), j.limits_deg[1])?;
            if j.limits_deg[0] >= j.limits_deg[1] {
                return Err(invalid(
                    f(limits),
                    format!(
                        "minimum {:?} must be below maximum {:?}",
                        j.limits_deg[0], j.limits_deg[1]
                    ),
                ));
            }
            if !(j.scale_mm_per_mm.is_finite() && j.scale_mm_per_mm > 0.0) {
                return Err(invalid(
                    f("scale_mm_per_mm"),
                    format!("{:?} must be a finite number > 0", j.scale_mm_per_mm),
                ));
            }
            if j.beta_deg.abs() >= 90.0 {
                return Err(invalid(
                    f("beta_deg"),
                    format!("{:?} is not a small Hayati angle (|β| < 90°)", j.beta_deg),
                ));
            }
        }
        if let Some((name, v)) = self.base.first_non_finite() {
            finite(format!("base.{name}"), v)?;
        }
        for (k, v) in self.tool_mm.iter().enumerate() {
            finite(format!("tool_mm[{k}]"), *v)?;
        }
        if let Some(r) = &self.tool_rotation_deg {
            for (k, v) in r.iter().enumerate() {
                finite(format!("tool_rotation_deg[{k}]"), *v)?;
            }
        }
        if let Some(targets) = &self.targets {
            for (k, t) in targets.iter().enumerate() {
                if t.name.is_empty() || targets[..k].iter().any(|u| u.name == t.name) {
                    return Err(invalid(
                        format!("targets[{k}].name"),
                        format!("{:?} is empty or repeated", t.name),
                    ));
                }
                for (c, v) in t.point_mm.iter().enumerate() {
                    finite(format!("targets[{k}].point_mm[{c}]"), *v)?;
                }
            }
        }
        if let Some(names) = &self.joint_names {
            if names.len() != self.joints.len() {
                return Err(invalid(
                    "joint_names".into(),
                    format!("{} names for {} joints", names.len(), self.joints.len()),
                ));
            }
            for (k, n) in names.iter().enumerate() {
                if n.is_empty() || names[..k].contains(n) {
                    return Err(invalid(
                        format!("joint_names[{k}]"),
                        format!("{n:?} is empty or repeated"),
                    ));
                }
            }
        }
        // A section of one entry per joint: `field` has `len` entries.
        let per_joint = |field: &str, len: usize| {
            if len == self.joints.len() {
                return Ok(());
            }
            Err(invalid(
                field.into(),
                format!(
                    "needs one entry per joint ({}), has {len}",
                    self.joints.len()
                ),
            ))
        };
        if let Some(c) = &self.controller {
            per_joint("controller.axes", c.axes.len())?;
            for (i, a) in c.axes.iter().enumerate() {
                if !(a.offset_deg.is_finite() && a.offset_deg.abs() <= MAX_ANGLE_DEG) {
                    return Err(invalid(
                        format!("controller.axes[{i}].offset_deg"),
                        format!(
                            "{} is not a finite offset within ±{MAX_ANGLE_DEG}",
                            short(a.offset_deg)
                        ),
                    ));
                }
                if a.sign != 1 && a.sign != -1 {
                    return Err(invalid(
                        format!("controller.axes[{i}].sign"),
                        format!("{} must be 1 or -1", a.sign),
                    ));
                }
            }
        }
        let first_prismatic = self.joints.iter().position(JointSpec::is_prismatic);
        if let (Some(_), Some(i)) = (&self.mass_model, first_prismatic) {
            return Err(invalid(
                "mass_model".into(),
                format!(
                    "the gravity-torque model covers revolute joints only, joint {} is prismatic",
                    i + 1
                ),
            ));
        }
        if let Some(m) = &self.mass_model {
            let non_negative = |field: String, v: f64| {
                if v.is_finite() && v >= 0.0 {
                    Ok(())
                } else {
                    Err(invalid(field, format!("{v:?} must be a finite number ≥ 0")))
                }
            };
            non_negative("mass_model.gravity_m_per_s2".into(), m.gravity_m_per_s2)?;
            per_joint("mass_model.links", m.links.len())?;
            for (i, l) in m.links.iter().enumerate() {
                non_negative(format!("mass_model.links[{i}].mass_kg"), l.mass_kg)?;
                for (k, v) in l.com_mm.iter().enumerate() {
                    finite(format!("mass_model.links[{i}].com_mm[{k}]"), *v)?;
                }
            }
            non_negative("mass_model.payload_kg".into(), m.payload_kg)?;
            for (k, v) in m.payload_com_mm.iter().enumerate() {
                finite(format!("mass_model.payload_com_mm[{k}]"), *v)?;
            }
        }
        Ok(())
    }
}
