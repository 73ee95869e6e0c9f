//! The arm's configuration at a joint vector, from the model's geometry, and its two
//! encodings: KUKA's Status and Turn, ABB's confdata.

use kinematics::{Frame, MAX_JOINTS, Robot};

use crate::AXES;

/// Which of the up to eight solutions of a six-axis arm a joint vector is, by three
/// geometric facts (the frames are the model's link frames at the joints, `docs/model.md`
/// §2, frame i after joint i):
///
/// - `behind_axis1`: the wrist point (the origin of link frame 4: the intersection of the
///   wrist axes of a spherical wrist) lies behind axis 1: `(p_w − o_0)·x_1 < 0` with `o_0`
///   the base origin (on axis 1) and `x_1` the x axis of link frame 1 (the arm's forward
///   direction, the common normal of axes 1 and 2). KUKA calls it the overhead area.
/// - `behind_lower_arm`: the wrist point lies behind the line through the axes of joints 2
///   and 3: `n·((o_2 − o_1) × (p_w − o_2)) < 0` with `o_1`, `o_2` the origins of link frames
///   1 and 2 (on those axes) and `n = z_0 × x_1` (the rotation that turns "up" towards
///   "forward"). For KUKA it is A3 beyond its stretched position.
/// - `wrist_negative`: the controller's axis 5 value is negative.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct ArmConfig {
    /// The wrist point is behind axis 1.
    pub behind_axis1: bool,
    /// The wrist point is behind the line through axes 2 and 3.
    pub behind_lower_arm: bool,
    /// Axis 5 (controller value) is negative.
    pub wrist_negative: bool,
}

impl ArmConfig {
    /// The configuration of `robot` at the model joints `joints_deg`, with `axes_deg` the
    /// controller's axis values of the same joints (for the sign of axis 5).
    pub fn of(robot: &Robot, joints_deg: &[f64], axes_deg: &[f64; AXES]) -> ArmConfig {
        let q: Vec<f64> = joints_deg.iter().map(|v| v.to_radians()).collect();
        let mut frames = [Frame::identity(); MAX_JOINTS + 1];
        robot.frames_into(&q, &mut frames);
        let (o0, z0) = (frames[0].pos_mm, frames[0].rot.column(2).into_owned());
        let x1 = frames[1].rot.column(0).into_owned();
        let (o1, o2, pw) = (frames[1].pos_mm, frames[2].pos_mm, frames[4].pos_mm);
        let n = z0.cross(&x1);
        ArmConfig {
            behind_axis1: (pw - o0).dot(&x1) < 0.0,
            behind_lower_arm: n.dot(&(o2 - o1).cross(&(pw - o2))) < 0.0,
            wrist_negative: axes_deg[4] < 0.0,
        }
    }
}

/// KUKA's Status S of the configuration and the axis values: bit 0 set in the overhead area
/// (`behind_axis1`); bit 1 set when the wrist point is in front of the line through A2 and
/// A3 (not `behind_lower_arm`: A3 at or beyond its stretched position towards the normal,
/// elbow-up side, as at KUKA's HOME); bit 2 set when A5 ≤ 0.
pub fn kuka_status(c: &ArmConfig, axes_deg: &[f64; AXES]) -> u8 {
    u8::from(c.behind_axis1)
        | u8::from(!c.behind_lower_arm) << 1
        | u8::from(axes_deg[4] <= 0.0) << 2
}

/// KUKA's Turn T: bit i set when axis i+1 is negative (A1 … A6).
pub fn kuka_turn(axes_deg: &[f64; AXES]) -> u8 {
    axes_deg
        .iter()
        .enumerate()
        .fold(0, |t, (i, a)| t | u8::from(*a < 0.0) << i)
}

/// ABB's confdata `[cf1, cf4, cf6, cfx]`: the quadrants `⌊axis/90°⌋` of axes 1, 4 and 6
/// and `cfx = 4·behind_axis1 + 2·behind_lower_arm + wrist_negative`.
pub fn abb_confdata(c: &ArmConfig, axes_deg: &[f64; AXES]) -> [i32; 4] {
    let quadrant = |a: f64| (a / 90.0).floor() as i32;
    [
        quadrant(axes_deg[0]),
        quadrant(axes_deg[3]),
        quadrant(axes_deg[5]),
        4 * i32::from(c.behind_axis1)
            + 2 * i32::from(c.behind_lower_arm)
            + i32::from(c.wrist_negative),
    ]
}
