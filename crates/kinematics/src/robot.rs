//! The robot: parameters in internal units, forward kinematics and the identification
//! Jacobian. One implementation of each; everything else in the workspace calls these.

use std::sync::Arc;

use nalgebra::{DMatrix, Matrix3, Matrix6, Rotation3, Vector3, Vector6};

use crate::error::ModelError;
use crate::extended::ExtendedModel;
use crate::frame::Frame;
use crate::model::{
    BaseSpec, ControllerSpec, ExtendedParamSpec, JointSpec, JointType, MAX_JOINTS, MassModelSpec,
    RobotSpec, TargetSpec,
};
use crate::params::{ParamKind, ParamLayout};

mod families;
mod fast;
use crate::trig::joint_sin_cos;
pub use fast::{POSE_LANES, PoseLanes, PoseTrig};

/// Largest parameter-vector length: 6 per joint (θ, d, a, α and β or an axis scale, or
/// both) plus base and tool.
pub const MAX_PARAMS: usize = 6 * MAX_JOINTS + 9;

/// Millimetres of a prismatic joint's variable per internal unit.
///
/// A joint vector crosses every interface in per-joint units (degrees for a revolute joint,
/// millimetres for a prismatic one) and is converted to and from internal units with one
/// `to_radians` / `to_degrees` for the whole vector, wherever that happens in the
/// workspace. A prismatic joint's internal value is therefore its millimetres times π/180,
/// and the kinematics reads it back as [`prismatic_mm`] (`to_degrees`): what a file gives
/// in mm is mm in the chain, and no conversion site needs to know joint types.
pub fn prismatic_mm(q_internal: f64) -> f64 {
    q_internal.to_degrees()
}

/// The internal value of a prismatic joint at `q_mm` (the inverse of [`prismatic_mm`]).
pub fn prismatic_internal(q_mm: f64) -> f64 {
    q_mm.to_radians()
}

/// What a prismatic joint's cosine slot holds in a pose's `[sin, cos]` pairs: its sine
/// slot holds the joint's internal value instead of a sine ([`Robot::joint_trig`],
/// [`PoseTrig::for_robot`]). No cosine is infinite, so the kernels can tell pairs built
/// without the robot's joint types (e.g. [`crate::joint_sin_cos`]) and refuse them.
pub const PRISMATIC_SLOT: f64 = f64::INFINITY;

/// One joint in internal units, with the trigonometry of its constant angles cached.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Link {
    theta_rad: f64,
    d_mm: f64,
    a_mm: f64,
    alpha_rad: f64,
    beta_rad: f64,
    limits_rad: [f64; 2],
    /// A prismatic joint's limits as the robot file gives them, mm (written back by
    /// [`Robot::to_spec`] exactly, not through radians).
    limits_mm: [f64; 2],
    /// A prismatic joint: q adds `scale · prismatic_mm(q)` to d instead of q to θ.
    prismatic: bool,
    /// The axis scale of a prismatic joint (1 for a revolute one).
    scale: f64,
    sin_alpha: f64,
    cos_alpha: f64,
    sin_beta: f64,
    cos_beta: f64,
    sin_theta: f64,
    cos_theta: f64,
}

/// Refreshes the cached sines and cosines of θ, α and β of every link, all at once.
fn refresh_links(links: &mut [Link]) {
    let n = links.len();
    let mut x = [0.0; 3 * MAX_JOINTS];
    for (i, l) in links.iter().enumerate() {
        x[3 * i] = l.alpha_rad;
        x[3 * i + 1] = l.beta_rad;
        x[3 * i + 2] = l.theta_rad;
    }
    let mut s = [0.0; 3 * MAX_JOINTS];
    let mut c = [0.0; 3 * MAX_JOINTS];
    crate::trig::sin_cos_slice(&x[..3 * n], &mut s[..3 * n], &mut c[..3 * n]);
    for (i, l) in links.iter_mut().enumerate() {
        (l.sin_alpha, l.cos_alpha) = (s[3 * i], c[3 * i]);
        (l.sin_beta, l.cos_beta) = (s[3 * i + 1], c[3 * i + 1]);
        (l.sin_theta, l.cos_theta) = (s[3 * i + 2], c[3 * i + 2]);
    }
}

impl Link {
    /// The rotation angle of `Rz` at the joint value `q_rad`: θ + q (revolute) or θ
    /// (prismatic).
    #[inline(always)]
    fn angle_of(&self, q_rad: f64) -> f64 {
        if self.prismatic {
            self.theta_rad
        } else {
            self.theta_rad + q_rad
        }
    }

    /// The offset along z at the joint value `q_rad`: d (revolute) or
    /// `d + scale · prismatic_mm(q)` (prismatic).
    #[inline(always)]
    fn d_of(&self, q_rad: f64) -> f64 {
        if self.prismatic {
            self.d_mm + self.scale * prismatic_mm(q_rad)
        } else {
            self.d_mm
        }
    }

    /// Columns 0 and 1 of `Rz(θ+q)·Rx(α)` and the sin/cos of θ+q, the pieces both the
    /// link frame and the Jacobian need.
    #[inline]
    fn frame(&self, q_rad: f64) -> Frame {
        let (st, ct) = self.angle_of(q_rad).sin_cos();
        let d_mm = self.d_of(q_rad);
        let (sa, ca) = (self.sin_alpha, self.cos_alpha);
        let (sb, cb) = (self.sin_beta, self.cos_beta);
        // R_dh = Rz(θ+q)·Rx(α) = [[ct, -st·ca, st·sa], [st, ct·ca, -ct·sa], [0, sa, ca]]
        // R = R_dh · Ry(β):  c0 = cb·r0 − sb·r2,  c1 = r1,  c2 = sb·r0 + cb·r2
        let r0 = Vector3::new(ct, st, 0.0);
        let r1 = Vector3::new(-st * ca, ct * ca, sa);
        let r2 = Vector3::new(st * sa, -ct * sa, ca);
        Frame {
            rot: Matrix3::from_columns(&[r0 * cb - r2 * sb, r1, r0 * sb + r2 * cb]),
            pos_mm: Vector3::new(self.a_mm * ct, self.a_mm * st, d_mm),
        }
    }
}

/// Base pose parameters in internal units.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Base {
    r_rad: [f64; 3],
    d_mm: [f64; 3],
}

impl Base {
    /// `Trans(d) · Rz(rz) · Ry(ry) · Rx(rx)` ([`Frame::from_base_pose`]).
    fn frame(&self) -> Frame {
        Frame::from_base_pose(self.r_rad, self.d_mm)
    }

    /// The axes of the base rotations in the measurement frame: `Rz Ry e_x` (rx),
    /// `Rz e_y` (ry) and `e_z` (rz).
    fn axes(&self) -> [Vector3<f64>; 3] {
        let [_, ry, rz] = self.r_rad;
        let rzm = Rotation3::from_axis_angle(&Vector3::z_axis(), rz);
        [
            rzm * Rotation3::from_axis_angle(&Vector3::y_axis(), ry) * Vector3::x(),
            rzm * Vector3::y(),
            Vector3::z(),
        ]
    }
}

/// A serial revolute robot with its full geometric parameter set.
///
/// FK of the measured point (`docs/model.md` §2):
/// `p = T_base · T_1(q_1) ··· T_N(q_N) · [t, 1]ᵀ`, with
/// `T_i = Rz(θ_i + q_i) · Tz(d_i) · Tx(a_i) · Rx(α_i) · Ry(β_i)`.
/// Joint values `q` are radians, lengths mm.
///
/// `clone_from` refills a robot in place (no allocation when the target's links have the
/// room and neither robot is extended): what a campaign's kept virtual robot does per trial.
#[derive(Debug, PartialEq)]
pub struct Robot {
    /// The model file's descriptive parts, shared between copies (one reference count: a
    /// copy of a robot, which the solvers and the virtual robot make per trial, allocates
    /// its links, and an extended robot's extended part, only).
    described: Arc<Described>,
    links: Vec<Link>,
    base: Base,
    base_frame: Frame,
    /// [`Base::axes`] of `base`, cached.
    base_axes: [Vector3<f64>; 3],
    tool_mm: Vector3<f64>,
    layout: ParamLayout,
    /// Parameter index of β for each joint (`None` where β is not a parameter).
    beta_index: [Option<usize>; MAX_JOINTS],
    /// Parameter index of the axis scale for each joint (`None` for a revolute joint).
    scale_index: [Option<usize>; MAX_JOINTS],
    /// Whether any joint is prismatic.
    has_prismatic: bool,
    /// The joints IK holds at their start values ([`Robot::ik_held`]); `None`: the default.
    ik_hold: Option<[bool; MAX_JOINTS]>,
    /// Index of `base_rx` (base and tool parameters follow in order).
    base_index: usize,
    /// The non-geometric joint-error parameters of an extended robot
    /// ([`Robot::with_extended`]).
    extended: Option<Box<ExtendedPart>>,
    /// The robot file's optional tool orientation (rx, ry, rz, rad; `R = Rz·Ry·Rx`).
    tool_rotation_rad: Option<[f64; 3]>,
}

impl Clone for Robot {
    fn clone(&self) -> Self {
        let mut r = Robot {
            described: Arc::clone(&self.described),
            links: Vec::new(),
            base: self.base,
            base_frame: self.base_frame,
            base_axes: self.base_axes,
            tool_mm: self.tool_mm,
            layout: self.layout.clone(),
            beta_index: self.beta_index,
            scale_index: self.scale_index,
            has_prismatic: self.has_prismatic,
            ik_hold: self.ik_hold,
            base_index: self.base_index,
            extended: None,
            tool_rotation_rad: self.tool_rotation_rad,
        };
        r.clone_from(self);
        r
    }

    /// Every field copied, the links into the vector `self` has (the derived `clone_from`
    /// would allocate a new one).
    fn clone_from(&mut self, source: &Self) {
        let Robot {
            described,
            links,
            base,
            base_frame,
            base_axes,
            tool_mm,
            layout,
            beta_index,
            scale_index,
            has_prismatic,
            ik_hold,
            base_index,
            extended,
            tool_rotation_rad,
        } = source;
        self.described.clone_from(described);
        self.links.clone_from(links);
        self.base = *base;
        self.base_frame = *base_frame;
        self.base_axes = *base_axes;
        self.tool_mm = *tool_mm;
        self.layout.clone_from(layout);
        self.beta_index = *beta_index;
        self.scale_index = *scale_index;
        self.has_prismatic = *has_prismatic;
        self.ik_hold = *ik_hold;
        self.base_index = *base_index;
        self.extended.clone_from(extended);
        self.tool_rotation_rad = *tool_rotation_rad;
    }
}

/// What a robot carries from its model file without computing with it (a [`Robot`]'s
/// `described`).
#[derive(Clone, Debug, PartialEq)]
struct Described {
    /// The robot's name.
    name: String,
    /// The model file's optional joint names, carried to [`Robot::to_spec`].
    joint_names: Option<Vec<String>>,
    /// The model file's optional controller axis mapping, carried to [`Robot::to_spec`].
    controller: Option<ControllerSpec>,
    /// The model file's optional mass model, kept as given (see [`MassModelSpec`]).
    mass_model: Option<MassModelSpec>,
    /// The robot file's optional named targets (flange frame, mm).
    targets: Option<Vec<(String, Vector3<f64>)>>,
}

/// The non-geometric part of an extended robot.
#[derive(Debug, PartialEq)]
struct ExtendedPart {
    /// Parameters, values (internal units) and the gravity model.
    model: ExtendedModel,
    /// The geometry the gravity torques are evaluated on: the robot as it was extended
    /// (normally the nominal), geometric only, fixed while the parameters move.
    torque_robot: Robot,
    /// Layout index of the first extended parameter (they follow in `model` order).
    first: usize,
    /// Layout index of θ_j for each extended parameter's joint j.
    theta_index: Vec<usize>,
    /// Whether joint j carries an extended parameter (its effective joint moves).
    joints: [bool; MAX_JOINTS],
    /// The parameters of each joint that carries any: (joint, their indices in `model`
    /// order), for the lane kernels' offsets.
    by_joint: Vec<(usize, Vec<usize>)>,
    /// What the weights depend on (parameter kinds, mass model, torque geometry), hashed:
    /// the lane kernels check that the weights of a [`PoseTrig`] are this model's. Never 0.
    fingerprint: u64,
}

// `clone_from` into the target's vectors and robot (see `Robot`'s); every field named in
// both (a struct literal and a destructuring), so a new one is a compile error.
impl Clone for ExtendedPart {
    fn clone(&self) -> Self {
        ExtendedPart {
            model: self.model.clone(),
            torque_robot: self.torque_robot.clone(),
            first: self.first,
            theta_index: self.theta_index.clone(),
            joints: self.joints,
            by_joint: self.by_joint.clone(),
            fingerprint: self.fingerprint,
        }
    }

    fn clone_from(&mut self, source: &Self) {
        let ExtendedPart {
            model,
            torque_robot,
            first,
            theta_index,
            joints,
            by_joint,
            fingerprint,
        } = source;
        self.model.clone_from(model);
        self.torque_robot.clone_from(torque_robot);
        self.first = *first;
        self.theta_index.clone_from(theta_index);
        self.joints = *joints;
        // Element by element: a tuple's `clone_from` would copy its vector anew.
        self.by_joint.truncate(by_joint.len());
        let kept = self.by_joint.len();
        for ((j, ks), (sj, sks)) in self.by_joint.iter_mut().zip(by_joint) {
            *j = *sj;
            ks.clone_from(sks);
        }
        self.by_joint.extend_from_slice(&by_joint[kept..]);
        self.fingerprint = *fingerprint;
    }
}

impl ExtendedPart {
    /// The joint offsets δ_j = Σ_k w_k x_k at the pose whose `[sin q, cos q]` are `sc`,
    /// and the weights `w` (into `w[..len]`), the torques on [`ExtendedPart::torque_robot`].
    fn offsets(&self, sc: &[[f64; 2]], w: &mut [f64], delta: &mut [f64; MAX_JOINTS]) {
        self.model.weights_trig(&self.torque_robot, sc, w);
        self.model.offsets(w, delta);
    }
}

/// Most non-geometric parameters one robot can carry (one weight each on the stack).
const MAX_EXTENDED: usize = 4 * MAX_JOINTS;

impl Robot {
    /// Builds a robot from a validated model file.
    pub fn from_spec(spec: &RobotSpec) -> Result<Robot, ModelError> {
        spec.validate(&spec.name)?;
        let alphas: Vec<f64> = spec.joints.iter().map(|j| j.alpha_deg).collect();
        let prismatic: Vec<bool> = spec.joints.iter().map(JointSpec::is_prismatic).collect();
        let layout = ParamLayout::for_chain(&alphas, &prismatic);
        let mut beta_index = [None; MAX_JOINTS];
        let mut scale_index = [None; MAX_JOINTS];
        for (k, p) in layout.params().iter().enumerate() {
            match p.kind {
                ParamKind::Beta(i) => beta_index[i] = Some(k),
                ParamKind::Scale(i) => scale_index[i] = Some(k),
                _ => {}
            }
        }
        let mut links: Vec<Link> = spec
            .joints
            .iter()
            .map(|j| Link {
                theta_rad: j.theta_deg.to_radians(),
                d_mm: j.d_mm,
                a_mm: j.a_mm,
                alpha_rad: j.alpha_deg.to_radians(),
                beta_rad: j.beta_deg.to_radians(),
                limits_rad: [j.limits_deg[0].to_radians(), j.limits_deg[1].to_radians()],
                limits_mm: j.limits_deg,
                prismatic: j.is_prismatic(),
                scale: j.scale_mm_per_mm,
                sin_alpha: 0.0,
                cos_alpha: 1.0,
                sin_beta: 0.0,
                cos_beta: 1.0,
                sin_theta: 0.0,
                cos_theta: 1.0,
            })
            .collect();
        refresh_links(&mut links);
        let base = Base {
            r_rad: spec.base.rotations_rad(),
            d_mm: spec.base.translation_mm(),
        };
        let base_index = layout.len() - 9;
        Ok(Robot {
            described: Arc::new(Described {
                name: spec.name.clone(),
                joint_names: spec.joint_names.clone(),
                controller: spec.controller.clone(),
                mass_model: spec.mass_model.clone(),
                targets: spec.targets.as_ref().map(|t| {
                    t.iter()
                        .map(|t| (t.name.clone(), Vector3::from(t.point_mm)))
                        .collect()
                }),
            }),
            links,
            base,
            base_frame: base.frame(),
            base_axes: base.axes(),
            tool_mm: Vector3::from(spec.tool_mm),
            layout,
            beta_index,
            scale_index,
            has_prismatic: prismatic.contains(&true),
            ik_hold: None,
            base_index,
            extended: None,
            tool_rotation_rad: spec
                .tool_rotation_deg
                .map(|r| [r[0].to_radians(), r[1].to_radians(), r[2].to_radians()]),
        })
        .and_then(|r: Robot| match &spec.extended {
            None => Ok(r),
            Some(list) => {
                // Errors name the file's field: `extended[i]`, not the model's `params[i]`.
                let rename = |e: ModelError| match e {
                    ModelError::Invalid {
                        source_name,
                        field,
                        message,
                    } => ModelError::Invalid {
                        source_name,
                        field: field.replacen("params", "extended", 1),
                        message,
                    },
                    other => other,
                };
                let names: Vec<&str> = list.iter().map(|e| e.name.as_str()).collect();
                let mut r = r.with_extended(&names, &spec.name).map_err(rename)?;
                let mut x = r.params();
                let first = x.len() - list.len();
                for (k, e) in list.iter().enumerate() {
                    if !e.value.is_finite() {
                        return Err(ModelError::Invalid {
                            source_name: spec.name.clone(),
                            field: format!("extended[{k}].value"),
                            message: format!("{:?} is not a finite number", e.value),
                        });
                    }
                    x[first + k] = r.layout().get(first + k).from_display(e.value);
                }
                r.set_params(&x)?;
                Ok(r)
            }
        })
    }

    /// This robot with the non-geometric joint-error parameters `names` (`compliance_j`,
    /// `gear_j_hk_sin|cos`, all zero) appended to its parameter vector, the gravity torques
    /// evaluated on this robot's geometry from then on (see [`ExtendedModel`] and
    /// `docs/extended-model.md`). Every commanded-joint entry point ([`Robot::point`],
    /// [`Robot::flange`], the `_trig` forms, IK) then evaluates the chain at the effective
    /// joints q̃ = q + Σ w_k(q)·x_k, and the Jacobians carry the columns w_k·∂p/∂θ_j; the
    /// vectorised lane kernels do too, from weights cached per pose
    /// ([`PoseTrig::for_robot`]). Errors name the field, as [`ExtendedModel::new`]'s.
    pub fn with_extended<S: AsRef<str>>(
        &self,
        names: &[S],
        source_name: &str,
    ) -> Result<Robot, ModelError> {
        let prismatic = self.links.iter().position(|l| l.prismatic);
        if let (false, Some(i)) = (names.is_empty(), prismatic) {
            return Err(ModelError::Invalid {
                source_name: source_name.to_string(),
                field: "params".into(),
                message: format!(
                    "the non-geometric families cover revolute chains only, joint {} is \
                     prismatic",
                    i + 1
                ),
            });
        }
        let mut geometric = self.clone();
        if geometric.extended.is_some() {
            geometric.extended = None;
            geometric.layout = self.layout.with_extended(&[]);
        }
        let model = ExtendedModel::new(&geometric, names, source_name)?;
        if model.len() > MAX_EXTENDED || geometric.n_params() + model.len() > MAX_PARAMS {
            return Err(ModelError::Invalid {
                source_name: source_name.to_string(),
                field: "params".into(),
                message: format!(
                    "{} non-geometric parameters: at most {} fit beside the {} geometric ones",
                    model.len(),
                    (MAX_PARAMS - geometric.n_params()).min(MAX_EXTENDED),
                    geometric.n_params()
                ),
            });
        }
        if model.is_empty() {
            return Ok(geometric);
        }
        let layout = geometric.layout.with_extended(model.kinds());
        let first = geometric.n_params();
        let theta_index = model
            .kinds()
            .iter()
            .map(|k| {
                layout
                    .params()
                    .iter()
                    .position(|p| p.kind == ParamKind::Theta(k.joint()))
                    .expect("every joint has a θ parameter")
            })
            .collect();
        let mut joints = [false; MAX_JOINTS];
        for k in model.kinds() {
            joints[k.joint()] = true;
        }
        let by_joint = (0..geometric.n_joints())
            .filter(|&j| joints[j])
            .map(|j| {
                let of_j = model.kinds().iter().enumerate();
                (
                    j,
                    of_j.filter(|(_, k)| k.joint() == j)
                        .map(|(i, _)| i)
                        .collect(),
                )
            })
            .collect();
        // FNV-1a over the weights' inputs (their Debug forms print every f64 exactly).
        let fingerprint = format!("{:?} {:?} {:?}", model.kinds(), model.gravity(), geometric)
            .bytes()
            .fold(0xcbf2_9ce4_8422_2325_u64, |h, b| {
                (h ^ u64::from(b)).wrapping_mul(0x0000_0100_0000_01b3)
            })
            .max(1);
        let mut r = geometric.clone();
        r.layout = layout;
        r.extended = Some(Box::new(ExtendedPart {
            model,
            torque_robot: geometric,
            first,
            theta_index,
            joints,
            by_joint,
            fingerprint,
        }));
        Ok(r)
    }

    /// The non-geometric parameters of an extended robot (`None` for a geometric one).
    pub fn extended(&self) -> Option<&ExtendedModel> {
        self.extended.as_ref().map(|e| &e.model)
    }

    /// Whether the robot has non-geometric parameters ([`Robot::with_extended`]).
    #[inline]
    pub fn is_extended(&self) -> bool {
        self.extended.is_some()
    }

    /// `[sin q̃, cos q̃]` of the effective joints at the pose whose `[sin q, cos q]` are `sc`,
    /// and the weights `w_k` (a copy of `sc` and no weights for a geometric robot):
    /// `sin(q + δ) = s·cos δ + c·sin δ`, `cos(q + δ) = c·cos δ − s·sin δ` on the joints that
    /// carry a parameter (sin δ, cos δ from [`crate::trig::sin_cos_small_lanes`], as the
    /// lane kernels).
    fn effective_trig_of(&self, sc: &[[f64; 2]]) -> ([[f64; 2]; MAX_JOINTS], [f64; MAX_EXTENDED]) {
        let mut out = [[0.0; 2]; MAX_JOINTS];
        let mut w = [0.0; MAX_EXTENDED];
        out[..sc.len()].copy_from_slice(sc);
        if let Some(ext) = &self.extended {
            let mut delta = [0.0; MAX_JOINTS];
            ext.offsets(sc, &mut w[..ext.model.len()], &mut delta);
            for (i, [s, c]) in sc.iter().enumerate() {
                if ext.joints[i] {
                    let (sd, cd) = crate::trig::sin_cos_small_lanes(&[delta[i]]);
                    let (sd, cd) = (sd[0], cd[0]);
                    out[i] = [s * cd + c * sd, c * cd - s * sd];
                }
            }
        }
        (out, w)
    }

    /// The effective joints q̃ (radians) of the commanded `q_rad` into `out` (a copy for a
    /// geometric robot), with the weights into `w`.
    fn effective_joints(
        &self,
        q_rad: &[f64],
        out: &mut [f64; MAX_JOINTS],
        w: &mut [f64; MAX_EXTENDED],
    ) {
        let n = q_rad.len();
        out[..n].copy_from_slice(q_rad);
        if let Some(ext) = &self.extended {
            let mut sc = [[0.0; 2]; MAX_JOINTS];
            joint_sin_cos(q_rad, &mut sc);
            let mut delta = [0.0; MAX_JOINTS];
            ext.offsets(&sc[..n], &mut w[..ext.model.len()], &mut delta);
            for i in 0..n {
                out[i] += delta[i];
            }
        }
    }

    /// Writes the extended parameters' Jacobian columns `w_k · ∂p/∂θ_j` from the θ columns.
    fn extended_columns<T: Copy + std::ops::Mul<f64, Output = T>>(
        &self,
        w: &[f64; MAX_EXTENDED],
        cols: &mut [T],
    ) {
        if let Some(ext) = &self.extended {
            for (k, &t) in ext.theta_index.iter().enumerate() {
                cols[ext.first + k] = cols[t] * w[k];
            }
        }
    }

    /// `[sin q_i, cos q_i]` of the joint vector `q_rad` as this robot's `_trig` and lane
    /// kernels read them, into `out[..q_rad.len()]`: [`joint_sin_cos`], except that a
    /// prismatic joint's pair is `[q_i, PRISMATIC_SLOT]` (its value; it has no angle). For a
    /// revolute chain this is [`joint_sin_cos`], bit for bit.
    #[inline]
    pub fn joint_trig(&self, q_rad: &[f64], out: &mut [[f64; 2]]) {
        joint_sin_cos(q_rad, out);
        self.mark_prismatic(q_rad, out);
    }

    /// Writes `[q_i, PRISMATIC_SLOT]` into the pairs of the prismatic joints of `out`, the
    /// `[sin q, cos q]` of `q_rad` from a sine kernel of the caller's own (nothing for a
    /// revolute chain).
    #[inline]
    pub fn mark_prismatic(&self, q_rad: &[f64], out: &mut [[f64; 2]]) {
        if self.has_prismatic {
            for (i, l) in self.links.iter().enumerate() {
                if l.prismatic {
                    out[i] = [q_rad[i], PRISMATIC_SLOT];
                }
            }
        }
    }

    /// The type of joint `i` (0-based).
    pub fn joint_type(&self, i: usize) -> JointType {
        if self.links[i].prismatic {
            JointType::Prismatic
        } else {
            JointType::Revolute
        }
    }

    /// The wrist joint whose zero is the wrist singularity the pose samplers keep away from:
    /// the fifth revolute joint (joint 5 of a six-axis arm, joint 6 of one on a linear
    /// track); `None` for chains with fewer than five revolute joints.
    pub fn wrist_joint(&self) -> Option<usize> {
        let mut revolute = (0..self.links.len()).filter(|&i| !self.links[i].prismatic);
        revolute.nth(4)
    }

    /// The joints that IK ([`Robot::solve_ik`], and so compensation) holds at their start
    /// values, the commanded ones: those set by [`Robot::set_ik_held`], else, for a chain
    /// of more than six joints, its prismatic joints, up to the N − 6 redundant ones (an arm
    /// on a linear track compensates with the arm, the track where it was commanded; a
    /// pose needs six joints). None for six or fewer joints.
    pub fn ik_held(&self) -> [bool; MAX_JOINTS] {
        if let Some(h) = self.ik_hold {
            return h;
        }
        let mut held = [false; MAX_JOINTS];
        let n = self.links.len();
        if n > 6 {
            let prismatic = (0..n).filter(|&i| self.links[i].prismatic);
            for i in prismatic.take(n - 6) {
                held[i] = true;
            }
        }
        held
    }

    /// Sets the joints IK holds at their start values (0-based; `None`: the default of
    /// [`Robot::ik_held`]; an empty list frees every joint).
    pub fn set_ik_held(&mut self, joints: Option<&[usize]>) {
        self.ik_hold = joints.map(|js| {
            let mut h = [false; MAX_JOINTS];
            for &j in js.iter().filter(|&&j| j < MAX_JOINTS) {
                h[j] = true;
            }
            h
        });
    }

    /// Whether any joint is prismatic.
    pub fn has_prismatic(&self) -> bool {
        self.has_prismatic
    }

    /// How fast joint `i` moves a point along its axis per internal unit of q, mm: `None`
    /// for a revolute joint (it turns), `scale · 180/π` for a prismatic one (its column of
    /// the geometric Jacobian is that times its axis, with no rotation).
    #[inline]
    pub fn prismatic_rate(&self, i: usize) -> Option<f64> {
        let l = &self.links[i];
        l.prismatic.then(|| l.scale * prismatic_mm(1.0))
    }

    /// Reads a model file (see [`RobotSpec`]).
    pub fn from_file(path: &std::path::Path) -> Result<Robot, ModelError> {
        Robot::from_spec(&RobotSpec::from_file(path)?)
    }

    /// The model file of this robot (degrees and mm), e.g. to save a calibrated robot.
    pub fn to_spec(&self) -> RobotSpec {
        RobotSpec {
            name: self.described.name.clone(),
            joints: self
                .links
                .iter()
                .map(|l| JointSpec {
                    joint_type: if l.prismatic {
                        JointType::Prismatic
                    } else {
                        JointType::Revolute
                    },
                    scale_mm_per_mm: l.scale,
                    theta_deg: l.theta_rad.to_degrees(),
                    d_mm: l.d_mm,
                    a_mm: l.a_mm,
                    alpha_deg: l.alpha_rad.to_degrees(),
                    beta_deg: l.beta_rad.to_degrees(),
                    limits_deg: if l.prismatic {
                        l.limits_mm
                    } else {
                        [l.limits_rad[0].to_degrees(), l.limits_rad[1].to_degrees()]
                    },
                })
                .collect(),
            base: BaseSpec::from_internal(self.base.r_rad, self.base.d_mm),
            tool_mm: self.tool_mm.into(),
            joint_names: self.described.joint_names.clone(),
            controller: self.described.controller.clone(),
            mass_model: self.described.mass_model.clone(),
            extended: self.extended.as_ref().map(|e| {
                e.model
                    .kinds()
                    .iter()
                    .zip(e.model.values())
                    .map(|(k, v)| ExtendedParamSpec {
                        name: k.name(),
                        value: k.to_display(*v),
                    })
                    .collect()
            }),
            tool_rotation_deg: self
                .tool_rotation_rad
                .map(|r| [r[0].to_degrees(), r[1].to_degrees(), r[2].to_degrees()]),
            targets: self.described.targets.as_ref().map(|t| {
                t.iter()
                    .map(|(name, p)| TargetSpec {
                        name: name.clone(),
                        point_mm: (*p).into(),
                    })
                    .collect()
            }),
            // A prior is an input of an identification, not a property of the identified
            // robot: `identified.json` carries none.
            prior_sd: None,
            provenance: None,
        }
    }

    /// The mass model of the robot file, if it has one (link masses, centres of mass, payload;
    /// see [`MassModelSpec`]).
    pub fn mass_model(&self) -> Option<&MassModelSpec> {
        self.described.mass_model.as_ref()
    }

    /// The controller axis mapping of the robot file, if it has one ([`ControllerSpec`]).
    pub fn controller(&self) -> Option<&ControllerSpec> {
        self.described.controller.as_ref()
    }

    /// The robot's name.
    pub fn name(&self) -> &str {
        &self.described.name
    }

    /// Renames the robot (e.g. "… (calibrated)").
    pub fn set_name(&mut self, name: impl Into<String>) {
        Arc::make_mut(&mut self.described).name = name.into();
    }

    /// Number of joints N.
    pub fn n_joints(&self) -> usize {
        self.links.len()
    }

    /// The parameter vector's layout.
    pub fn layout(&self) -> &ParamLayout {
        &self.layout
    }

    /// Number of parameters.
    pub fn n_params(&self) -> usize {
        self.layout.len()
    }

    /// Joint limits `[min, max]` of joint `i`, radians.
    pub fn limits_rad(&self, i: usize) -> [f64; 2] {
        self.links[i].limits_rad
    }

    /// Replaces the limits of joint `i` (internal units; `min < max`), e.g. to draw poses
    /// over part of a joint's range.
    pub fn set_limits_rad(&mut self, i: usize, limits_rad: [f64; 2]) {
        assert!(
            limits_rad[0] < limits_rad[1],
            "joint limits must have min < max"
        );
        self.links[i].limits_rad = limits_rad;
        self.links[i].limits_mm = limits_rad.map(prismatic_mm);
    }

    /// True if every joint value lies within its limits (inclusive).
    pub fn in_limits(&self, q_rad: &[f64]) -> bool {
        q_rad.len() == self.links.len()
            && q_rad
                .iter()
                .zip(&self.links)
                .all(|(q, l)| *q >= l.limits_rad[0] && *q <= l.limits_rad[1])
    }

    /// The measured point in the flange frame, mm.
    pub fn tool_mm(&self) -> Vector3<f64> {
        self.tool_mm
    }

    /// Replaces the measured point in the flange frame.
    pub fn set_tool_mm(&mut self, tool_mm: Vector3<f64>) {
        self.tool_mm = tool_mm;
    }

    /// The tool orientation of the robot file, if it gives one: `[rx, ry, rz]` (rad) with
    /// `R_tool = Rz·Ry·Rx`, the measured frame's axes in the flange frame.
    pub fn tool_rotation_rad(&self) -> Option<[f64; 3]> {
        self.tool_rotation_rad
    }

    /// The tool orientation as a matrix (identity when the file gives none).
    pub fn tool_rotation(&self) -> Matrix3<f64> {
        self.tool_rotation_rad.map_or_else(Matrix3::identity, |r| {
            Frame::from_base_pose(r, [0.0; 3]).rot
        })
    }

    /// Replaces the tool orientation (`None`: not given, as in a point-only robot file).
    pub fn set_tool_rotation_rad(&mut self, r_rad: Option<[f64; 3]>) {
        self.tool_rotation_rad = r_rad;
    }

    /// The named targets of the robot file (flange frame, mm), if it gives any.
    pub fn targets(&self) -> Option<&[(String, Vector3<f64>)]> {
        self.described.targets.as_deref()
    }

    /// Replaces the named targets.
    pub fn set_targets(&mut self, targets: Option<Vec<(String, Vector3<f64>)>>) {
        Arc::make_mut(&mut self.described).targets = targets;
    }

    /// The flange frame and its exact derivatives with respect to every parameter: for
    /// parameter k, `lin[k] = ∂o/∂param_k` (the flange origin's, mm per rad or mm per mm) and
    /// `ang[k] = ω_k`, the flange's angular derivative in the measurement frame
    /// (`∂R_flange/∂param_k = [ω_k]× · R_flange`, rad per unit). With the notation of
    /// [`Robot::point_jacobian_into`] and `o` the flange origin:
    /// - `θ_i`: `ω = z_{i−1}`, `∂o = z_{i−1} × (o − o_{i−1})`; `d_i`: `ω = 0`, `∂o = z_{i−1}`;
    /// - `a_i`: `ω = 0`, `∂o = x'_i`; `α_i`: `ω = x'_i`, `∂o = x'_i × (o − o_i)`;
    ///   `β_i`: `ω = y'_i`, `∂o = y'_i × (o − o_i)`;
    /// - base rotations: `ω = axis`, `∂o = axis × (o − d)`; base translation: `ω = 0`, `∂o = I`;
    /// - tool point: 0 (the flange does not depend on it); extended: `w_k` times θ_j's.
    ///
    /// A point `t` fixed in the flange then has `∂p/∂param_k = lin[k] + ω_k × (R_flange t)`
    /// (and `R_flange`'s columns for the tool-point parameters). No heap allocation; the
    /// straightforward chain (one [`Frame`] per link).
    pub fn frame_jacobian_into(
        &self,
        q_rad: &[f64],
        lin: &mut [Vector3<f64>],
        ang: &mut [Vector3<f64>],
    ) -> Frame {
        assert_eq!(
            lin.len(),
            self.layout.len(),
            "Jacobian column buffer length"
        );
        assert_eq!(
            ang.len(),
            self.layout.len(),
            "Jacobian column buffer length"
        );
        assert_eq!(q_rad.len(), self.links.len(), "joint vector length");
        let mut frames = [Frame::identity(); MAX_JOINTS + 1];
        let mut qe = [0.0; MAX_JOINTS];
        let mut w = [0.0; MAX_EXTENDED];
        self.effective_joints(q_rad, &mut qe, &mut w);
        let q_rad = &qe[..q_rad.len()];
        self.chain_reference(q_rad, &mut frames);
        let n = self.links.len();
        let o = frames[n].pos_mm;
        let zero = Vector3::zeros();
        for (i, (l, q)) in self.links.iter().zip(q_rad).enumerate() {
            let prev = &frames[i];
            let z = prev.rot.column(2).into_owned();
            let (st, ct) = l.angle_of(*q).sin_cos();
            let x = prev.rot * Vector3::new(ct, st, 0.0);
            let r_prev = o - prev.pos_mm;
            let r_this = o - frames[i + 1].pos_mm;
            (lin[4 * i], ang[4 * i]) = (z.cross(&r_prev), z);
            (lin[4 * i + 1], ang[4 * i + 1]) = (z, zero);
            (lin[4 * i + 2], ang[4 * i + 2]) = (x, zero);
            (lin[4 * i + 3], ang[4 * i + 3]) = (x.cross(&r_this), x);
            if let Some(k) = self.beta_index[i] {
                let y = prev.rot * Vector3::new(-st * l.cos_alpha, ct * l.cos_alpha, l.sin_alpha);
                (lin[k], ang[k]) = (y.cross(&r_this), y);
            }
            if let Some(k) = self.scale_index[i] {
                (lin[k], ang[k]) = (z * prismatic_mm(*q), zero);
            }
        }
        let b = self.base_index;
        let [_, ry, rz] = self.base.r_rad;
        let rzm = Rotation3::from_axis_angle(&Vector3::z_axis(), rz);
        let axes = [
            rzm * Rotation3::from_axis_angle(&Vector3::y_axis(), ry) * Vector3::x(),
            rzm * Vector3::y(),
            Vector3::z(),
        ];
        let r_base = o - self.base_frame.pos_mm;
        for (c, axis) in axes.iter().enumerate() {
            (lin[b + c], ang[b + c]) = (axis.cross(&r_base), *axis);
        }
        for (c, e) in [Vector3::x(), Vector3::y(), Vector3::z()]
            .iter()
            .enumerate()
        {
            (lin[b + 3 + c], ang[b + 3 + c]) = (*e, zero);
        }
        for c in 6..9 {
            (lin[b + c], ang[b + c]) = (zero, zero);
        }
        self.extended_columns(&w, lin);
        self.extended_columns(&w, ang);
        frames[n]
    }

    /// The base frame `T_base` (measurement frame ← robot base).
    pub fn base_frame(&self) -> Frame {
        self.base_frame
    }

    /// The parameter vector in internal units (rad, mm), in layout order.
    pub fn params(&self) -> Vec<f64> {
        let mut out = Vec::with_capacity(self.layout.len());
        self.params_into(&mut out);
        out
    }

    /// [`Robot::params`] written into `out` (cleared first; no allocation once `out` has
    /// the capacity: what a solver's iterations reuse).
    pub fn params_into(&self, out: &mut Vec<f64>) {
        out.clear();
        out.extend((0..self.layout.len()).map(|k| self.param(k)));
    }

    /// Parameter `k` (layout order) in internal units, as [`Robot::params`] has it, without
    /// allocation. Panics past the layout.
    pub fn param(&self, k: usize) -> f64 {
        match self.layout.params()[k].kind {
            ParamKind::Theta(i) => self.links[i].theta_rad,
            ParamKind::D(i) => self.links[i].d_mm,
            ParamKind::A(i) => self.links[i].a_mm,
            ParamKind::Alpha(i) => self.links[i].alpha_rad,
            ParamKind::Beta(i) => self.links[i].beta_rad,
            ParamKind::Scale(i) => self.links[i].scale,
            ParamKind::BaseRx => self.base.r_rad[0],
            ParamKind::BaseRy => self.base.r_rad[1],
            ParamKind::BaseRz => self.base.r_rad[2],
            ParamKind::BaseDx => self.base.d_mm[0],
            ParamKind::BaseDy => self.base.d_mm[1],
            ParamKind::BaseDz => self.base.d_mm[2],
            ParamKind::ToolX => self.tool_mm.x,
            ParamKind::ToolY => self.tool_mm.y,
            ParamKind::ToolZ => self.tool_mm.z,
            ParamKind::Extended(_) => {
                let e = self.extended.as_ref().expect("extended layout");
                e.model.values()[k - e.first]
            }
        }
    }

    /// Sets every parameter from a vector in internal units, in layout order.
    pub fn set_params(&mut self, p: &[f64]) -> Result<(), ModelError> {
        if p.len() != self.layout.len() {
            return Err(ModelError::Length {
                what: "parameter vector",
                expected: self.layout.len(),
                found: p.len(),
            });
        }
        for (k, info) in self.layout.params().iter().enumerate() {
            let v = p[k];
            match info.kind {
                ParamKind::Theta(i) => self.links[i].theta_rad = v,
                ParamKind::D(i) => self.links[i].d_mm = v,
                ParamKind::A(i) => self.links[i].a_mm = v,
                ParamKind::Alpha(i) => self.links[i].alpha_rad = v,
                ParamKind::Beta(i) => self.links[i].beta_rad = v,
                ParamKind::Scale(i) => self.links[i].scale = v,
                ParamKind::BaseRx => self.base.r_rad[0] = v,
                ParamKind::BaseRy => self.base.r_rad[1] = v,
                ParamKind::BaseRz => self.base.r_rad[2] = v,
                ParamKind::BaseDx => self.base.d_mm[0] = v,
                ParamKind::BaseDy => self.base.d_mm[1] = v,
                ParamKind::BaseDz => self.base.d_mm[2] = v,
                ParamKind::ToolX => self.tool_mm.x = v,
                ParamKind::ToolY => self.tool_mm.y = v,
                ParamKind::ToolZ => self.tool_mm.z = v,
                ParamKind::Extended(_) => {}
            }
        }
        if let Some(e) = self.extended.as_mut() {
            e.model.set_values(&p[e.first..])?;
        }
        refresh_links(&mut self.links);
        self.base_frame = self.base.frame();
        self.base_axes = self.base.axes();
        Ok(())
    }

    /// A copy with the given parameter vector (internal units).
    pub fn with_params(&self, p: &[f64]) -> Result<Robot, ModelError> {
        let mut r = self.clone();
        r.set_params(p)?;
        Ok(r)
    }

    /// Frames `T_base · T_1 ··· T_i` for i = 0..N written to `frames[0..=N]` (frame 0 is the
    /// base; frame i the link frame after joint i; frame N the flange). No allocation.
    #[inline]
    pub fn frames_into(&self, q_rad: &[f64], frames: &mut [Frame; MAX_JOINTS + 1]) {
        assert_eq!(q_rad.len(), self.links.len(), "joint vector length");
        let mut sc = [[0.0; 2]; MAX_JOINTS];
        self.joint_trig(q_rad, &mut sc);
        self.frames_trig(&sc[..q_rad.len()], frames)
    }

    /// The straightforward chain at the joints given (the effective joints of an extended
    /// robot): one [`Frame::compose`] per link with `sin_cos(θ+q)`.
    fn chain_reference(&self, q_rad: &[f64], frames: &mut [Frame; MAX_JOINTS + 1]) {
        frames[0] = self.base_frame;
        for (i, (l, q)) in self.links.iter().zip(q_rad).enumerate() {
            frames[i + 1] = frames[i].compose(&l.frame(*q));
        }
    }

    /// The flange frame in the measurement frame: `T_base · T_1(q_1) ··· T_N(q_N)`.
    ///
    /// Panics if `q_rad.len() != n_joints()` (a programming error; file readers check
    /// joint counts with a named error before this point).
    pub fn flange(&self, q_rad: &[f64]) -> Frame {
        assert_eq!(q_rad.len(), self.links.len(), "joint vector length");
        let mut sc = [[0.0; 2]; MAX_JOINTS];
        self.joint_trig(q_rad, &mut sc);
        self.flange_trig(&sc[..q_rad.len()])
    }

    /// [`Robot::flange`] by the straightforward composition of one [`Frame`] per link: the
    /// reference the fast kernels are tested against (equal up to rounding).
    pub fn flange_reference(&self, q_rad: &[f64]) -> Frame {
        assert_eq!(q_rad.len(), self.links.len(), "joint vector length");
        let mut qe = [0.0; MAX_JOINTS];
        let mut w = [0.0; MAX_EXTENDED];
        self.effective_joints(q_rad, &mut qe, &mut w);
        let mut f = self.base_frame;
        for (l, q) in self.links.iter().zip(&qe[..q_rad.len()]) {
            f = f.compose(&l.frame(*q));
        }
        f
    }

    /// The measured point `p = T_flange · t` in the measurement frame, mm.
    ///
    /// Panics if `q_rad.len() != n_joints()`.
    pub fn point(&self, q_rad: &[f64]) -> Vector3<f64> {
        assert_eq!(q_rad.len(), self.links.len(), "joint vector length");
        let mut sc = [[0.0; 2]; MAX_JOINTS];
        self.joint_trig(q_rad, &mut sc);
        self.point_trig(&sc[..q_rad.len()])
    }

    /// [`Robot::point`] through [`Robot::flange_reference`] (equal up to rounding).
    pub fn point_reference(&self, q_rad: &[f64]) -> Vector3<f64> {
        self.flange_reference(q_rad).transform_point(&self.tool_mm)
    }

    /// Measured points for a batch of poses stored row after row (`poses_rad.len() = m·N`).
    pub fn points(&self, poses_rad: &[f64]) -> Vec<Vector3<f64>> {
        poses_rad
            .chunks_exact(self.n_joints())
            .map(|q| self.point(q))
            .collect()
    }

    /// The measured point and its exact derivative with respect to every parameter.
    ///
    /// `cols[k] = ∂p/∂param_k` (mm per rad or mm per mm), `cols.len() == n_params()`.
    /// With `z_{i−1}`, `o_{i−1}` the z axis and origin of frame i−1, `x'_i`, `y'_i` the x and y
    /// axes after `Rz(θ_i+q_i)·Rx(α_i)` and `o_i` the origin of frame i:
    /// - `∂p/∂θ_i = z_{i−1} × (p − o_{i−1})`, `∂p/∂d_i = z_{i−1}`,
    /// - `∂p/∂a_i = x'_i`, `∂p/∂α_i = x'_i × (p − o_i)`, `∂p/∂β_i = y'_i × (p − o_i)`,
    /// - base (`p = d + Rz·Ry·Rx·p_b`): `∂p/∂rz = e_z × (p − d)`, `∂p/∂ry = (Rz e_y) × (p − d)`,
    ///   `∂p/∂rx = (Rz Ry e_x) × (p − d)`, `∂p/∂d = I`,
    /// - tool: `∂p/∂t = R_flange`.
    ///
    /// No heap allocation. This is the straightforward implementation (one [`Frame`] composed
    /// per link), kept as the reference of the fast [`Robot::point_jacobian_trig`] that the
    /// batch methods use; the two agree up to rounding.
    pub fn point_jacobian_into(&self, q_rad: &[f64], cols: &mut [Vector3<f64>]) -> Vector3<f64> {
        assert_eq!(
            cols.len(),
            self.layout.len(),
            "Jacobian column buffer length"
        );
        assert_eq!(q_rad.len(), self.links.len(), "joint vector length");
        let mut frames = [Frame::identity(); MAX_JOINTS + 1];
        let mut qe = [0.0; MAX_JOINTS];
        let mut w = [0.0; MAX_EXTENDED];
        self.effective_joints(q_rad, &mut qe, &mut w);
        let q_rad = &qe[..q_rad.len()];
        self.chain_reference(q_rad, &mut frames);
        let n = self.links.len();
        let p = frames[n].transform_point(&self.tool_mm);
        for (i, (l, q)) in self.links.iter().zip(q_rad).enumerate() {
            let prev = &frames[i];
            let z = prev.rot.column(2).into_owned();
            let (st, ct) = l.angle_of(*q).sin_cos();
            let x = prev.rot * Vector3::new(ct, st, 0.0);
            let r_prev = p - prev.pos_mm;
            let r_this = p - frames[i + 1].pos_mm;
            cols[4 * i] = z.cross(&r_prev);
            cols[4 * i + 1] = z;
            cols[4 * i + 2] = x;
            cols[4 * i + 3] = x.cross(&r_this);
            if let Some(k) = self.beta_index[i] {
                let y = prev.rot * Vector3::new(-st * l.cos_alpha, ct * l.cos_alpha, l.sin_alpha);
                cols[k] = y.cross(&r_this);
            }
            if let Some(k) = self.scale_index[i] {
                cols[k] = z * prismatic_mm(*q);
            }
        }
        let b = self.base_index;
        let [_, ry, rz] = self.base.r_rad;
        let rzm = Rotation3::from_axis_angle(&Vector3::z_axis(), rz);
        let ax_z = Vector3::z();
        let ax_y = rzm * Vector3::y();
        let ax_x = rzm * Rotation3::from_axis_angle(&Vector3::y_axis(), ry) * Vector3::x();
        let r_base = p - self.base_frame.pos_mm;
        cols[b] = ax_x.cross(&r_base);
        cols[b + 1] = ax_y.cross(&r_base);
        cols[b + 2] = ax_z.cross(&r_base);
        cols[b + 3] = Vector3::x();
        cols[b + 4] = Vector3::y();
        cols[b + 5] = Vector3::z();
        let rf = &frames[n].rot;
        cols[b + 6] = rf.column(0).into_owned();
        cols[b + 7] = rf.column(1).into_owned();
        cols[b + 8] = rf.column(2).into_owned();
        self.extended_columns(&w, cols);
        p
    }

    /// Stacked identification Jacobian for `m` poses (rows `3j..3j+3` belong to pose j) and
    /// the predicted points, written into caller-owned storage (no per-pose allocation).
    ///
    /// `jac` must be `3m × n_params()` and `points.len() == m`.
    pub fn jacobian_batch_into(
        &self,
        poses_rad: &[f64],
        points: &mut [Vector3<f64>],
        jac: &mut DMatrix<f64>,
    ) {
        let n = self.n_joints();
        let np = self.n_params();
        let m = poses_rad.len() / n;
        assert_eq!(poses_rad.len(), m * n, "pose buffer is not a multiple of N");
        assert_eq!(points.len(), m, "points buffer length");
        assert_eq!(jac.shape(), (3 * m, np), "Jacobian shape");
        let (mut jx, mut jy, mut jz) = ([0.0; MAX_PARAMS], [0.0; MAX_PARAMS], [0.0; MAX_PARAMS]);
        let mut sc = [[0.0; 2]; MAX_JOINTS];
        for (j, q) in poses_rad.chunks_exact(n).enumerate() {
            self.joint_trig(q, &mut sc);
            points[j] = self.point_jacobian_trig(&sc[..n], &mut jx, &mut jy, &mut jz);
            for k in 0..np {
                jac[(3 * j, k)] = jx[k];
                jac[(3 * j + 1, k)] = jy[k];
                jac[(3 * j + 2, k)] = jz[k];
            }
        }
    }

    /// Allocating convenience form of [`Robot::jacobian_batch_into`].
    pub fn jacobian_batch(&self, poses_rad: &[f64]) -> (Vec<Vector3<f64>>, DMatrix<f64>) {
        let m = poses_rad.len() / self.n_joints();
        let mut points = vec![Vector3::zeros(); m];
        let mut jac = DMatrix::zeros(3 * m, self.n_params());
        self.jacobian_batch_into(poses_rad, &mut points, &mut jac);
        (points, jac)
    }

    /// Geometric Jacobian (6×N) of a point fixed in the flange frame: rows 0–2 are
    /// `∂p/∂q_i = z_{i−1} × (p − o_{i−1})` (mm/rad), rows 3–5 the angular velocity `z_{i−1}`
    /// multiplied by `orientation_scale_mm` so both halves share units.
    pub fn geometric_jacobian(
        &self,
        q_rad: &[f64],
        point_in_flange_mm: &Vector3<f64>,
        orientation_scale_mm: f64,
    ) -> DMatrix<f64> {
        let entry =
            self.geometric_jacobian_entries(q_rad, point_in_flange_mm, orientation_scale_mm);
        DMatrix::from_fn(6, self.n_joints(), entry)
    }

    /// Entry `(row, i)` of [`Robot::geometric_jacobian`] at `q_rad`, as a function (the one
    /// formula behind the allocating and the fixed-size Jacobian).
    fn geometric_jacobian_entries(
        &self,
        q_rad: &[f64],
        point_in_flange_mm: &Vector3<f64>,
        orientation_scale_mm: f64,
    ) -> impl Fn(usize, usize) -> f64 + '_ {
        let mut axes = [(Vector3::zeros(), Vector3::zeros()); MAX_JOINTS];
        let f = self.joint_axes(q_rad, &mut axes);
        let p = f.transform_point(point_in_flange_mm);
        move |row, i| {
            let (z, o) = axes[i];
            match (self.prismatic_rate(i), row < 3) {
                (None, true) => z.cross(&(p - o))[row],
                (None, false) => z[row - 3] * orientation_scale_mm,
                (Some(v), true) => z[row] * v,
                (Some(_), false) => 0.0,
            }
        }
    }

    /// `J Jᵀ` (6 × 6) of [`Robot::geometric_jacobian`], summed over the joints in order,
    /// without allocation: its eigenvalues are the squared singular values of J (N ≥ 6).
    pub fn geometric_gram(
        &self,
        q_rad: &[f64],
        point_in_flange_mm: &Vector3<f64>,
        orientation_scale_mm: f64,
    ) -> Matrix6<f64> {
        let mut axes = [(Vector3::zeros(), Vector3::zeros()); MAX_JOINTS];
        let f = self.joint_axes(q_rad, &mut axes);
        let p = f.transform_point(point_in_flange_mm);
        gram_of_axes(
            axes[..self.n_joints()]
                .iter()
                .enumerate()
                .map(|(i, (z, o))| (*z, *o, self.prismatic_rate(i))),
            &p,
            orientation_scale_mm,
        )
    }

    /// Condition number σ_max/σ_min of [`Robot::geometric_jacobian`] for the flange origin
    /// (∞ at a singularity). Pose samplers use it to keep away from singular configurations.
    ///
    /// The singular values of the 6 × N Jacobian on the stack for N in
    /// `stack_linalg::SVD_COLUMNS` (nalgebra's SVD for that size: the dynamic matrix's bits,
    /// no heap allocation per pose screened, issue 43); longer chains allocate.
    pub fn singularity_condition(&self, q_rad: &[f64], orientation_scale_mm: f64) -> f64 {
        let n = self.n_joints();
        let entry = self.geometric_jacobian_entries(q_rad, &Vector3::zeros(), orientation_scale_mm);
        let mut columns = [0.0; 6 * MAX_JOINTS];
        for (k, v) in columns[..6 * n].iter_mut().enumerate() {
            *v = entry(k % 6, k / 6);
        }
        let (max, min) = stack_linalg::singular_value_range_6xn(&columns[..6 * n], n);
        if min > 0.0 { max / min } else { f64::INFINITY }
    }

    /// The flange frame and, for every joint, the axis `z_{i−1}` and a point `o_{i−1}` on
    /// it (measurement frame): what the geometric Jacobian of any point on the flange needs.
    pub(crate) fn joint_axes(
        &self,
        q_rad: &[f64],
        axes: &mut [(Vector3<f64>, Vector3<f64>); MAX_JOINTS],
    ) -> Frame {
        assert_eq!(q_rad.len(), self.links.len(), "joint vector length");
        let mut sc = [[0.0; 2]; MAX_JOINTS];
        self.joint_trig(q_rad, &mut sc);
        self.joint_axes_trig(&sc[..q_rad.len()], axes)
    }
}

/// `J Jᵀ` (6 × 6) of the geometric Jacobian whose column i is `(z_i × (p − o_i), s·z_i)` for
/// the joint axes `(z_i, o_i, None)` of revolute joints in order and the point `p` (or
/// `(v·z_i, 0)` for a prismatic joint's `(z_i, o_i, Some(v))`, [`Robot::prismatic_rate`]),
/// summed joint by joint (the one implementation behind [`Robot::geometric_gram`] and the
/// pose sampler's condition test).
pub fn gram_of_axes(
    axes: impl Iterator<Item = (Vector3<f64>, Vector3<f64>, Option<f64>)>,
    p: &Vector3<f64>,
    orientation_scale_mm: f64,
) -> Matrix6<f64> {
    let mut m = Matrix6::zeros();
    for (z, o, prismatic) in axes {
        let c = match prismatic {
            None => {
                let lin = z.cross(&(p - o));
                Vector6::new(
                    lin.x,
                    lin.y,
                    lin.z,
                    z.x * orientation_scale_mm,
                    z.y * orientation_scale_mm,
                    z.z * orientation_scale_mm,
                )
            }
            Some(v) => Vector6::new(z.x * v, z.y * v, z.z * v, 0.0, 0.0, 0.0),
        };
        for b in 0..6 {
            for a in 0..=b {
                m[(a, b)] += c[a] * c[b];
            }
        }
    }
    for b in 0..6 {
        for a in 0..b {
            m[(b, a)] = m[(a, b)];
        }
    }
    m
}
