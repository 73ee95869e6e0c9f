//! Beyond geometry: gravity torques and the non-geometric joint-error families of
//! `docs/extended-model.md` (joint compliance and gear / encoder harmonics).
//!
//! Both families perturb the joint angle before the geometric chain: the extended model
//! evaluates the MD-H chain of [`crate::Robot`] at
//!
//! `q̃_j = q_j + Σ_k w_k(q) · x_k`, for the parameters k acting on joint j,
//!
//! where `x_k` is the parameter's value and `w_k(q)` its per-pose weight:
//!
//! - `compliance_j` (internal unit rad/(N·m), display µrad/(N·m)): `w = τ_j(q)`, the gravity
//!   torque about joint j ([`Gravity`]) from the mass model of the robot file, evaluated on the
//!   **nominal** geometry at the **commanded** joints (first order in the deflection, as the
//!   virtual robot's truth does), so `w` is a per-pose constant;
//! - `gear_j_hk_sin` / `gear_j_hk_cos` (internal rad, display arcsec): `w = sin(k·q_j)` /
//!   `cos(k·q_j)`, k the harmonic (cycles per joint revolution), q_j commanded.
//!
//! Because `q̃` is linear in `x` with weights that do not depend on any parameter, the
//! identification Jacobian extends exactly by the chain rule: the column of `x_k` is
//! `w_k(q) · ∂p/∂θ_j (q̃)`, the θ_j column of [`crate::Robot::point_jacobian_into`] at `q̃`
//! scaled by the weight, and the geometric columns are those of the chain at `q̃`
//! (tested against central differences).
//!
//! This module knows frames, not robots: the entry points that evaluate a robot's chain
//! ([`ExtendedModel::new`], [`ExtendedModel::weights`], [`Gravity::torques_nm`]) are written
//! next to [`crate::Robot`] (`robot/families.rs`), which imports this module and not the
//! other way round.

use nalgebra::Vector3;

use crate::error::ModelError;
use crate::frame::Frame;
use crate::model::{MAX_JOINTS, MassModelSpec};
use crate::params::ExtendedKind;

/// The gravity torque about every joint of a chain with a mass model.
///
/// `τ_i = ẑ_{i−1} · Σ_{j≥i} (c_j − o_{i−1}) × m_j g` over the links j ≥ i and the payload
/// (`c_j` centres of mass, `ẑ_{i−1}`, `o_{i−1}` axis and origin of joint i, `g = −g ẑ_0`:
/// gravity along −z of the robot base), N·m. The one implementation of it: the virtual
/// robot's compliance truth and the compliance parameter family both call it.
#[derive(Debug, PartialEq)]
pub struct Gravity {
    /// (mass kg, centre of mass mm in link frame i+1) per joint i.
    links: Vec<(f64, Vector3<f64>)>,
    /// Payload (mass kg, centre of mass mm in the flange frame).
    payload: (f64, Vector3<f64>),
    /// Gravitational acceleration, m/s².
    gravity_m_per_s2: f64,
}

impl Gravity {
    /// The gravity model of per-joint link masses `(mass_kg, com_mm)`, a payload and `g`.
    pub fn new(
        links: impl IntoIterator<Item = (f64, [f64; 3])>,
        payload: (f64, [f64; 3]),
        gravity_m_per_s2: f64,
    ) -> Gravity {
        Gravity {
            links: links
                .into_iter()
                .map(|(m, c)| (m, Vector3::from(c)))
                .collect(),
            payload: (payload.0, Vector3::from(payload.1)),
            gravity_m_per_s2,
        }
    }

    /// The gravity model of a robot file's `mass_model` section.
    pub fn from_spec(m: &MassModelSpec) -> Gravity {
        Gravity::new(
            m.links.iter().map(|l| (l.mass_kg, l.com_mm)),
            (m.payload_kg, m.payload_com_mm),
            m.gravity_m_per_s2,
        )
    }

    /// τ_i (N·m) for every joint from the chain's frames (`frames[i]` the frame before joint
    /// i+1, as [`crate::Robot::frames_into`] writes them), into `out[..n_joints]`. No
    /// allocation.
    pub fn torques_from_frames(&self, frames: &[Frame; MAX_JOINTS + 1], out: &mut [f64]) {
        let n = self.links.len();
        let g = frames[0].rot.column(2) * (-self.gravity_m_per_s2);
        // Accumulate total mass M and first moment S = Σ m c (kg·mm) from the tip.
        let (mp, cp) = self.payload;
        let mut mass = mp;
        let mut moment = frames[n].transform_point(&cp) * mp;
        for i in (0..n).rev() {
            let (m, c) = self.links[i];
            mass += m;
            moment += frames[i + 1].transform_point(&c) * m;
            let axis = frames[i].rot.column(2);
            let lever_m = (moment - frames[i].pos_mm * mass) * 1e-3;
            out[i] = axis.dot(&lever_m.cross(&g));
        }
    }
}

/// One item of a list of non-geometric parameters, expanded for an `n_joints` robot: the
/// family `compliance` (every joint's), the family `gears` (the first harmonic, sine and
/// cosine, of every joint), or a parameter name, as itself. Scenario files
/// (`identification.extended`) and `--params …+…` both read their lists through it.
pub fn expand_family(item: &str, n_joints: usize) -> Vec<String> {
    match item {
        "compliance" => (1..=n_joints).map(|j| format!("compliance_{j}")).collect(),
        "gears" => (1..=n_joints)
            .flat_map(|j| [format!("gear_{j}_h1_sin"), format!("gear_{j}_h1_cos")])
            .collect(),
        name => vec![name.to_string()],
    }
}

/// The non-geometric part of an extended model: which parameters, their values, and the
/// gravity model compliance needs. [`crate::Robot::with_extended`] carries one and evaluates the
/// chain with it; the weights and offsets below are the one implementation it calls.
#[derive(Debug, PartialEq)]
pub struct ExtendedModel {
    kinds: Vec<ExtendedKind>,
    /// Values in internal units (rad/(N·m), rad), in `kinds` order.
    values: Vec<f64>,
    gravity: Option<Gravity>,
    n_joints: usize,
}

// `clone_from` copies into the vectors the target has (the derived one would allocate new
// ones): an extended robot refilled by `Robot::clone_from` (a solver's trial point, a
// campaign's kept robots) allocates nothing. Every field is named in both (a struct literal
// and a destructuring), so a new one is a compile error here rather than a stale copy.
impl Clone for Gravity {
    fn clone(&self) -> Self {
        Gravity {
            links: self.links.clone(),
            payload: self.payload,
            gravity_m_per_s2: self.gravity_m_per_s2,
        }
    }

    fn clone_from(&mut self, source: &Self) {
        let Gravity {
            links,
            payload,
            gravity_m_per_s2,
        } = source;
        self.links.clone_from(links);
        self.payload = *payload;
        self.gravity_m_per_s2 = *gravity_m_per_s2;
    }
}

impl Clone for ExtendedModel {
    fn clone(&self) -> Self {
        ExtendedModel {
            kinds: self.kinds.clone(),
            values: self.values.clone(),
            gravity: self.gravity.clone(),
            n_joints: self.n_joints,
        }
    }

    fn clone_from(&mut self, source: &Self) {
        let ExtendedModel {
            kinds,
            values,
            gravity,
            n_joints,
        } = source;
        self.kinds.clone_from(kinds);
        self.values.clone_from(values);
        // (`Option::clone_from` refills a `Some` with `Gravity::clone_from`.)
        self.gravity.clone_from(gravity);
        self.n_joints = *n_joints;
    }
}

impl ExtendedModel {
    /// [`ExtendedModel::new`] for a chain of `n` joints with the robot file's mass model
    /// `mass_model` (the checks and errors of `new`).
    pub(crate) fn for_chain<S: AsRef<str>>(
        n: usize,
        mass_model: Option<&MassModelSpec>,
        names: &[S],
        source_name: &str,
    ) -> Result<ExtendedModel, ModelError> {
        let invalid = |field: String, message: String| ModelError::Invalid {
            source_name: source_name.to_string(),
            field,
            message,
        };
        let mut kinds: Vec<ExtendedKind> = Vec::with_capacity(names.len());
        for (i, name) in names.iter().enumerate() {
            let name = name.as_ref().trim();
            let field = format!("params[{i}]");
            let kind = ExtendedKind::parse(name).ok_or_else(|| {
                invalid(
                    field.clone(),
                    format!(
                        "{name:?} is not a parameter of the extended families \
                         (compliance_J, gear_J_hK_sin, gear_J_hK_cos; J a joint from 1, K ≥ 1)"
                    ),
                )
            })?;
            if kind.joint() >= n {
                return Err(invalid(
                    field,
                    format!(
                        "{name:?}: joint {} does not exist (the robot has {n} joints)",
                        kind.joint() + 1
                    ),
                ));
            }
            if kinds.contains(&kind) {
                return Err(invalid(field, format!("{name:?} is given twice")));
            }
            kinds.push(kind);
        }
        let needs_mass = kinds
            .iter()
            .any(|k| matches!(k, ExtendedKind::Compliance(_)));
        let gravity = mass_model.map(Gravity::from_spec);
        if needs_mass && gravity.is_none() {
            return Err(invalid(
                "mass_model".into(),
                "the compliance parameters need the robot file's mass model (link masses and \
                 centres of mass, docs/extended-model.md); this robot has none"
                    .into(),
            ));
        }
        Ok(ExtendedModel {
            values: vec![0.0; kinds.len()],
            kinds,
            gravity,
            n_joints: n,
        })
    }

    /// The gravity model of the robot file's mass model, if it has one.
    pub fn gravity(&self) -> Option<&Gravity> {
        self.gravity.as_ref()
    }

    /// The parameters, in order.
    pub fn kinds(&self) -> &[ExtendedKind] {
        &self.kinds
    }

    /// Number of parameters.
    pub fn len(&self) -> usize {
        self.kinds.len()
    }

    /// True when the model has no parameter (the geometric model).
    pub fn is_empty(&self) -> bool {
        self.kinds.is_empty()
    }

    /// Values in internal units (rad/(N·m), rad).
    pub fn values(&self) -> &[f64] {
        &self.values
    }

    /// Sets every value (internal units).
    pub fn set_values(&mut self, v: &[f64]) -> Result<(), ModelError> {
        if v.len() != self.kinds.len() {
            return Err(ModelError::Length {
                what: "extended parameter vector",
                expected: self.kinds.len(),
                found: v.len(),
            });
        }
        self.values.copy_from_slice(v);
        Ok(())
    }

    /// Joints of the chain the model is for.
    pub(crate) fn n_joints(&self) -> usize {
        self.n_joints
    }

    /// Whether the weights need the gravity torques (a compliance parameter and a mass
    /// model), i.e. the frames of the torque geometry at the pose.
    pub(crate) fn needs_torques(&self) -> bool {
        self.gravity.is_some()
            && self
                .kinds
                .iter()
                .any(|k| matches!(k, ExtendedKind::Compliance(_)))
    }

    /// The weights `w_k` at the pose whose `[sin q, cos q]` are `sc` and whose torque-geometry
    /// frames are `frames` (read only when [`ExtendedModel::needs_torques`]), into
    /// `out[..len]`: τ_j from the frames, `sin(kq)`/`cos(kq)` by angle addition.
    pub(crate) fn weights_from_frames(
        &self,
        sc: &[[f64; 2]],
        frames: &[Frame; MAX_JOINTS + 1],
        out: &mut [f64],
    ) {
        let mut tau = [0.0; MAX_JOINTS];
        if let Some(g) = &self.gravity
            && self.needs_torques()
        {
            g.torques_from_frames(frames, &mut tau);
        }
        for (w, k) in out.iter_mut().zip(&self.kinds) {
            *w = match *k {
                ExtendedKind::Compliance(j) => tau[j],
                ExtendedKind::GearSin { joint, harmonic } => {
                    harmonic_sin_cos(sc[joint], harmonic)[0]
                }
                ExtendedKind::GearCos { joint, harmonic } => {
                    harmonic_sin_cos(sc[joint], harmonic)[1]
                }
            };
        }
    }

    /// The joint offsets `δ_j = Σ_k w_k x_k` over the parameters of joint j, given the
    /// weights `w`, into `delta[..n_joints]` (zero where no parameter acts).
    pub fn offsets(&self, w: &[f64], delta: &mut [f64]) {
        delta[..self.n_joints].fill(0.0);
        for ((k, wk), x) in self.kinds.iter().zip(w).zip(&self.values) {
            delta[k.joint()] += wk * x;
        }
    }

    /// The joints the geometric chain is evaluated at: `q̃ = q + δ`
    /// ([`ExtendedModel::offsets`]), given the weights `w` of [`ExtendedModel::weights`].
    pub fn effective_joints(&self, q_rad: &[f64], w: &[f64], out: &mut [f64]) {
        let mut delta = [0.0; MAX_JOINTS];
        self.offsets(w, &mut delta);
        for ((o, q), d) in out.iter_mut().zip(q_rad).zip(&delta) {
            *o = q + d;
        }
    }
}

/// `[sin kq, cos kq]` from `[sin q, cos q]` by the angle-addition recurrence.
fn harmonic_sin_cos([s, c]: [f64; 2], k: u32) -> [f64; 2] {
    let (mut sk, mut ck) = (s, c);
    for _ in 1..k {
        (sk, ck) = (sk * c + ck * s, ck * c - sk * s);
    }
    [sk, ck]
}
