//! The `unmodelled` section: errors the identification model does not contain
//! (`docs/model.md` §11).
//! Each is switched by its own `enabled` flag and sized in the scenario; compliance and
//! repeatability are on by default, gear errors and drift off.
//!
//! For a commanded joint vector `q` (rad), the true robot reaches
//! `p = FK_true,k(q + Δq_c(q) + Δq_g(q)) + ε_k`:
//!
//! - **Compliance** `Δq_c,i = (1 − c_i)·τ_i(q) / k_i`: τ_i is the gravity torque about
//!   axis i of every body beyond it, `τ_i = ẑ_{i−1} · Σ_{j≥i} (c_j − o_{i−1}) × m_j g`
//!   (links j ≥ i and the payload; `c_j` centres of mass, `ẑ_{i−1}`, `o_{i−1}` axis and origin
//!   of joint i from [`Robot::frames_into`] of the true robot at the commanded joints;
//!   `g = −g ẑ_0`, gravity along −z of the robot base). `k_i` is the joint stiffness
//!   (N·m/rad) and `c_i` the share of the torque a counterbalance carries (0 by default).
//!   Joints are the only elastic elements (links rigid), and the torque is evaluated at
//!   the commanded joints (first order in the deflection). Default masses are an
//!   approximate KR1000 titan split: see the crate docs.
//! - **Gear cyclic errors** `Δq_g,i = Σ_terms A·sin(n·q_i + φ)` with A in arcseconds,
//!   harmonic n (cycles per joint revolution) and phase φ (degrees, or drawn uniformly in
//!   [0°, 360°) per trial from stream `GEAR_PHASES` with `random_phase`).
//! - **Repeatability** `ε_k ~ N(0, σ² I₃)` at the point, drawn per move from stream
//!   `REPEATABILITY`: isotropic Cartesian scatter, the usual model of ISO 9283 RP. For
//!   Gaussian scatter `RP_l = l̄ + 3 S_l ≈ (1.596 + 3·0.673) σ = 3.62 σ`, so the default
//!   σ = 0.028 mm gives RP ≈ 0.10 mm, the KR1000 titan's ±0.1 mm.
//! - **Thermal drift**: the true parameters at move k (0-based, counting every call of
//!   [`crate::World::measure`]) are `p_true + k·rate`, `rate_per_move` given by parameter
//!   name in display units per move (mm or deg).
//!
//! ```json
//! "unmodelled": {
//!   "compliance": { "enabled": true, "payload_kg": 0, "payload_com_mm": [0, 0, 250] },
//!   "gears": { "enabled": false, "random_phase": false,
//!              "terms": [{ "joint": 2, "amplitude_arcsec": 10, "harmonic": 1, "phase_deg": 60 }] },
//!   "repeatability": { "enabled": true, "sigma_mm": 0.028 },
//!   "drift": { "enabled": false, "rate_per_move": { "a2": 0.0003, "d4": 0.0003 } }
//! }
//! ```
//! (`compliance` also takes `gravity_m_per_s2`, `links` (`[{ "mass_kg", "com_mm" }]`, one per
//! joint, centre of mass in the frame after that joint), `stiffness_nm_per_rad` and
//! `counterbalance_fraction`, one per joint.)

use std::collections::BTreeMap;
use std::sync::Arc;

use kinematics::{ExtendedKind, Frame, Gravity, MAX_JOINTS, MassModelSpec, ParamLayout, Robot};
use nalgebra::Vector3;
use rand::RngExt;
use rand::rngs::ChaCha8Rng;
use serde::{Deserialize, Serialize};

use crate::error::ConfigError;
use crate::validate::{all_finite, finite, non_negative, positive};

/// Mass and centre of mass of one link, in the link frame after its joint (frame i of
/// `docs/model.md` §2, the frame [`Robot::frames_into`] writes at index i).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LinkMass {
    /// Mass, kg.
    pub mass_kg: f64,
    /// Centre of mass in the link frame, mm.
    pub com_mm: [f64; 3],
}

/// Joint compliance under gravity.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ComplianceConfig {
    /// On (default) or off.
    pub enabled: bool,
    /// Gravitational acceleration, m/s² (default 9.80665), along −z of the robot base.
    pub gravity_m_per_s2: f64,
    /// One entry per joint. In a scenario file, left out means the robot file's own
    /// `mass_model` ([`UnmodelledConfig::use_robot_mass_model`]; refused when it has none and
    /// compliance is on); [`ComplianceConfig::default`] holds the KR1000 titan split of the
    /// crate docs.
    #[serde(default)]
    pub links: Vec<LinkMass>,
    /// Joint stiffness k_i per joint, N·m/rad (default: see the crate docs).
    pub stiffness_nm_per_rad: Vec<f64>,
    /// Share of the gravity torque carried by a counterbalance instead of the gear, per joint,
    /// in [0, 1] (a constant share of the whole torque, payload included: a crude model of a
    /// balancer); empty means none. Default: [`KR1000_COUNTERBALANCE_FRACTION`].
    pub counterbalance_fraction: Vec<f64>,
    /// Payload mass, kg (default 0).
    pub payload_kg: f64,
    /// Payload centre of mass in the flange frame, mm (default (0, 0, 250)).
    pub payload_com_mm: [f64; 3],
    /// Factor on every deflection (default 1; 0 to 2 in the extended-model sweep): the
    /// compliance (1 − c_i)/k_i times it. Left out of summaries at 1.
    #[serde(skip_serializing_if = "is_one")]
    pub scale: f64,
}

impl ComplianceConfig {
    /// The mass model of this configuration in the robot file's form (links, payload, g):
    /// what a robot file must carry for its compliance parameters to see the same torques.
    pub fn mass_model_spec(&self) -> MassModelSpec {
        MassModelSpec {
            gravity_m_per_s2: self.gravity_m_per_s2,
            links: self
                .links
                .iter()
                .map(|l| kinematics::LinkMassSpec {
                    mass_kg: l.mass_kg,
                    com_mm: l.com_mm,
                })
                .collect(),
            payload_kg: self.payload_kg,
            payload_com_mm: self.payload_com_mm,
        }
    }
}

/// `v == 1` (a default left out of summaries).
fn is_one(v: &f64) -> bool {
    *v == 1.0
}

/// Default link masses (kg) and centres of mass (mm, link frames) for the KR1000 titan;
/// see the crate docs for the split and its sources.
pub const KR1000_LINKS: [(f64, [f64; 3]); 6] = [
    (1650.0, [-350.0, 400.0, 0.0]),
    (850.0, [-700.0, 0.0, 0.0]),
    (800.0, [0.0, 0.0, 300.0]),
    (200.0, [0.0, -400.0, 0.0]),
    (70.0, [0.0, 0.0, 150.0]),
    (20.0, [0.0, 0.0, -20.0]),
];

/// Mass of the KR1000 titan's fixed base frame in the default split, kg (carries no joint
/// torque; with [`KR1000_LINKS`] it adds up to the data sheet's 4690 kg).
pub const KR1000_BASE_MASS_KG: f64 = 1100.0;

/// Default joint stiffness of the KR1000 titan, N·m/rad (see the crate docs).
pub const KR1000_STIFFNESS_NM_PER_RAD: [f64; 6] = [3.0e7, 3.0e7, 2.0e7, 2.0e6, 2.0e6, 1.0e6];

/// Default counterbalance shares of the KR1000 titan: 0.8 on axis 2 (its hydropneumatic
/// counterbalancing system; the share is an assumption, see the crate docs).
pub const KR1000_COUNTERBALANCE_FRACTION: [f64; 6] = [0.0, 0.8, 0.0, 0.0, 0.0, 0.0];

impl Default for ComplianceConfig {
    fn default() -> Self {
        ComplianceConfig {
            enabled: true,
            gravity_m_per_s2: 9.80665,
            links: KR1000_LINKS
                .iter()
                .map(|(m, c)| LinkMass {
                    mass_kg: *m,
                    com_mm: *c,
                })
                .collect(),
            stiffness_nm_per_rad: KR1000_STIFFNESS_NM_PER_RAD.to_vec(),
            counterbalance_fraction: KR1000_COUNTERBALANCE_FRACTION.to_vec(),
            payload_kg: 0.0,
            payload_com_mm: [0.0, 0.0, 250.0],
            scale: 1.0,
        }
    }
}

impl ComplianceConfig {
    /// Checks values; when enabled, also one entry per joint.
    pub fn validate(&self, n_joints: usize) -> Result<(), ConfigError> {
        let f = |name: &str| format!("unmodelled.compliance.{name}");
        non_negative(&f("gravity_m_per_s2"), self.gravity_m_per_s2)?;
        for (i, l) in self.links.iter().enumerate() {
            non_negative(&f(&format!("links[{i}].mass_kg")), l.mass_kg)?;
            all_finite(&f(&format!("links[{i}].com_mm")), &l.com_mm)?;
        }
        for (i, k) in self.stiffness_nm_per_rad.iter().enumerate() {
            positive(&f(&format!("stiffness_nm_per_rad[{i}]")), *k)?;
        }
        for (i, c) in self.counterbalance_fraction.iter().enumerate() {
            let field = f(&format!("counterbalance_fraction[{i}]"));
            finite(&field, *c)?;
            if !(0.0..=1.0).contains(c) {
                return Err(ConfigError::invalid(
                    field,
                    format!("a fraction must lie in [0, 1], got {c:?}"),
                ));
            }
        }
        non_negative(&f("payload_kg"), self.payload_kg)?;
        all_finite(&f("payload_com_mm"), &self.payload_com_mm)?;
        non_negative(&f("scale"), self.scale)?;
        if self.enabled {
            let count = |name: &str, len: usize| {
                if len == n_joints {
                    Ok(())
                } else {
                    Err(ConfigError::invalid(
                        f(name),
                        format!("{len} entries for a robot with {n_joints} joints"),
                    ))
                }
            };
            count("links", self.links.len())?;
            count("stiffness_nm_per_rad", self.stiffness_nm_per_rad.len())?;
            if !self.counterbalance_fraction.is_empty() {
                count(
                    "counterbalance_fraction",
                    self.counterbalance_fraction.len(),
                )?;
            }
        }
        Ok(())
    }
}

/// One cyclic term of a gear's transmission error.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GearTerm {
    /// Joint, 1-based.
    pub joint: usize,
    /// Amplitude A, arcseconds.
    pub amplitude_arcsec: f64,
    /// Harmonic n: cycles per joint revolution (≥ 0).
    pub harmonic: f64,
    /// Phase φ, degrees (replaced by a random draw with `random_phase`).
    pub phase_deg: f64,
}

/// Gear cyclic (transmission) errors.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct GearConfig {
    /// On or off (default off).
    pub enabled: bool,
    /// Draw every phase uniformly in [0°, 360°) per trial instead of using `phase_deg`.
    pub random_phase: bool,
    /// The terms. Default: one first-harmonic term per joint of the KR1000, 10″ on axes 1–3
    /// and 20″ on the wrist, phases 0°, 60°, …, 300° — illustrative sizes, not measured
    /// KR1000 data (10″ is ≈ 0.15 mm at 3 m).
    pub terms: Vec<GearTerm>,
    /// Factor on every term's amplitude (default 1; 0 to 2 in the extended-model sweep).
    /// Left out of summaries at 1.
    #[serde(skip_serializing_if = "is_one")]
    pub scale: f64,
}

impl Default for GearConfig {
    fn default() -> Self {
        GearConfig {
            enabled: false,
            random_phase: false,
            terms: (1..=6)
                .map(|j| GearTerm {
                    joint: j,
                    amplitude_arcsec: if j <= 3 { 10.0 } else { 20.0 },
                    harmonic: 1.0,
                    phase_deg: 60.0 * (j - 1) as f64,
                })
                .collect(),
            scale: 1.0,
        }
    }
}

impl GearConfig {
    /// Checks values; when enabled, also that every joint number exists.
    pub fn validate(&self, n_joints: usize) -> Result<(), ConfigError> {
        non_negative("unmodelled.gears.scale", self.scale)?;
        for (k, t) in self.terms.iter().enumerate() {
            let f = |name: &str| format!("unmodelled.gears.terms[{k}].{name}");
            non_negative(&f("amplitude_arcsec"), t.amplitude_arcsec)?;
            non_negative(&f("harmonic"), t.harmonic)?;
            finite(&f("phase_deg"), t.phase_deg)?;
            if self.enabled && !(1..=n_joints).contains(&t.joint) {
                return Err(ConfigError::invalid(
                    f("joint"),
                    format!(
                        "joint {} does not exist (joints are numbered 1 to {n_joints})",
                        t.joint
                    ),
                ));
            }
        }
        Ok(())
    }
}

/// Per-move repeatability scatter at the point.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct RepeatabilityConfig {
    /// On (default) or off.
    pub enabled: bool,
    /// σ per Cartesian axis at the point, mm (default 0.028 ⇒ RP ≈ 0.1 mm).
    pub sigma_mm: f64,
}

impl Default for RepeatabilityConfig {
    fn default() -> Self {
        RepeatabilityConfig {
            enabled: true,
            sigma_mm: 0.028,
        }
    }
}

/// Thermal drift: linear growth of parameters over the move index.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct DriftConfig {
    /// On or off (default off).
    pub enabled: bool,
    /// Growth per move by parameter name, display units (mm or deg) per move. Default
    /// a2 and d4 grow 0.0003 mm per move (≈ 2 K warm-up of 1.4 m of steel over 100 moves).
    pub rate_per_move: BTreeMap<String, f64>,
}

impl Default for DriftConfig {
    fn default() -> Self {
        DriftConfig {
            enabled: false,
            rate_per_move: [("a2".to_string(), 3e-4), ("d4".to_string(), 3e-4)]
                .into_iter()
                .collect(),
        }
    }
}

impl DriftConfig {
    /// Checks values; when enabled, also the parameter names.
    pub fn validate(&self, layout: &ParamLayout) -> Result<(), ConfigError> {
        for (name, v) in &self.rate_per_move {
            let field = format!("unmodelled.drift.rate_per_move.{name}");
            if self.enabled && layout.index_of(name).is_err() {
                return Err(ConfigError::UnknownParameter {
                    field,
                    name: name.clone(),
                    known: layout.names().join(", "),
                });
            }
            finite(&field, *v)?;
        }
        Ok(())
    }
}

/// The `unmodelled` section. Its default's compliance has no `links`: the robot file's own
/// `mass_model` ([`UnmodelledConfig::use_robot_mass_model`]).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct UnmodelledConfig {
    /// Joint compliance under gravity (on by default).
    pub compliance: ComplianceConfig,
    /// Gear cyclic errors (off by default).
    pub gears: GearConfig,
    /// Repeatability scatter (on by default).
    pub repeatability: RepeatabilityConfig,
    /// Thermal drift (off by default).
    pub drift: DriftConfig,
}

impl Default for UnmodelledConfig {
    fn default() -> Self {
        UnmodelledConfig {
            compliance: ComplianceConfig {
                links: Vec::new(),
                ..ComplianceConfig::default()
            },
            gears: GearConfig::default(),
            repeatability: RepeatabilityConfig::default(),
            drift: DriftConfig::default(),
        }
    }
}

impl UnmodelledConfig {
    /// Fills the compliance section's `links`, when it gives none, from the robot file's
    /// `mass_model`: a simulated robot is weighed by its own
    /// masses, not by the KR1000's. With compliance on and neither, the error names the field
    /// and the two ways out. Idempotent.
    pub fn use_robot_mass_model(&mut self, robot: &Robot) -> Result<(), ConfigError> {
        let c = &mut self.compliance;
        if !c.links.is_empty() {
            return Ok(());
        }
        match robot.mass_model() {
            Some(m) => {
                c.links = m
                    .links
                    .iter()
                    .map(|l| LinkMass {
                        mass_kg: l.mass_kg,
                        com_mm: l.com_mm,
                    })
                    .collect();
                Ok(())
            }
            None if c.enabled => Err(ConfigError::invalid(
                "unmodelled.compliance.links",
                format!(
                    "the simulated joint compliance needs link masses, but the robot file of \
                     `{}` has no `mass_model` and this section gives no `links`: add a \
                     `mass_model` to the robot file (docs/model.md §4), give `links` here, or \
                     set `unmodelled.compliance.enabled` to false",
                    robot.name()
                ),
            )),
            None => Ok(()),
        }
    }

    /// Everything off.
    pub fn off() -> Self {
        let mut c = UnmodelledConfig::default();
        c.compliance.enabled = false;
        c.gears.enabled = false;
        c.repeatability.enabled = false;
        c.drift.enabled = false;
        c
    }

    /// Checks every subsection against the robot.
    pub fn validate(&self, nominal: &Robot) -> Result<(), ConfigError> {
        let n = nominal.n_joints();
        if self.compliance.links.is_empty() {
            let mut resolved = self.clone();
            resolved.use_robot_mass_model(nominal)?;
            resolved.compliance.validate(n)?;
        } else {
            self.compliance.validate(n)?;
        }
        self.gears.validate(n)?;
        non_negative(
            "unmodelled.repeatability.sigma_mm",
            self.repeatability.sigma_mm,
        )?;
        self.drift.validate(nominal.layout())
    }
}

/// The compliance model `Δq_i = (1 − c_i)·τ_i(q)/k_i` (see the module docs); τ_i is
/// [`kinematics::Gravity`]'s, the one implementation of the gravity torque.
#[derive(Clone, Debug, PartialEq)]
pub struct ComplianceModel {
    /// Link masses, centres of mass, payload and g.
    gravity: Gravity,
    /// (1 − c_i)/k_i, rad per N·m.
    gain: Vec<f64>,
}

impl ComplianceModel {
    /// Builds the model for a robot with `n_joints` joints, whatever `cfg.enabled` says.
    pub fn new(cfg: &ComplianceConfig, n_joints: usize) -> Result<Self, ConfigError> {
        let mut on = cfg.clone();
        on.enabled = true;
        on.validate(n_joints)?;
        Ok(Self::from_validated(cfg, n_joints))
    }

    /// [`ComplianceModel::new`] for a configuration already validated (enabled).
    fn from_validated(cfg: &ComplianceConfig, n_joints: usize) -> Self {
        ComplianceModel {
            gravity: Gravity::new(
                cfg.links.iter().map(|l| (l.mass_kg, l.com_mm)),
                (cfg.payload_kg, cfg.payload_com_mm),
                cfg.gravity_m_per_s2,
            ),
            gain: (0..n_joints)
                .map(|i| {
                    let c = cfg.counterbalance_fraction.get(i).copied().unwrap_or(0.0);
                    // × 1 (the default scale) is exact: the same bits as without it.
                    (1.0 - c) / cfg.stiffness_nm_per_rad[i] * cfg.scale
                })
                .collect(),
        }
    }

    /// Gravity torque τ_i about every joint axis, N·m (before the counterbalance), at the
    /// joints `q_rad` of `robot`. No allocation.
    pub fn torques_nm(&self, robot: &Robot, q_rad: &[f64], out: &mut [f64]) {
        self.gravity.torques_nm(robot, q_rad, out);
    }

    /// Joint deflections Δq_i (rad) at the joints `q_rad` of `robot`. No allocation.
    pub fn deflection_rad(&self, robot: &Robot, q_rad: &[f64], out: &mut [f64]) {
        self.torques_nm(robot, q_rad, out);
        for (d, k) in out.iter_mut().zip(&self.gain) {
            *d *= k;
        }
    }

    /// [`ComplianceModel::deflection_rad`] at the joints whose `[sin q, cos q]` are `sc`
    /// (the same bits: the frames come from [`Robot::frames_trig`]).
    fn deflection_trig(&self, robot: &Robot, sc: &[[f64; 2]], out: &mut [f64]) {
        let mut frames = [Frame::identity(); MAX_JOINTS + 1];
        robot.frames_trig(sc, &mut frames);
        self.gravity.torques_from_frames(&frames, out);
        for (d, k) in out.iter_mut().zip(&self.gain) {
            *d *= k;
        }
    }

    /// Displacement of the measured point caused by the deflection,
    /// `p(q + Δq) − p(q)`, mm.
    pub fn point_deflection_mm(&self, robot: &Robot, q_rad: &[f64]) -> Vector3<f64> {
        let n = q_rad.len();
        let mut dq = [0.0; MAX_JOINTS];
        self.deflection_rad(robot, q_rad, &mut dq[..n]);
        let mut q = [0.0; MAX_JOINTS];
        for i in 0..n {
            q[i] = q_rad[i] + dq[i];
        }
        robot.point(&q[..n]) - robot.point(q_rad)
    }
}

/// A gear term in internal units.
#[derive(Clone, Copy, Debug, PartialEq)]
struct GearRad {
    joint: usize,
    amplitude_rad: f64,
    harmonic: f64,
    phase_deg: f64,
    phase_rad: f64,
}

/// The unmodelled-error model of one trial (built from a validated [`UnmodelledConfig`]).
/// What does not depend on the trial (the compliance model, the drift rates) is shared
/// between the trials' copies; only the gear terms (their random phases) are a trial's own.
#[derive(Debug, PartialEq)]
pub struct Unmodelled {
    compliance: Option<Arc<ComplianceModel>>,
    gears: Vec<GearRad>,
    scatter_sigma_mm: f64,
    drift_per_move: Option<Arc<[f64]>>,
}

impl Clone for Unmodelled {
    fn clone(&self) -> Self {
        let mut u = Unmodelled {
            compliance: None,
            gears: Vec::new(),
            scatter_sigma_mm: 0.0,
            drift_per_move: None,
        };
        u.clone_from(self);
        u
    }

    /// The shared parts by reference count, the gear terms into `self`'s vector (no
    /// allocation once it has the room).
    fn clone_from(&mut self, source: &Self) {
        // (Every field named: a new one is a compile error here, not a stale copy.)
        let Unmodelled {
            compliance,
            gears,
            scatter_sigma_mm,
            drift_per_move,
        } = source;
        self.compliance.clone_from(compliance);
        self.gears.clone_from(gears);
        self.scatter_sigma_mm = *scatter_sigma_mm;
        self.drift_per_move.clone_from(drift_per_move);
    }
}

impl Unmodelled {
    /// Builds the model from a configuration validated against `robot` (as
    /// [`crate::Setup::new`] does once for all trials) with the configured gear phases:
    /// what every trial shares; a trial's copy draws its random phases
    /// ([`Unmodelled::draw_phases`]).
    pub(crate) fn configured(cfg: &UnmodelledConfig, robot: &Robot) -> Result<Self, ConfigError> {
        debug_assert!(cfg.validate(robot).is_ok(), "validated configuration");
        let n = robot.n_joints();
        let compliance = if cfg.compliance.enabled {
            Some(Arc::new(ComplianceModel::from_validated(
                &cfg.compliance,
                n,
            )))
        } else {
            None
        };
        let gears = if cfg.gears.enabled {
            cfg.gears
                .terms
                .iter()
                .map(|t| {
                    let phase_deg = t.phase_deg;
                    GearRad {
                        joint: t.joint - 1,
                        amplitude_rad: (t.amplitude_arcsec / 3600.0).to_radians() * cfg.gears.scale,
                        harmonic: t.harmonic,
                        phase_deg,
                        phase_rad: phase_deg.to_radians(),
                    }
                })
                .collect()
        } else {
            Vec::new()
        };
        let drift_per_move = if cfg.drift.enabled {
            let layout = robot.layout();
            let mut rates = vec![0.0; layout.len()];
            for (name, v) in &cfg.drift.rate_per_move {
                if let Ok(k) = layout.index_of(name) {
                    rates[k] = layout.get(k).from_display(*v);
                }
            }
            Some(Arc::from(rates))
        } else {
            None
        };
        Ok(Unmodelled {
            compliance,
            gears,
            scatter_sigma_mm: if cfg.repeatability.enabled {
                cfg.repeatability.sigma_mm
            } else {
                0.0
            },
            drift_per_move,
        })
    }

    /// With `cfg.gears.random_phase`, draws every gear term's phase from `gear_rng`
    /// (uniform in [0°, 360°), in the terms' order); otherwise leaves the configured ones
    /// (what [`crate::Setup::world_into`] does to its copy of the setup's model).
    pub(crate) fn draw_phases(&mut self, cfg: &UnmodelledConfig, gear_rng: &mut ChaCha8Rng) {
        if !(cfg.gears.enabled && cfg.gears.random_phase) {
            return;
        }
        for g in &mut self.gears {
            g.phase_deg = 360.0 * gear_rng.random::<f64>();
            g.phase_rad = g.phase_deg.to_radians();
        }
    }

    /// The compliance model, if enabled.
    pub fn compliance(&self) -> Option<&ComplianceModel> {
        self.compliance.as_deref()
    }

    /// The values (internal units: rad/(N·m), rad) that the non-geometric parameters `kinds`
    /// take for this model's compliance and gear terms: `compliance_j` is the gain
    /// `(1 − c_j)/k_j` (× scale; 0 with compliance off), and a term `A·sin(k·q_j + φ)` of
    /// integer harmonic k is `A·cos φ·sin(k q_j) + A·sin φ·cos(k q_j)`, so it adds `A·cos φ`
    /// to `gear_j_hk_sin` and `A·sin φ` to `gear_j_hk_cos`. Terms the family does not contain
    /// (another joint or harmonic) have no parameter: they stay outside the model.
    pub fn extended_values(&self, kinds: &[ExtendedKind]) -> Vec<f64> {
        kinds
            .iter()
            .map(|kind| match *kind {
                ExtendedKind::Compliance(j) => self
                    .compliance
                    .as_deref()
                    .and_then(|c| c.gain.get(j).copied())
                    .unwrap_or(0.0),
                ExtendedKind::GearSin { joint, harmonic }
                | ExtendedKind::GearCos { joint, harmonic } => {
                    let sin_term = matches!(kind, ExtendedKind::GearSin { .. });
                    self.gears
                        .iter()
                        .filter(|g| g.joint == joint && g.harmonic == f64::from(harmonic))
                        .map(|g| {
                            let (s, c) = g.phase_rad.sin_cos();
                            g.amplitude_rad * if sin_term { c } else { s }
                        })
                        .sum()
                }
            })
            .collect()
    }

    /// Phases actually used by the gear terms, degrees (empty if gears are off).
    pub fn gear_phases_deg(&self) -> Vec<f64> {
        self.gears.iter().map(|g| g.phase_deg).collect()
    }

    /// σ of the repeatability scatter per axis, mm (0 if off).
    pub fn scatter_sigma_mm(&self) -> f64 {
        self.scatter_sigma_mm
    }

    /// Drift per move in internal units, layout order (`None` if off).
    pub fn drift_per_move(&self) -> Option<&[f64]> {
        self.drift_per_move.as_deref()
    }

    /// True if the joints are perturbed at all (compliance or gears).
    pub fn perturbs_joints(&self) -> bool {
        self.compliance.is_some() || !self.gears.is_empty()
    }

    /// The joints the robot actually reaches: `q_out = q_cmd + Δq_c(q_cmd) + Δq_g(q_cmd)`
    /// (compliance evaluated with `robot`'s frames). `q_out` is a copy of `q_cmd` when both
    /// are off. No allocation.
    pub fn actual_joints(&self, robot: &Robot, q_cmd: &[f64], q_out: &mut [f64]) {
        let mut trig = CmdTrig::default();
        trig.compute(Some(self), q_cmd);
        self.actual_joints_trig(robot, q_cmd, &trig, q_out);
    }

    /// [`Unmodelled::actual_joints`] with the sines and cosines of `q_cmd` (and the gear
    /// terms' sines) already in `trig` ([`CmdTrig::compute`] of the same `q_cmd`).
    pub(crate) fn actual_joints_trig(
        &self,
        robot: &Robot,
        q_cmd: &[f64],
        trig: &CmdTrig,
        q_out: &mut [f64],
    ) {
        q_out.copy_from_slice(q_cmd);
        let n = q_cmd.len();
        if let Some(c) = &self.compliance {
            let mut dq = [0.0; MAX_JOINTS];
            c.deflection_trig(robot, &trig.sc[..n], &mut dq[..n]);
            for (q, d) in q_out.iter_mut().zip(&dq[..n]) {
                *q += d;
            }
        }
        if trig.gears_done {
            for (g, s) in self.gears.iter().zip(&trig.wide_sin[n..]) {
                q_out[g.joint] += g.amplitude_rad * s;
            }
            return;
        }
        // The gear terms' sines all at once (kinematics::trig, eight per vector).
        let mut arg = [0.0; 4 * MAX_JOINTS];
        let mut sin = [0.0; 4 * MAX_JOINTS];
        let mut cos = [0.0; 4 * MAX_JOINTS];
        for chunk in self.gears.chunks(4 * MAX_JOINTS) {
            let k = chunk.len();
            for (a, g) in arg.iter_mut().zip(chunk) {
                *a = g.harmonic * q_cmd[g.joint] + g.phase_rad;
            }
            kinematics::trig::sin_cos_slice(&arg[..k], &mut sin[..k], &mut cos[..k]);
            for (g, s) in chunk.iter().zip(&sin[..k]) {
                q_out[g.joint] += g.amplitude_rad * s;
            }
        }
    }
}

/// Lanes of [`CmdTrig`]'s one kernel call: the joints and the gear terms' arguments.
const CMD_LANES: usize = 16;

/// The trigonometry of a commanded joint vector: `[sin q_i, cos q_i]` and, when the joints
/// and the gear terms fit in [`CMD_LANES`] lanes together, the gear terms' sines, all from
/// one call of the sine kernel. Every value is the one the separate calls give, bit for bit.
#[derive(Clone, Copy, Debug)]
pub(crate) struct CmdTrig {
    /// `[sin q_i, cos q_i]` of the commanded joints.
    pub(crate) sc: [[f64; 2]; MAX_JOINTS],
    /// Lane i < N: sin q_i; lane N + t: sine of gear term t's argument.
    wide_sin: [f64; CMD_LANES],
    /// Whether the gear sines are in `wide_sin`.
    gears_done: bool,
}

impl Default for CmdTrig {
    fn default() -> Self {
        CmdTrig {
            sc: [[0.0; 2]; MAX_JOINTS],
            wide_sin: [0.0; CMD_LANES],
            gears_done: false,
        }
    }
}

impl CmdTrig {
    /// `robot`'s point at the commanded joints `q_cmd` whose trigonometry this holds
    /// ([`kinematics::Robot::point_trig`]): a prismatic joint's pair is marked for the
    /// kernels first ([`kinematics::Robot::mark_prismatic`]; nothing for a revolute chain).
    #[inline]
    pub(crate) fn point(&self, robot: &Robot, q_cmd: &[f64]) -> Vector3<f64> {
        let n = q_cmd.len();
        if robot.has_prismatic() {
            let mut sc = self.sc;
            robot.mark_prismatic(q_cmd, &mut sc[..n]);
            return robot.point_trig(&sc[..n]);
        }
        robot.point_trig(&self.sc[..n])
    }

    /// Fills in the trigonometry of `q_cmd` for `unmodelled`'s gear terms (of the joints
    /// only with `None`).
    #[inline]
    pub(crate) fn compute(&mut self, unmodelled: Option<&Unmodelled>, q_cmd: &[f64]) {
        self.fill(unmodelled, q_cmd, None);
    }

    /// [`CmdTrig::compute`] given the joints' `[sin q_i, cos q_i]` already (`sc`, as
    /// [`kinematics::joint_sin_cos`] gives them: the same bits), which are then not computed
    /// again unless the gear terms' kernel call computes them along.
    #[inline]
    pub(crate) fn compute_with_joints(
        &mut self,
        unmodelled: Option<&Unmodelled>,
        q_cmd: &[f64],
        sc: &[[f64; 2]],
    ) {
        self.fill(unmodelled, q_cmd, Some(sc));
    }

    #[inline]
    fn fill(
        &mut self,
        unmodelled: Option<&Unmodelled>,
        q_cmd: &[f64],
        joints: Option<&[[f64; 2]]>,
    ) {
        let n = q_cmd.len();
        let gears: &[GearRad] = unmodelled.map_or(&[], |u| &u.gears);
        let k = gears.len();
        if k == 0 || n + k > CMD_LANES {
            match joints {
                Some(sc) => self.sc[..n].copy_from_slice(sc),
                None => crate::sincos::joint_trig(q_cmd, &mut self.sc),
            }
            self.gears_done = false;
            return;
        }
        let mut x = [0.0; CMD_LANES];
        x[..n].copy_from_slice(q_cmd);
        for (a, g) in x[n..n + k].iter_mut().zip(gears) {
            *a = g.harmonic * q_cmd[g.joint] + g.phase_rad;
        }
        let (s, c) = crate::sincos::block::<CMD_LANES>(&x);
        for i in 0..n {
            self.sc[i] = [s[i], c[i]];
        }
        self.wide_sin = s;
        self.gears_done = true;
    }
}
