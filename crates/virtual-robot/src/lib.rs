//! The virtual robot: the "truth" of kincal's simulations.
//!
//! A [`World`] is one trial of a simulated calibration campaign: the nominal robot, the
//! true robot (nominal parameters plus injected errors), a Leica AT960-class laser tracker,
//! errors the identification model does not contain, the sampled pose sets and the random
//! streams of the measuring process. [`simulate()`] measures the pose sets and returns the two
//! measurement files of `docs/model.md` §5 and the truth; [`Simulation::write`] puts them on disk.
//!
//! # Measuring chain
//!
//! For commanded joints `q` (radians) at move k, [`World::measure`] returns
//!
//! `p_meas = T_res · (FK_true,k(q + Δq_compliance(q) + Δq_gears(q)) + ε_k) + ν`
//!
//! with `FK_true,k` the true geometry drifted to move k, `ε_k` the repeatability scatter,
//! `T_res` the residual of the base frame built from the tracker and `ν` the tracker noise
//! (drawn in the beam frame, before `T_res`). Poses outside the joint limits or the tracker's
//! view give [`NotMeasurable`]. With every error off and no noise the result is
//! [`kinematics::Robot::point`] of the true robot, bit for bit.
//!
//! # Configuration
//!
//! Four serde sections, each with defaults and `deny_unknown_fields`, grouped in
//! [`VirtualRobotConfig`]: `truth` ([`InjectedErrors`], module [`truth`]), `tracker`
//! ([`TrackerConfig`], [`tracker`]), `unmodelled` ([`UnmodelledConfig`], [`unmodelled`]) and
//! `poses` ([`PoseSampling`], [`poses`]). The module docs give the models and formulas.
//! [`VirtualRobotConfig::validate`] names the offending field
//! of every error (`tracker.sigma_fraction`, `truth.explicit.thetaX`, …).
//!
//! ```
//! use kinematics::{Robot, RobotSpec};
//! use virtual_robot::{VirtualRobotConfig, simulate};
//!
//! let spec = RobotSpec::from_json_str(
//!     include_str!("../../../scenarios/robots/kr1000-titan.json"), "kr1000")?;
//! let robot = Robot::from_spec(&spec)?;
//! let cfg = VirtualRobotConfig::from_json_str(r#"{
//!   "truth": {
//!     "random": { "distribution": "normal", "joint_angle_sigma_deg": 0.005,
//!                 "length_sigma_mm": 0.2, "base_rotation_sigma_deg": 0.005,
//!                 "base_translation_sigma_mm": 0.5, "tool_sigma_mm": 0.2 },
//!     "explicit": { "beta2": 0.01 },
//!     "scale_to": { "mean_error_mm": 1.122, "poses": 200 }
//!   },
//!   "tracker": {
//!     "position_mm": [4000, -1500, 1200], "noise_model": "anisotropic",
//!     "sigma_fraction": 0.5, "elevation_limit_deg": 45,
//!     "base_residual": { "rz_deg": 0.002, "dx_mm": 0.05 }
//!   },
//!   "unmodelled": {
//!     "compliance": { "enabled": true, "payload_kg": 0 },
//!     "gears": { "enabled": true, "random_phase": true },
//!     "repeatability": { "enabled": true, "sigma_mm": 0.028 },
//!     "drift": { "enabled": false }
//!   },
//!   "poses": { "identification": 50, "validation": 50, "min_point_z_mm": 300,
//!              "min_abs_q5_deg": 10, "max_condition": 100 }
//! }"#)?;
//! cfg.validate(&robot)?;
//! let sim = simulate(&robot, &cfg, 42, 0)?;
//! assert_eq!(sim.identification.rows.len(), 50);
//! assert!((sim.truth.scale.as_ref().unwrap().mean_error_mm - 1.122).abs() < 1e-9);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! # Randomness
//!
//! Every draw comes from `ChaCha8Rng::seed_from_u64(seed)` with stream
//! `(purpose << 56) | trial` ([`stream`], [`Purpose`]): truth, identification poses,
//! validation poses, tracker noise, repeatability and gear phases each have their own stream
//! per trial, so a trial's results depend on (seed, trial, configuration) only — not on
//! thread count, nor on which other trials ran before. The scaling pose set uses trial 0 for
//! every trial. [`Setup`] holds the trial-independent part (validated configuration,
//! scaling poses) so a campaign builds it once.
//!
//! # Joint compliance of the KR1000 titan (defaults)
//!
//! Model: [`unmodelled`], `Δq_i = (1 − c_i)·τ_i(q)/k_i`.
//!
//! **Masses.** KUKA's data sheet gives ≈ 4690 kg for the KR 1000 titan (rated payload
//! 1000 kg, reach 3202 mm). It gives no per-link split; this one is an estimate from the
//! robot's proportions ([`KR1000_LINKS`], centres of mass in the link frames of
//! `docs/model.md` §2):
//!
//! | body | mass (kg) | centre of mass |
//! |---|---|---|
//! | base frame (fixed) | 1100 | — (no joint torque) |
//! | rotating column with A1/A2 drives and counterbalance (link 1) | 1650 | 250 mm from axis 1, 700 mm above the floor |
//! | link arm (link 2) | 850 | middle of the 1400 mm arm |
//! | arm with A3 gear and the A4–A6 motors at its rear (link 3) | 800 | on axis 4, 300 mm ahead of axis 3 |
//! | wrist housing (link 4) | 200 | on axis 4, 400 mm behind the wrist centre |
//! | wrist bend (link 5) | 70 | on axis 6, 150 mm from the wrist centre |
//! | flange (link 6) | 20 | 20 mm behind the flange |
//!
//! **Stiffness.** Identified joint stiffnesses of heavy KUKA robots are of order
//! 10⁶–10⁷ N·m/rad for the main axes and a few 10⁵–10⁶ for the wrist (Dumas, Caro,
//! Garnier, Furet, "Joint stiffness identification of six-revolute industrial serial
//! robots", Robotics and Computer-Integrated Manufacturing 27(4), 2011, KR 240-2; Jubien,
//! Abba, Gautier, "Joint stiffness identification of a heavy Kuka robot with a low-cost
//! clamped end-effector procedure", ICINCO 2014, KR 500 axes 1–2). The KR1000 has four times
//! the KR 240's payload and correspondingly larger gears; the defaults
//! ([`KR1000_STIFFNESS_NM_PER_RAD`]) are k = (3·10⁷, 3·10⁷, 2·10⁷, 2·10⁶, 2·10⁶, 10⁶) N·m/rad
//! with 80 % of the axis-2 torque carried by the robot's hydropneumatic counterbalance
//! ([`KR1000_COUNTERBALANCE_FRACTION`], an assumption). These are chosen so that the
//! self-weight deflection left over after a linearised fit of the 34 parameters on 50
//! sampled poses is ≈ 0.2 mm — about 55 % of the paper's 0.340 mm residual, the share a
//! published KR 210 study attributes to elasticity (`docs/model.md` §11); the test
//! `compliance_left_after_a_linear_fit` checks that figure.
//!
//! **Deflection at the measured point** `‖p(q + Δq) − p(q)‖` of the nominal KR1000 with the
//! ball at (60, 20, 150) mm in the flange frame, gravity 9.80665 m/s², payload centre of mass
//! 250 mm in front of the flange (computed by the test `compliance_table_matches_the_docs`).
//! The first two columns use the defaults above (balancer 80 %); the last is the shipped
//! `paper-kr1000` scenario's setting (no payload, balancer 58 %, tuned so that its Table 4
//! lands within 10 % of the paper's):
//!
//! | q1…q6 (deg) | point (mm) | 0 kg (mm) | 1000 kg (mm) | 0 kg, balancer 58 % (mm) |
//! |---|---|---|---|---|
//! | (0, 0, 0, 0, 0, 0) | (2322, −20, 2625) | 0.555 | 3.924 | 0.630 |
//! | (0, 45, 0, 0, 45, 0) | (2544, −20, 765) | 0.532 | 1.434 | 0.785 |
//! | (0, 60, −60, 0, 30, 0) | (3495, −20, 1656) | 0.915 | 4.213 | 1.411 |
//! | (0, −30, −90, 0, 90, 0) | (−334, −20, 3632) | 0.423 | 1.346 | 0.687 |
//! | (0, 30, 30, 0, 60, 0) | (1747, −20, 824) | 0.290 | 0.693 | 0.387 |
//!
//! Most of this is a smooth function of the pose that the geometric parameters partly
//! absorb; what they cannot absorb remains after calibration.
//!
//! # Not modelled
//!
//! Link (as opposed to joint) elasticity, backlash and approach-direction effects,
//! temperature fields beyond linear parameter drift, tracker warm-up and refraction, and
//! occlusion of the beam by the robot itself.

#![warn(missing_docs)]

pub mod config;
pub mod error;
pub mod poses;
pub mod rng;
pub mod sampling;
pub mod simulate;
mod sincos;
pub mod tracker;
pub mod truth;
pub mod unmodelled;
mod validate;
pub mod world;

pub use config::VirtualRobotConfig;
pub use error::{ConfigError, NotMeasurable, SimError};
pub use poses::{PoseSampling, PoseSet, SAMPLING_MARGIN_DEG, SAMPLING_MARGIN_MM};
pub use rng::{MAX_TRIAL, Purpose, stream};
pub use sampling::{SamplingReport, SamplingStats};
pub use simulate::{
    IDENTIFICATION_FILE, Probe, Simulation, TRUTH_FILE, VALIDATION_FILE, simulate, simulate_with,
};
pub use tracker::{NoiseModel, Tracker, TrackerConfig};
pub use truth::{ErrorDistribution, InjectedErrors, RandomErrors, ScaleOutcome, ScaleTarget};
pub use unmodelled::{
    ComplianceConfig, ComplianceModel, DriftConfig, GearConfig, GearTerm, KR1000_BASE_MASS_KG,
    KR1000_COUNTERBALANCE_FRACTION, KR1000_LINKS, KR1000_STIFFNESS_NM_PER_RAD, LinkMass,
    RepeatabilityConfig, Unmodelled, UnmodelledConfig,
};
pub use world::{Setup, ToolReading, TrueParameter, Truth, World};
