//! The `tracker` section and the virtual Leica AT960-class laser tracker (`docs/model.md` §10).
//!
//! With `r` the range head → target in metres and `f` = `sigma_fraction` (½ by default,
//! Leica's "typical = MPE/2"; ⅓ is the other common choice):
//!
//! - MPE: `U = a + b·r` µm (`mpe_a_um` = 15, `mpe_b_um_per_m` = 6).
//! - `anisotropic` (default): along the beam (ADM) `σ_r = f·(10 + 0.3 r)` µm
//!   (`adm_a_um`, `adm_b_um_per_m`); across the beam `σ_⊥ = f·(15 + 6 r)` µm = `f·U` in each
//!   of the two transverse directions (horizontal `ê_h = ẑ × û / ‖ẑ × û‖` and
//!   `ê_v = û × ê_h`, û the beam direction).
//! - `isotropic`: `σ = f·U` along every axis.
//! - Every σ is multiplied by `noise_scale`; `noise: false` switches noise off (no draws).
//!
//! - Orientation (a 6-DoF probe on the flange, scenario `measurement.type: "frame"`): the
//!   measured rotation is `R_meas = R_res · R · exp([n]×)`, `n` three independent normal
//!   draws (rad, probe axes) of σ = `f·orientation_mpe_deg` per axis (`noise_scale` and
//!   `noise` apply too). Default `orientation_mpe_deg` = 0.01°: the rotation accuracy Leica
//!   states for the AT960 with the T-Mac 6-DoF probe (±0.01°), so σ = 0.005° at `f` = ½.
//!   The draws follow the position draws of the same reading, from the same stream, and are
//!   made only for frame readings: point readings draw exactly as before.
//! - Several reflectors on the tool (scenario `measurement.type: "targets"`): each is a
//!   reading of its own (visibility and three position draws each, in target order).
//!
//! Visibility: a target is measurable if its elevation seen from the head,
//! `atan2(Δz, ‖(Δx, Δy)‖)` in the robot base frame (z up), is within
//! ±`elevation_limit_deg` and its range within `range_m`. Anything else is
//! [`NotMeasurable`].
//!
//! The measurement frame is the robot base frame as built from the tracker; the
//! `base_residual` is the error of that construction, applied to every reading as
//! `p_meas = T_res · p` with `T_res = Trans(dx, dy, dz)·Rz(rz)·Ry(ry)·Rx(rx)` (the base
//! convention of `docs/model.md` §2, so the six `base_*` parameters can absorb it exactly).
//! It is a [`BaseSpec`], the robot file's base type, read with
//! [`BaseSpec::deserialize_omitted_zero`]: here a field left out is zero.
//!
//! ```json
//! "tracker": {
//!   "position_mm": [4000, -1500, 1200], "envelope_radius_mm": 3202,
//!   "mpe_a_um": 15, "mpe_b_um_per_m": 6, "adm_a_um": 10, "adm_b_um_per_m": 0.3,
//!   "noise_model": "anisotropic", "sigma_fraction": 0.5, "noise": true, "noise_scale": 1,
//!   "elevation_limit_deg": 45, "range_m": [0.8, 20],
//!   "base_residual": { "rx_deg": 0, "ry_deg": 0, "rz_deg": 0,
//!                      "dx_mm": 0, "dy_mm": 0, "dz_mm": 0 }
//! }
//! ```

use kinematics::{BaseSpec, Frame, Robot};
use nalgebra::{Matrix3, Rotation3, Vector3};
use rand::{Rng, RngExt};
use rand_distr::StandardNormal;
use serde::{Deserialize, Serialize};

use crate::error::{ConfigError, NotMeasurable};
use crate::validate::{all_finite, finite, non_negative};

/// Noise model of the tracker.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum NoiseModel {
    /// Radial (ADM) and transverse (angle encoders) σ differ.
    #[default]
    Anisotropic,
    /// The same σ = f·MPE along every axis.
    Isotropic,
}

/// The `tracker` section (see the module docs for the model).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct TrackerConfig {
    /// Tracker head in the robot base frame, mm. Default (4000, −1500, 1200): 4.27 m from
    /// axis 1 (`docs/model.md` §10: outside the envelope, 3.5–5 m away), at tripod height.
    pub position_mm: [f64; 3],
    /// The head must be at least this far from axis 1 horizontally, mm (the robot's
    /// envelope; default 3202 mm, the KR1000 titan's reach).
    pub envelope_radius_mm: f64,
    /// Constant term of the MPE, µm.
    pub mpe_a_um: f64,
    /// Range term of the MPE, µm per m.
    pub mpe_b_um_per_m: f64,
    /// Constant term of the ADM (radial) error, µm (anisotropic model).
    pub adm_a_um: f64,
    /// Range term of the ADM (radial) error, µm per m (anisotropic model).
    pub adm_b_um_per_m: f64,
    /// Anisotropic (default) or isotropic.
    pub noise_model: NoiseModel,
    /// σ as a fraction of the error bound: ½ (default) or ⅓; any value in (0, 1].
    pub sigma_fraction: f64,
    /// Switches the noise on (default) or off.
    pub noise: bool,
    /// Multiplies every σ (default 1).
    pub noise_scale: f64,
    /// Half-width of the elevation window, degrees, in (0, 90) (default 45).
    pub elevation_limit_deg: f64,
    /// Measurable range `[min, max]`, metres (default 0.8–20 m).
    pub range_m: [f64; 2],
    /// Residual error of the base frame built from the tracker (default zero; fields left
    /// out are zero).
    #[serde(deserialize_with = "BaseSpec::deserialize_omitted_zero")]
    pub base_residual: BaseSpec,
    /// Orientation error bound of the 6-DoF probe, degrees per axis (used by frame readings
    /// only). Default 0.01°: Leica AT960 with T-Mac, rotation accuracy ±0.01° (datasheet);
    /// σ = `sigma_fraction` × this. Left out of serialized configurations at its default,
    /// so truths written before it keep their bytes.
    #[serde(skip_serializing_if = "is_default_orientation_mpe")]
    pub orientation_mpe_deg: f64,
}

/// The T-Mac's ±0.01° (see [`TrackerConfig::orientation_mpe_deg`]).
pub const DEFAULT_ORIENTATION_MPE_DEG: f64 = 0.01;

fn is_default_orientation_mpe(v: &f64) -> bool {
    *v == DEFAULT_ORIENTATION_MPE_DEG
}

impl Default for TrackerConfig {
    fn default() -> Self {
        TrackerConfig {
            position_mm: [4000.0, -1500.0, 1200.0],
            envelope_radius_mm: 3202.0,
            mpe_a_um: 15.0,
            mpe_b_um_per_m: 6.0,
            adm_a_um: 10.0,
            adm_b_um_per_m: 0.3,
            noise_model: NoiseModel::Anisotropic,
            sigma_fraction: 0.5,
            noise: true,
            noise_scale: 1.0,
            elevation_limit_deg: 45.0,
            range_m: [0.8, 20.0],
            base_residual: BaseSpec::default(),
            orientation_mpe_deg: DEFAULT_ORIENTATION_MPE_DEG,
        }
    }
}

impl TrackerConfig {
    /// Checks every value; the head must be outside the robot's envelope: at least
    /// `envelope_radius_mm` from axis 1 of `nominal` (the z axis of its base frame).
    pub fn validate(&self, nominal: &Robot) -> Result<(), ConfigError> {
        self.validate_values()?;
        let horizontal = distance_from_axis1_mm(nominal, &Vector3::from(self.position_mm));
        if horizontal < self.envelope_radius_mm {
            return Err(ConfigError::invalid(
                "tracker.position_mm",
                format!(
                    "the head is {horizontal:.1} mm from axis 1, inside the robot's envelope \
                     (it must be at least envelope_radius_mm = {} mm away)",
                    self.envelope_radius_mm
                ),
            ));
        }
        Ok(())
    }

    fn validate_values(&self) -> Result<(), ConfigError> {
        all_finite("tracker.position_mm", &self.position_mm)?;
        non_negative("tracker.envelope_radius_mm", self.envelope_radius_mm)?;
        non_negative("tracker.mpe_a_um", self.mpe_a_um)?;
        non_negative("tracker.mpe_b_um_per_m", self.mpe_b_um_per_m)?;
        non_negative("tracker.adm_a_um", self.adm_a_um)?;
        non_negative("tracker.adm_b_um_per_m", self.adm_b_um_per_m)?;
        finite("tracker.sigma_fraction", self.sigma_fraction)?;
        if !(self.sigma_fraction > 0.0 && self.sigma_fraction <= 1.0) {
            return Err(ConfigError::invalid(
                "tracker.sigma_fraction",
                format!(
                    "σ is a fraction of the MPE in (0, 1] (0.5 or 1/3), got {:?}",
                    self.sigma_fraction
                ),
            ));
        }
        non_negative("tracker.noise_scale", self.noise_scale)?;
        finite("tracker.elevation_limit_deg", self.elevation_limit_deg)?;
        if !(self.elevation_limit_deg > 0.0 && self.elevation_limit_deg < 90.0) {
            return Err(ConfigError::invalid(
                "tracker.elevation_limit_deg",
                format!(
                    "the elevation window's half-width must lie in (0, 90)°, got {:?}",
                    self.elevation_limit_deg
                ),
            ));
        }
        all_finite("tracker.range_m", &self.range_m)?;
        let [lo, hi] = self.range_m;
        if !(lo >= 0.0 && lo < hi) {
            return Err(ConfigError::invalid(
                "tracker.range_m",
                format!("need 0 ≤ min < max, got [{lo}, {hi}]"),
            ));
        }
        non_negative("tracker.orientation_mpe_deg", self.orientation_mpe_deg)?;
        if let Some((name, v)) = self.base_residual.first_non_finite() {
            finite(&format!("tracker.base_residual.{name}"), v)?;
        }
        Ok(())
    }
}

/// The virtual tracker built from a [`TrackerConfig`].
#[derive(Clone, Debug, PartialEq)]
pub struct Tracker {
    head_mm: Vector3<f64>,
    model: NoiseModel,
    /// σ_r = radial[0] + radial[1]·r_m, mm (noise scale and fraction included).
    radial_mm: [f64; 2],
    /// σ_⊥ = transverse[0] + transverse[1]·r_m, mm.
    transverse_mm: [f64; 2],
    noisy: bool,
    elevation_limit_deg: f64,
    tan_limit: f64,
    range_mm: [f64; 2],
    residual: Option<Frame>,
    /// σ of each orientation axis of a frame reading, rad.
    rot_sigma_rad: f64,
}

impl Tracker {
    /// Builds the tracker; checks the values (not the placement, which needs the robot:
    /// see [`TrackerConfig::validate`]).
    pub fn new(cfg: &TrackerConfig) -> Result<Tracker, ConfigError> {
        cfg.validate_values()?;
        let k = if cfg.noise { cfg.noise_scale } else { 0.0 } * cfg.sigma_fraction * 1e-3;
        let transverse_mm = [k * cfg.mpe_a_um, k * cfg.mpe_b_um_per_m];
        let radial_mm = match cfg.noise_model {
            NoiseModel::Anisotropic => [k * cfg.adm_a_um, k * cfg.adm_b_um_per_m],
            NoiseModel::Isotropic => transverse_mm,
        };
        Ok(Tracker {
            head_mm: Vector3::from(cfg.position_mm),
            model: cfg.noise_model,
            radial_mm,
            transverse_mm,
            noisy: k > 0.0,
            elevation_limit_deg: cfg.elevation_limit_deg,
            tan_limit: cfg.elevation_limit_deg.to_radians().tan(),
            range_mm: [cfg.range_m[0] * 1e3, cfg.range_m[1] * 1e3],
            residual: (!cfg.base_residual.is_zero()).then(|| cfg.base_residual.frame()),
            rot_sigma_rad: (if cfg.noise { cfg.noise_scale } else { 0.0 })
                * cfg.sigma_fraction
                * cfg.orientation_mpe_deg.to_radians(),
        })
    }

    /// Tracker head in the robot base frame, mm.
    pub fn head_mm(&self) -> Vector3<f64> {
        self.head_mm
    }

    /// The noise model.
    pub fn noise_model(&self) -> NoiseModel {
        self.model
    }

    /// `[σ_r, σ_⊥]` in mm at range `range_m` (equal for the isotropic model; zero with
    /// noise off).
    pub fn sigmas_mm(&self, range_m: f64) -> [f64; 2] {
        [
            self.radial_mm[0] + self.radial_mm[1] * range_m,
            self.transverse_mm[0] + self.transverse_mm[1] * range_m,
        ]
    }

    /// Beam frame at target `p_mm`: `[û, ê_h, ê_v]` (radial, horizontal transverse,
    /// vertical transverse), orthonormal.
    pub fn beam_frame(&self, p_mm: &Vector3<f64>) -> [Vector3<f64>; 3] {
        let u = (p_mm - self.head_mm).normalize();
        let h = Vector3::z().cross(&u);
        let h = if h.norm_squared() > 1e-24 {
            h.normalize()
        } else {
            Vector3::x()
        };
        [u, h, u.cross(&h)]
    }

    /// Residual transform of the base frame built from the tracker (`None` if zero).
    pub fn residual_frame(&self) -> Option<Frame> {
        self.residual
    }

    /// Checks the elevation window and range for a target at `p_mm` (robot base frame).
    pub fn check_visible(&self, p_mm: &Vector3<f64>) -> Result<(), NotMeasurable> {
        self.check_window(p_mm, 0.0, 0.0)
    }

    /// [`Tracker::check_visible`] with the window shrunk by `margin_deg` and the range by
    /// `margin_mm` at each end (pose sampling keeps a margin for scatter and drift).
    pub(crate) fn check_window(
        &self,
        p_mm: &Vector3<f64>,
        margin_deg: f64,
        margin_mm: f64,
    ) -> Result<(), NotMeasurable> {
        let d = p_mm - self.head_mm;
        let horizontal = d.x.hypot(d.y);
        let tan_limit = if margin_deg == 0.0 {
            self.tan_limit
        } else {
            (self.elevation_limit_deg - margin_deg).to_radians().tan()
        };
        let in_window = d.z.abs() <= tan_limit * horizontal;
        if !in_window {
            return Err(NotMeasurable::Elevation {
                elevation_deg: d.z.atan2(horizontal).to_degrees(),
                limit_deg: self.elevation_limit_deg,
            });
        }
        let r = d.norm();
        if !(r >= self.range_mm[0] + margin_mm && r <= self.range_mm[1] - margin_mm) {
            return Err(NotMeasurable::Range {
                range_m: r * 1e-3,
                min_m: self.range_mm[0] * 1e-3,
                max_m: self.range_mm[1] * 1e-3,
            });
        }
        Ok(())
    }

    /// One reading of a target at `p_mm` (robot base frame): visibility check, noise in the
    /// beam frame (three standard normal draws, none with noise off), then the base-frame
    /// residual. Returns the point in the measurement frame, mm.
    pub fn observe<R: Rng + ?Sized>(
        &self,
        p_mm: &Vector3<f64>,
        rng: &mut R,
    ) -> Result<Vector3<f64>, NotMeasurable> {
        self.check_visible(p_mm)?;
        let mut p = *p_mm;
        if self.noisy {
            let [u, h, v] = self.beam_frame(p_mm);
            let [sr, st] = self.sigmas_mm((p_mm - self.head_mm).norm() * 1e-3);
            let n0: f64 = rng.sample(StandardNormal);
            let n1: f64 = rng.sample(StandardNormal);
            let n2: f64 = rng.sample(StandardNormal);
            p += u * (sr * n0) + h * (st * n1) + v * (st * n2);
        }
        Ok(match &self.residual {
            Some(f) => f.transform_point(&p),
            None => p,
        })
    }
}

impl Tracker {
    /// σ of each orientation axis of a frame reading, degrees (zero with noise off).
    pub fn orientation_sigma_deg(&self) -> f64 {
        self.rot_sigma_rad.to_degrees()
    }

    /// One 6-DoF reading of the probe frame (`p_mm`, `rot`: its position and axes in the
    /// robot base frame): the position as [`Tracker::observe`], then the orientation
    /// `R_res · rot · exp([n]×)` (three more draws, none with noise off; module docs).
    pub fn observe_frame<R: Rng + ?Sized>(
        &self,
        p_mm: &Vector3<f64>,
        rot: &Matrix3<f64>,
        rng: &mut R,
    ) -> Result<(Vector3<f64>, Matrix3<f64>), NotMeasurable> {
        let p = self.observe(p_mm, rng)?;
        let mut r = *rot;
        if self.rot_sigma_rad > 0.0 {
            let n0: f64 = rng.sample(StandardNormal);
            let n1: f64 = rng.sample(StandardNormal);
            let n2: f64 = rng.sample(StandardNormal);
            let n = Vector3::new(n0, n1, n2) * self.rot_sigma_rad;
            r *= Rotation3::new(n).into_inner();
        }
        Ok((
            p,
            match &self.residual {
                Some(f) => f.rot * r,
                None => r,
            },
        ))
    }
}

/// Horizontal distance of `p` from axis 1 of `robot` (the z axis of its base frame), mm.
pub(crate) fn distance_from_axis1_mm(robot: &Robot, p: &Vector3<f64>) -> f64 {
    let base = robot.base_frame();
    let axis = base.rot.column(2).into_owned();
    let rel = p - base.pos_mm;
    (rel - axis * rel.dot(&axis)).norm()
}
