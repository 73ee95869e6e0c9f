//! The proof by simulation of Cartesian compensation (issue 40): a scenario's virtual robot
//! measured with a 6-DoF probe, calibrated as `kincal identify` calibrates
//! (`calibrate::calibrate`), then its TRUE robot driven through Cartesian targets with
//! orientation — the ISO 9283 cube's positions and the nominal poses of the scenario's
//! random validation poses — at the nominal controller's joints (before), at the
//! compensated joints (after), and at the joints a nominal controller finds for the
//! corrected targets (`calibrate::CorrectedTarget`). [`CartesianProof::run`] returns the
//! figures; `cargo xtask regenerate` writes them to `results/cartesian-kr1000/`.

use std::fmt::Write as _;
use std::path::PathBuf;

use calibrate::{
    CartesianOptions, Compensation, IdentifyRequest, Inputs, LoadedRobot, TargetFrame,
    orientation_wxyz,
};
use identify::CompensationOptions;
use kinematics::rotation::log_so3;
use kinematics::{IkTarget, Robot};
use measurements::{Measurement, MeasurementSet, quaternion_to_matrix};
use nalgebra::{Matrix3, Vector3};
use virtual_robot::{Probe, World};

use crate::error::CampaignError;
use crate::scenario::Scenario;

/// The proof of Cartesian compensation on trial `trial` of `scenario`.
#[derive(Clone, Debug, PartialEq)]
#[non_exhaustive]
pub struct CartesianProof {
    /// The scenario file (JSON): its robot, truth, tracker and poses; measured with a 6-DoF
    /// probe whatever its `measurement`.
    pub scenario: PathBuf,
    /// The trial whose truth, poses and noise are drawn.
    pub trial: u64,
}

/// Mean and max of the errors of a set of targets at some joints of the true robot.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct PoseErrors {
    /// Position error, mean, mm.
    pub position_mean_mm: f64,
    /// Position error, max, mm.
    pub position_max_mm: f64,
    /// Orientation error (angle of the rotation between the target and the true TCP
    /// frame), mean, degrees.
    pub orientation_mean_deg: f64,
    /// Orientation error, max, degrees.
    pub orientation_max_deg: f64,
}

/// The figures of one set of targets.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct TargetSetProof {
    /// What the targets are.
    pub name: String,
    /// Targets in the set.
    pub targets: usize,
    /// Targets compensated (the others unreachable for a model).
    pub compensated: usize,
    /// Flagged rows (a joint moves by more than the flag threshold).
    pub flagged: usize,
    /// The true robot at the nominal controller's joints (no compensation).
    pub before: PoseErrors,
    /// The true robot at the compensated joints.
    pub after: PoseErrors,
    /// The true robot at the joints a nominal controller's IK gives for the corrected
    /// targets (from its own solution of the original target).
    pub through_controller: PoseErrors,
    /// A bound on the largest difference between those joints and the compensated ones,
    /// degrees: the smallest power of ten above it.
    pub controller_joint_diff_deg: f64,
}

/// What [`CartesianProof::run`] found.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct CartesianProofOutcome {
    /// The scenario's name.
    pub scenario: String,
    /// The trial.
    pub trial: u64,
    /// The identification's held-out validation, as `identify` prints it.
    pub validation: String,
    /// The ISO 9283 cube's targets, then the random targets.
    pub sets: Vec<TargetSetProof>,
}

impl CartesianProof {
    /// Trial 0 of `scenario`.
    pub fn new(scenario: impl Into<PathBuf>) -> CartesianProof {
        CartesianProof {
            scenario: scenario.into(),
            trial: 0,
        }
    }

    /// Simulates, calibrates and drives the true robot through the targets.
    pub fn run(&self) -> Result<CartesianProofOutcome, CampaignError> {
        let loaded = Scenario::from_file(&self.scenario)?;
        let trial = self.trial;
        let sim_err = |source| CampaignError::Sim { trial, source };
        let vr = loaded.virtual_robot();
        let new_world = || World::new(&loaded.nominal, &vr, loaded.scenario.seed, trial);
        let sim = new_world()
            .and_then(|mut w| w.simulate_with(&Probe::Frame))
            .map_err(sim_err)?;
        let world = new_world().map_err(sim_err)?;
        let cal_err = |what: &str| {
            let what = what.to_string();
            move |source| CampaignError::Calibrate {
                what,
                source: Box::new(source),
            }
        };
        let nominal = LoadedRobot::from_spec(loaded.nominal.to_spec(), &loaded.source, "nominal")
            .map_err(cal_err("the nominal robot"))?;
        let request = IdentifyRequest::new(&loaded.source, "identification.csv");
        let inputs = Inputs::from_sets(
            &request,
            nominal,
            sim.identification.clone(),
            Some(sim.validation.clone()),
        )
        .map_err(cal_err("the simulated 6-DoF measurements"))?;
        let calibration =
            calibrate::calibrate(&request, inputs).map_err(cal_err("identification"))?;
        let validation = match &calibration {
            calibrate::Calibration::ToolFrame(c) => c.validation.as_ref().map(|(_, b, a)| {
                format!(
                    "{} poses: position mean {:.3} mm, max {:.3} mm; orientation mean {:.4}°, \
                     max {:.4}° (nominal, registered) → position mean {:.3} mm, max {:.3} mm; \
                     orientation mean {:.4}°, max {:.4}° (identified)",
                    b.poses,
                    b.position_mm.0,
                    b.position_mm.1,
                    b.orientation_deg.0,
                    b.orientation_deg.1,
                    a.position_mm.0,
                    a.position_mm.1,
                    a.orientation_deg.0,
                    a.orientation_deg.1
                )
            }),
            calibrate::Calibration::Points(_) => None,
        }
        .unwrap_or_default();
        let as_loaded = |robot: Robot, label: &str| {
            LoadedRobot::from_spec(robot.to_spec(), label, "robot")
                .map_err(cal_err("the calibrated robots"))
        };
        let calibrated = as_loaded(calibration.identified_robot(), "identified.json")?;
        let registered = as_loaded(calibration.registered_robot(), "registered-nominal.json")?;
        let n = registered.robot.n_joints();
        // The targets: the registered nominal's TCP pose (position and orientation, in the
        // measurement frame) at joints the nominal controller reaches.
        let targets = |name: &str, poses_rad: &[f64]| {
            let rows = poses_rad
                .chunks_exact(n)
                .enumerate()
                .map(|(k, q)| {
                    let p = registered.robot.point(q);
                    let o = orientation_wxyz(&registered.robot, q).expect("a 6-DoF calibration");
                    Measurement {
                        line: k + 2,
                        id: Some(format!("{name}{:02}", k + 1)),
                        point_mm: Some([p.x, p.y, p.z]),
                        orientation: Some(o),
                        ..Default::default()
                    }
                })
                .collect();
            MeasurementSet::new(name, 0, rows)
        };
        let mut sets = Vec::new();
        if loaded.scenario.iso.enabled {
            let plan = crate::trial::iso_plan(&loaded, &vr.tracker)?;
            let cube_rad: Vec<f64> = plan.q_cmd_rad.concat();
            sets.push(self.prove(
                "ISO 9283 cube P1–P5",
                targets("P", &cube_rad),
                (&calibrated, &registered),
                &world,
                &plan.q_cmd_rad[0],
            )?);
        }
        let random = world.validation_poses_rad();
        sets.push(self.prove(
            "random (the validation poses)",
            targets("R", random),
            (&calibrated, &registered),
            &world,
            &random[..n],
        )?);
        Ok(CartesianProofOutcome {
            scenario: loaded.scenario.name.clone(),
            trial,
            validation,
            sets,
        })
    }

    /// Compensates `set` (Cartesian targets in the measurement frame) from the start joints
    /// `start_rad` and drives the true robot of `world` at the joints before, after and
    /// through a nominal controller.
    fn prove(
        &self,
        name: &str,
        set: MeasurementSet,
        (calibrated, registered): (&LoadedRobot, &LoadedRobot),
        world: &World,
        start_rad: &[f64],
    ) -> Result<TargetSetProof, CampaignError> {
        let options = CompensationOptions::default();
        let cartesian = CartesianOptions {
            frame: TargetFrame::Measurement,
            start_deg: Some(start_rad.iter().map(|v| v.to_degrees()).collect()),
            ..Default::default()
        };
        let targets = set.rows.clone();
        let c: Compensation = calibrate::compensate_poses(
            calibrated,
            registered,
            set,
            true,
            (&options, &cartesian),
            name,
        )
        .map_err(|source| CampaignError::Calibrate {
            what: format!("compensating the {name} targets"),
            source: Box::new(source),
        })?;
        let nominal = &registered.robot;
        let base = nominal.base_frame();
        let rad = |d: &[f64]| d.iter().map(|v| v.to_radians()).collect::<Vec<f64>>();
        let rotation = |q: [f64; 4]| {
            let m = quaternion_to_matrix(q);
            Matrix3::from_fn(|i, j| m[i][j])
        };
        let (mut before, mut after, mut through) = (Vec::new(), Vec::new(), Vec::new());
        let mut joint_diff = 0.0_f64;
        let error = |q: &[f64], target: &Measurement| -> Result<(f64, f64), CampaignError> {
            let (p, r) = world.true_pose(q).map_err(|e| CampaignError::Proof {
                what: format!("the true pose of a {name} target"),
                reason: e.to_string(),
            })?;
            let t = Vector3::from(target.point_mm.expect("targets have points"));
            let rt = rotation(target.orientation.expect("targets have orientations"));
            Ok((
                (p - t).norm(),
                log_so3(&(rt.transpose() * r)).norm().to_degrees(),
            ))
        };
        for ct in &c.corrected {
            let target = targets
                .iter()
                .find(|t| t.id.as_deref() == Some(ct.id.as_str()))
                .expect("ids kept");
            let (q_nom, q_c) = (rad(&ct.nominal_joints_deg), rad(&ct.joints_deg));
            before.push(error(&q_nom, target)?);
            after.push(error(&q_c, target)?);
            // A nominal controller given the corrected target (base frame → measurement
            // frame through the nominal's base), solving from its own joints for the target.
            let ik_target = IkTarget {
                point_in_flange_mm: nominal.tool_mm(),
                position_mm: base.transform_point(&Vector3::from(ct.position_mm)),
                rotation: base.rot
                    * rotation(ct.orientation_wxyz)
                    * nominal.tool_rotation().transpose(),
            };
            let mut q = q_nom.clone();
            nominal
                .solve_ik_nearest(&ik_target, &mut q, &options.ik, &options.search)
                .map_err(|e| CampaignError::Proof {
                    what: format!("the nominal controller's IK of corrected target {}", ct.id),
                    reason: e.to_string(),
                })?;
            for (a, b) in q.iter().zip(&q_c) {
                joint_diff = joint_diff.max((a - b).abs().to_degrees());
            }
            through.push(error(&q, target)?);
        }
        Ok(TargetSetProof {
            name: name.to_string(),
            targets: c.targets,
            compensated: c.compensated,
            flagged: c.flagged.len(),
            before: stats(&before),
            after: stats(&after),
            through_controller: stats(&through),
            controller_joint_diff_deg: decade_above(joint_diff),
        })
    }
}

/// Mean and max of (position mm, orientation deg) pairs, rounded to 10⁻⁶ (mm, °): the
/// committed result holds figures, not the last bits of an IK's convergence.
fn stats(e: &[(f64, f64)]) -> PoseErrors {
    let n = e.len().max(1) as f64;
    let r = |v: f64| (v * 1e6).round() / 1e6;
    PoseErrors {
        position_mean_mm: r(e.iter().map(|x| x.0).sum::<f64>() / n),
        position_max_mm: r(e.iter().map(|x| x.0).fold(0.0, f64::max)),
        orientation_mean_deg: r(e.iter().map(|x| x.1).sum::<f64>() / n),
        orientation_max_deg: r(e.iter().map(|x| x.1).fold(0.0, f64::max)),
    }
}

/// The smallest power of ten at or above `v` (> 0; 0 for 0): a bound that does not depend
/// on the last bits of `v`.
fn decade_above(v: f64) -> f64 {
    if v > 0.0 {
        10f64.powi(v.log10().ceil() as i32)
    } else {
        0.0
    }
}

impl CartesianProofOutcome {
    /// The figures as a Markdown page (`cartesian.md`).
    pub fn markdown(&self) -> String {
        let mut s = format!(
            "# Cartesian compensation on the true robot ({}, trial {})\n\n\
             Written by `cargo xtask regenerate` (`campaign::CartesianProof`). The scenario's \
             virtual robot measured with a 6-DoF probe (position and orientation at each \
             identification pose), calibrated as `kincal identify` calibrates; then its true \
             robot (compliance, gears, base residual included; no noise) driven through \
             Cartesian targets with orientation in the measurement frame: the registered \
             nominal model's TCP pose at the ISO 9283 cube's P1–P5 and at the scenario's \
             random validation poses. *Before*: the nominal controller's joints (the nominal \
             model's IK of each target); *after*: the compensated joints \
             (`calibrate::compensate_poses`); *through a nominal controller*: the nominal \
             model's IK of each corrected target.\n\n\
             Identification's held-out validation: {}\n\n\
             | targets | n | flagged | position mean / max, mm: before → after | orientation \
             mean / max, °: before → after | through a nominal controller: position mean / \
             max mm, orientation mean / max °, joints vs compensated max ° |\n\
             |---|---|---|---|---|---|\n",
            self.scenario, self.trial, self.validation
        );
        for t in &self.sets {
            let (b, a, c) = (&t.before, &t.after, &t.through_controller);
            let _ = writeln!(
                s,
                "| {} | {} of {} | {} | {:.3} / {:.3} → {:.3} / {:.3} | {:.4} / {:.4} → {:.4} / \
                 {:.4} | {:.3} / {:.3}, {:.4} / {:.4}, < {:.0e} |",
                t.name,
                t.compensated,
                t.targets,
                t.flagged,
                b.position_mean_mm,
                b.position_max_mm,
                a.position_mean_mm,
                a.position_max_mm,
                b.orientation_mean_deg,
                b.orientation_max_deg,
                a.orientation_mean_deg,
                a.orientation_max_deg,
                c.position_mean_mm,
                c.position_max_mm,
                c.orientation_mean_deg,
                c.orientation_max_deg,
                t.controller_joint_diff_deg
            );
        }
        s
    }
}
