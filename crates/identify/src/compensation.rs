//! Compensation: the joint values to command so that the calibrated robot reaches what the
//! nominal model promised (`docs/model.md` §8).
//!
//! For commanded joints q, the target is the nominal model's measured point
//! `p* = T_nom(q)·t_nom` with the nominal flange orientation `R* = R_nom(q)`; the physical
//! point is the identified tool offset `t_id`. IK of the identified model from q (damped
//! Newton, [`kinematics::Robot::solve_ik`]) gives the compensated joints.

use kinematics::{IkError, IkOptions, IkReport, IkTarget, Robot};

/// The IK target that compensates commanded joints `q_rad`.
pub fn compensation_target(nominal: &Robot, identified: &Robot, q_rad: &[f64]) -> IkTarget {
    let mut sc = [[0.0; 2]; kinematics::MAX_JOINTS];
    kinematics::joint_sin_cos(q_rad, &mut sc);
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
