//! The `truth` section: which geometric errors the true robot has.
//!
//! Errors are differences true − nominal of the identification parameters (`docs/model.md` §3),
//! in the interface units of each parameter (degrees or millimetres). Three ways to choose
//! them, combined in this order:
//!
//! 1. `random`: every parameter drawn independently with the σ of its class — joint angles
//!    (θ, α, β: `joint_angle_sigma_deg`), lengths (d, a: `length_sigma_mm`), base rotation
//!    (`base_rotation_sigma_deg`), base translation (`base_translation_sigma_mm`) and tool
//!    (`tool_sigma_mm`) — from a normal `σ·N(0, 1)` or a uniform `U(−√3 σ, √3 σ)` (same σ).
//!    All parameters are drawn in layout order from the trial's `TRUTH` stream, whatever the σ,
//!    so changing one σ does not reshuffle the others.
//! 2. `explicit`: values by parameter name replace the drawn value of that parameter.
//! 3. `scale_to`: the whole error vector δ is multiplied by the factor s that makes the
//!    mean nominal-vs-true position error over a fixed pose set equal the target:
//!    `(1/m) Σ_k ‖p_true(s)(q_k) − p_nom(q_k)‖ = target`, with `p_true(s)` the robot with
//!    parameters `nominal + s·δ` (geometry only: no unmodelled errors, no tracker residual).
//!    The poses are sampled once per seed (stream `SCALE_POSES`, trial 0) with the `poses`
//!    constraints evaluated on the nominal robot, so every trial of a seed is scaled on the
//!    same "workspace". s is found by a safeguarded secant iteration to 1e-11 relative.
//!
//! Redundant parameters (`docs/model.md` §6) may carry errors: the truth need not be identifiable.
//!
//! ```json
//! "truth": {
//!   "random": { "distribution": "normal", "joint_angle_sigma_deg": 0.005,
//!               "length_sigma_mm": 0.2, "base_rotation_sigma_deg": 0.005,
//!               "base_translation_sigma_mm": 0.5, "tool_sigma_mm": 0.2 },
//!   "explicit": { "beta2": 0.01 },
//!   "scale_to": { "mean_error_mm": 1.122, "poses": 200 }
//! }
//! ```
//! An empty section `{}` injects no error at all.

use std::collections::BTreeMap;

use kinematics::{POSE_LANES, ParamKind, ParamLayout, PoseTrig, Robot};
use nalgebra::Vector3;
use rand::RngExt;
use rand::rngs::ChaCha8Rng;
use rand_distr::StandardNormal;
use serde::{Deserialize, Serialize};

use crate::error::{ConfigError, SimError};
use crate::validate::{finite, non_negative};

/// The `truth` section: the injected geometric errors (see the module docs).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct InjectedErrors {
    /// Errors by parameter name in display units (deg or mm), added to the nominal value;
    /// they replace the random draw of the same parameter.
    pub explicit: BTreeMap<String, f64>,
    /// Random errors per parameter class; `None` (absent) draws nothing.
    pub random: Option<RandomErrors>,
    /// Scale the error vector to a target mean position error; `None` keeps it as drawn.
    pub scale_to: Option<ScaleTarget>,
}

/// Distribution of the random errors; both have standard deviation σ.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ErrorDistribution {
    /// `σ·N(0, 1)`.
    #[default]
    Normal,
    /// `U(−√3 σ, +√3 σ)`.
    Uniform,
}

/// σ per parameter class. Defaults are illustrative (≈ 1 mm mean error on the KR1000
/// before any scaling); use `scale_to` to fix the magnitude.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct RandomErrors {
    /// Normal or uniform.
    pub distribution: ErrorDistribution,
    /// σ of θ_i, α_i and β_i, degrees.
    pub joint_angle_sigma_deg: f64,
    /// σ of d_i and a_i, mm.
    pub length_sigma_mm: f64,
    /// σ of `base_rx`, `base_ry`, `base_rz`, degrees.
    pub base_rotation_sigma_deg: f64,
    /// σ of `base_dx`, `base_dy`, `base_dz`, mm.
    pub base_translation_sigma_mm: f64,
    /// σ of `tool_x`, `tool_y`, `tool_z`, mm.
    pub tool_sigma_mm: f64,
    /// σ of the axis scale `scale_i` of each prismatic joint, mm/mm (default 0; absent from
    /// the echo when 0, so revolute scenarios read and write as before).
    #[serde(skip_serializing_if = "is_zero")]
    pub scale_sigma_mm_per_mm: f64,
}

fn is_zero(v: &f64) -> bool {
    *v == 0.0
}

impl Default for RandomErrors {
    fn default() -> Self {
        RandomErrors {
            distribution: ErrorDistribution::Normal,
            joint_angle_sigma_deg: 0.005,
            length_sigma_mm: 0.2,
            base_rotation_sigma_deg: 0.005,
            base_translation_sigma_mm: 0.5,
            tool_sigma_mm: 0.2,
            scale_sigma_mm_per_mm: 0.0,
        }
    }
}

/// Target of the error scaling.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ScaleTarget {
    /// Target mean nominal-vs-true position error, mm (the paper's 1.122 by default).
    pub mean_error_mm: f64,
    /// Number of poses the mean is taken over.
    pub poses: usize,
}

impl Default for ScaleTarget {
    fn default() -> Self {
        ScaleTarget {
            mean_error_mm: 1.122,
            poses: 200,
        }
    }
}

/// What the scaling did.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ScaleOutcome {
    /// The factor s applied to the drawn errors.
    pub factor: f64,
    /// Mean error of the unscaled errors (s = 1) over the pose set, mm.
    pub unscaled_mean_error_mm: f64,
    /// Mean error after scaling, mm (equals the target to 1e-11 relative).
    pub mean_error_mm: f64,
    /// Number of poses of the set.
    pub poses: usize,
}

impl InjectedErrors {
    /// Checks σ ≥ 0, finite values, known parameter names and a positive target.
    pub fn validate(&self, layout: &ParamLayout) -> Result<(), ConfigError> {
        for (name, v) in &self.explicit {
            let field = format!("truth.explicit.{name}");
            if layout.index_of(name).is_err() {
                return Err(ConfigError::UnknownParameter {
                    field,
                    name: name.clone(),
                    known: layout.names().join(", "),
                });
            }
            finite(&field, *v)?;
        }
        if let Some(r) = &self.random {
            non_negative(
                "truth.random.joint_angle_sigma_deg",
                r.joint_angle_sigma_deg,
            )?;
            non_negative("truth.random.length_sigma_mm", r.length_sigma_mm)?;
            non_negative(
                "truth.random.scale_sigma_mm_per_mm",
                r.scale_sigma_mm_per_mm,
            )?;
            non_negative(
                "truth.random.base_rotation_sigma_deg",
                r.base_rotation_sigma_deg,
            )?;
            non_negative(
                "truth.random.base_translation_sigma_mm",
                r.base_translation_sigma_mm,
            )?;
            non_negative("truth.random.tool_sigma_mm", r.tool_sigma_mm)?;
        }
        if let Some(s) = &self.scale_to {
            let f = "truth.scale_to.mean_error_mm";
            finite(f, s.mean_error_mm)?;
            if s.mean_error_mm <= 0.0 {
                return Err(ConfigError::invalid(
                    f,
                    format!("the target must be positive, got {:?}", s.mean_error_mm),
                ));
            }
            if s.poses == 0 {
                return Err(ConfigError::invalid(
                    "truth.scale_to.poses",
                    "at least one pose is needed",
                ));
            }
        }
        Ok(())
    }

    /// The unscaled error vector in internal units (rad, mm), layout order: random draws,
    /// then explicit values. Assumes [`InjectedErrors::validate`] passed.
    /// Written into `delta` (cleared and resized with zeros: no allocation once it has the
    /// room).
    pub(crate) fn draw_internal(
        &self,
        layout: &ParamLayout,
        rng: &mut ChaCha8Rng,
        delta: &mut Vec<f64>,
    ) {
        delta.clear();
        delta.resize(layout.len(), 0.0);
        if let Some(r) = &self.random {
            for (k, info) in layout.params().iter().enumerate() {
                let sigma = match info.kind {
                    ParamKind::Theta(_) | ParamKind::Alpha(_) | ParamKind::Beta(_) => {
                        r.joint_angle_sigma_deg
                    }
                    ParamKind::D(_) | ParamKind::A(_) => r.length_sigma_mm,
                    ParamKind::BaseRx | ParamKind::BaseRy | ParamKind::BaseRz => {
                        r.base_rotation_sigma_deg
                    }
                    ParamKind::BaseDx | ParamKind::BaseDy | ParamKind::BaseDz => {
                        r.base_translation_sigma_mm
                    }
                    ParamKind::ToolX | ParamKind::ToolY | ParamKind::ToolZ => r.tool_sigma_mm,
                    ParamKind::Scale(_) => r.scale_sigma_mm_per_mm,
                    // The truth is geometric (its joint errors are `unmodelled`): no draw.
                    ParamKind::Extended(_) => continue,
                };
                let z: f64 = match r.distribution {
                    ErrorDistribution::Normal => rng.sample(StandardNormal),
                    ErrorDistribution::Uniform => 3f64.sqrt() * (2.0 * rng.random::<f64>() - 1.0),
                };
                delta[k] = info.from_display(sigma * z);
            }
        }
        for (name, v) in &self.explicit {
            if let Ok(k) = layout.index_of(name) {
                delta[k] = layout.get(k).from_display(*v);
            }
        }
    }
}

/// Mean ‖p_robot(q_k) − p_nom,k‖ over the poses whose sines and cosines are `trig` (the
/// points [`Robot::point`] gives, [`POSE_LANES`] poses at a time; summed in pose order).
///
/// The pose lanes run at the run-time [`kinematics::simd::simd_level`] (the FK kernel gives
/// the same bits at every vector width: no FMA).
pub(crate) fn mean_error_mm(
    robot: &Robot,
    trig: &PoseTrig,
    nominal_points: &[Vector3<f64>],
) -> f64 {
    kinematics::simd::vectorised(
        #[inline(always)]
        || mean_error_impl(robot, trig, nominal_points),
    )
}

#[inline(always)]
fn mean_error_impl(robot: &Robot, trig: &PoseTrig, nominal_points: &[Vector3<f64>]) -> f64 {
    let m = nominal_points.len();
    let mut sum = 0.0;
    for b in 0..trig.n_blocks() {
        let p = robot.point_lanes(trig.lanes(b));
        let first = b * POSE_LANES;
        for (t, p0) in nominal_points[first..m.min(first + POSE_LANES)]
            .iter()
            .enumerate()
        {
            sum += (Vector3::new(p[0][t], p[1][t], p[2][t]) - p0).norm();
        }
    }
    sum / m as f64
}

/// Finds s > 0 with `mean_error(nominal + s·δ) = target` over the poses of `trig` (whose nominal
/// points are `nominal_points`). Secant iteration from the exact point (0, 0) and s = 1,
/// safeguarded by bisection inside the bracket found so far; the mean error is nearly
/// proportional to s, so about 3 evaluations reach the 1e-11 relative tolerance. `delta` is
/// left unscaled.
///
/// `p_nom` is `nominal`'s parameter vector; `scratch` holds the robot and the parameter
/// vector each evaluation writes (overwritten: no allocation once they have the room).
pub(crate) fn solve_scale(
    (nominal, p_nom): (&Robot, &[f64]),
    delta: &[f64],
    trig: &PoseTrig,
    nominal_points: &[Vector3<f64>],
    target_mm: f64,
    (scratch, params): (&mut Robot, &mut Vec<f64>),
) -> Result<ScaleOutcome, SimError> {
    scratch.clone_from(nominal);
    params.clear();
    params.extend_from_slice(p_nom);
    let mut eval = |s: f64| -> f64 {
        for ((p, p0), d) in params.iter_mut().zip(p_nom).zip(delta) {
            *p = p0 + s * d;
        }
        // Lengths match by construction.
        if scratch.set_params(params).is_err() {
            return f64::NAN;
        }
        mean_error_mm(scratch, trig, nominal_points)
    };
    let m = nominal_points.len();
    let unscaled = eval(1.0);
    if !(unscaled > 0.0 && unscaled.is_finite()) {
        return Err(SimError::Scale {
            message: format!(
                "the drawn errors give a mean error of {unscaled} mm, which cannot be scaled \
                 to {target_mm} mm (are all σ and explicit values zero?)"
            ),
        });
    }
    // The mean error itself carries rounding noise of ~1e-13 relative (differences of
    // metre-sized FK results), so ask for 1e-11.
    let tol = 1e-11 * target_mm;
    // Bracket [lo, hi] with g(lo) < 0 < g(hi), g(s) = mean(s) − target; hi unknown at first.
    let mut lo = 0.0;
    let mut hi = f64::INFINITY;
    let (mut s_a, mut g_a) = (0.0, -target_mm);
    let (mut s_b, mut v_b) = (1.0, unscaled);
    let mut g_b = v_b - target_mm;
    let mut best = (s_b, v_b);
    for _ in 0..200 {
        if g_b.abs() <= tol {
            break;
        }
        if g_b < 0.0 {
            lo = f64::max(lo, s_b);
        } else {
            hi = f64::min(hi, s_b);
        }
        let mut s = s_b - g_b * (s_b - s_a) / (g_b - g_a);
        if !(s > lo && s < hi) {
            s = if hi.is_finite() {
                0.5 * (lo + hi)
            } else {
                2.0 * lo.max(s_b)
            };
        }
        if s == s_b || hi - lo <= 4.0 * f64::EPSILON * lo {
            break;
        }
        let v = eval(s);
        if !v.is_finite() {
            break;
        }
        (s_a, g_a) = (s_b, g_b);
        (s_b, v_b, g_b) = (s, v, v - target_mm);
        if g_b.abs() < (best.1 - target_mm).abs() {
            best = (s_b, v_b);
        }
    }
    let reached = (best.1 - target_mm).abs() <= 1e-9 * target_mm;
    if !reached {
        return Err(SimError::Scale {
            message: format!(
                "no scale factor reaches {target_mm} mm (best {} mm at factor {})",
                best.1, best.0
            ),
        });
    }
    Ok(ScaleOutcome {
        factor: best.0,
        unscaled_mean_error_mm: unscaled,
        mean_error_mm: best.1,
        poses: m,
    })
}
