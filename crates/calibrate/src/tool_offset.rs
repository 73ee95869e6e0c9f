//! The registration of point data with the tool offset estimated with the frame
//! (`identify::tool_registration`): a probe far from where the robot file puts it does not
//! bend the registration.
//!
//! The rigid registration ([`identify::register_base_robust`]) takes the start model's tool as
//! given. With the probe 125 mm from the flange and the file saying 0, it leaves the base yaw
//! 5° off, the fit moves θ1 by as much (redundant with the yaw, which is held), and the
//! parameters check refuses good data. [`prefer`] estimates the tool with the frame and takes
//! that registration when the tool it finds is more than [`TOOL_REGISTRATION_MM`] from the
//! file's and it fits the points [`TOOL_IMPROVEMENT`] times better; otherwise the rigid
//! registration stands (a file whose tool is right gives exactly today's result).

use identify::{RobustRegistration, register_base_and_tool};
use kinematics::Robot;
use nalgebra::Vector3;

/// Distance between the tool estimated with the frame and the robot file's above which the
/// registration takes the estimate, mm [25: a probe 125 mm off tilts the rigid registration's
/// yaw by 5.3°, so 25 mm by about 1°, which the fit takes from θ1 far inside the parameters
/// check's 5°; the estimate itself moves with the robot's geometric errors: the UR10 of
/// `data/ur10-ipa` gives 15 mm, its d6 + tool_z being 185 mm where its file says 201 mm, and
/// keeps the rigid registration].
pub const TOOL_REGISTRATION_MM: f64 = 25.0;

/// How many times lower the median and the mean point error must be with the tool estimated
/// than with the file's, for the estimate to be taken [2: with the file's tool right the
/// rigid registration leaves the robot's geometric errors (2.6 mm mean on the UR10 of
/// `data/ur10-ipa`), which three more unknowns lower by a fraction; a tool 100 mm off leaves
/// the rigid registration tens of millimetres].
pub const TOOL_IMPROVEMENT: f64 = 2.0;

fn mm(v: &Vector3<f64>) -> String {
    format!("[{:.3}, {:.3}, {:.3}]", v.x, v.y, v.z)
}

/// The registration to start from: `rigid` (the rigid one), or the one with the tool
/// estimated when the robot file's tool is more than [`TOOL_REGISTRATION_MM`] off and the
/// estimate fits [`TOOL_IMPROVEMENT`] times better (median and mean point error); with a
/// sentence saying so then.
pub(crate) fn prefer(
    nominal: &Robot,
    poses_rad: &[f64],
    points_mm: &[Vector3<f64>],
    rigid: RobustRegistration,
) -> (RobustRegistration, Option<String>) {
    let Ok(with_tool) = register_base_and_tool(nominal, poses_rad, points_mm) else {
        return (rigid, None);
    };
    let moved = (with_tool.tool_after_mm - with_tool.tool_before_mm).norm();
    let r = with_tool.registration;
    if moved <= TOOL_REGISTRATION_MM
        || r.median_after_mm * TOOL_IMPROVEMENT >= rigid.median_after_mm
        || r.report.mean_error_after_mm * TOOL_IMPROVEMENT >= rigid.report.mean_error_after_mm
    {
        return (rigid, None);
    }
    let note = format!(
        "the tool offset estimated with the frame: {} mm where the robot file says {} mm \
         ({moved:.1} mm away, more than {TOOL_REGISTRATION_MM} mm; the rigid registration with \
         the file's tool left a median error of {:.3} mm), the fit starts from it",
        mm(&with_tool.tool_after_mm),
        mm(&with_tool.tool_before_mm),
        rigid.median_after_mm,
    );
    (r, Some(note))
}
