//! The identification of a trial whose scenario measures one point per pose (the paper's
//! measurement): the virtual robot measures the identification poses, the free set is
//! resolved on them and LM identifies the robot from the nominal model; the observability
//! of the poses and the recovery of the minimal set are scored on the same points.

use std::borrow::Cow;

use evaluate::ParameterRecovery;
use identify::{Covariance, Fit, Observability, Problem};
use kinematics::Robot;
use kinematics::kept::{Kept, with_kept};
use nalgebra::{DMatrix, DVector, Vector3};
use virtual_robot::World;

use super::context::Context;
use super::result::FitSummary;
use crate::error::CampaignError;

/// What the point identification of a trial gives the rest of the trial.
pub(super) struct PointIdentification {
    /// The fit.
    pub fit: Fit,
    /// The identification poses measured, flat, rad.
    pub poses_rad: Vec<f64>,
    /// Their measured points, mm.
    pub points_mm: Vec<Vector3<f64>>,
    /// Identification poses that could not be measured.
    pub unmeasurable: usize,
    /// The free set the fit solved (parameter indices).
    pub free: Vec<usize>,
}

/// Measures `poses_rad` (flat) one point per pose and identifies; the measured poses and
/// points and the free set are written into `(id_poses, id_points, free)` (cleared first),
/// which the result holds.
pub(super) fn identify_points(
    ctx: &Context,
    world: &mut World,
    poses_rad: &[f64],
    (mut id_poses, mut id_points, mut free): (Vec<f64>, Vec<Vector3<f64>>, Vec<usize>),
    trial: u64,
) -> Result<PointIdentification, CampaignError> {
    let scenario = &ctx.loaded.scenario;
    let n = ctx.nominal().n_joints();
    let ident = |source| CampaignError::Identify { trial, source };
    let mut unmeasurable = 0;
    id_poses.clear();
    id_poses.reserve(poses_rad.len());
    id_points.clear();
    id_points.reserve(poses_rad.len() / n.max(1));
    for q in poses_rad.chunks_exact(n) {
        match world.measure(q) {
            Ok(p) => {
                id_poses.extend_from_slice(q);
                id_points.push(p);
            }
            Err(_) => unmeasurable += 1,
        }
    }
    scenario
        .identification
        .params
        .resolve_into(
            &ctx.id_nominal,
            &id_poses,
            None,
            &scenario.identification.identifiability,
            &mut free,
        )
        .map_err(ident)?;
    let problem =
        Problem::from_slices(&ctx.id_nominal, &id_poses, &id_points, &free).map_err(ident)?;
    let fit = identify::identify(&problem, &ctx.id_options).map_err(ident)?;
    drop(problem);
    Ok(PointIdentification {
        fit,
        poses_rad: id_poses,
        points_mm: id_points,
        unmeasurable,
        free,
    })
}

impl PointIdentification {
    /// The fit's figures.
    pub fn summary(&self) -> FitSummary {
        let fit = &self.fit;
        FitSummary {
            iterations: fit.iterations,
            stop: fit.stop,
            converged: fit.stop.converged(),
            rms_mm: fit.rms_mm,
            free: fit.free.len(),
            rank: fit.covariance.as_ref().map(|c| c.parameters.len()),
            gradient_cosine: fit.gradient_cosine,
        }
    }

    /// O1–O5 of the measured identification poses on the minimal set at the nominal model.
    pub fn observability(&self, ctx: &Context) -> Option<Observability> {
        observability(
            ctx.nominal(),
            &self.poses_rad,
            &self.points_mm,
            &ctx.minimal_free,
        )
    }

    /// Recovery per minimal-set parameter against `truth` (see [`recovery`]).
    pub fn recovery(
        &self,
        ctx: &Context,
        truth: &Robot,
    ) -> Result<Vec<ParameterRecovery>, identify::IdentifyError> {
        recovery(ctx, &self.fit, truth, &self.poses_rad, &self.points_mm)
    }
}

/// Re-expresses a robot's geometry in the minimal parameter set: the minimal-set model that
/// reproduces `model`'s points on `poses` (noise-free fit from the nominal model), and, with
/// `measured`, its covariance with those measurements at that solution (reusing the normal
/// matrix the solver assembled there).
fn reexpress(
    ctx: &Context,
    model: &Robot,
    poses_rad: &[f64],
    measured: Option<&[Vector3<f64>]>,
) -> Result<(identify::LmSolution, Option<Covariance>), identify::IdentifyError> {
    // The model's points in the thread's buffer of the last trial.
    with_kept(&POINTS, |points| {
        points.clear();
        points.extend(
            poses_rad
                .chunks_exact(model.n_joints())
                .map(|q| model.point(q)),
        );
        let result = solve_on_points(ctx, poses_rad, points, measured);
        // (A large pose set's buffer is not kept: `kinematics::KEPT_BUFFER_MAX_BYTES`.)
        if !kinematics::keep_buffer::<Vector3<f64>>(points.capacity()) {
            *points = Vec::new();
        }
        result
    })
}

/// [`reexpress`]'s solve (and covariance, with `measured`) on the model's `points`.
fn solve_on_points(
    ctx: &Context,
    poses_rad: &[f64],
    points: &[Vector3<f64>],
    measured: Option<&[Vector3<f64>]>,
) -> Result<(identify::LmSolution, Option<Covariance>), identify::IdentifyError> {
    let problem = Problem::from_slices(&ctx.id_nominal, poses_rad, points, &ctx.recovery_free)?;
    let sol = identify::solve(&problem, &ctx.id_options.lm)?;
    let cov = match measured {
        Some(measured) => identify::covariance_at_solution(
            &problem,
            &sol,
            measured,
            &ctx.id_options.identifiability,
            ctx.id_options.correlation_flag,
        )?,
        None => None,
    };
    Ok((sol, cov))
}

thread_local! {
    /// The points [`reexpress`] fits, kept by the thread for its next trial.
    static POINTS: Kept<Vec<Vector3<f64>>> = const { Kept::new() };
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
    let problem = Problem::from_slices(nominal, poses_rad, points_mm, free).ok()?;
    // The normal equations, the scaled matrix and the singular values in this thread's
    // buffers of the last trial (the same size every trial of a campaign); the eigenvalues
    // on the stack for a minimal set's size (`stack_linalg::EIGEN_SIZES`).
    thread_local! {
        static BUFFERS: Kept<ObservabilityBuffers> = const { Kept::new() };
    }
    let compute = |bufs: &mut ObservabilityBuffers| {
        let ObservabilityBuffers {
            a,
            g,
            d,
            scaled,
            sv,
        } = bufs;
        problem.normal_equations(a, g);
        let p = a.nrows();
        d.clear();
        d.extend((0..p).map(|k| a[(k, k)].sqrt()));
        if d.iter().any(|&dk| !(dk.is_finite() && dk > 0.0)) {
            return None;
        }
        if scaled.shape() != (p, p) {
            *scaled = DMatrix::zeros(p, p);
        }
        for j in 0..p {
            for i in 0..p {
                scaled[(i, j)] = a[(i, j)] / (d[i] * d[j]);
            }
        }
        stack_linalg::symmetric_eigenvalues_into(scaled, sv);
        for l in sv.iter_mut() {
            *l = l.max(0.0).sqrt();
        }
        sv.sort_by(|x, y| y.total_cmp(x));
        Observability::from_singular_values(sv, problem.n_poses())
    };
    with_kept(&BUFFERS, compute)
}

/// [`observability`]'s buffers, kept by a thread between trials.
#[derive(Default)]
struct ObservabilityBuffers {
    a: DMatrix<f64>,
    g: DVector<f64>,
    /// √diag(a): the column norms of the Jacobian.
    d: Vec<f64>,
    scaled: DMatrix<f64>,
    sv: Vec<f64>,
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
    let free = &ctx.recovery_free;
    let (truth_min, _) = reexpress(ctx, truth, poses, None)?;
    let layout = ctx.id_nominal.layout();
    // A fit from the nominal model that solved exactly the minimal set (its other free
    // parameters held, or none) is its own re-expression, with its own covariance.
    let own = fit.registration.as_ref().is_none_or(|r| !r.applied)
        && fit
            .free
            .iter()
            .filter(|n| !fit.held.contains(n))
            .filter_map(|n| layout.index_of(n).ok())
            .eq(free.iter().copied());
    // Otherwise the estimate's re-expression, with its covariance.
    let reexpressed = if own {
        None
    } else {
        Some(reexpress(ctx, &fit.robot, poses, Some(measured))?)
    };
    let (est_min, cov) = match &reexpressed {
        None => (&fit.params, fit.covariance.as_ref()),
        Some((est, cov)) => (&est.params, cov.as_ref()),
    };
    let rows = match cov {
        None => Vec::new(),
        Some(cov) => {
            let mut rows = super::result::recovery_rows(cov.indices.len());
            rows.extend(cov.indices.iter().zip(&cov.std_errors).map(|(&k, &se)| {
                let info = layout.get(k);
                let t = info.to_display(truth_min.params[k]);
                let e = info.to_display(est_min[k]);
                ParameterRecovery {
                    name: Cow::Borrowed(info.name.as_str()),
                    unit: Cow::Borrowed(info.unit.as_str()),
                    truth: t,
                    estimate: e,
                    error: e - t,
                    std_error: se,
                    z: if se > 0.0 { (e - t) / se } else { f64::NAN },
                }
            }));
            rows
        }
    };
    // The solutions' buffers back to the thread for the next trial.
    truth_min.recycle();
    if let Some((est, cov)) = reexpressed {
        est.recycle();
        if let Some(cov) = cov {
            cov.recycle();
        }
    }
    Ok(rows)
}

#[cfg(test)]
mod tests {
    use super::*;
    use identify::ParamSet;

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
}
