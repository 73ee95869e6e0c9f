//! Robot file → URDF: the chain with its joint origins, rooted at the measurement frame and
//! ending in a fixed link at the measured point.

use std::fmt::Write as _;

use kinematics::{BaseSpec, Frame, JointSpec, Robot, RobotSpec};

use crate::UrdfError;
use kinematics::rotation::rpy_of;

/// Names of the exported URDF's elements.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ExportOptions {
    /// The joints' names, base to tip (default: the robot file's `joint_names`,
    /// else `joint_1` … `joint_N`).
    pub joint_names: Option<Vec<String>>,
    /// `<robot name>` (default: the robot file's name).
    pub robot_name: Option<String>,
}

/// The root link: the measurement frame (the frame of the robot file's points).
pub const ROOT_LINK: &str = "measurement";
/// The robot base frame (frame 0 of the robot file).
pub const BASE_LINK: &str = "base";
/// The flange frame (frame N of the robot file).
pub const FLANGE_LINK: &str = "flange";
/// The deepest link: a fixed link at the measured point (ball, probe), flange orientation.
pub const TOOL_LINK: &str = "tool";

/// Link i's child link name (1-based).
fn link_name(i: usize) -> String {
    format!("link_{i}")
}

/// The joint names to use, checked.
fn joint_names(spec: &RobotSpec, opts: &ExportOptions) -> Result<Vec<String>, UrdfError> {
    let n = spec.joints.len();
    match opts.joint_names.as_ref().or(spec.joint_names.as_ref()) {
        None => Ok((1..=n).map(|i| format!("joint_{i}")).collect()),
        Some(names) if names.len() != n => Err(UrdfError::Options(format!(
            "{} joint names given for a robot with {n} joints",
            names.len()
        ))),
        Some(names) => {
            for (k, a) in names.iter().enumerate() {
                if a.is_empty() || names[..k].contains(a) {
                    return Err(UrdfError::Options(format!(
                        "joint name {:?} is empty or repeated",
                        a
                    )));
                }
            }
            Ok(names.clone())
        }
    }
}

/// The fixed transform of joint i after its motion (a rotation `Rz(q)` or a translation
/// `Tz(q)`, both commute with the first two factors):
/// `Rz(θ_i) · Tz(d_i) · Tx(a_i) · Rx(α_i) · Ry(β_i)`, as the kinematics crate computes it.
fn link_transform(j: &JointSpec) -> Result<Frame, UrdfError> {
    let one = RobotSpec {
        name: String::new(),
        joints: vec![j.clone()],
        base: BaseSpec::default(),
        tool_mm: [0.0; 3],
        joint_names: None,
        mass_model: None,
        extended: None,
        tool_rotation_deg: None,
        targets: None,
        prior_sd: None,
        controller: None,
        provenance: None,
    };
    Ok(Robot::from_spec(&one)?.flange_reference(&[0.0]))
}

/// A joint limit in URDF units: radians, or metres for a prismatic joint.
fn urdf_limit(j: &JointSpec, v: f64) -> f64 {
    if j.is_prismatic() {
        v / 1000.0
    } else {
        v.to_radians()
    }
}

/// A number as URDF text: the shortest decimal that reads back to the same `f64`.
fn num(v: f64) -> String {
    let a = v.abs();
    if a == 0.0 {
        "0".to_string()
    } else if (1e-4..1e7).contains(&a) {
        format!("{v}")
    } else {
        format!("{v:e}")
    }
}

/// `<origin xyz rpy>` of a frame, metres and radians.
fn origin(f: &Frame) -> String {
    let [r, p, y] = rpy_of(&f.rot);
    let t = f.pos_mm / 1000.0;
    format!(
        "<origin xyz=\"{} {} {}\" rpy=\"{} {} {}\"/>",
        num(t.x),
        num(t.y),
        num(t.z),
        num(r),
        num(p),
        num(y)
    )
}

/// XML attribute text.
fn esc(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
        .replace('\'', "&apos;")
}

/// The URDF of a robot file (see `docs/urdf.md`): root link [`ROOT_LINK`] (the measurement
/// frame), a fixed joint to [`BASE_LINK`] (the base pose), one revolute joint per revolute
/// robot joint about its z axis with the limits (one prismatic joint along it, limits in
/// metres, per prismatic joint), the fixed joint to [`FLANGE_LINK`], and a fixed
/// link [`TOOL_LINK`] at the measured point. The θ offsets are folded into the joint
/// origins, so joint value q in the URDF is q of the robot file; no `<calibration>` tags.
/// Effort and velocity limits, which a robot file does not hold, are written as 0.
pub fn export(spec: &RobotSpec, opts: &ExportOptions) -> Result<String, UrdfError> {
    spec.validate(&spec.name)?;
    if let Some(ext) = spec.extended.as_ref().filter(|e| !e.is_empty()) {
        return Err(UrdfError::Options(format!(
            "the robot file has an `extended` section ({} non-geometric parameters: joint \
             compliance, gear harmonics) that a URDF cannot carry; exporting it would drop \
             them silently. Calibrate with geometric `--params` for a URDF",
            ext.len()
        )));
    }
    if let Some((i, j)) = spec
        .joints
        .iter()
        .enumerate()
        .find(|(_, j)| j.is_prismatic() && j.scale_mm_per_mm != 1.0)
    {
        return Err(UrdfError::Options(format!(
            "joint {} is prismatic with an axis scale of {} mm/mm, which a URDF cannot carry \
             (its axis is a unit vector); exporting it would drop the scale silently. \
             Calibrate without `scale{}` for a URDF",
            i + 1,
            j.scale_mm_per_mm,
            i + 1
        )));
    }
    let names = joint_names(spec, opts)?;
    let robot = Robot::from_spec(spec)?;
    let n = spec.joints.len();
    let mut out = String::new();
    let robot_name = opts.robot_name.as_deref().unwrap_or(&spec.name);
    out.push_str("<?xml version=\"1.0\"?>\n");
    let _ = writeln!(
        out,
        "<!-- Written by kincal (urdf export) from the robot file \"{}\". Root link \"{ROOT_LINK}\" is the measurement frame; \"{TOOL_LINK}\" is the measured point. Joint values are those of the robot file (theta offsets are in the origins). Effort and velocity limits are not in a robot file and are written as 0. -->",
        esc(&spec.name).replace("--", "- -")
    );
    let _ = writeln!(out, "<robot name=\"{}\">", esc(robot_name));
    let fixed = |out: &mut String, name: &str, parent: &str, child: &str, f: &Frame| {
        let _ = writeln!(out, "  <link name=\"{child}\"/>");
        let _ = writeln!(out, "  <joint name=\"{name}\" type=\"fixed\">");
        let _ = writeln!(out, "    <parent link=\"{parent}\"/>");
        let _ = writeln!(out, "    <child link=\"{child}\"/>");
        let _ = writeln!(out, "    {}", origin(f));
        out.push_str("  </joint>\n");
    };
    let _ = writeln!(out, "  <link name=\"{ROOT_LINK}\"/>");
    fixed(
        &mut out,
        "measurement_to_base",
        ROOT_LINK,
        BASE_LINK,
        &robot.base_frame(),
    );
    let mut prev_fixed = Frame::identity();
    let mut parent = BASE_LINK.to_string();
    for (i, (j, name)) in spec.joints.iter().zip(&names).enumerate() {
        let child = link_name(i + 1);
        let _ = writeln!(out, "  <link name=\"{child}\"/>");
        let _ = writeln!(
            out,
            "  <joint name=\"{}\" type=\"{}\">",
            esc(name),
            j.joint_type.as_str()
        );
        let _ = writeln!(out, "    <parent link=\"{parent}\"/>");
        let _ = writeln!(out, "    <child link=\"{child}\"/>");
        let _ = writeln!(out, "    {}", origin(&prev_fixed));
        out.push_str("    <axis xyz=\"0 0 1\"/>\n");
        let _ = writeln!(
            out,
            "    <limit lower=\"{}\" upper=\"{}\" effort=\"0\" velocity=\"0\"/>",
            num(urdf_limit(j, j.limits_deg[0])),
            num(urdf_limit(j, j.limits_deg[1]))
        );
        out.push_str("  </joint>\n");
        prev_fixed = link_transform(j)?;
        parent = child;
    }
    let _ = n;
    fixed(&mut out, "flange_fixed", &parent, FLANGE_LINK, &prev_fixed);
    // The tool frame: its orientation where the robot file gives one (a 6-DoF
    // calibration's identified probe frame), else the flange's axes.
    let tool = Frame {
        rot: spec
            .tool_rotation_deg
            .map_or_else(nalgebra::Matrix3::identity, |r| {
                Frame::from_base_pose(r.map(f64::to_radians), [0.0; 3]).rot
            }),
        pos_mm: nalgebra::Vector3::from(spec.tool_mm),
    };
    fixed(&mut out, "tool_fixed", FLANGE_LINK, TOOL_LINK, &tool);
    out.push_str("</robot>\n");
    Ok(out)
}

/// The joint-angle offsets θ of a robot file as a small JSON file, for controllers that take
/// offsets only: per joint its name, `theta_deg`, and with a nominal robot file
/// `nominal_theta_deg` and `delta_deg` (θ − θ nominal, what to add to the controller's zero).
pub fn offsets_json(
    spec: &RobotSpec,
    nominal: Option<&RobotSpec>,
    opts: &ExportOptions,
) -> Result<String, UrdfError> {
    let names = joint_names(spec, opts)?;
    if let Some(nom) = nominal
        && nom.joints.len() != spec.joints.len()
    {
        return Err(UrdfError::Options(format!(
            "the nominal robot \"{}\" has {} joints, \"{}\" has {}",
            nom.name,
            nom.joints.len(),
            spec.name,
            spec.joints.len()
        )));
    }
    let joints: Vec<serde_json::Value> = spec
        .joints
        .iter()
        .zip(&names)
        .enumerate()
        .map(|(i, (j, name))| {
            let mut o = serde_json::Map::new();
            o.insert("name".into(), name.clone().into());
            o.insert("theta_deg".into(), j.theta_deg.into());
            if let Some(nom) = nominal {
                let t0 = nom.joints[i].theta_deg;
                o.insert("nominal_theta_deg".into(), t0.into());
                o.insert("delta_deg".into(), (j.theta_deg - t0).into());
            }
            serde_json::Value::Object(o)
        })
        .collect();
    let mut doc = serde_json::Map::new();
    doc.insert("robot".into(), spec.name.clone().into());
    if let Some(nom) = nominal {
        doc.insert("nominal_robot".into(), nom.name.clone().into());
    }
    doc.insert(
        "note".into(),
        "theta_deg: the robot file's joint-angle offset (the model's joint zero is q = -theta); delta_deg = theta - nominal theta. Only the offsets: the other calibrated parameters are in the URDF.".into(),
    );
    doc.insert("joints".into(), serde_json::Value::Array(joints));
    let mut s = serde_json::to_string_pretty(&serde_json::Value::Object(doc))
        .expect("plain JSON values serialise");
    s.push('\n');
    Ok(s)
}
