//! The entry points of the extended families ([`crate::ExtendedModel`], [`crate::Gravity`])
//! that evaluate a robot's chain: the model of a robot, the per-pose weights on the torque
//! geometry's frames, the gravity torque at a robot's pose. The families themselves
//! (`crate::extended`) know frames, not robots, so that module does not import this one.

use super::Robot;
use crate::ModelError;
use crate::extended::{ExtendedModel, Gravity};
use crate::frame::Frame;
use crate::model::MAX_JOINTS;
use crate::trig::joint_sin_cos;

impl ExtendedModel {
    /// The model with parameters `names` (stable names, e.g. `compliance_2`,
    /// `gear_1_h1_sin`), all zero, for `robot`. `source_name` labels errors, which name the
    /// field: a name of neither family, a joint the robot does not have, a repeated name, or
    /// a compliance parameter on a robot file without `mass_model`.
    pub fn new<S: AsRef<str>>(
        robot: &Robot,
        names: &[S],
        source_name: &str,
    ) -> Result<ExtendedModel, ModelError> {
        ExtendedModel::for_chain(robot.n_joints(), robot.mass_model(), names, source_name)
    }

    /// The per-pose weights `w_k(q)` of every parameter at the commanded joints `q_rad`,
    /// with the torques on `nominal` (see the module docs of `crate::extended`), into
    /// `out[..len]`.
    pub fn weights(&self, nominal: &Robot, q_rad: &[f64], out: &mut [f64]) {
        assert_eq!(q_rad.len(), self.n_joints(), "joint vector length");
        let mut sc = [[0.0; 2]; MAX_JOINTS];
        joint_sin_cos(q_rad, &mut sc);
        self.weights_trig(nominal, &sc[..q_rad.len()], out);
    }

    /// [`ExtendedModel::weights`] at the pose whose `[sin q, cos q]` are `sc`: τ from the
    /// frames of `nominal` there, `sin(kq)`/`cos(kq)` by angle addition.
    pub fn weights_trig(&self, nominal: &Robot, sc: &[[f64; 2]], out: &mut [f64]) {
        let mut frames = [Frame::identity(); MAX_JOINTS + 1];
        self.weights_trig_in(nominal, sc, &mut frames, out);
    }

    /// [`ExtendedModel::weights_trig`] with a scratch buffer for the frames (the same bits;
    /// for loops over many poses, which then set it up once).
    pub fn weights_trig_in(
        &self,
        nominal: &Robot,
        sc: &[[f64; 2]],
        frames: &mut [Frame; MAX_JOINTS + 1],
        out: &mut [f64],
    ) {
        if self.needs_torques() {
            nominal.frames_trig(sc, frames);
        }
        self.weights_from_frames(sc, frames, out);
    }
}

impl Gravity {
    /// τ_i (N·m) at the joints `q_rad` of `robot`, into `out[..n_joints]`. No allocation.
    pub fn torques_nm(&self, robot: &Robot, q_rad: &[f64], out: &mut [f64]) {
        let mut frames = [Frame::identity(); MAX_JOINTS + 1];
        robot.frames_into(q_rad, &mut frames);
        self.torques_from_frames(&frames, out);
    }
}
