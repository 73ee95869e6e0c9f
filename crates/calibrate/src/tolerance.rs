//! The manufacturing tolerances: how far each kind of parameter may plausibly move from the
//! robot file's value. One source for the parameters check (`crate::checks::parameters`
//! refuses beyond them), the default prior (`crate::prior`: its standard deviations) and the
//! weak-excitation diagnosis (`crate::excitation`: a parameter whose standard error from the
//! data exceeds a fraction of its tolerance is undetermined).

use identify::Fit;
use kinematics::{ParamKind, Robot};

/// Largest plausible change of a link length or offset (a, d), mm [20: manufacturing and
/// assembly errors are tenths of a millimetre to a few millimetres].
pub const MAX_LINK_CHANGE_MM: f64 = 20.0;

/// Largest plausible change of a joint angle offset or twist (θ, α, β), degrees [5: zero
/// offsets of tenths of a degree are common, several degrees are a wrong model or frame].
pub const MAX_ANGLE_CHANGE_DEG: f64 = 5.0;

/// Largest plausible change of the measured point in the flange frame, mm [250: the
/// reflector's offset is often unknown and a fit from zero finding 30 mm is good; a quarter
/// metre is another tool or a wrong frame].
pub const MAX_TOOL_CHANGE_MM: f64 = 250.0;

/// Largest plausible change of a prismatic joint's axis scale, mm/mm [0.01: encoder and
/// rack errors are tens to hundreds of ppm; a percent is a wrong unit or gear ratio].
pub const MAX_SCALE_CHANGE: f64 = 0.01;

/// The manufacturing tolerance of a parameter of kind `kind`, display units (mm, °): the
/// change beyond which [`crate::checks::parameters`] refuses a fit, and the standard deviation of the
/// default prior (`crate::prior`) — one source for both. `None` for the base (the
/// measurement frame, anywhere) and the parameters beyond geometry.
pub fn tolerance(kind: ParamKind) -> Option<f64> {
    match kind {
        ParamKind::A(_) | ParamKind::D(_) => Some(MAX_LINK_CHANGE_MM),
        ParamKind::Theta(_) | ParamKind::Alpha(_) | ParamKind::Beta(_) => {
            Some(MAX_ANGLE_CHANGE_DEG)
        }
        ParamKind::ToolX | ParamKind::ToolY | ParamKind::ToolZ => Some(MAX_TOOL_CHANGE_MM),
        ParamKind::Scale(_) => Some(MAX_SCALE_CHANGE),
        _ => None,
    }
}

/// A parameter is undetermined by the data when its standard error from the data alone
/// exceeds this fraction of its manufacturing tolerance [0.5: the same line as the prior's
/// "held by the prior" (`identify::HELD_BY_PRIOR`); the data then cannot tell a good robot
/// from one at the edge of its tolerance].
pub const UNDETERMINED_FRACTION: f64 = 0.5;

/// Whether the data of `fit` (its covariance, the data's alone) leave some free geometric
/// parameter of `robot` undetermined: standard error above [`UNDETERMINED_FRACTION`] × its
/// tolerance.
pub fn leaves_undetermined(robot: &Robot, fit: &Fit) -> bool {
    let layout = robot.layout();
    fit.covariance.as_ref().is_some_and(|c| {
        c.indices.iter().zip(&c.std_errors).any(|(&k, &se)| {
            tolerance(layout.get(k).kind).is_some_and(|t| se > UNDETERMINED_FRACTION * t)
        })
    })
}
