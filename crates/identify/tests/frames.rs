//! 6-DoF and multi-target identification (`identify::frames`): the analytic Jacobian of the
//! orientation and multi-target rows against central differences, and a known-truth
//! simulation recovering the tool frame within its standard errors.

use identify::frames::{
    FrameData, FrameFree, FrameModel, FrameRow, apply_step, closed_form_tool, fit_frames,
    residual_jacobian, select_free,
};
use identify::{Damping, IdentifyError, LmOptions, Redundant, StopReason};
use kinematics::rotation::{exp_so3, log_so3};
use nalgebra::{DMatrix, DVector, Vector3};
use rand::SeedableRng;
use rand::rngs::ChaCha8Rng;
use rand_distr::{Distribution, Normal};

use crate::common::{TOOL, kr1000, perturbed, poses};

/// Three targets at 120° on a 100 mm circle about the tool point, in the tool frame.
fn target_offsets() -> [Vector3<f64>; 3] {
    let c = |deg: f64| {
        let a = deg.to_radians();
        Vector3::new(100.0 * a.cos(), 100.0 * a.sin(), 0.0)
    };
    [c(0.0), c(120.0), c(240.0)]
}

/// Data measured on `truth` at `poses`: one frame per pose (`k = 0`) or `k` targets per
/// pose, with Gaussian noise σ_mm per axis and σ_deg about each axis
/// (`R_meas = exp([δ]×)·R_true`).
fn measure(
    truth: &FrameModel,
    poses_rad: &[f64],
    orientation: bool,
    n_targets: usize,
    (sigma_mm, sigma_deg): (f64, f64),
    seed: u64,
) -> FrameData {
    let n = truth.robot.n_joints();
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let np = Normal::new(0.0, sigma_mm).unwrap();
    let nr = Normal::new(0.0, sigma_deg.to_radians()).unwrap();
    let mut rows = Vec::new();
    for (j, q) in poses_rad.chunks_exact(n).enumerate() {
        let f = truth.robot.flange(q);
        for (k, t) in truth.targets_mm.iter().enumerate() {
            let mut noise = || {
                Vector3::new(
                    np.sample(&mut rng),
                    np.sample(&mut rng),
                    np.sample(&mut rng),
                )
            };
            let p = f.rot * t + f.pos_mm + noise();
            let rotation = (orientation && k == 0).then(|| {
                let d = Vector3::new(
                    nr.sample(&mut rng),
                    nr.sample(&mut rng),
                    nr.sample(&mut rng),
                );
                exp_so3(&d) * f.rot * truth.tool_rotation
            });
            rows.push(FrameRow {
                pose: j,
                target: k,
                point_mm: p,
                rotation,
                w_pos: [1.0 / sigma_mm; 3],
                w_rot: 1.0 / sigma_deg.to_radians(),
            });
        }
    }
    let target_names = if n_targets == 0 {
        vec![String::new()]
    } else {
        (0..n_targets).map(|k| format!("T{k}")).collect()
    };
    FrameData {
        poses_rad: poses_rad.to_vec(),
        n_joints: n,
        target_names,
        rows,
    }
}

fn truth_model(n_targets: usize, seed: u64) -> FrameModel {
    let nominal = kr1000(TOOL);
    let all: Vec<usize> = (0..nominal.n_params()).collect();
    let robot = perturbed(&nominal, &all, seed);
    let tool_rotation = exp_so3(&Vector3::new(0.3, -0.2, 1.1));
    let targets_mm = if n_targets == 0 {
        vec![Vector3::from(TOOL)]
    } else {
        target_offsets()
            .iter()
            .take(n_targets)
            .map(|o| Vector3::from(TOOL) + tool_rotation * o)
            .collect()
    };
    FrameModel {
        robot,
        tool_rotation,
        targets_mm,
    }
}

/// Central differences of the weighted residual along every unknown (through
/// [`apply_step`], so the tool orientation moves as `R·exp([δ]×)`).
fn numeric_jacobian(model: &FrameModel, data: &FrameData, free: &FrameFree) -> DMatrix<f64> {
    let p = free.len();
    let n_robot = free.robot.len();
    let mut j = DMatrix::zeros(data.n_equations(), p);
    for c in 0..p {
        let unit = if c < n_robot {
            model.robot.layout().get(free.robot[c]).unit
        } else if free.rotation && c < n_robot + 3 {
            kinematics::Unit::Deg
        } else {
            kinematics::Unit::Mm
        };
        let h = if unit == kinematics::Unit::Mm {
            1e-3
        } else {
            1e-6
        };
        let mut s = DVector::zeros(p);
        s[c] = h;
        let ep = residual_jacobian(&apply_step(model, free, &s).unwrap(), data, free, None);
        let em = residual_jacobian(&apply_step(model, free, &(-s)).unwrap(), data, free, None);
        j.set_column(c, &((ep - em) / (2.0 * h)));
    }
    j
}

fn check_jacobian(model: &FrameModel, data: &FrameData) {
    let layout = model.robot.layout();
    let robot: Vec<usize> = (0..model.robot.n_params())
        .filter(|&k| !layout.get(k).name.starts_with("tool"))
        .collect();
    let free = FrameFree {
        robot,
        rotation: data.has_orientation(),
        n_targets: data.target_names.len(),
    };
    let mut j = DMatrix::zeros(0, 0);
    residual_jacobian(model, data, &free, Some(&mut j));
    let num = numeric_jacobian(model, data, &free);
    let names = free.names(&model.robot, &data.target_names);
    for c in 0..free.len() {
        // Differences are exact to ~1e-7 of the column's largest entry (truncation h², and
        // rounding of residuals up to ~1e5 weighted units over 2h).
        let scale = 1.0 + j.column(c).amax();
        for r in 0..j.nrows() {
            let (a, b) = (j[(r, c)], num[(r, c)]);
            assert!(
                (a - b).abs() <= 1e-6 * scale,
                "row {r}, {}: analytic {a}, numeric {b}",
                names[c]
            );
        }
    }
}

#[test]
fn orientation_rows_jacobian_matches_central_differences() {
    let truth = truth_model(0, 3);
    let q = poses(&truth.robot, 6, 11);
    let data = measure(&truth, &q, true, 0, (0.02, 0.005), 1);
    // Evaluate far from the truth (residual rotations of ~10°) so that J_l⁻¹ is not I.
    let mut model = truth.clone();
    model.tool_rotation = truth.tool_rotation * exp_so3(&Vector3::new(0.1, -0.12, 0.08));
    model.targets_mm[0] += Vector3::new(3.0, -2.0, 1.0);
    let phi = log_so3(&(model.tool_rotation.transpose() * truth.tool_rotation));
    assert!(phi.norm() > 0.15);
    check_jacobian(&model, &data);
    // Unit weights as well (radian residuals).
    let mut unit = data.clone();
    for r in &mut unit.rows {
        r.w_pos = [1.0; 3];
        r.w_rot = 1.0;
    }
    check_jacobian(&model, &unit);
}

#[test]
fn multi_target_rows_jacobian_matches_central_differences() {
    let truth = truth_model(3, 4);
    let q = poses(&truth.robot, 5, 12);
    let data = measure(&truth, &q, false, 3, (0.02, 0.005), 2);
    assert_eq!(data.n_equations(), 5 * 3 * 3);
    let mut model = truth.clone();
    for t in &mut model.targets_mm {
        *t += Vector3::new(1.0, 2.0, -1.5);
    }
    check_jacobian(&model, &data);
    // Targets and the frame together: 3 targets, orientation on target 0 (12 rows a pose).
    let both = measure(&truth, &q, true, 3, (0.02, 0.005), 3);
    assert_eq!(both.n_equations(), 5 * 12);
    check_jacobian(&model, &both);
}

/// The tool frame recovered within its standard errors: over many noisy trials, the
/// z-scores (estimate − truth)/standard error of the tool orientation (δ about the tool axes)
/// and the tool point have mean 0 and standard deviation 1 (± 0.15).
#[test]
fn known_truth_tool_frame_z_scores_have_unit_spread() {
    let nominal = kr1000(TOOL);
    let q = poses(&nominal, 25, 13);
    // The truth differs from the nominal in the identifiable robot parameters only (those a
    // 6-DoF fit keeps beside the tool frame: θ6, for one, is confounded with the tool's
    // rotation about the flange axis), and in the tool frame.
    let mut truth = truth_model(0, 5);
    let probe = measure(&truth, &q, true, 0, (0.02, 0.005), 1);
    let all: Vec<usize> = (0..nominal.n_params()).collect();
    let (kept, dropped) = select_free(
        &closed_form_tool(&nominal, &probe, None, &[None]),
        &probe,
        &all,
    )
    .unwrap();
    assert!(dropped.contains(&nominal.layout().index_of("theta6").unwrap()));
    truth.robot = perturbed(&nominal, &kept.robot, 5);
    let noise = (0.02, 0.005); // mm, deg (tracker and T-Mac order of magnitude)
    let mut z = Vec::new();
    let trials = 120;
    for trial in 0..trials {
        let data = measure(&truth, &q, true, 0, noise, 1000 + trial);
        // Start: the nominal robot and the closed-form tool frame from the data.
        let start = closed_form_tool(&nominal, &data, None, &[None]);
        let all: Vec<usize> = (0..nominal.n_params()).collect();
        let (free, _) = select_free(&start, &data, &all).unwrap();
        let fit = fit_frames(&start, &data, &free, &LmOptions::default()).unwrap();
        assert!(
            fit.stop.converged(),
            "trial {trial}: {} after {} iterations, cost {:?}",
            fit.stop,
            fit.iterations,
            fit.cost
        );
        assert!((fit.sigma_hat - 1.0).abs() < 0.25, "σ̂ = {}", fit.sigma_hat);
        let nr = free.robot.len();
        // δ_true relative to the start orientation, degrees.
        let d_true = log_so3(&(start.tool_rotation.transpose() * truth.tool_rotation));
        for c in 0..3 {
            let e = &fit.estimates[nr + c];
            z.push((e.value - d_true[c].to_degrees()) / e.std_error);
            let t = &fit.estimates[nr + 3 + c];
            z.push((t.value - truth.targets_mm[0][c]) / t.std_error);
        }
    }
    let n = z.len() as f64;
    let mean = z.iter().sum::<f64>() / n;
    let sd = (z.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt();
    eprintln!(
        "tool-frame z-scores: mean {mean:.3}, sd {sd:.3} over {} values",
        z.len()
    );
    assert!(mean.abs() < 0.15, "z mean {mean}");
    assert!((sd - 1.0).abs() < 0.15, "z sd {sd} over {} values", z.len());
}

/// One rank decision: on point-only data (one unnamed target, no orientation) the frame
/// path's free set is the point path's minimal set (`identify::analyze`), the tool point's
/// three unknowns standing for `tool_x, tool_y, tool_z`; with orientation it holds θ6 (the
/// tool's rotation about the flange axis takes it) and keeps the whole tool frame.
#[test]
fn the_free_set_is_the_identifiability_analysis_one() {
    let nominal = kr1000(TOOL);
    let q = poses(&nominal, 20, 21);
    let truth = truth_model(0, 4);
    let all: Vec<usize> = (0..nominal.n_params()).collect();
    let layout = nominal.layout();
    let tool: Vec<usize> = ["tool_x", "tool_y", "tool_z"]
        .iter()
        .map(|n| layout.index_of(n).unwrap())
        .collect();
    let points = measure(&truth, &q, false, 0, (0.02, 0.005), 5);
    let start = closed_form_tool(&nominal, &points, None, &[Some(Vector3::from(TOOL))]);
    let (free, dropped) = select_free(&start, &points, &all).unwrap();
    let report = identify::analyze(
        &nominal,
        &q,
        None,
        &all,
        &identify::IdentifiabilityOptions::default(),
    )
    .unwrap();
    let minimal: Vec<usize> = report
        .identifiable_indices
        .iter()
        .copied()
        .filter(|k| !tool.contains(k))
        .collect();
    assert_eq!(free.robot, minimal);
    let mut redundant: Vec<usize> = report
        .redundant
        .iter()
        .map(|n| layout.index_of(n).unwrap())
        .collect();
    redundant.sort_unstable();
    assert_eq!(dropped, redundant);
    assert!(!free.rotation && free.n_targets == 1);

    let frames = measure(&truth, &q, true, 0, (0.02, 0.005), 6);
    let start = closed_form_tool(&nominal, &frames, None, &[None]);
    let (free6, dropped6) = select_free(&start, &frames, &all).unwrap();
    assert!(free6.rotation);
    assert!(dropped6.contains(&layout.index_of("theta6").unwrap()));
    // Orientation adds equations, never unknowns of the robot beyond the point path's.
    assert!(free6.robot.iter().all(|k| minimal.contains(k)), "{free6:?}");
}

/// One outlier rule: a pose with a gross orientation error (2°, σ 0.005°) or one gross
/// target point (2 mm, σ 0.02 mm) is flagged as a whole pose, and nothing else.
#[test]
fn a_gross_pose_is_flagged_as_a_block() {
    let nominal = kr1000(TOOL);
    let q = poses(&nominal, 30, 22);
    let all: Vec<usize> = (0..nominal.n_params()).collect();
    for (orientation, n_targets) in [(true, 0), (false, 3)] {
        let truth = truth_model(n_targets, 7);
        let mut data = measure(&truth, &q, orientation, n_targets, (0.02, 0.005), 8);
        let bad_pose = 11;
        let row = data.rows.iter().position(|r| r.pose == bad_pose).unwrap();
        if orientation {
            let m = data.rows[row].rotation.unwrap();
            data.rows[row].rotation = Some(m * exp_so3(&Vector3::new(0.0, 2f64.to_radians(), 0.0)));
        } else {
            data.rows[row + 1].point_mm += Vector3::new(1.2, -1.0, 1.2);
        }
        let known: Vec<Option<Vector3<f64>>> = vec![None; data.target_names.len()];
        let start = closed_form_tool(&truth.robot, &data, None, &known);
        let (free, _) = select_free(&start, &data, &all).unwrap();
        let fit = fit_frames(&start, &data, &free, &LmOptions::default()).unwrap();
        let screen = identify::frames::screen_poses(&fit, &data, 3.0)
            .unwrap()
            .unwrap();
        assert_eq!(screen.indices(), vec![bad_pose], "{screen:?}");
        let d = if orientation { 6 } else { 9 };
        assert_eq!(screen.outliers[0].rows, d);
        let (_, threshold) = identify::outliers::block_threshold(3.0, fit.sigma_hat, d);
        assert_eq!(screen.outliers[0].threshold, threshold);
        assert!(screen.outliers[0].ratio > 3.0);
    }
}

/// Issue 42: the 6-DoF fit runs the one solver with the caller's schedule. The first
/// iteration damps with the schedule's μ0 (column-scaled: Nielsen's τ·max diag = τ), the
/// schedules' traces differ, and all converge to the same solution. (Column-scaled,
/// diag(Ã) = 1, so Marquardt's schedule is Levenberg's.)
#[test]
fn frame_fit_honours_the_schedule() {
    let nominal = kr1000(TOOL);
    let truth = truth_model(0, 41);
    let q = poses(&nominal, 30, 42);
    let data = measure(&truth, &q, true, 0, (0.02, 0.005), 43);
    let start = closed_form_tool(&nominal, &data, None, &[None]);
    let all: Vec<usize> = (0..nominal.n_params()).collect();
    let (free, _) = select_free(&start, &data, &all).unwrap();
    let schedules = [
        (Damping::levenberg(), 1e-3),
        (
            Damping::Levenberg {
                mu0: 0.5,
                decrease: 3.0,
                increase: 4.0,
            },
            0.5,
        ),
        (
            Damping::Nielsen {
                tau: 0.25,
                nu0: 2.0,
            },
            0.25,
        ),
    ];
    let fits: Vec<_> = schedules
        .iter()
        .map(|&(d, _)| fit_frames(&start, &data, &free, &LmOptions::with_damping(d)).unwrap())
        .collect();
    for (fit, &(damping, mu0)) in fits.iter().zip(&schedules) {
        assert!(fit.stop.converged(), "{damping:?}: {}", fit.stop);
        assert_eq!(fit.damping, damping);
        assert_eq!(fit.trace.len(), fit.iterations);
        assert!(
            (fit.trace[0].mu - mu0).abs() <= 1e-12 * mu0,
            "{damping:?}: μ {}",
            fit.trace[0].mu
        );
    }
    let mus = |f: &identify::frames::FrameFit| f.trace.iter().map(|t| t.mu).collect::<Vec<_>>();
    for i in 0..fits.len() {
        for j in i + 1..fits.len() {
            assert_ne!(mus(&fits[i]), mus(&fits[j]), "schedules {i} and {j}");
            // The same minimum: every estimate within 1e-3 of its standard error.
            for (a, b) in fits[i].estimates.iter().zip(&fits[j].estimates) {
                assert!(
                    (a.value - b.value).abs() < 1e-3 * a.std_error,
                    "{}: {} vs {} (σ {})",
                    a.name,
                    a.value,
                    b.value,
                    a.std_error
                );
            }
        }
    }
    // Redundant unknowns are held by `select_free`: damping them is refused, not ignored.
    let damp = LmOptions {
        redundant: Redundant::Damp,
        ..LmOptions::default()
    };
    assert!(matches!(
        fit_frames(&start, &data, &free, &damp),
        Err(IdentifyError::InvalidOption {
            name: "redundant",
            ..
        })
    ));
}

/// Issue 42: a damping blow-up — every step rejected while μ grows, until the rejection
/// limit — is reported as not converged (`too_many_rejections`); the hand-written loop this
/// solver replaced reported it as converged. A start 45° off on every free angle and 300 mm
/// on every free length makes the nearly undamped steps overshoot; a schedule that barely
/// raises μ after a rejection keeps rejecting them.
#[test]
fn frame_fit_reports_a_damping_blow_up_as_not_converged() {
    let nominal = kr1000(TOOL);
    let truth = truth_model(0, 51);
    let q = poses(&nominal, 30, 52);
    let data = measure(&truth, &q, true, 0, (0.02, 0.005), 53);
    let mut start = closed_form_tool(&nominal, &data, None, &[None]);
    let all: Vec<usize> = (0..nominal.n_params()).collect();
    let (free, _) = select_free(&start, &data, &all).unwrap();
    let mut x = start.robot.params();
    for (i, &k) in free.robot.iter().enumerate() {
        let sign = if i % 2 == 0 { 1.0 } else { -1.0 };
        x[k] += sign
            * match nominal.layout().get(k).unit {
                kinematics::Unit::Deg => 45f64.to_radians(),
                _ => 300.0,
            };
    }
    start.robot = start.robot.with_params(&x).unwrap();
    let options = LmOptions {
        max_rejections: 5,
        ..LmOptions::with_damping(Damping::Levenberg {
            mu0: 1e-9,
            decrease: 10.0,
            increase: 1.000001,
        })
    };
    let fit = fit_frames(&start, &data, &free, &options).unwrap();
    let marks: String = fit
        .trace
        .iter()
        .map(|t| if t.accepted { 'A' } else { 'r' })
        .collect();
    assert_eq!(fit.stop, StopReason::TooManyRejections, "{marks}");
    assert!(!fit.stop.converged());
    assert!(marks.ends_with("rrrrr"), "{marks}");
    // The same start under the default schedule (μ ×10 per rejection) gets further.
    let default = fit_frames(&start, &data, &free, &LmOptions::default()).unwrap();
    assert!(
        default.cost.1 < fit.cost.1,
        "{} vs {}",
        default.cost.1,
        fit.cost.1
    );
}
