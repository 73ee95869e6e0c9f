//! URDF → robot file: the serial chain between a base link and a tip link.

use std::collections::{HashMap, HashSet};
use std::path::Path;

use kinematics::JointType as KinJointType;
use kinematics::{BaseSpec, Frame, JointSpec, MAX_JOINTS, Robot, RobotSpec};
use nalgebra::{Matrix3, Vector3};
use urdf_rs::JointType;

use crate::UrdfError;
use kinematics::rotation::{from_rpy, rpy_of};

/// Axes closer to parallel than this (degrees) are converted with Hayati's β (d = 0) instead
/// of the common normal, which is ill-defined there; it is the robot file's own threshold
/// for making β a parameter ([`kinematics::BETA_ALPHA_TOL_DEG`]).
const PARALLEL_DEG: f64 = kinematics::BETA_ALPHA_TOL_DEG;

/// A parallel axis meeting the plane z = 0 this close (mm) to the origin gets θ = 0, a = 0.
const INTERSECT_MM: f64 = 1e-10;

/// What to import besides the chain.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ImportOptions {
    /// The measured point (ball, probe) in the tip link's frame, mm (default: the tip
    /// link's origin).
    pub tool_in_tip_mm: [f64; 3],
    /// The robot file's name (default: the URDF's `<robot name>`).
    pub name: Option<String>,
    /// Import a chain whose reach is implausible for a robot arm ([`check_reach`]), e.g. a
    /// URDF that really describes a 60 m crane (default false: refused).
    pub allow_implausible_size: bool,
}

/// Smallest plausible reach of an imported robot ([`reach_mm`]), mm [20: the smallest arms
/// calibrated with a tracker reach a few hundred mm (a UR3 0.5 m); a chain in a unit a
/// thousand times too large for its numbers (kilometres) reaches a few mm].
pub const MIN_REACH_MM: f64 = 20.0;

/// Largest plausible reach of an imported robot, mm [50,000: the largest serial arms reach
/// 3–5 m (the KR1000 Titan 3.6 m); a URDF written in millimetres, where the format requires
/// metres, gives a thousand times the robot: hundreds of metres to kilometres].
pub const MAX_REACH_MM: f64 = 50_000.0;

/// The reach of a robot file, mm: the larger distance of the measured point from the base
/// frame's origin at q = 0 and at the middle of the joint limits. A physical size: unlike
/// Σ(|a| + |d|) it does not grow with the common normals of nearly parallel axes, which lie
/// metres away on a compact robot.
pub fn reach_mm(spec: &RobotSpec) -> Result<f64, UrdfError> {
    let robot = Robot::from_spec(spec)?;
    let origin = Vector3::new(spec.base.dx_mm, spec.base.dy_mm, spec.base.dz_mm);
    let zero = vec![0.0; spec.joints.len()];
    let mid: Vec<f64> = spec
        .joints
        .iter()
        .map(|j| (0.5 * (j.limits_deg[0] + j.limits_deg[1])).to_radians())
        .collect();
    Ok([zero, mid]
        .iter()
        .map(|q| (robot.point(q) - origin).norm())
        .fold(0.0, f64::max))
}

/// Refuses a robot whose reach ([`reach_mm`]) is outside
/// [[`MIN_REACH_MM`], [`MAX_REACH_MM`]]: lengths in the wrong unit (a URDF's
/// `<origin xyz>` in millimetres instead of metres, ×1000).
pub fn check_reach(spec: &RobotSpec, source_name: &str) -> Result<(), UrdfError> {
    let reach_mm = reach_mm(spec)?;
    if (MIN_REACH_MM..=MAX_REACH_MM).contains(&reach_mm) {
        return Ok(());
    }
    let looks_like = if reach_mm > MAX_REACH_MM {
        "URDF lengths are metres: these look like millimetres (each length 1000 times the robot's)"
    } else {
        "smaller than any robot arm (lengths in a unit larger than metres, or a scaled model)"
    };
    Err(UrdfError::ImplausibleSize {
        source_name: source_name.to_string(),
        reach_mm,
        looks_like,
    })
}

/// A converted chain.
#[derive(Clone, Debug, PartialEq)]
pub struct Imported {
    /// The robot file.
    pub spec: RobotSpec,
    /// The URDF names of the revolute and prismatic joints, base to tip (joint i of the
    /// robot file).
    pub joint_names: Vec<String>,
    /// The fixed joints folded into the parameters, base to tip.
    pub fixed_joints: Vec<String>,
    /// The tip link's frame in the robot file's flange frame (identity rotation unless the
    /// tip's orientation cannot be given to the flange, see `docs/urdf.md`): the tip link is
    /// `flange · tip_in_flange`.
    pub tip_in_flange: Frame,
}

/// Reads a URDF file and converts the chain from `base` to `tip` (see [`import_str`]).
pub fn import_file(
    path: &Path,
    base: &str,
    tip: &str,
    opts: &ImportOptions,
) -> Result<Imported, UrdfError> {
    let text = std::fs::read_to_string(path).map_err(|source| UrdfError::Io {
        file: path.to_path_buf(),
        source,
    })?;
    import_str(&text, &path.display().to_string(), base, tip, opts)
}

/// The first loop of parent joints, if any: with at most one parent joint per link, walking
/// up from every link must end at a root; a walk that meets a link of its own path has found a
/// closed structure (e.g. a fixed joint from the tip back to the base). Each link is walked
/// through once.
fn closed_loop(
    joints: &[urdf_rs::Joint],
    parent_joint: &HashMap<&str, &urdf_rs::Joint>,
    source_name: &str,
) -> Option<UrdfError> {
    let mut finished: HashSet<&str> = HashSet::new();
    for start in joints.iter().map(|j| j.child.link.as_str()) {
        // The links of this walk, in order, with the joint above each.
        let mut path: Vec<(&str, &urdf_rs::Joint)> = Vec::new();
        let mut link = start;
        while !finished.contains(link) {
            let Some(&j) = parent_joint.get(link) else {
                break;
            };
            if let Some(k) = path.iter().position(|(l, _)| *l == link) {
                let cycle = &path[k..];
                // Name the loop's last joint in the file, and list the loop from its child.
                let position = |name: &str| joints.iter().position(|j| j.name == name);
                let c = (0..cycle.len())
                    .max_by_key(|&i| position(&cycle[i].1.name))
                    .unwrap_or(0);
                let links: Vec<&str> = cycle[c..]
                    .iter()
                    .chain(&cycle[..=c])
                    .map(|(l, _)| *l)
                    .collect();
                return Some(UrdfError::ClosedLoop {
                    source_name: source_name.to_string(),
                    joint: cycle[c].1.name.clone(),
                    cycle: links.join(" ← "),
                });
            }
            path.push((link, j));
            link = j.parent.link.as_str();
        }
        finished.extend(path.iter().map(|(l, _)| *l));
    }
    None
}

/// One element of the chain at q = 0: a fixed transform or a revolute joint.
struct Step<'a> {
    joint: &'a urdf_rs::Joint,
    origin: Frame,
}

/// Converts the serial chain from link `base` to link `tip` of a plain URDF (xacro already
/// expanded) into a robot file whose measured point, for every joint vector, is the tip
/// link's point `tool_in_tip_mm` as the URDF places it (base link frame = measurement frame).
///
/// Revolute and prismatic joints become the robot file's joints (same zero, same sign,
/// limits kept: radians → degrees, metres → millimetres); fixed joints are folded into the
/// parameters; everything off the chain is ignored.
/// `source_name` labels errors.
pub fn import_str(
    text: &str,
    source_name: &str,
    base: &str,
    tip: &str,
    opts: &ImportOptions,
) -> Result<Imported, UrdfError> {
    let src = || source_name.to_string();
    let robot = urdf_rs::read_from_string(text).map_err(|e| UrdfError::Xml {
        source_name: src(),
        message: e.to_string(),
    })?;
    for (link, role) in [(base, "base"), (tip, "tip")] {
        if !robot.links.iter().any(|l| l.name == link) {
            return Err(UrdfError::UnknownLink {
                source_name: src(),
                link: link.to_string(),
                role,
                known: robot
                    .links
                    .iter()
                    .map(|l| l.name.as_str())
                    .collect::<Vec<_>>()
                    .join(", "),
            });
        }
    }
    // A joint from a link to itself is the smallest closed loop.
    if let Some(j) = robot.joints.iter().find(|j| j.parent.link == j.child.link) {
        return Err(UrdfError::ClosedLoop {
            source_name: src(),
            joint: j.name.clone(),
            cycle: format!("{0} ← {0}", j.child.link),
        });
    }
    // The joint above each link; a second one means the description is not a tree.
    let mut parent_joint: HashMap<&str, &urdf_rs::Joint> = HashMap::new();
    for j in &robot.joints {
        if let Some(first) = parent_joint.insert(j.child.link.as_str(), j) {
            return Err(UrdfError::Branching {
                source_name: src(),
                link: j.child.link.clone(),
                first: first.name.clone(),
                second: j.name.clone(),
            });
        }
    }
    if let Some(err) = closed_loop(&robot.joints, &parent_joint, source_name) {
        return Err(err);
    }
    // Walk up from the tip to the base.
    let mut chain: Vec<&urdf_rs::Joint> = Vec::new();
    let mut path = vec![tip.to_string()];
    let mut link = tip;
    while link != base {
        match parent_joint.get(link) {
            Some(j) if chain.len() <= robot.joints.len() => {
                chain.push(j);
                link = j.parent.link.as_str();
                path.push(link.to_string());
            }
            _ => {
                return Err(UrdfError::TipNotBelowBase {
                    source_name: src(),
                    base: base.to_string(),
                    tip: tip.to_string(),
                    path: path.join(" ← "),
                });
            }
        }
    }
    chain.reverse();

    // Every element in mm, checked.
    let mut steps = Vec::with_capacity(chain.len());
    for j in chain {
        let unsupported = |hint: &'static str| UrdfError::UnsupportedJoint {
            source_name: src(),
            joint: j.name.clone(),
            kind: joint_type_name(&j.joint_type),
            chain: format!("from \"{base}\" to \"{tip}\""),
            hint,
        };
        match j.joint_type {
            JointType::Fixed => {}
            JointType::Revolute | JointType::Prismatic => {
                let (lo, hi) = (j.limit.lower, j.limit.upper);
                if !(lo.is_finite() && hi.is_finite() && lo < hi) {
                    return Err(UrdfError::MissingLimits {
                        source_name: src(),
                        joint: j.name.clone(),
                        lower: lo,
                        upper: hi,
                    });
                }
                let a = Vector3::from(j.axis.xyz.0);
                if !(a.iter().all(|v| v.is_finite()) && a.norm() > 0.0) {
                    return Err(UrdfError::BadAxis {
                        source_name: src(),
                        joint: j.name.clone(),
                        xyz: format!("{} {} {}", a.x, a.y, a.z),
                    });
                }
            }
            JointType::Continuous => {
                return Err(unsupported(
                    " (a continuous joint has no limits: make it revolute with the range the robot may use)",
                ));
            }
            _ => return Err(unsupported("")),
        }
        let (xyz, rpy) = (j.origin.xyz.0, j.origin.rpy.0);
        if !xyz.iter().chain(rpy.iter()).all(|v| v.is_finite()) {
            return Err(UrdfError::NotFinite {
                source_name: src(),
                joint: j.name.clone(),
            });
        }
        steps.push(Step {
            joint: j,
            origin: Frame {
                rot: from_rpy(rpy),
                pos_mm: Vector3::from(xyz) * 1000.0,
            },
        });
    }
    let moving = |t: &JointType| matches!(t, JointType::Revolute | JointType::Prismatic);
    let n = steps.iter().filter(|s| moving(&s.joint.joint_type)).count();
    if n == 0 || n > MAX_JOINTS {
        return Err(UrdfError::JointCount {
            source_name: src(),
            base: base.to_string(),
            tip: tip.to_string(),
            found: n,
            max: MAX_JOINTS,
        });
    }

    // The axes (point, direction) and the tip in the base link's frame at q = 0.
    let mut world = Frame::identity();
    let mut axes: Vec<(Vector3<f64>, Vector3<f64>)> = Vec::with_capacity(n);
    let mut limits = Vec::with_capacity(n);
    let mut types = Vec::with_capacity(n);
    let mut joint_names = Vec::with_capacity(n);
    let mut fixed_joints = Vec::new();
    for s in &steps {
        world = world.compose(&s.origin);
        if moving(&s.joint.joint_type) {
            let a = Vector3::from(s.joint.axis.xyz.0);
            axes.push((world.pos_mm, world.rot * (a / a.norm())));
            let (lo, hi) = (s.joint.limit.lower, s.joint.limit.upper);
            if s.joint.joint_type == JointType::Prismatic {
                // A prismatic joint moves along its axis: its line can be taken through the
                // joint's origin, which is where the chain is at q = 0.
                types.push(KinJointType::Prismatic);
                limits.push([lo * 1000.0, hi * 1000.0]);
            } else {
                types.push(KinJointType::Revolute);
                limits.push([lo.to_degrees(), hi.to_degrees()]);
            }
            joint_names.push(s.joint.name.clone());
        } else {
            fixed_joints.push(s.joint.name.clone());
        }
    }
    let tip_frame = world;

    // Frame 0: z along axis 1, origin the point of axis 1 nearest the base link's origin,
    // x the base link's x (or y) projected on the plane normal to the axis.
    let (p1, u1) = axes[0];
    let o0 = p1 - u1 * p1.dot(&u1);
    let mut x0 = Vector3::x() - u1 * u1.x;
    if x0.norm() < 0.1 {
        x0 = Vector3::y() - u1 * u1.y;
    }
    let x0 = x0.normalize();
    let r0 = Matrix3::from_columns(&[x0, u1.cross(&x0), u1]);
    let [rx, ry, rz] = rpy_of(&r0);
    let ang = |v: f64| if v.abs() < 1e-12 { 0.0 } else { v.to_degrees() };
    let len = |v: f64| if v.abs() < 1e-10 { 0.0 } else { v };
    let base_spec = BaseSpec {
        rx_deg: ang(rx),
        ry_deg: ang(ry),
        rz_deg: ang(rz),
        dx_mm: len(o0.x),
        dy_mm: len(o0.y),
        dz_mm: len(o0.z),
    };
    let name = opts.name.clone().unwrap_or_else(|| robot.name.clone());
    let mut spec = RobotSpec {
        name,
        joints: Vec::with_capacity(n),
        base: base_spec,
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

    // Joints 1..N−1: frame i has z along axis i+1 and its origin on it; each frame is the
    // one the kinematics crate computes from the parameters found so far, so rounding does
    // not accumulate along the chain.
    for i in 0..n {
        let prev = frame_of(&spec, source_name, limits[i])?;
        let joint = if i + 1 < n {
            let (p, u) = axes[i + 1];
            let pl = prev.rot.transpose() * (p - prev.pos_mm);
            let ul = prev.rot.transpose() * u;
            link_to_axis(&pl, &ul.normalize())
        } else {
            let rl = prev.rot.transpose() * tip_frame.rot;
            let pl = prev.rot.transpose() * (tip_frame.pos_mm - prev.pos_mm);
            link_to_frame(&rl, &pl)
        };
        spec.joints.push(JointSpec {
            limits_deg: limits[i],
            joint_type: types[i],
            ..snap(joint)
        });
    }
    // The measured point: the tip link's point in the flange frame.
    let robot_k = Robot::from_spec(&spec)?;
    let flange = robot_k.flange_reference(&vec![0.0; n]);
    let tip_in_flange = flange.inverse().compose(&tip_frame);
    let tool = tip_in_flange.transform_point(&Vector3::from(opts.tool_in_tip_mm));
    spec.tool_mm = tool.map(|v| if v.abs() < 1e-10 { 0.0 } else { v }).into();
    spec.joint_names = Some(joint_names.clone());
    spec.validate(source_name)?;
    if !opts.allow_implausible_size {
        check_reach(&spec, source_name)?;
    }
    Ok(Imported {
        spec,
        joint_names,
        fixed_joints,
        tip_in_flange,
    })
}

/// Rounding residue (|angle| < 1e-12°, |length| < 1e-10 mm) set to zero, for readable files:
/// each later frame is computed from the snapped values, so the change stays below
/// 1e-10 mm at the tip and does not accumulate.
fn snap(j: JointSpec) -> JointSpec {
    let ang = |v: f64| if v.abs() < 1e-12 { 0.0 } else { v };
    let len = |v: f64| if v.abs() < 1e-10 { 0.0 } else { v };
    JointSpec {
        theta_deg: ang(j.theta_deg),
        d_mm: len(j.d_mm),
        a_mm: len(j.a_mm),
        alpha_deg: ang(j.alpha_deg),
        beta_deg: ang(j.beta_deg),
        ..j
    }
}

fn joint_type_name(t: &JointType) -> &'static str {
    match t {
        JointType::Revolute => "revolute",
        JointType::Continuous => "continuous",
        JointType::Prismatic => "prismatic",
        JointType::Fixed => "fixed",
        JointType::Floating => "floating",
        JointType::Planar => "planar",
        JointType::Spherical => "spherical",
    }
}

/// The frame at the end of the joints converted so far (frame 0, the base, when there are
/// none), at q = 0, as the kinematics crate computes it.
fn frame_of(spec: &RobotSpec, source_name: &str, limits: [f64; 2]) -> Result<Frame, UrdfError> {
    let mut s = spec.clone();
    if s.joints.is_empty() {
        // A placeholder joint to make a valid file: only its base frame is used.
        s.joints
            .push(JointSpec::revolute(0.0, 0.0, 0.0, 0.0, 0.0, limits));
        s.validate(source_name)?;
        return Ok(Robot::from_spec(&s)?.base_frame());
    }
    s.validate(source_name)?;
    let r = Robot::from_spec(&s)?;
    Ok(r.flange_reference(&vec![0.0; s.joints.len()]))
}

/// Wraps an angle in degrees into (−180, 180].
fn wrap_deg(a: f64) -> f64 {
    let w = a % 360.0;
    if w > 180.0 {
        w - 360.0
    } else if w <= -180.0 {
        w + 360.0
    } else {
        w
    }
}

/// The link parameters taking the previous frame (z along this joint's axis, origin on it)
/// to a frame with z along the next axis `u` (unit, previous frame's coordinates) through
/// the point `p`: the common normal (DH) where the axes are not parallel, Hayati's β with
/// d = 0 where they are. Of the two directions of x, the one with |θ| ≤ 90° is taken.
fn link_to_axis(p: &Vector3<f64>, u: &Vector3<f64>) -> JointSpec {
    let c = u.z;
    let s = u.x.hypot(u.y);
    let parallel = s < PARALLEL_DEG.to_radians().sin();
    let (theta, d, a) = if parallel {
        // The point where the next axis meets the plane z = 0.
        let q = p - u * (p.z / u.z);
        let r = q.x.hypot(q.y);
        if r < INTERSECT_MM {
            (0.0, 0.0, 0.0)
        } else {
            (q.y.atan2(q.x), 0.0, r)
        }
    } else {
        // The common normal is along e_z × u; a is the lines' distance along it, d the
        // foot of the normal on this axis (closest points of t·e_z and p + s·u).
        let x = Vector3::new(-u.y, u.x, 0.0) / s;
        let t = (p.z - c * p.dot(u)) / (1.0 - c * c);
        (x.y.atan2(x.x), t, p.dot(&x))
    };
    // Prefer |θ| ≤ 90° (a and x flip sign together).
    let (theta, a) = if theta.abs() > std::f64::consts::FRAC_PI_2 + 1e-12 {
        let t = if theta > 0.0 {
            theta - std::f64::consts::PI
        } else {
            theta + std::f64::consts::PI
        };
        (t, -a)
    } else {
        (theta, a)
    };
    // The next axis in the frame after Rz(θ)·Tz(d)·Tx(a).
    let (st, ct) = theta.sin_cos();
    let ul = Vector3::new(ct * u.x + st * u.y, -st * u.x + ct * u.y, u.z);
    let (alpha, beta) = if parallel {
        // Rx(α)·Ry(β)·e_z = (sin β, −sin α cos β, cos α cos β).
        ((-ul.y).atan2(ul.z), ul.x.clamp(-1.0, 1.0).asin())
    } else {
        ((-ul.y).atan2(ul.z), 0.0)
    };
    JointSpec::revolute(
        wrap_deg(theta.to_degrees()),
        d,
        a,
        alpha.to_degrees(),
        beta.to_degrees(),
        [0.0, 0.0],
    )
}

/// The last link: a flange frame with the tip link's orientation `r` where that is possible
/// with `Rz(θ)·Rx(α)·Ry(β)`, |β| < 90° (always, but for |β| at 90° exactly), origin the
/// point `(a cos θ, a sin θ, d)` nearest the tip's origin `p`; the remainder goes to the tool.
fn link_to_frame(r: &Matrix3<f64>, p: &Vector3<f64>) -> JointSpec {
    // y column of Rz(θ)·Rx(α)·Ry(β) = (−sin θ cos α, cos θ cos α, sin α).
    let y = r.column(1);
    let h = y.x.hypot(y.y);
    let mut best: Option<(f64, f64, f64)> = None;
    for sign in [1.0, -1.0] {
        let alpha = y.z.atan2(sign * h);
        let theta = (-sign * y.x).atan2(sign * y.y);
        let m = rot_x(-alpha) * rot_z(-theta) * r;
        let beta = m[(0, 2)].atan2(m[(0, 0)]);
        if best.is_none_or(|(_, _, b)| beta.abs() < b.abs()) {
            best = Some((theta, alpha, beta));
        }
    }
    let (theta, alpha, beta) = best.expect("two candidates");
    let (theta, alpha, beta) = if beta.abs() < 89.0_f64.to_radians() {
        (theta, alpha, beta)
    } else {
        // The tip's y axis along the joint axis: the flange keeps the joint's orientation.
        (0.0, 0.0, 0.0)
    };
    let (st, ct) = theta.sin_cos();
    JointSpec::revolute(
        wrap_deg(theta.to_degrees()),
        p.z,
        ct * p.x + st * p.y,
        alpha.to_degrees(),
        beta.to_degrees(),
        [0.0, 0.0],
    )
}

fn rot_x(a: f64) -> Matrix3<f64> {
    let (s, c) = a.sin_cos();
    Matrix3::new(1.0, 0.0, 0.0, 0.0, c, -s, 0.0, s, c)
}

fn rot_z(a: f64) -> Matrix3<f64> {
    let (s, c) = a.sin_cos();
    Matrix3::new(c, -s, 0.0, s, c, 0.0, 0.0, 0.0, 1.0)
}
