//! One trial end to end: draw the truth → measure identification poses → identify →
//! compensate validation poses by IK of the identified model → measure again → Table 4,
//! recovery scoring, ISO 9283.

use evaluate::{IsoCube, IsoReport, ParameterRecovery, Table4};
use identify::{Fit, IdentifyOptions, Observability, ParamSet, Problem};
use kinematics::{IkTarget, PoseTrig, Robot};
use nalgebra::{DMatrix, DVector, Vector3};
use serde::{Deserialize, Serialize};
use virtual_robot::{Setup, Tracker, World};

use crate::error::CampaignError;
use crate::scenario::LoadedScenario;

/// The ISO 9283 test plan, fixed for a campaign (nominal model, tracker placement).
#[derive(Clone, Debug)]
pub struct IsoPlan {
    /// The cube.
    pub cube: IsoCube,
    /// Targets P1…P5 (nominal point position, reference flange orientation).
    pub targets: [IkTarget; 5],
    /// Commanded joints reaching P1…P5 on the nominal model, rad.
    pub q_cmd_rad: [Vec<f64>; 5],
}

/// What is shared by all trials of a campaign.
pub struct Context {
    /// The scenario.
    pub loaded: LoadedScenario,
    /// The virtual robot's per-seed setup.
    pub setup: Setup,
    /// Identification options.
    pub id_options: IdentifyOptions,
    /// The minimal identifiable set (computed at the nominal model on trial 0's
    /// identification poses): recovery is scored on it.
    pub minimal_free: Vec<usize>,
    /// The ISO plan when the test is on.
    pub iso: Option<IsoPlan>,
    /// A designed pose selection: criterion, poses to choose and column scale.
    pub design: Option<(design::Criterion, usize, design::Scale)>,
    /// The start model of the identification: the nominal robot, extended by the
    /// scenario's non-geometric parameters (`identification.extended`) when it has any.
    pub id_nominal: Robot,
    /// The minimal identifiable set of `id_nominal` (on the same poses as `minimal_free`,
    /// which it equals for a geometric identification): recovery is scored on it.
    pub recovery_free: Vec<usize>,
}

impl Context {
    /// Builds the shared state: validates the virtual robot, resolves the minimal set,
    /// finds the ISO cube.
    pub fn new(loaded: LoadedScenario) -> Result<Context, CampaignError> {
        let vr = loaded.trial_virtual_robot();
        let seed = loaded.scenario.seed;
        let setup = Setup::new(&loaded.nominal, &vr, seed)
            .map_err(|source| CampaignError::Sim { trial: 0, source })?;
        let id = &loaded.scenario.identification;
        let reference = setup
            .world(0)
            .map_err(|source| CampaignError::Sim { trial: 0, source })?;
        let minimal_free = ParamSet::Minimal
            .resolve(
                &loaded.nominal,
                reference.identification_poses_rad(),
                None,
                &id.identifiability,
            )
            .map_err(|source| CampaignError::Identify { trial: 0, source })?;
        let iso = if loaded.scenario.iso.enabled {
            Some(iso_plan(&loaded, &vr.tracker)?)
        } else {
            None
        };
        let design = match (
            loaded.scenario.pose_selection.method.criterion(),
            &loaded.scenario.poses.identification,
        ) {
            (Some(c), virtual_robot::PoseSet::Count(n)) => Some((c, *n, loaded.design_scale())),
            _ => None,
        };
        let id_nominal = loaded
            .nominal
            .with_extended(
                &id.extended_names(loaded.nominal.n_joints()),
                &loaded.source,
            )
            .map_err(|source| CampaignError::ExtendedModel { source })?;
        let recovery_free = if id_nominal.is_extended() {
            ParamSet::Minimal
                .resolve(
                    &id_nominal,
                    reference.identification_poses_rad(),
                    None,
                    &id.identifiability,
                )
                .map_err(|source| CampaignError::Identify { trial: 0, source })?
        } else {
            minimal_free.clone()
        };
        Ok(Context {
            design,
            id_nominal,
            recovery_free,
            id_options: id.options(),
            loaded,
            setup,
            minimal_free,
            iso,
        })
    }

    /// The nominal robot.
    pub fn nominal(&self) -> &Robot {
        &self.loaded.nominal
    }
}

/// Finds the largest cube in the reachable, tracker-visible workspace around the ISO
/// reference pose, and the nominal joints of P1…P5.
fn iso_plan(
    loaded: &LoadedScenario,
    tracker_cfg: &virtual_robot::TrackerConfig,
) -> Result<IsoPlan, CampaignError> {
    let iso = &loaded.scenario.iso;
    let nominal = &loaded.nominal;
    let tracker =
        Tracker::new(tracker_cfg).map_err(|source| CampaignError::IsoTracker { source })?;
    let q_ref: Vec<f64> = iso.reference_q_deg.iter().map(|v| v.to_radians()).collect();
    let reference = nominal.flange(&q_ref);
    let p_ref = reference.transform_point(&nominal.tool_mm());
    let ik = loaded.scenario.compensation.ik_options();
    let min_q5 = loaded.scenario.poses.min_abs_q5_deg.to_radians();
    let max_cond = loaded.scenario.poses.max_condition.unwrap_or(f64::INFINITY);
    let solve = |p: &[f64; 3]| -> Option<Vec<f64>> {
        let target = IkTarget {
            point_in_flange_mm: nominal.tool_mm(),
            position_mm: Vector3::from(*p),
            rotation: reference.rot,
        };
        let mut q = q_ref.clone();
        nominal.solve_ik(&target, &mut q, &ik).ok()?;
        let ok = q.get(4).is_none_or(|q5| q5.abs() >= min_q5)
            && nominal.singularity_condition(&q, 1000.0) <= max_cond
            && tracker.check_visible(&Vector3::from(*p)).is_ok();
        ok.then_some(q)
    };
    let h = iso.centre_half_count as i64;
    let mut centres = Vec::new();
    for i in -h..=h {
        for j in -h..=h {
            for k in -h..=h {
                let s = iso.centre_step_mm;
                centres.push([
                    p_ref.x + s * i as f64,
                    p_ref.y + s * j as f64,
                    p_ref.z + s * k as f64,
                ]);
            }
        }
    }
    // Nearest centres first, so ties go to the cube closest to the reference pose.
    centres.sort_by(|a, b| {
        let d = |c: &[f64; 3]| (Vector3::from(*c) - p_ref).norm_squared();
        d(a).total_cmp(&d(b))
    });
    let cube = evaluate::largest_cube(&centres, iso.min_edge_mm, iso.max_edge_mm, |p| {
        solve(p).is_some()
    })
    .map_err(|source| CampaignError::IsoCube { source })?;
    let points = cube.test_points_mm();
    let mut targets = Vec::with_capacity(5);
    let mut q_cmd = Vec::with_capacity(5);
    for p in &points {
        let q = solve(p).ok_or(CampaignError::IsoUnreachable { point_mm: *p })?;
        targets.push(IkTarget {
            point_in_flange_mm: nominal.tool_mm(),
            position_mm: Vector3::from(*p),
            rotation: reference.rot,
        });
        q_cmd.push(q);
    }
    let targets: [IkTarget; 5] = targets.try_into().expect("five test points");
    let q_cmd_rad: [Vec<f64>; 5] = q_cmd.try_into().expect("five test points");
    Ok(IsoPlan {
        cube,
        targets,
        q_cmd_rad,
    })
}

/// A stop on a small step or a small cost change with the gradient cosine at the solution
/// above this is counted as *stalled*, not converged: at a true minimum the residual is
/// orthogonal to every column (cosines of 10⁻⁹–10⁻⁶ on the shipped scenarios), while an
/// over-damped solver (e.g. Nielsen with τ = 1000 on an unscaled Jacobian) stops on tiny steps
/// with cosines of 10⁻³–1.
pub const STALL_GRADIENT_COSINE: f64 = 1e-4;

/// The identification outcome of one trial, in brief.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FitSummary {
    /// LM iterations (accepted and rejected).
    pub iterations: usize,
    /// Why LM stopped.
    pub stop: String,
    /// Converged (a stop reason other than the caps).
    pub converged: bool,
    /// RMS of the 3-D residuals at the solution, mm.
    pub rms_mm: f64,
    /// Free parameters.
    pub free: usize,
    /// Numerical rank of the free parameters at the solution (size of the identifiable set).
    pub rank: Option<usize>,
    /// max_k |J_kᵀe| / (‖J_k‖‖e‖) at the solution (see [`identify::Fit::gradient_cosine`]).
    pub gradient_cosine: f64,
}

impl FitSummary {
    /// `converged`, `stalled` (a converged stop reason but a gradient cosine above
    /// [`STALL_GRADIENT_COSINE`]) or `cap` (iteration or rejection cap).
    pub fn convergence(&self) -> &'static str {
        if !self.converged {
            "cap"
        } else if self.gradient_cosine > STALL_GRADIENT_COSINE {
            "stalled"
        } else {
            "converged"
        }
    }
}

/// Everything one trial produces.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TrialResult {
    /// Trial index.
    pub trial: u64,
    /// Per validation pose: measured − nominal target before compensation, mm.
    pub before_mm: Vec<[f64; 3]>,
    /// Per validation pose: measured − nominal target after compensation, mm (poses whose
    /// compensation failed are left out and counted).
    pub after_mm: Vec<[f64; 3]>,
    /// Table 4 statistics.
    pub table4: Table4,
    /// Poses the tracker could not measure (skipped).
    pub unmeasurable: usize,
    /// Validation targets the identified model could not reach within limits.
    pub compensation_failures: usize,
    /// ISO 9283 targets (P1–P5) the identified model could not reach within limits: those
    /// points are commanded uncompensated in the "after" cycles, and counted here.
    pub iso_compensation_failures: usize,
    /// Share of candidate poses the sampler rejected (identification and validation sets):
    /// wrist, floor, tracker window, range or condition constraints.
    pub pose_rejection_rate: f64,
    /// Identification summary.
    pub fit: FitSummary,
    /// Mean distance between the identified model's and the true geometry's points on the
    /// validation poses, mm (how well the geometry itself was recovered).
    pub predicted_error_mm: f64,
    /// Recovery per minimal-set parameter (when enabled and computable).
    pub recovery: Vec<ParameterRecovery>,
    /// Observability indices O1–O5 of the identification poses (`docs/model.md` §6; see
    /// [`Observability`]).
    pub observability: Option<Observability>,
    /// ISO 9283 results (when enabled).
    pub iso: Option<IsoReport>,
}

fn to_arr(v: Vector3<f64>) -> [f64; 3] {
    [v.x, v.y, v.z]
}

/// Re-expresses a robot's geometry in the minimal parameter set: the minimal-set model that
/// reproduces `model`'s points on `poses` (noise-free fit from the nominal model).
fn reexpress(
    nominal: &Robot,
    model: &Robot,
    poses_rad: &[f64],
    free: &[usize],
    lm: &identify::LmOptions,
) -> Result<Vec<f64>, identify::IdentifyError> {
    let points = model.points(poses_rad);
    let problem = Problem::new(nominal, poses_rad, &points, free.to_vec())?;
    Ok(identify::solve(&problem, lm)?.params)
}

/// Runs trial `trial` of the campaign.
pub fn run_trial(ctx: &Context, trial: u64) -> Result<TrialResult, CampaignError> {
    let nominal = ctx.nominal();
    let scenario = &ctx.loaded.scenario;
    let n = nominal.n_joints();
    let sim = |source| CampaignError::Sim { trial, source };
    let ident = |source| CampaignError::Identify { trial, source };
    let eval = |source| CampaignError::Evaluate { trial, source };
    let mut world: World = ctx.setup.world(trial).map_err(sim)?;

    // Identification measurements.
    let mut unmeasurable = 0;
    let mut id_poses = Vec::with_capacity(world.identification_poses_rad().len());
    let mut id_points = Vec::with_capacity(id_poses.capacity() / n.max(1));
    let all_id: Vec<f64> = match &ctx.design {
        None => world.identification_poses_rad().to_vec(),
        Some((criterion, count, scale)) => {
            // Designed on the nominal model from the sampled pool, before any measurement.
            let pool = world.identification_poses_rad();
            let des = |source| CampaignError::Design { trial, source };
            let measure = scenario.measurement.kind;
            let model = if measure == design::Measure::Point {
                design::InfoModel::new(nominal, pool, None, Some(&ctx.minimal_free), scale)
            } else {
                // The design of the frame rows needs the targets in the robot.
                let mut robot = nominal.clone();
                if measure == design::Measure::Targets {
                    let names = scenario.measurement.target_names();
                    let offsets = scenario.measurement.offsets_mm();
                    robot.set_targets(Some(
                        names
                            .into_iter()
                            .zip(offsets.iter().map(|o| nominal.tool_mm() + o))
                            .collect(),
                    ));
                }
                design::InfoModel::with_measure(&robot, pool, None, None, scale, measure)
            }
            .map_err(des)?;
            let chosen = design::select(&model, &design::DesignOptions::new(*criterion, *count))
                .map_err(des)?;
            chosen
                .selected
                .iter()
                .flat_map(|&i| pool[i * n..(i + 1) * n].iter().copied())
                .collect()
        }
    };
    // A point fit (the paper's measurement), or a frame / multi-target fit.
    let point_fit: Option<Fit>;
    let frame_id = if scenario.measurement.kind == design::Measure::Point {
        for q in all_id.chunks_exact(n) {
            match world.measure(q) {
                Ok(p) => {
                    id_poses.extend_from_slice(q);
                    id_points.push(p);
                }
                Err(_) => unmeasurable += 1,
            }
        }
        let free = scenario
            .identification
            .params
            .resolve(
                &ctx.id_nominal,
                &id_poses,
                None,
                &scenario.identification.identifiability,
            )
            .map_err(ident)?;
        let problem = Problem::new(&ctx.id_nominal, &id_poses, &id_points, free).map_err(ident)?;
        point_fit = Some(identify::identify(&problem, &ctx.id_options).map_err(ident)?);
        None
    } else {
        let f = crate::trial_frames::identify_frames(ctx, &mut world, &all_id, trial)?;
        unmeasurable += f.unmeasurable;
        point_fit = None;
        Some(f)
    };
    let fit_robot: &Robot = match (&point_fit, &frame_id) {
        (Some(fit), _) => &fit.robot,
        (None, Some(f)) => &f.robot,
        (None, None) => unreachable!("one of the two fits ran"),
    };

    // Validation before compensation, then after.
    let val: Vec<f64> = world.validation_poses_rad().to_vec();
    // Sines and cosines of the validation poses, once for the four models evaluated there.
    let val_trig = PoseTrig::for_robot(nominal, &val);
    let mut before = Vec::with_capacity(val.len() / n);
    let mut measured_val = Vec::with_capacity(val.len() / n);
    for (j, q) in val.chunks_exact(n).enumerate() {
        match world.measure(q) {
            Ok(p) => {
                before.push(to_arr(p - nominal.point_trig(val_trig.pose(j))));
                measured_val.push((j, q, p));
            }
            Err(_) => unmeasurable += 1,
        }
    }
    let ik = scenario.compensation.ik_options();
    let mut after = Vec::with_capacity(before.len());
    let mut compensation_failures = 0;
    let mut q_c = vec![0.0; n];
    for &(j, q, p_meas) in &measured_val {
        if scenario.compensation.enabled {
            let target = identify::compensation_target_trig(nominal, fit_robot, val_trig.pose(j));
            q_c.copy_from_slice(q);
            if fit_robot.solve_ik(&target, &mut q_c, &ik).is_err() {
                compensation_failures += 1;
                continue;
            }
            match world.measure(&q_c) {
                Ok(p) => after.push(to_arr(p - target.position_mm)),
                Err(_) => unmeasurable += 1,
            }
        } else {
            after.push(to_arr(p_meas - fit_robot.point_trig(val_trig.pose(j))));
        }
    }
    let table4 = Table4::from_errors(&before, &after).map_err(eval)?;

    // Geometry recovery: identified vs true geometry on the validation poses.
    let truth_robot = world.effective_true_robot().clone();
    let predicted_error_mm = (0..val_trig.n_poses())
        .map(|j| {
            let sc = val_trig.pose(j);
            (fit_robot.point_trig(sc) - truth_robot.point_trig(sc)).norm()
        })
        .sum::<f64>()
        / (val.len() / n).max(1) as f64;

    let observability = match &frame_id {
        None => observability(nominal, &id_poses, &id_points, &ctx.minimal_free),
        Some(f) => f.observability,
    };

    let recovery = if let (true, Some(fit)) = (scenario.recovery.enabled, &point_fit) {
        // An extended identification is scored against the truth in its own family.
        let truth = match ctx.id_nominal.extended() {
            Some(model) => {
                let names: Vec<String> = model.kinds().iter().map(|k| k.name()).collect();
                world
                    .extended_truth(&names)
                    .map_err(|source| CampaignError::ExtendedTruth { trial, source })?
            }
            None => truth_robot.clone(),
        };
        recovery(ctx, fit, &truth, &id_poses, &id_points).map_err(ident)?
    } else {
        // Frame fits: the tool-frame recovery is tested in identify (z-scores of the tool
        // frame); the minimal-set re-expression is a point construction.
        Vec::new()
    };

    let pose_rejection_rate = world.sampling_report().rejection_rate();
    let (iso, iso_compensation_failures) = match &ctx.iso {
        Some(plan) => {
            let (report, failures) = iso_trial(plan, fit_robot, &mut world, scenario, trial)?;
            (Some(report), failures)
        }
        None => (None, 0),
    };

    Ok(TrialResult {
        trial,
        before_mm: before,
        after_mm: after,
        table4,
        unmeasurable,
        compensation_failures,
        iso_compensation_failures,
        pose_rejection_rate,
        fit: match (&point_fit, frame_id) {
            (Some(fit), _) => FitSummary {
                iterations: fit.iterations,
                stop: fit.stop.as_str().to_string(),
                converged: fit.stop.converged(),
                rms_mm: fit.rms_mm,
                free: fit.free.len(),
                rank: fit.covariance.as_ref().map(|c| c.parameters.len()),
                gradient_cosine: fit.gradient_cosine,
            },
            (None, Some(f)) => f.summary,
            (None, None) => unreachable!("one of the two fits ran"),
        },
        predicted_error_mm,
        recovery,
        observability,
        iso,
    })
}

/// Observability indices O1–O5 (`docs/model.md` §6) of a trial's identification poses: on the
/// singular values of the Jacobian of the minimal identifiable set at the nominal model, columns
/// scaled to unit Euclidean norm — the square roots of the eigenvalues of the scaled Gram
/// matrix `D·JᵀJ·D`, `D = diag(1/‖J_k‖)` (relative accuracy ≈ ε·cond², ample for the
/// condition numbers of a full-rank set). `None` if the set is degenerate on these poses.
fn observability(
    nominal: &Robot,
    poses_rad: &[f64],
    points_mm: &[Vector3<f64>],
    free: &[usize],
) -> Option<Observability> {
    let problem = Problem::new(nominal, poses_rad, points_mm, free.to_vec()).ok()?;
    let (mut a, mut g) = (DMatrix::zeros(0, 0), DVector::zeros(0));
    problem.normal_equations(&mut a, &mut g);
    let p = a.nrows();
    let d: Vec<f64> = (0..p).map(|k| a[(k, k)].sqrt()).collect();
    if d.iter().any(|&x| !(x.is_finite() && x > 0.0)) {
        return None;
    }
    let scaled = DMatrix::from_fn(p, p, |i, j| a[(i, j)] / (d[i] * d[j]));
    let mut sv: Vec<f64> = scaled
        .symmetric_eigenvalues()
        .iter()
        .map(|&l| l.max(0.0).sqrt())
        .collect();
    sv.sort_by(|x, y| y.total_cmp(x));
    Observability::from_singular_values(&sv, problem.n_poses())
}

/// Scores the estimate against the truth on the minimal set of the identified model
/// ([`Context::recovery_free`]): both are re-expressed in it (a noise-free fit of the
/// minimal set to each model's points on the identification poses), and the standard
/// errors come from the covariance at the re-expressed estimate with the trial's
/// measurements. For an extended identification `truth` is [`World::extended_truth`].
fn recovery(
    ctx: &Context,
    fit: &Fit,
    truth: &Robot,
    poses: &[f64],
    measured: &[Vector3<f64>],
) -> Result<Vec<ParameterRecovery>, identify::IdentifyError> {
    let nominal = &ctx.id_nominal;
    let free = &ctx.recovery_free;
    let lm = &ctx.id_options.lm;
    let truth_min = reexpress(nominal, truth, poses, free, lm)?;
    let layout = nominal.layout();
    // A fit from the nominal model that solved exactly the minimal set (its other free
    // parameters held, or none) is its own re-expression, with its own covariance.
    let solved: Vec<usize> = fit
        .free
        .iter()
        .filter(|n| !fit.held.contains(n))
        .filter_map(|n| layout.index_of(n).ok())
        .collect();
    let registered = fit.registration.as_ref().is_some_and(|r| r.applied);
    let (est_min, cov) = if !registered && solved == *free {
        (fit.params.clone(), fit.covariance.clone())
    } else {
        // The estimate's re-expression, then its covariance with the trial's measurements
        // at that solution (reusing the normal matrix the solver assembled there).
        let est_points = fit.robot.points(poses);
        let est_problem = Problem::new(nominal, poses, &est_points, free.to_vec())?;
        let est = identify::solve(&est_problem, lm)?;
        let cov = identify::covariance_at_solution(
            &est_problem,
            &est,
            measured,
            &ctx.id_options.identifiability,
            ctx.id_options.correlation_flag,
        )?;
        (est.params, cov)
    };
    let Some(cov) = cov else {
        return Ok(Vec::new());
    };
    Ok(cov
        .indices
        .iter()
        .zip(&cov.std_errors)
        .map(|(&k, &se)| {
            let info = layout.get(k);
            let t = info.to_display(truth_min[k]);
            let e = info.to_display(est_min[k]);
            ParameterRecovery {
                name: info.name.clone(),
                unit: info.unit.as_str().to_string(),
                truth: t,
                estimate: e,
                error: e - t,
                std_error: se,
                z: if se > 0.0 { (e - t) / se } else { f64::NAN },
            }
        })
        .collect())
}

/// The ISO 9283 position test of one trial; also returns how many of P1–P5 the identified
/// model could not reach (commanded uncompensated instead, and counted).
fn iso_trial(
    plan: &IsoPlan,
    identified: &Robot,
    world: &mut World,
    scenario: &crate::scenario::Scenario,
    trial: u64,
) -> Result<(IsoReport, usize), CampaignError> {
    let ik = scenario.compensation.ik_options();
    // Compensated joints of P1…P5; a target the identified model cannot reach keeps its
    // commanded joints and is counted.
    let mut failures = 0;
    let mut q_after: Vec<Vec<f64>> = Vec::with_capacity(5);
    for (t, q) in plan.targets.iter().zip(&plan.q_cmd_rad) {
        let mut qc = q.clone();
        let target = IkTarget {
            point_in_flange_mm: identified.tool_mm(),
            ..*t
        };
        if scenario.compensation.enabled && identified.solve_ik(&target, &mut qc, &ik).is_err() {
            failures += 1;
            qc.clone_from(q);
        }
        q_after.push(qc);
    }
    let cycles = scenario.iso.cycles;
    let mut before: [Vec<[f64; 3]>; 5] = Default::default();
    let mut after: [Vec<[f64; 3]>; 5] = Default::default();
    for (joints, out) in [
        (&plan.q_cmd_rad[..], &mut before),
        (&q_after[..], &mut after),
    ] {
        for _ in 0..cycles {
            for &i in &evaluate::ISO_CYCLE_ORDER {
                let p =
                    world
                        .measure(&joints[i])
                        .map_err(|source| CampaignError::IsoMeasurement {
                            trial,
                            point: i + 1,
                            source,
                        })?;
                out[i].push(to_arr(p));
            }
        }
    }
    let report = IsoReport::from_attained(
        plan.cube,
        [&before[0], &before[1], &before[2], &before[3], &before[4]],
        [&after[0], &after[1], &after[2], &after[3], &after[4]],
    )
    .map_err(|source| CampaignError::Evaluate { trial, source })?;
    Ok((report, failures))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The trial's O1–O5 (eigenvalues of the scaled Gram matrix) agree with the
    /// identifiability report's (SVD of the scaled Jacobian) on the same minimal set.
    #[test]
    fn observability_matches_the_identifiability_report() {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../../scenarios/robots/kr1000-titan.json");
        let text = std::fs::read_to_string(&path).unwrap();
        let spec = kinematics::RobotSpec::from_json_str(&text, "kr1000").unwrap();
        let robot = Robot::from_spec(&spec).unwrap();
        let mut rng = <rand::rngs::ChaCha8Rng as rand::SeedableRng>::seed_from_u64(3);
        let poses = kinematics::PoseSampler::default()
            .sample(&robot, 50, &mut rng)
            .unwrap()
            .rad;
        let points = robot.points(&poses);
        let opts = identify::IdentifiabilityOptions::default();
        let free = ParamSet::Minimal
            .resolve(&robot, &poses, None, &opts)
            .unwrap();
        let ours = observability(&robot, &poses, &points, &free).unwrap();
        let report = identify::analyze(&robot, &poses, None, &free, &opts).unwrap();
        assert_eq!(report.rank, free.len());
        let theirs = report.observability.unwrap();
        for (a, b) in [
            (ours.o1, theirs.o1),
            (ours.o2, theirs.o2),
            (ours.o3, theirs.o3),
            (ours.o4, theirs.o4),
            (ours.o5, theirs.o5),
        ] {
            assert!((a - b).abs() <= 1e-9 * b.abs(), "{ours:?} vs {theirs:?}");
        }
    }

    /// A designed selection measures N of the candidates (the first N of which are the
    /// random set), designed on the nominal model; on the exact-model scenario its geometry
    /// error beats the random set's in the same trials; bad selections are named.
    #[test]
    fn designed_identification_poses_come_from_the_candidates() {
        use crate::scenario::Scenario;
        let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenarios");
        let text = std::fs::read_to_string(dir.join("noise-floor.json")).unwrap();
        let load = |method: &str, candidates: usize, n: usize| {
            let mut v: serde_json::Value = serde_json::from_str(&text).unwrap();
            v["pose_selection"] = serde_json::json!({ "method": method, "candidates": candidates });
            v["poses"]["identification"] = n.into();
            v["recovery"] = serde_json::json!({ "enabled": false });
            Scenario::from_value(v, "t").and_then(|s| s.load(&dir, "t"))
        };
        let random = Context::new(load("random", 1000, 15).unwrap()).unwrap();
        let designed = Context::new(load("d", 200, 15).unwrap()).unwrap();
        assert!(random.design.is_none());
        assert!(designed.design.is_some());
        let (mut r_err, mut d_err) = (0.0, 0.0);
        for trial in 0..6 {
            let r = run_trial(&random, trial).unwrap();
            let d = run_trial(&designed, trial).unwrap();
            assert_eq!(r.fit.free, d.fit.free);
            r_err += r.predicted_error_mm;
            d_err += d.predicted_error_mm;
        }
        assert!(d_err < r_err, "designed {d_err} vs random {r_err}");
        // The default is not written out (existing summaries keep their bytes).
        let json = serde_json::to_string(&random.loaded.scenario).unwrap();
        assert!(!json.contains("pose_selection"));
        let e = load("d", 10, 15).unwrap_err().to_string();
        assert!(e.contains("pose_selection.candidates"), "{e}");
        let e = load("x", 100, 15).unwrap_err().to_string();
        assert!(e.contains("pose_selection.method"), "{e}");
    }
}
