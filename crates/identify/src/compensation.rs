//! Compensation: the joint values to command so that the calibrated robot reaches what the
//! nominal model promised (`docs/model.md` §8).
//!
//! For commanded joints q, the target is the nominal model's measured point
//! `p* = T_nom(q)·t_nom` with the nominal flange orientation `R* = R_nom(q)`; the physical
//! point is the identified tool offset `t_id`. IK of the identified model from q (damped
//! Newton, [`kinematics::Robot::solve_ik`]) gives the compensated joints.
//!
//! [`compensate_nearest`] is what `kincal compensate` uses: the exact solution nearest the
//! commanded joints ([`kinematics::Robot::solve_ik_nearest`]: other branches and starts are
//! tried before a target is called unreachable, with the reason), and a flag on a row whose
//! solution moves a joint by more than [`CompensationOptions::flag_change_deg`], with the
//! singularity that explains it ([`FlagReason`]).

use std::fmt;

use kinematics::{
    ArmSingularity, IkError, IkOptions, IkReport, IkSearch, IkTarget, IkUnreachable, Robot,
};

/// The IK target that compensates commanded joints `q_rad`.
pub fn compensation_target(nominal: &Robot, identified: &Robot, q_rad: &[f64]) -> IkTarget {
    let mut sc = [[0.0; 2]; kinematics::MAX_JOINTS];
    nominal.joint_trig(q_rad, &mut sc);
    compensation_target_trig(nominal, identified, &sc[..q_rad.len()])
}

/// [`compensation_target`] from the sines and cosines of the commanded joints
/// ([`kinematics::PoseTrig::pose`]): the same target, bit for bit, without recomputing them.
pub fn compensation_target_trig(nominal: &Robot, identified: &Robot, sc: &[[f64; 2]]) -> IkTarget {
    let f = nominal.flange_trig(sc);
    IkTarget {
        point_in_flange_mm: identified.tool_mm(),
        position_mm: f.transform_point(&nominal.tool_mm()),
        rotation: f.rot,
    }
}

/// Compensates commanded joints `q_rad` in place (radians). On failure (target outside the
/// identified model's reach or limits) `q_rad` is restored and the IK error returned.
pub fn compensate(
    nominal: &Robot,
    identified: &Robot,
    q_rad: &mut [f64],
    options: &IkOptions,
) -> Result<IkReport, IkError> {
    let target = compensation_target(nominal, identified, q_rad);
    let mut q = [0.0; kinematics::MAX_JOINTS];
    let n = q_rad.len().min(kinematics::MAX_JOINTS);
    q[..n].copy_from_slice(&q_rad[..n]);
    let result = identified.solve_ik(&target, q_rad, options);
    if result.is_err() {
        q_rad.copy_from_slice(&q[..n]);
    }
    result
}

/// Options of [`compensate_nearest`]. Defaults in brackets.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CompensationOptions {
    /// The damped Newton solve \[`IkOptions::default()`\].
    pub ik: IkOptions,
    /// Starts and seed of the search for the nearest solution \[`IkSearch::default()`; its
    /// `accept_change_rad` is replaced by `flag_change_deg`\].
    pub search: IkSearch,
    /// A row whose solution moves any joint by more than this is flagged, degrees \[2°: a
    /// calibration moves joints by hundredths of a degree away from singularities (the UR10
    /// README example: 95 % of rows below 0.2°), so 2° is ten times what the geometry
    /// errors themselves explain, and small enough that a flagged move is still one a user
    /// wants to look at before sending it to a controller\].
    pub flag_change_deg: f64,
}

impl Default for CompensationOptions {
    fn default() -> Self {
        CompensationOptions {
            ik: IkOptions::default(),
            search: IkSearch::default(),
            flag_change_deg: DEFAULT_FLAG_CHANGE_DEG,
        }
    }
}

/// Default of [`CompensationOptions::flag_change_deg`], degrees.
pub const DEFAULT_FLAG_CHANGE_DEG: f64 = 2.0;

/// Angle between the axes of joints 4 and 6 below which a large change is put down to the
/// wrist singularity, degrees [20°: the amplification of an orientation error into q4/q6
/// grows as 1/sin of that angle, ≈ 3 at 20°; beyond it a change of several degrees needs
/// another cause].
pub const WRIST_NEAR_DEG: f64 = 20.0;
/// Elbow angle from stretched (or folded) below which a large change is put down to the
/// elbow singularity, degrees [20°, as for the wrist].
pub const ELBOW_NEAR_DEG: f64 = 20.0;
/// Distance of the wrist point from the shoulder-singular surface, as a fraction of the
/// distance from axis 2 to the wrist point, below which a large change is put down to the
/// shoulder singularity [0.2 ≈ sin 12°, as for the angles].
pub const SHOULDER_NEAR_FRACTION: f64 = 0.2;

/// Why a compensated row moves a joint by more than the threshold.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum FlagReason {
    /// Axes 4 and 6 at this angle, degrees (below [`WRIST_NEAR_DEG`]).
    Wrist {
        /// ∠(z₄, z₆), degrees.
        angle_deg: f64,
    },
    /// The wrist point this far from the shoulder-singular surface, mm (below
    /// [`SHOULDER_NEAR_FRACTION`] of the arm).
    Shoulder {
        /// mm.
        distance_mm: f64,
    },
    /// The elbow this far from stretched, degrees (below [`ELBOW_NEAR_DEG`]).
    Elbow {
        /// degrees.
        angle_deg: f64,
    },
    /// The commanded branch has no exact solution within the limits (it needs joint
    /// `joint` beyond them): the nearest solution is on another branch.
    LimitOnBranch {
        /// The joint (0-based).
        joint: usize,
    },
    /// None of the above: no named singularity nearby (or an arm without six joints).
    Other,
}

impl fmt::Display for FlagReason {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            FlagReason::Wrist { angle_deg } => write!(
                f,
                "near the wrist singularity (axes 4 and 6 at {angle_deg:.1}°)"
            ),
            FlagReason::Shoulder { distance_mm } => write!(
                f,
                "near the shoulder singularity (wrist point {distance_mm:.0} mm from it)"
            ),
            FlagReason::Elbow { angle_deg } => write!(
                f,
                "near the elbow singularity (elbow {angle_deg:.1}° from stretched)"
            ),
            FlagReason::LimitOnBranch { joint } => write!(
                f,
                "the commanded branch would pass q{}'s limit: solution on another branch",
                joint + 1
            ),
            FlagReason::Other => write!(f, "no singularity nearby: another solution branch"),
        }
    }
}

impl FlagReason {
    /// A short key for counting: `wrist`, `shoulder`, `elbow`, `limit`, `other`.
    pub fn key(&self) -> &'static str {
        match self {
            FlagReason::Wrist { .. } => "wrist",
            FlagReason::Shoulder { .. } => "shoulder",
            FlagReason::Elbow { .. } => "elbow",
            FlagReason::LimitOnBranch { .. } => "limit",
            FlagReason::Other => "other",
        }
    }
}

/// A compensated row ([`compensate_nearest`]).
#[derive(Clone, Debug, PartialEq)]
pub struct Compensated {
    /// The final solve.
    pub report: IkReport,
    /// Largest joint change from the commanded joints, degrees.
    pub max_change_deg: f64,
    /// The joint (0-based) with that change.
    pub joint: usize,
    /// Why the change exceeds [`CompensationOptions::flag_change_deg`] (nearest first);
    /// empty when it does not.
    pub flags: Vec<FlagReason>,
}

/// The reasons a large joint change at commanded joints `q_cmd` (radians) happens, from the
/// geometry of `robot` there ([`Robot::arm_singularity`]), nearest first (by how far below
/// its threshold each measure is).
pub fn singularity_reasons(robot: &Robot, q_cmd: &[f64]) -> Vec<FlagReason> {
    let Some(ArmSingularity {
        wrist_deg,
        shoulder_mm,
        elbow_deg,
        arm_mm,
    }) = robot.arm_singularity(q_cmd)
    else {
        return Vec::new();
    };
    let mut near: Vec<(f64, FlagReason)> = Vec::new();
    if wrist_deg < WRIST_NEAR_DEG {
        near.push((
            wrist_deg / WRIST_NEAR_DEG,
            FlagReason::Wrist {
                angle_deg: wrist_deg,
            },
        ));
    }
    if shoulder_mm < SHOULDER_NEAR_FRACTION * arm_mm {
        near.push((
            shoulder_mm / (SHOULDER_NEAR_FRACTION * arm_mm),
            FlagReason::Shoulder {
                distance_mm: shoulder_mm,
            },
        ));
    }
    if elbow_deg < ELBOW_NEAR_DEG {
        near.push((
            elbow_deg / ELBOW_NEAR_DEG,
            FlagReason::Elbow {
                angle_deg: elbow_deg,
            },
        ));
    }
    near.sort_by(|a, b| a.0.total_cmp(&b.0));
    near.into_iter().map(|(_, r)| r).collect()
}

/// Compensates commanded joints `q_rad` in place (radians): the exact solution nearest
/// them ([`Robot::solve_ik_nearest`]), flagged with its reasons when it moves a joint by
/// more than [`CompensationOptions::flag_change_deg`]. On failure `q_rad` is restored and
/// the reason returned ([`IkUnreachable`]: beyond a joint limit or beyond reach on every
/// branch tried).
pub fn compensate_nearest(
    nominal: &Robot,
    identified: &Robot,
    q_rad: &mut [f64],
    options: &CompensationOptions,
) -> Result<Compensated, IkUnreachable> {
    let target = compensation_target(nominal, identified, q_rad);
    compensate_nearest_to(identified, &target, q_rad, options)
}

/// [`compensate_nearest`] of any target: the exact solution of `identified` for `target`
/// nearest the start `q_rad` (the nominal controller's joints; overwritten with the
/// solution), flagged with its reasons when it moves a joint by more than
/// [`CompensationOptions::flag_change_deg`] from them. On failure `q_rad` is restored.
/// Cartesian targets use it with the nominal model's IK solution as the start.
pub fn compensate_nearest_to(
    identified: &Robot,
    target: &IkTarget,
    q_rad: &mut [f64],
    options: &CompensationOptions,
) -> Result<Compensated, IkUnreachable> {
    let target = *target;
    let mut q_cmd = [0.0; kinematics::MAX_JOINTS];
    let n = q_rad.len().min(kinematics::MAX_JOINTS);
    q_cmd[..n].copy_from_slice(&q_rad[..n]);
    let search = IkSearch {
        accept_change_rad: options.flag_change_deg.to_radians(),
        ..options.search
    };
    let sol = identified.solve_ik_nearest(&target, q_rad, &options.ik, &search)?;
    Ok(assess_solution(
        identified,
        &target,
        &q_cmd[..n],
        (sol.report, sol.max_change_rad, sol.joint),
        options,
    ))
}

/// The [`Compensated`] of a solution of `identified` for `target` reached from the
/// commanded joints `q_cmd` (radians) by the solve `report`, whose largest joint change is
/// `max_change_rad`, at joint `joint` (0-based): flagged with its reasons when that change
/// exceeds [`CompensationOptions::flag_change_deg`] ([`compensate_nearest_to`]'s flags, for
/// a solution found another way — e.g. a fixed point on its target).
pub fn assess_solution(
    identified: &Robot,
    target: &IkTarget,
    q_cmd: &[f64],
    (report, max_change_rad, joint): (IkReport, f64, usize),
    options: &CompensationOptions,
) -> Compensated {
    let target = *target;
    let n = q_cmd.len().min(kinematics::MAX_JOINTS);
    let max_change_deg = max_change_rad.to_degrees();
    let mut flags = Vec::new();
    if max_change_deg > options.flag_change_deg {
        flags = singularity_reasons(identified, &q_cmd[..n]);
        if flags.is_empty() {
            // Does the commanded branch itself end beyond a limit?
            let mut q = [0.0; kinematics::MAX_JOINTS];
            q[..n].copy_from_slice(&q_cmd[..n]);
            let unlimited = identified.solve_ik_unlimited(&target, &mut q[..n], &options.ik);
            let beyond = unlimited.is_ok().then(|| {
                (0..n).find(|&i| {
                    let [lo, hi] = identified.limits_rad(i);
                    q[i] < lo || q[i] > hi
                })
            });
            flags.push(match beyond.flatten() {
                Some(joint) => FlagReason::LimitOnBranch { joint },
                None => FlagReason::Other,
            });
        }
    }
    Compensated {
        report,
        max_change_deg,
        joint,
        flags,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use kinematics::RobotSpec;

    #[test]
    fn compensated_joints_put_the_true_point_on_the_nominal_target() {
        let text = include_str!("../../../scenarios/robots/kr1000-titan.json");
        let nominal = Robot::from_spec(&RobotSpec::from_json_str(text, "kr1000").unwrap()).unwrap();
        let mut p = nominal.params();
        for (k, v) in p.iter_mut().enumerate() {
            *v += if nominal.layout().get(k).unit == kinematics::Unit::Deg {
                (0.02f64).to_radians() * ((k % 3) as f64 - 1.0)
            } else {
                0.4 * ((k % 5) as f64 - 2.0)
            };
        }
        let truth = nominal.with_params(&p).unwrap();
        let q_cmd = [0.3, 0.4, -0.5, 0.2, 0.8, -0.1];
        let before = (truth.point(&q_cmd) - nominal.point(&q_cmd)).norm();
        assert!(before > 0.5, "the perturbation must matter: {before}");
        let mut q = q_cmd;
        compensate(&nominal, &truth, &mut q, &IkOptions::default()).unwrap();
        let after = (truth.point(&q) - nominal.point(&q_cmd)).norm();
        assert!(after < 1e-6, "after compensation {after} mm");
        // Unreachable: the nominal target of an identified model with a 5 m longer arm.
        let mut long = p.clone();
        long[nominal.layout().index_of("a2").unwrap()] += 5000.0;
        let far = nominal.with_params(&long).unwrap();
        let mut q = q_cmd;
        assert!(compensate(&nominal, &far, &mut q, &IkOptions::default()).is_err());
        assert_eq!(
            q, q_cmd,
            "failed compensation restores the commanded joints"
        );
    }
}
