//! Noise-free known truth: every schedule, `paper` and `minimal`, recovers the identifiable
//! model exactly (held-out points < 1e-6 mm; minimal-set parameters < 1e-6 deg/mm).

use crate::common::{TOOL, kr1000, max_point_diff, perturbed, poses};
use identify::{
    Damping, IdentifyOptions, LmOptions, ParamSet, Problem, Redundant, RegistrationPolicy,
    StopReason, identify, solve,
};
use kinematics::Robot;

const TOL: f64 = 1e-6;

fn schedules() -> [Damping; 3] {
    [
        Damping::levenberg(),
        Damping::marquardt(),
        Damping::nielsen(),
    ]
}

/// Largest difference over `which` between two parameter vectors, display units.
fn max_param_diff(robot: &Robot, a: &[f64], b: &[f64], which: &[usize]) -> (f64, String) {
    which
        .iter()
        .map(|&k| {
            let info = robot.layout().get(k);
            (
                (info.to_display(a[k]) - info.to_display(b[k])).abs(),
                info.name.to_string(),
            )
        })
        .fold((0.0, String::new()), |m, v| if v.0 > m.0 { v } else { m })
}

/// Re-expresses `fitted` in the minimal set: the redundant parameters are put back to the
/// nominal values and the minimal ones refitted to `fitted`'s own (exact) points.
fn reexpress(fitted: &Robot, nominal: &Robot, minimal: &[usize], poses: &[f64]) -> Vec<f64> {
    let mut x = fitted.params();
    let xn = nominal.params();
    for k in 0..x.len() {
        if !minimal.contains(&k) {
            x[k] = xn[k];
        }
    }
    let start = fitted.with_params(&x).unwrap();
    let target = fitted.points(poses);
    let problem = Problem::new(&start, poses, &target, minimal.to_vec()).unwrap();
    let sol = solve(&problem, &LmOptions::default()).unwrap();
    assert!(sol.stop.converged(), "re-expression stopped: {}", sol.stop);
    sol.params
}

#[test]
fn every_schedule_and_both_sets_recover_the_truth() {
    let nominal = kr1000(TOOL);
    let poses_id = poses(&nominal, 50, 1);
    let poses_val = poses(&nominal, 50, 2);
    let minimal = ParamSet::Minimal
        .resolve(&nominal, &poses_id, None, &Default::default())
        .unwrap();
    assert_eq!(minimal.len(), 27);

    // Truth differing in every parameter: only predictions are comparable.
    let all: Vec<usize> = (0..34).collect();
    let truth_all = perturbed(&nominal, &all, 11);
    // Truth differing only in identifiable directions: the minimal-set values are comparable.
    let truth_min = perturbed(&nominal, &minimal, 12);

    let redundant_names: Vec<String> = (0..34)
        .filter(|k| !minimal.contains(k))
        .map(|k| nominal.layout().get(k).name.to_string())
        .collect();
    for (set_name, free, redundant) in [
        ("paper", all.clone(), Redundant::Hold),
        ("paper", all.clone(), Redundant::Damp),
        ("minimal", minimal.clone(), Redundant::Hold),
    ] {
        for damping in schedules() {
            let opts = IdentifyOptions {
                lm: LmOptions {
                    redundant,
                    ..LmOptions::with_damping(damping)
                },
                ..Default::default()
            };
            let label = format!("{set_name}/{redundant:?}/{}", damping.name());

            let meas = truth_all.points(&poses_id);
            let problem = Problem::new(&nominal, &poses_id, &meas, free.clone()).unwrap();
            let fit = identify(&problem, &opts).unwrap();
            assert!(fit.stop.converged(), "{label}: stopped by {}", fit.stop);
            // Holding, the paper set holds exactly what the minimal set drops.
            if set_name == "paper" && redundant == Redundant::Hold {
                assert_eq!(fit.held, redundant_names, "{label}");
                let cov = fit.covariance.as_ref().unwrap();
                assert_eq!(cov.omitted, redundant_names, "{label}");
            } else {
                assert!(fit.held.is_empty(), "{label}: held {:?}", fit.held);
            }
            assert!(
                fit.iterations <= 20,
                "{label}: {} iterations",
                fit.iterations
            );
            let held_out = max_point_diff(&fit.robot, &truth_all, &poses_val);
            assert!(held_out < TOL, "{label}: held-out error {held_out:e} mm");
            assert!(fit.rms_mm < TOL, "{label}: rms {:e}", fit.rms_mm);

            let meas = truth_min.points(&poses_id);
            let problem = Problem::new(&nominal, &poses_id, &meas, free.clone()).unwrap();
            let fit = identify(&problem, &opts).unwrap();
            assert!(fit.stop.converged(), "{label}: stopped by {}", fit.stop);
            let held_out = max_point_diff(&fit.robot, &truth_min, &poses_val);
            assert!(held_out < TOL, "{label}: held-out error {held_out:e} mm");
            let x = if set_name == "paper" {
                reexpress(&fit.robot, &nominal, &minimal, &poses_id)
            } else {
                fit.params.clone()
            };
            let (err, name) = max_param_diff(&nominal, &x, &truth_min.params(), &minimal);
            assert!(err < TOL, "{label}: {name} off by {err:e} (deg or mm)");
            // The minimal fit leaves the redundant parameters exactly where they were.
            if set_name == "minimal" {
                let redundant: Vec<usize> = (0..34).filter(|k| !minimal.contains(k)).collect();
                let (err, name) =
                    max_param_diff(&nominal, &fit.params, &nominal.params(), &redundant);
                assert_eq!(err, 0.0, "{label}: redundant {name} moved");
            }
        }
    }
}

#[test]
fn paper_verbatim_unscaled_levenberg_also_converges() {
    let nominal = kr1000(TOOL);
    let poses_id = poses(&nominal, 50, 1);
    let poses_val = poses(&nominal, 50, 2);
    let all: Vec<usize> = (0..34).collect();
    let truth = perturbed(&nominal, &all, 11);
    let meas = truth.points(&poses_id);
    let problem = Problem::new(&nominal, &poses_id, &meas, all).unwrap();
    let opts = IdentifyOptions {
        lm: LmOptions {
            column_scaling: false,
            redundant: Redundant::Damp,
            ..LmOptions::default()
        },
        registration: RegistrationPolicy::Never,
        ..Default::default()
    };
    let fit = identify(&problem, &opts).unwrap();
    assert!(fit.stop.converged(), "{}", fit.stop);
    assert!(max_point_diff(&fit.robot, &truth, &poses_val) < TOL);
    // The trace is consistent: accepted steps lower the cost, μ follows ÷10 / ×10.
    // (μ may stop at its floor, mu_min_rel·max diag, after many successes.)
    for w in fit.trace.windows(2) {
        let factor = w[1].mu / w[0].mu;
        if w[0].accepted {
            assert!(
                (0.1 - 1e-12..=1.001).contains(&factor),
                "μ after success ×{factor}"
            );
        } else {
            assert!((factor - 10.0).abs() < 1e-9, "μ after failure ×{factor}");
        }
    }
    for t in &fit.trace {
        assert_eq!(t.accepted, t.cost_trial < t.cost_before);
    }
}

#[test]
fn starting_at_the_truth_stops_at_once_on_the_gradient_test() {
    let nominal = kr1000(TOOL);
    let poses_id = poses(&nominal, 30, 1);
    let meas = nominal.points(&poses_id);
    let problem = Problem::new(&nominal, &poses_id, &meas, (0..34).collect()).unwrap();
    let fit = identify(&problem, &IdentifyOptions::default()).unwrap();
    assert_eq!(fit.stop, StopReason::SmallGradient);
    assert_eq!(fit.iterations, 0);
    assert!(fit.trace.is_empty());
    assert_eq!(fit.params, nominal.params());
}

#[test]
fn iteration_cap_is_reported() {
    let nominal = kr1000(TOOL);
    let poses_id = poses(&nominal, 30, 1);
    let truth = perturbed(&nominal, &(0..34).collect::<Vec<_>>(), 3);
    let meas = truth.points(&poses_id);
    let problem = Problem::new(&nominal, &poses_id, &meas, (0..34).collect()).unwrap();
    let opts = IdentifyOptions {
        lm: LmOptions {
            max_iterations: 2,
            ..LmOptions::default()
        },
        ..Default::default()
    };
    let fit = identify(&problem, &opts).unwrap();
    assert_eq!(fit.stop, StopReason::MaxIterations);
    assert_eq!(fit.iterations, 2);
    assert_eq!(fit.trace.len(), 2);
}

/// With no damping floor to speak of, rounding makes JᵀJ of the paper's redundant set
/// indefinite: the solver raises μ, refactorises, and still converges.
#[test]
fn indefinite_damped_matrix_is_rescued_by_raising_mu() {
    let nominal = kr1000(TOOL);
    let poses_id = poses(&nominal, 50, 1);
    let truth = perturbed(&nominal, &(0..34).collect::<Vec<_>>(), 11);
    let meas = truth.points(&poses_id);
    let problem = Problem::new(&nominal, &poses_id, &meas, (0..34).collect()).unwrap();
    let lm = LmOptions {
        damping: Damping::Levenberg {
            mu0: 1e-300,
            decrease: 10.0,
            increase: 10.0,
        },
        column_scaling: false,
        mu_min_rel: 1e-300,
        redundant: Redundant::Damp,
        ..LmOptions::default()
    };
    let sol = solve(&problem, &lm).unwrap();
    assert!(
        sol.trace[0].mu > 1e-12,
        "μ was raised: {:e}",
        sol.trace[0].mu
    );
    assert!(sol.stop.converged(), "{}", sol.stop);
    assert!(max_point_diff(&sol.robot, &truth, &poses(&nominal, 30, 2)) < TOL);
}
