//! [`World`]: one trial's truth and its measuring process.

use std::sync::Arc;

use kinematics::{Frame, MAX_JOINTS, ModelError, PoseTrig, Robot, RobotSpec};
use nalgebra::{Matrix3, Rotation3, Vector3};
use rand::RngExt;
use rand::rngs::ChaCha8Rng;
use rand_distr::StandardNormal;
use serde::{Deserialize, Serialize};

use crate::config::VirtualRobotConfig;
use crate::error::{NotMeasurable, SimError};
use crate::poses::{PoseSet, Sampled, sample, sample_into};
use crate::rng::{MAX_TRIAL, Purpose, stream};
use crate::sampling::{SamplingReport, SamplingStats};
use crate::tracker::Tracker;
use crate::truth::{ScaleOutcome, solve_scale};
use crate::unmodelled::{CmdTrig, Unmodelled};

/// One parameter of the truth, display units (deg or mm).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TrueParameter {
    /// Stable parameter name (`theta1`, `beta2`, `base_dz`, …).
    pub name: String,
    /// `"deg"` or `"mm"`.
    pub unit: String,
    /// Nominal value.
    pub nominal: f64,
    /// Injected error, true − nominal.
    pub error: f64,
    /// True value of the robot's geometry.
    pub true_value: f64,
    /// What the identification can recover: the true value with the tracker's base-frame
    /// residual folded into the six base parameters (equal to `true_value` elsewhere).
    pub effective: f64,
}

/// Everything `truth.json` holds: the true parameters by name, the nominal robot, the seed
/// and trial, and the full configuration (tracker placement, unmodelled settings, …).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Truth {
    /// Format tag, `"kincal-truth/1"`.
    pub format: String,
    /// Master seed.
    pub seed: u64,
    /// Trial number.
    pub trial: u64,
    /// The nominal robot (model file).
    pub nominal_robot: RobotSpec,
    /// The true geometry as a model file (residual not folded in).
    pub true_robot: RobotSpec,
    /// Every parameter in layout order.
    pub parameters: Vec<TrueParameter>,
    /// The error scaling, if `truth.scale_to` was given.
    pub scale: Option<ScaleOutcome>,
    /// Phases used by the gear terms, degrees (drawn with `random_phase`; empty if off).
    pub gear_phases_deg: Vec<f64>,
    /// Pose sampling statistics.
    pub sampling: SamplingReport,
    /// Moves made so far (measurements attempted).
    pub moves: u64,
    /// The configuration the world was built from.
    pub config: VirtualRobotConfig,
}

/// One trial's truth: the nominal and true robots, the tracker, the unmodelled errors with
/// their random streams, the pose sets and a move counter.
#[derive(Debug)]
pub struct World {
    seed: u64,
    trial: u64,
    config: Arc<VirtualRobotConfig>,
    nominal: Robot,
    true_robot: Robot,
    effective_robot: Robot,
    errors_rad_mm: Vec<f64>,
    scale: Option<ScaleOutcome>,
    scale_poses_rad: Arc<[f64]>,
    tracker: Tracker,
    unmodelled: Unmodelled,
    tracker_rng: ChaCha8Rng,
    scatter_rng: ChaCha8Rng,
    moves: u64,
    id_deg: Vec<f64>,
    id_rad: Vec<f64>,
    val_deg: Vec<f64>,
    val_rad: Vec<f64>,
    report: SamplingReport,
    true_params: Vec<f64>,
    drift_params: Vec<f64>,
    drift_robot: Robot,
    cache: PointCache,
    /// [`solve_scale`]'s robot and parameter vector, and the residual fold's parameters:
    /// kept so that a refilled world ([`Setup::world_into`]) allocates nothing.
    scratch_robot: Robot,
    scratch_params: Vec<f64>,
    /// The validation poses' points before they join the identification poses' in the
    /// cache.
    scratch_points: Vec<Vector3<f64>>,
}

/// The point the robot reaches without scatter, drift or residual (robot base frame).
fn reached_point(robot: &Robot, unmodelled: &Unmodelled, q_cmd: &[f64]) -> Vector3<f64> {
    let mut trig = CmdTrig::default();
    trig.compute(Some(unmodelled), q_cmd);
    reached_point_trig(robot, unmodelled, q_cmd, &trig)
}

/// [`reached_point`] with the trigonometry of `q_cmd` in `trig` (bit for bit the same).
fn reached_point_trig(
    robot: &Robot,
    unmodelled: &Unmodelled,
    q_cmd: &[f64],
    trig: &CmdTrig,
) -> Vector3<f64> {
    let n = q_cmd.len();
    if !unmodelled.perturbs_joints() {
        return trig.point(robot, q_cmd);
    }
    let mut q = [0.0; MAX_JOINTS];
    unmodelled.actual_joints_trig(robot, q_cmd, trig, &mut q[..n]);
    let mut sc = [[0.0; 2]; MAX_JOINTS];
    crate::sincos::joint_trig(&q[..n], &mut sc);
    robot.mark_prismatic(&q[..n], &mut sc[..n]);
    robot.point_trig(&sc[..n])
}

/// A reading of [`World::measure_tool`]: the points (measurement frame, mm) and, for a
/// frame reading, the orientation (the probe's axes in measurement coordinates).
pub type ToolReading = (Vec<Vector3<f64>>, Option<Matrix3<f64>>);

/// The points [`reached_point`] gave for the sampled poses (identification, then
/// validation) on the true robot, kept so that measuring those poses again (without drift)
/// does not recompute them: a lookup by the joints' bits, first at the position after the
/// last hit (poses are usually measured in order). Other joints (compensated targets, the
/// ISO 9283 test's P1–P5, measured 30 times each) go through a ring of the
/// [`RECENT_POINTS`] last ones. A hit returns the bits the computation gave, so the cache
/// changes no result, only the time.
#[derive(Debug, Default)]
struct PointCache {
    /// Bits of q_1 per pose, for the search.
    key: Vec<u64>,
    points: Vec<Vector3<f64>>,
    /// Where the next lookup starts.
    cursor: usize,
    /// The ring: joints of up to [`RECENT_POINTS`] other poses, flat.
    recent_q: Vec<f64>,
    /// Their points.
    recent_points: Vec<Vector3<f64>>,
    /// The ring's slot written next.
    recent_next: usize,
}

/// Joint sets outside the sampled poses whose points a world keeps (the ISO test cycles 5
/// commanded and 5 compensated targets).
const RECENT_POINTS: usize = 16;

impl PointCache {
    /// The point of the recent joints `q`, if kept.
    fn recent(&self, q: &[f64]) -> Option<Vector3<f64>> {
        let n = q.len();
        self.recent_points
            .iter()
            .enumerate()
            .find(|(k, _)| {
                self.recent_q[k * n..(k + 1) * n]
                    .iter()
                    .zip(q)
                    .all(|(a, b)| a.to_bits() == b.to_bits())
            })
            .map(|(_, p)| *p)
    }

    /// Keeps the point `p` of the joints `q` in the ring (replacing the oldest when full).
    fn keep(&mut self, q: &[f64], p: Vector3<f64>) {
        let n = q.len();
        let k = self.recent_next;
        if self.recent_points.len() < RECENT_POINTS {
            self.recent_q.extend_from_slice(q);
            self.recent_points.push(p);
        } else {
            self.recent_q[k * n..(k + 1) * n].copy_from_slice(q);
            self.recent_points[k] = p;
        }
        self.recent_next = (k + 1) % RECENT_POINTS;
    }
}

/// Everything of a simulation that does not depend on the trial: the validated
/// configuration, the nominal robot, the tracker and the fixed pose set of the error
/// scaling (sampled once per seed). Build it once and call [`Setup::world`] per trial;
/// it is `Sync`, so trials can run in parallel.
#[derive(Clone, Debug)]
pub struct Setup {
    seed: u64,
    config: Arc<VirtualRobotConfig>,
    nominal: Robot,
    tracker: Tracker,
    scale_poses_rad: Arc<[f64]>,
    /// Sines and cosines of the scaling poses (computed once; every trial's scaling evaluates
    /// them at a few parameter vectors).
    scale_trig: PoseTrig,
    scale_points: Vec<Vector3<f64>>,
    scale_stats: Option<SamplingStats>,
    /// The nominal parameter vector (layout order, internal units).
    nominal_params: Vec<f64>,
    /// The robot the identification poses are drawn for
    /// ([`crate::PoseSampling::identification_robot`]; `None`: the nominal).
    narrowed: Option<Robot>,
    /// The unmodelled errors with the configured gear phases; each trial copies it and
    /// draws its phases.
    unmodelled: Unmodelled,
}

impl Setup {
    /// Validates `cfg` against `nominal` and samples the scaling poses (stream
    /// `SCALE_POSES`, trial 0) if `truth.scale_to` is given.
    pub fn new(nominal: &Robot, cfg: &VirtualRobotConfig, seed: u64) -> Result<Setup, SimError> {
        cfg.validate(nominal)?;
        // Compliance without `links`: the robot's own mass model (validated above).
        let mut cfg = cfg.clone();
        cfg.unmodelled.use_robot_mass_model(nominal)?;
        let cfg = &cfg;
        let tracker = Tracker::new(&cfg.tracker)?;
        let (scale_poses_rad, scale_stats) = match &cfg.truth.scale_to {
            Some(target) => {
                let nominal_point = |q: &[f64], t: &CmdTrig| t.point(nominal, q);
                let sampled = sample(
                    "truth.scale_to.poses",
                    target.poses,
                    &cfg.poses,
                    nominal,
                    &tracker,
                    None,
                    &nominal_point,
                    &mut stream(seed, 0, Purpose::ScalePoses),
                )?;
                (Arc::from(sampled.rad), Some(sampled.stats))
            }
            None => (Arc::from(Vec::new()), None),
        };
        let scale_points = nominal.points(&scale_poses_rad);
        let scale_trig = PoseTrig::for_robot(nominal, &scale_poses_rad);
        Ok(Setup {
            seed,
            config: Arc::new(cfg.clone()),
            nominal: nominal.clone(),
            tracker,
            scale_poses_rad,
            scale_trig,
            scale_points,
            scale_stats,
            nominal_params: nominal.params(),
            narrowed: cfg.poses.identification_robot(nominal),
            unmodelled: Unmodelled::configured(&cfg.unmodelled, nominal)?,
        })
    }

    /// The master seed.
    pub fn seed(&self) -> u64 {
        self.seed
    }

    /// The validated configuration.
    pub fn config(&self) -> &VirtualRobotConfig {
        &self.config
    }

    /// The nominal robot.
    pub fn nominal(&self) -> &Robot {
        &self.nominal
    }

    /// Builds trial `trial`: draws the truth (and scales it), builds the unmodelled errors
    /// and samples the pose sets, each from its own stream ([`crate::stream`]).
    pub fn world(&self, trial: u64) -> Result<World, SimError> {
        let nominal = &self.nominal;
        let mut world = World {
            seed: self.seed,
            trial,
            config: Arc::clone(&self.config),
            nominal: nominal.clone(),
            true_robot: nominal.clone(),
            effective_robot: nominal.clone(),
            errors_rad_mm: Vec::new(),
            scale: None,
            scale_poses_rad: Arc::clone(&self.scale_poses_rad),
            tracker: self.tracker.clone(),
            unmodelled: self.unmodelled.clone(),
            tracker_rng: stream(self.seed, trial, Purpose::TrackerNoise),
            scatter_rng: stream(self.seed, trial, Purpose::Repeatability),
            moves: 0,
            id_deg: Vec::new(),
            id_rad: Vec::new(),
            val_deg: Vec::new(),
            val_rad: Vec::new(),
            report: SamplingReport::default(),
            true_params: Vec::new(),
            drift_params: Vec::new(),
            drift_robot: nominal.clone(),
            cache: PointCache::default(),
            scratch_robot: nominal.clone(),
            scratch_params: Vec::new(),
            scratch_points: Vec::new(),
        };
        self.world_into(trial, &mut world)?;
        Ok(world)
    }

    /// [`Setup::world`] written into `world`, a world of this setup or any other: every part
    /// of it is overwritten, its vectors and robots refilled in place, so a thread that
    /// keeps one world for its trials allocates nothing here once the world has the room
    /// (the same trial in a fresh world and a refilled one is the same, bit for bit). On
    /// `Err` the world is left partly written: build or refill it again before use.
    pub fn world_into(&self, trial: u64, world: &mut World) -> Result<(), SimError> {
        if trial > MAX_TRIAL {
            return Err(SimError::Trial {
                trial,
                max: MAX_TRIAL,
            });
        }
        let (seed, cfg, nominal, tracker) = (self.seed, &self.config, &self.nominal, &self.tracker);
        let layout = nominal.layout();
        let p_nom = &self.nominal_params;
        world.seed = seed;
        world.trial = trial;
        world.config.clone_from(&self.config);
        world.scale_poses_rad.clone_from(&self.scale_poses_rad);
        world.nominal.clone_from(nominal);
        world.tracker.clone_from(tracker);

        // Truth: draw, then scale on the seed's fixed pose set.
        let delta = &mut world.errors_rad_mm;
        cfg.truth
            .draw_internal(layout, &mut stream(seed, trial, Purpose::Truth), delta);
        let mut report = SamplingReport {
            scale: self.scale_stats,
            ..SamplingReport::default()
        };
        world.scale = None;
        if let Some(target) = &cfg.truth.scale_to {
            let outcome = solve_scale(
                (nominal, p_nom),
                delta,
                &self.scale_trig,
                &self.scale_points,
                target.mean_error_mm,
                (&mut world.scratch_robot, &mut world.scratch_params),
            )?;
            for d in delta.iter_mut() {
                *d *= outcome.factor;
            }
            world.scale = Some(outcome);
        }
        world.true_params.clear();
        world
            .true_params
            .extend(p_nom.iter().zip(delta.iter()).map(|(p, d)| p + d));
        world.true_robot.clone_from(nominal);
        world
            .true_robot
            .set_params(&world.true_params)
            .map_err(|e| SimError::Scale {
                message: e.to_string(),
            })?;
        fold_residual_into(
            &world.true_robot,
            tracker.residual_frame(),
            &mut world.effective_robot,
            &mut world.scratch_params,
        );
        world.unmodelled.clone_from(&self.unmodelled);
        world.unmodelled.draw_phases(
            &cfg.unmodelled,
            &mut stream(seed, trial, Purpose::GearPhases),
        );

        // Pose sets, checked on where the true robot puts the point; written into the
        // world's vectors (moved out and back).
        let n = nominal.n_joints();
        let mut id = Sampled {
            deg: std::mem::take(&mut world.id_deg),
            rad: std::mem::take(&mut world.id_rad),
            points: std::mem::take(&mut world.cache.points),
            stats: SamplingStats::default(),
        };
        let mut val = Sampled {
            deg: std::mem::take(&mut world.val_deg),
            rad: std::mem::take(&mut world.val_rad),
            points: std::mem::take(&mut world.scratch_points),
            stats: SamplingStats::default(),
        };
        {
            let (true_robot, unmodelled) = (&world.true_robot, &world.unmodelled);
            let reached = |q: &[f64], t: &CmdTrig| reached_point_trig(true_robot, unmodelled, q, t);
            for (field, set, purpose, out) in [
                (
                    "poses.identification",
                    &cfg.poses.identification,
                    Purpose::IdentificationPoses,
                    &mut id,
                ),
                (
                    "poses.validation",
                    &cfg.poses.validation,
                    Purpose::ValidationPoses,
                    &mut val,
                ),
            ] {
                match set {
                    PoseSet::Count(count) => sample_into(
                        field,
                        *count,
                        &cfg.poses,
                        match (purpose, &self.narrowed) {
                            (Purpose::IdentificationPoses, Some(r)) => r,
                            _ => nominal,
                        },
                        tracker,
                        Some(unmodelled),
                        &reached,
                        &mut stream(seed, trial, purpose),
                        out,
                    )?,
                    PoseSet::ListDeg(rows) => {
                        out.deg.clear();
                        out.deg.extend(rows.iter().flatten().copied());
                        out.rad.clear();
                        out.rad.extend(out.deg.iter().map(|d| d.to_radians()));
                        out.points.clear();
                        for (index, q) in out.rad.chunks_exact(n).enumerate() {
                            let p = reached_point(true_robot, unmodelled, q);
                            tracker.check_visible(&p).map_err(|source| {
                                SimError::NotMeasurable {
                                    field: field.to_string(),
                                    index,
                                    source,
                                }
                            })?;
                            out.points.push(p);
                        }
                        out.stats = SamplingStats {
                            wanted: rows.len(),
                            accepted: rows.len(),
                            ..SamplingStats::default()
                        };
                    }
                }
            }
        }
        report.identification = id.stats;
        report.validation = val.stats;
        let cache = &mut world.cache;
        cache.key.clear();
        cache.key.extend(
            id.rad
                .chunks_exact(n)
                .chain(val.rad.chunks_exact(n))
                .map(|q| q[0].to_bits()),
        );
        cache.points = id.points;
        cache.points.extend_from_slice(&val.points);
        cache.cursor = 0;
        // The ring at its full size at once (no regrowth while a trial measures).
        cache.recent_q.clear();
        cache.recent_q.reserve_exact(RECENT_POINTS * n);
        cache.recent_points.clear();
        cache.recent_points.reserve_exact(RECENT_POINTS);
        cache.recent_next = 0;
        (world.id_deg, world.id_rad) = (id.deg, id.rad);
        (world.val_deg, world.val_rad) = (val.deg, val.rad);
        world.scratch_points = val.points;

        world.drift_robot.clone_from(&world.true_robot);
        world.drift_params.clone_from(&world.true_params);
        world.tracker_rng = stream(seed, trial, Purpose::TrackerNoise);
        world.scatter_rng = stream(seed, trial, Purpose::Repeatability);
        world.moves = 0;
        world.report = report;
        Ok(())
    }
}

impl World {
    /// The largest of the world's buffers (pose sets, points, parameter vectors), bytes of
    /// capacity: what a thread that keeps a world for its next trial
    /// ([`Setup::world_into`]) weighs against its budget for kept buffers.
    pub fn largest_buffer_bytes(&self) -> usize {
        let f = std::mem::size_of::<f64>();
        let v = std::mem::size_of::<Vector3<f64>>();
        [
            self.id_deg.capacity() * f,
            self.id_rad.capacity() * f,
            self.val_deg.capacity() * f,
            self.val_rad.capacity() * f,
            self.errors_rad_mm.capacity() * f,
            self.true_params.capacity() * f,
            self.drift_params.capacity() * f,
            self.scratch_params.capacity() * f,
            self.scratch_points.capacity() * v,
            self.cache.points.capacity() * v,
            self.cache.key.capacity() * std::mem::size_of::<u64>(),
            self.cache.recent_q.capacity() * f,
            self.cache.recent_points.capacity() * v,
        ]
        .into_iter()
        .max()
        .unwrap_or(0)
    }

    /// Builds trial `trial` of `seed`: `Setup::new(nominal, cfg, seed)?.world(trial)`.
    /// Validates `cfg` against `nominal`, draws the truth (and scales it), builds the
    /// tracker and the unmodelled errors, and samples the pose sets.
    pub fn new(
        nominal: &Robot,
        cfg: &VirtualRobotConfig,
        seed: u64,
        trial: u64,
    ) -> Result<World, SimError> {
        Setup::new(nominal, cfg, seed)?.world(trial)
    }

    /// `count` poses drawn as trial `trial`'s identification poses of `seed` (the stream and
    /// constraints a campaign's trial uses: joint limits, floor clearance, tracker window and
    /// range, wrist and condition limits of `cfg.poses`, checked where that trial's true
    /// robot puts the point), joints in degrees, flat with stride N: the candidate pool of a
    /// pose design (`design::Candidates::from_poses_deg`). The validation set is cut to one
    /// pose; nothing is measured.
    pub fn identification_pool_deg(
        nominal: &Robot,
        cfg: &VirtualRobotConfig,
        seed: u64,
        trial: u64,
        count: usize,
    ) -> Result<Vec<f64>, SimError> {
        let mut cfg = cfg.clone();
        cfg.poses.identification = PoseSet::Count(count);
        cfg.poses.validation = PoseSet::Count(1);
        Ok(World::new(nominal, &cfg, seed, trial)?.id_deg)
    }

    /// Measures the point at commanded joints `q_cmd_rad`: the true robot (drifted to the
    /// current move) reaches `q_cmd + Δq_compliance + Δq_gears`, repeatability scatter is
    /// added at the point, then the tracker checks visibility, adds its noise and maps the
    /// reading into the measurement frame (base-frame residual). Every call counts as one
    /// move, measurable or not, except calls rejected for the joint count or limits. No heap
    /// allocation once the ring of recent points (`PointCache`) is full (its first 16
    /// misses grow it).
    pub fn measure(&mut self, q_cmd_rad: &[f64]) -> Result<Vector3<f64>, NotMeasurable> {
        self.check_joints(q_cmd_rad)?;
        let drifting = self.next_move();
        let cached = if drifting {
            None
        } else {
            self.cached_point(q_cmd_rad)
        };
        let robot = if drifting {
            &self.drift_robot
        } else {
            &self.true_robot
        };
        let mut p = match cached {
            Some(p) => p,
            None if drifting => reached_point(robot, &self.unmodelled, q_cmd_rad),
            None => match self.cache.recent(q_cmd_rad) {
                Some(p) => p,
                None => {
                    let p = reached_point(robot, &self.unmodelled, q_cmd_rad);
                    self.cache.keep(q_cmd_rad, p);
                    p
                }
            },
        };
        let sigma = self.unmodelled.scatter_sigma_mm();
        if sigma > 0.0 {
            let e0: f64 = self.scatter_rng.sample(StandardNormal);
            let e1: f64 = self.scatter_rng.sample(StandardNormal);
            let e2: f64 = self.scatter_rng.sample(StandardNormal);
            p += Vector3::new(e0, e1, e2) * sigma;
        }
        self.tracker.observe(&p, &mut self.tracker_rng)
    }

    /// Counts one move and, when the robot drifts, sets the drifting robot's parameters to
    /// those of this move (`p + k·rate`, k the moves before it); returns whether it drifts
    /// (then the move is made by `drift_robot`, else by `true_robot`).
    fn next_move(&mut self) -> bool {
        let k = self.moves;
        self.moves += 1;
        let Some(rates) = self.unmodelled.drift_per_move() else {
            return false;
        };
        let kf = k as f64;
        for ((d, p), r) in self
            .drift_params
            .iter_mut()
            .zip(&self.true_params)
            .zip(rates)
        {
            *d = p + kf * r;
        }
        // The parameter vector has the layout's length by construction.
        let _ = self.drift_robot.set_params(&self.drift_params);
        true
    }

    /// Measures several things on the tool at commanded joints `q_cmd_rad` (one move): the
    /// points at `offsets_mm` from the tool point (flange frame; offset zero is the tool
    /// point itself), each a tracker reading of its own in order, and with `orientation`
    /// the probe frame's orientation (the true robot's tool orientation) read with the
    /// first point ([`Tracker::observe_frame`]). The true robot, drift, compliance and
    /// gears as [`World::measure`]; the repeatability scatter moves the whole tool (one
    /// draw of three for the move). The reflectors are rigidly mounted on the true tool:
    /// they carry the tool point's error.
    pub fn measure_tool(
        &mut self,
        q_cmd_rad: &[f64],
        offsets_mm: &[Vector3<f64>],
        orientation: bool,
    ) -> Result<ToolReading, NotMeasurable> {
        self.check_joints(q_cmd_rad)?;
        let robot = if self.next_move() {
            &self.drift_robot
        } else {
            &self.true_robot
        };
        let n = q_cmd_rad.len();
        let mut q = [0.0; MAX_JOINTS];
        self.unmodelled.actual_joints(robot, q_cmd_rad, &mut q[..n]);
        let flange = robot.flange(&q[..n]);
        let rot = flange.rot * robot.tool_rotation();
        let tool = robot.tool_mm();
        let mut shift = Vector3::zeros();
        let sigma = self.unmodelled.scatter_sigma_mm();
        if sigma > 0.0 {
            let e0: f64 = self.scatter_rng.sample(StandardNormal);
            let e1: f64 = self.scatter_rng.sample(StandardNormal);
            let e2: f64 = self.scatter_rng.sample(StandardNormal);
            shift = Vector3::new(e0, e1, e2) * sigma;
        }
        let mut points = Vec::with_capacity(offsets_mm.len());
        let mut measured_rot = None;
        for (i, off) in offsets_mm.iter().enumerate() {
            let p = flange.rot * (tool + off) + flange.pos_mm + shift;
            if orientation && i == 0 {
                let (pm, rm) = self
                    .tracker
                    .observe_frame(&p, &rot, &mut self.tracker_rng)?;
                points.push(pm);
                measured_rot = Some(rm);
            } else {
                points.push(self.tracker.observe(&p, &mut self.tracker_rng)?);
            }
        }
        Ok((points, measured_rot))
    }

    /// Where the true robot puts the point at commanded joints `q_cmd_rad`, in the
    /// measurement frame, without scatter, drift or tracker noise (but with compliance,
    /// gears and the base-frame residual): the reference for evaluating accuracy. No
    /// visibility or limit check; errors only for a wrong joint count.
    pub fn true_point(&self, q_cmd_rad: &[f64]) -> Result<Vector3<f64>, NotMeasurable> {
        if q_cmd_rad.len() != self.nominal.n_joints() {
            return Err(NotMeasurable::JointCount {
                expected: self.nominal.n_joints(),
                found: q_cmd_rad.len(),
            });
        }
        let p = reached_point(&self.true_robot, &self.unmodelled, q_cmd_rad);
        Ok(match self.tracker.residual_frame() {
            Some(f) => f.transform_point(&p),
            None => p,
        })
    }

    /// Where the true robot puts its tool frame at commanded joints `q_cmd_rad`, in the
    /// measurement frame: the tool point and the frame's orientation (flange rotation times
    /// the true tool rotation, what a 6-DoF probe reads), without scatter, drift or tracker
    /// noise (with compliance, gears and the base-frame residual, as [`World::true_point`]):
    /// the reference for evaluating the accuracy of a pose. Errors only for a wrong joint
    /// count.
    pub fn true_pose(
        &self,
        q_cmd_rad: &[f64],
    ) -> Result<(Vector3<f64>, Matrix3<f64>), NotMeasurable> {
        let n = self.nominal.n_joints();
        if q_cmd_rad.len() != n {
            return Err(NotMeasurable::JointCount {
                expected: n,
                found: q_cmd_rad.len(),
            });
        }
        let mut q = [0.0; MAX_JOINTS];
        self.unmodelled
            .actual_joints(&self.true_robot, q_cmd_rad, &mut q[..n]);
        let flange = self.true_robot.flange(&q[..n]);
        let p = flange.transform_point(&self.true_robot.tool_mm());
        let rot = flange.rot * self.true_robot.tool_rotation();
        Ok(match self.tracker.residual_frame() {
            Some(f) => (f.transform_point(&p), f.rot * rot),
            None => (p, rot),
        })
    }

    /// The point of a sampled pose whose joints are `q`, bit for bit (see [`PointCache`]).
    fn cached_point(&mut self, q: &[f64]) -> Option<Vector3<f64>> {
        let n = q.len();
        let n_id = self.id_rad.len() / n.max(1);
        let (id, val) = (&self.id_rad, &self.val_rad);
        let same = |k: usize| {
            let row = if k < n_id {
                &id[k * n..(k + 1) * n]
            } else {
                &val[(k - n_id) * n..(k - n_id + 1) * n]
            };
            row.iter().zip(q).all(|(a, b)| a.to_bits() == b.to_bits())
        };
        let c = &mut self.cache;
        let total = c.points.len();
        let first = q.first()?.to_bits();
        let hit = if c.cursor < total && c.key[c.cursor] == first && same(c.cursor) {
            Some(c.cursor)
        } else {
            (0..total).find(|&k| c.key[k] == first && same(k))
        }?;
        c.cursor = hit + 1;
        Some(c.points[hit])
    }

    fn check_joints(&self, q: &[f64]) -> Result<(), NotMeasurable> {
        let n = self.nominal.n_joints();
        if q.len() != n {
            return Err(NotMeasurable::JointCount {
                expected: n,
                found: q.len(),
            });
        }
        for (i, v) in q.iter().enumerate() {
            let [lo, hi] = self.nominal.limits_rad(i);
            if !(*v >= lo && *v <= hi) {
                return Err(NotMeasurable::JointLimits {
                    joint: i + 1,
                    value_deg: v.to_degrees(),
                    min_deg: lo.to_degrees(),
                    max_deg: hi.to_degrees(),
                });
            }
        }
        Ok(())
    }

    /// Master seed.
    pub fn seed(&self) -> u64 {
        self.seed
    }

    /// Trial number.
    pub fn trial(&self) -> u64 {
        self.trial
    }

    /// The configuration.
    pub fn config(&self) -> &VirtualRobotConfig {
        &self.config
    }

    /// The nominal robot.
    pub fn nominal(&self) -> &Robot {
        &self.nominal
    }

    /// The true geometry (nominal + injected errors; no drift, no residual).
    pub fn true_robot(&self) -> &Robot {
        &self.true_robot
    }

    /// The true geometry with the tracker's base-frame residual folded into the base
    /// parameters: what a perfect identification recovers. Without unmodelled errors and
    /// noise its `point` equals the measurements up to rounding.
    pub fn effective_true_robot(&self) -> &Robot {
        &self.effective_robot
    }

    /// The truth as an extended robot with the non-geometric parameters `names`
    /// ([`Robot::with_extended`]): the geometry of [`World::effective_true_robot`], the
    /// gravity torques on the true geometry with the compliance section's mass model (as
    /// the virtual robot evaluates them), and the values of the injected compliance and gear
    /// terms ([`crate::Unmodelled::extended_values`]). Without repeatability, tracker noise,
    /// drift and the terms the family does not contain, its points are the measured ones up
    /// to rounding. What recovery scoring compares an extended identification with.
    pub fn extended_truth<S: AsRef<str>>(&self, names: &[S]) -> Result<Robot, ModelError> {
        let mut spec = self.true_robot.to_spec();
        spec.extended = None;
        let compliance = &self.config.unmodelled.compliance;
        if compliance.enabled {
            spec.mass_model = Some(compliance.mass_model_spec());
        }
        let ext = Robot::from_spec(&spec)?.with_extended(names, "virtual robot")?;
        let Some(model) = ext.extended() else {
            return Ok(self.effective_robot.clone());
        };
        let mut x = self.effective_robot.params();
        x.extend(self.unmodelled.extended_values(model.kinds()));
        ext.with_params(&x)
    }

    /// Injected errors, internal units (rad, mm), layout order.
    pub fn errors_internal(&self) -> &[f64] {
        &self.errors_rad_mm
    }

    /// Injected errors, display units (deg, mm), layout order.
    pub fn errors_display(&self) -> Vec<f64> {
        self.nominal
            .layout()
            .params()
            .iter()
            .zip(&self.errors_rad_mm)
            .map(|(info, e)| info.to_display(*e))
            .collect()
    }

    /// The error scaling, if configured.
    pub fn scale_outcome(&self) -> Option<&ScaleOutcome> {
        self.scale.as_ref()
    }

    /// The poses the scaling averaged over (flat, stride N, radians; empty without scaling).
    pub fn scale_poses_rad(&self) -> &[f64] {
        &self.scale_poses_rad
    }

    /// The tracker.
    pub fn tracker(&self) -> &Tracker {
        &self.tracker
    }

    /// The unmodelled-error model.
    pub fn unmodelled(&self) -> &Unmodelled {
        &self.unmodelled
    }

    /// Moves made so far.
    pub fn moves(&self) -> u64 {
        self.moves
    }

    /// Identification poses, radians, flat with stride N.
    pub fn identification_poses_rad(&self) -> &[f64] {
        &self.id_rad
    }

    /// Identification poses, degrees, flat with stride N (`to_radians` of these gives
    /// [`World::identification_poses_rad`] exactly).
    pub fn identification_poses_deg(&self) -> &[f64] {
        &self.id_deg
    }

    /// Validation poses, radians, flat with stride N.
    pub fn validation_poses_rad(&self) -> &[f64] {
        &self.val_rad
    }

    /// Validation poses, degrees, flat with stride N.
    pub fn validation_poses_deg(&self) -> &[f64] {
        &self.val_deg
    }

    /// Sampling statistics (draws and rejections by reason, per set).
    pub fn sampling_report(&self) -> &SamplingReport {
        &self.report
    }

    /// The truth of this world (for `truth.json`).
    pub fn truth(&self) -> Truth {
        let layout = self.nominal.layout();
        let p_nom = self.nominal.params();
        let p_eff = self.effective_robot.params();
        let parameters = layout
            .params()
            .iter()
            .enumerate()
            .map(|(k, info)| TrueParameter {
                name: info.name.to_string(),
                unit: info.unit.as_str().to_string(),
                nominal: info.to_display(p_nom[k]),
                error: info.to_display(self.errors_rad_mm[k]),
                true_value: info.to_display(self.true_params[k]),
                effective: info.to_display(p_eff[k]),
            })
            .collect();
        Truth {
            format: "kincal-truth/1".to_string(),
            seed: self.seed,
            trial: self.trial,
            nominal_robot: self.nominal.to_spec(),
            true_robot: self.true_robot.to_spec(),
            parameters,
            scale: self.scale.clone(),
            gear_phases_deg: self.unmodelled.gear_phases_deg(),
            sampling: self.report.clone(),
            moves: self.moves,
            config: (*self.config).clone(),
        }
    }
}

/// `robot` with its base replaced by `residual ∘ base` (ZYX angles re-extracted), written
/// into `out` (`params`: scratch for the parameter vector).
fn fold_residual_into(
    robot: &Robot,
    residual: Option<Frame>,
    out: &mut Robot,
    params: &mut Vec<f64>,
) {
    out.clone_from(robot);
    let Some(res) = residual else {
        return;
    };
    let base = res.compose(&robot.base_frame());
    let (rx, ry, rz) = Rotation3::from_matrix_unchecked(base.rot).euler_angles();
    let layout = robot.layout();
    robot.params_into(params);
    for (name, v) in [
        ("base_rx", rx),
        ("base_ry", ry),
        ("base_rz", rz),
        ("base_dx", base.pos_mm.x),
        ("base_dy", base.pos_mm.y),
        ("base_dz", base.pos_mm.z),
    ] {
        if let Ok(k) = layout.index_of(name) {
            params[k] = v;
        }
    }
    if out.set_params(params).is_err() {
        out.clone_from(robot);
    }
}
