//! The fast linear algebra (sin/cos once per pose, vectorised assembly, in-place Cholesky)
//! against the straightforward reference path, and the vector widths against each other.

use crate::common::{TOOL, kr1000, noisy, perturbed, poses};
use identify::covariance::covariance_reference;
use identify::identifiability::cholesky_certifies;
use identify::lm::solve_reference;
use identify::{
    Covariance, Damping, IdentifiabilityOptions, LmOptions, LmSolution, ParamSet, Problem,
    SimdLevel, covariance, covariance_at_solution, set_simd_level, solve,
};
use kinematics::{Robot, RobotSpec};
use nalgebra::{DMatrix, DVector, Vector3};

fn ur10() -> Robot {
    let text = include_str!("../../../scenarios/robots/ur10.json");
    Robot::from_spec(&RobotSpec::from_json_str(text, "ur10").unwrap()).unwrap()
}

/// Both converge to the same fit: costs within 1e-9 relative, predicted points within
/// 1e-8 mm (1e-6 unscaled). The iterations agree until the end, where the stopping tests sit at rounding
/// level (a gradient cosine of 1e-10, a relative cost change of 1e-10) and may decide one
/// iteration apart or for a different one of the three convergence reasons. With the
/// paper's unscaled `JᵀJ + μI` (exactly singular, practically undamped) the steps amplify
/// rounding, so only the end point is compared.
fn assert_close(fast: &LmSolution, reference: &LmSolution, problem: &Problem, what: &str) {
    assert!(
        fast.stop.converged() && reference.stop.converged(),
        "{what}: {:?} {:?}",
        fast.stop,
        reference.stop
    );
    assert!(
        fast.iterations.abs_diff(reference.iterations) <= 1,
        "{what}: iterations"
    );
    if !what.contains("scaling false") {
        let common = fast.trace.len().min(reference.trace.len()) - 1;
        for (a, b) in fast.trace.iter().zip(&reference.trace).take(common) {
            assert_eq!(
                a.accepted, b.accepted,
                "{what}: acceptance at {}",
                a.iteration
            );
            let rel = (a.cost_trial - b.cost_trial).abs() / b.cost_trial.max(1e-300);
            assert!(rel < 1e-6, "{what}: trial cost at {}: {rel:e}", a.iteration);
        }
    }
    let rel = (fast.cost - reference.cost).abs() / reference.cost.max(1e-300);
    assert!(rel < 1e-9, "{what}: cost {rel:e}");
    let poses = problem.poses_rad();
    let d = fast
        .robot
        .points(poses)
        .iter()
        .zip(reference.robot.points(poses))
        .map(|(p, q)| (p - q).norm())
        .fold(0.0, f64::max);
    // Unscaled, the conditioning of JᵀJ (~1e16) leaves the end point determined only to the
    // stopping tolerance: 1e-6 mm there.
    let tol = if what.contains("scaling false") {
        1e-6
    } else {
        1e-8
    };
    assert!(d < tol, "{what}: points differ by {d:e} mm");
}

#[test]
fn fast_lm_matches_the_reference() {
    let nominal = kr1000(TOOL);
    let all: Vec<usize> = (0..nominal.n_params()).collect();
    for seed in 0..4 {
        let truth = perturbed(&nominal, &all, 100 + seed);
        let q = poses(&nominal, 50, 200 + seed);
        let meas = noisy(&truth.points(&q), 0.02, 300 + seed);
        let minimal = ParamSet::Minimal
            .resolve(&nominal, &q, None, &Default::default())
            .unwrap();
        let weights: Vec<f64> = (0..3 * 50)
            .map(|r| 1.0 / (0.01 + 0.001 * (r % 7) as f64))
            .collect();
        for (name, free, weighted) in [
            ("paper", &all, false),
            ("minimal", &minimal, false),
            ("minimal weighted", &minimal, true),
        ] {
            let mut problem = Problem::new(&nominal, &q, &meas, free.clone()).unwrap();
            if weighted {
                problem = problem.with_weights(&weights).unwrap();
            }
            for damping in [
                Damping::levenberg(),
                Damping::marquardt(),
                Damping::nielsen(),
            ] {
                for column_scaling in [true, false] {
                    let opts = LmOptions {
                        column_scaling,
                        ..LmOptions::with_damping(damping)
                    };
                    let what = format!(
                        "seed {seed}, {name}, {}, scaling {column_scaling}",
                        damping.name()
                    );
                    let fast = solve(&problem, &opts).unwrap();
                    let reference = solve_reference(&problem, &opts).unwrap();
                    assert_close(&fast, &reference, &problem, &what);
                }
            }
        }
    }
    // UR10: two β parameters, α = 0 twice, 35 parameters.
    let ur = ur10();
    let all: Vec<usize> = (0..ur.n_params()).collect();
    let truth = perturbed(&ur, &all, 9);
    let q = poses(&ur, 60, 10);
    let meas = noisy(&truth.points(&q), 0.02, 11);
    let problem = Problem::new(&ur, &q, &meas, all).unwrap();
    let opts = LmOptions::default();
    let fast = solve(&problem, &opts).unwrap();
    let reference = solve_reference(&problem, &opts).unwrap();
    assert_close(&fast, &reference, &problem, "ur10");
}

#[test]
fn normal_equations_match_the_reference() {
    let nominal = kr1000(TOOL);
    let all: Vec<usize> = (0..nominal.n_params()).collect();
    let truth = perturbed(&nominal, &all, 5);
    let q = poses(&nominal, 50, 6);
    let meas = noisy(&truth.points(&q), 0.02, 7);
    let free: Vec<usize> = all.iter().copied().filter(|k| k % 3 != 1).collect();
    for free in [all.clone(), free] {
        let problem = Problem::new(&nominal, &q, &meas, free).unwrap();
        let (mut a, mut g) = (DMatrix::zeros(0, 0), DVector::zeros(0));
        let (mut ar, mut gr) = (DMatrix::zeros(0, 0), DVector::zeros(0));
        let cost = problem.normal_equations(&mut a, &mut g);
        let cost_ref = problem.normal_equations_reference(&mut ar, &mut gr);
        assert!((cost - cost_ref).abs() <= 1e-12 * cost_ref);
        let pf = a.nrows();
        for l in 0..pf {
            for k in 0..pf {
                let scale = (ar[(k, k)] * ar[(l, l)]).sqrt();
                assert!(
                    (a[(k, l)] - ar[(k, l)]).abs() <= 1e-12 * scale,
                    "({k}, {l})"
                );
                assert_eq!(a[(k, l)], a[(l, k)]);
            }
            let scale = (ar[(l, l)] * cost_ref).sqrt();
            assert!((g[l] - gr[l]).abs() <= 1e-10 * scale, "g {l}");
        }
    }
}

/// Every vector width the CPU has gives the same bits (no FMA, element-wise kernels).
#[test]
fn vector_widths_give_identical_bits() {
    let nominal = kr1000(TOOL);
    let all: Vec<usize> = (0..nominal.n_params()).collect();
    let truth = perturbed(&nominal, &all, 1);
    let q = poses(&nominal, 50, 2);
    let meas: Vec<Vector3<f64>> = noisy(&truth.points(&q), 0.02, 3);
    let problem = Problem::new(&nominal, &q, &meas, all).unwrap();
    let opts = LmOptions::default();
    let levels: Vec<SimdLevel> = [SimdLevel::Portable, SimdLevel::Avx2, SimdLevel::Avx512]
        .into_iter()
        .filter(|l| *l <= SimdLevel::detect())
        .collect();
    let mut results = Vec::new();
    for level in &levels {
        set_simd_level(Some(*level));
        let sol = solve(&problem, &opts).unwrap();
        let (mut a, mut g) = (DMatrix::zeros(0, 0), DVector::zeros(0));
        problem.normal_equations(&mut a, &mut g);
        results.push((sol, a, g));
    }
    set_simd_level(None);
    let (first, a0, g0) = &results[0];
    for ((sol, a, g), level) in results.iter().zip(&levels).skip(1) {
        assert_eq!(a, a0, "{level:?}: JᵀJ");
        assert_eq!(g, g0, "{level:?}: Jᵀe");
        assert_eq!(sol.params, first.params, "{level:?}: parameters");
        assert_eq!(sol.trace, first.trace, "{level:?}: trace");
    }
}

fn assert_cov_close(fast: &Covariance, reference: &Covariance, what: &str) {
    assert_eq!(fast.parameters, reference.parameters, "{what}: parameters");
    assert_eq!(fast.omitted, reference.omitted, "{what}: omitted");
    assert_eq!(fast.dof, reference.dof, "{what}: dof");
    let rel = (fast.sigma_hat - reference.sigma_hat).abs() / reference.sigma_hat;
    assert!(rel < 1e-12, "{what}: σ̂ {rel:e}");
    for (i, (a, b)) in fast
        .std_errors
        .iter()
        .zip(&reference.std_errors)
        .enumerate()
    {
        assert!(
            (a - b).abs() <= 1e-8 * b,
            "{what}: std error {i}: {a} vs {b}"
        );
    }
    let r = fast.parameters.len();
    for i in 0..r {
        for j in 0..r {
            let s = reference.std_errors[i] * reference.std_errors[j];
            let d = (fast.covariance[(i, j)] - reference.covariance[(i, j)]).abs();
            assert!(d <= 1e-8 * s, "{what}: cov ({i}, {j})");
        }
    }
}

/// Name, robot at the solution, poses, measured points, free set, weighted.
type Case = (String, Robot, Vec<f64>, Vec<Vector3<f64>>, Vec<usize>, bool);

/// The covariance's Cholesky path certifies the usual problems (paper set with its exact
/// redundancies, minimal set, weights, UR10) and agrees with the SVD path.
#[test]
fn covariance_fast_path_matches_the_svd() {
    let opts = IdentifiabilityOptions::default();
    let mut cases: Vec<Case> = Vec::new();
    let nominal = kr1000(TOOL);
    let all: Vec<usize> = (0..nominal.n_params()).collect();
    for seed in 0..5 {
        let truth = perturbed(&nominal, &all, 40 + seed);
        let q = poses(&nominal, 50, 50 + seed);
        let meas = noisy(&truth.points(&q), 0.02, 60 + seed);
        let minimal = ParamSet::Minimal
            .resolve(&nominal, &q, None, &opts)
            .unwrap();
        let fit = solve(
            &Problem::new(&nominal, &q, &meas, all.clone()).unwrap(),
            &LmOptions::default(),
        )
        .unwrap()
        .robot;
        cases.push((
            format!("kr1000 paper {seed}"),
            fit.clone(),
            q.clone(),
            meas.clone(),
            all.clone(),
            false,
        ));
        cases.push((
            format!("kr1000 minimal {seed}"),
            fit.clone(),
            q.clone(),
            meas.clone(),
            minimal,
            true,
        ));
    }
    let ur = ur10();
    let ur_all: Vec<usize> = (0..ur.n_params()).collect();
    let truth = perturbed(&ur, &ur_all, 3);
    let q = poses(&ur, 100, 4);
    let meas = noisy(&truth.points(&q), 0.05, 5);
    cases.push(("ur10 paper".into(), truth, q, meas, ur_all, false));
    let weights: Vec<f64> = (0..3 * 100)
        .map(|r| 1.0 / (0.02 + 0.003 * (r % 5) as f64))
        .collect();
    for (what, robot, q, meas, free, weighted) in &cases {
        let m = q.len() / robot.n_joints();
        let w = weighted.then(|| &weights[..3 * m]);
        assert!(
            cholesky_certifies(robot, q, w, free, &opts),
            "{what}: the Cholesky path should certify this problem"
        );
        let fast = covariance(robot, q, meas, w, free, &opts, 0.9)
            .unwrap()
            .unwrap();
        let reference = covariance_reference(robot, q, meas, w, free, &opts, 0.9)
            .unwrap()
            .unwrap();
        assert_cov_close(&fast, &reference, what);
    }
}

/// A nearly redundant parameter (an almost parallel pair of columns) is left to the SVD.
#[test]
fn covariance_leaves_near_redundancy_to_the_svd() {
    let opts = IdentifiabilityOptions::default();
    let nominal = kr1000(TOOL);
    // Poses that barely move joint 6: θ6 is then almost confounded with the rest.
    let mut q = poses(&nominal, 50, 77);
    for (j, row) in q.chunks_exact_mut(6).enumerate() {
        row[5] = 1e-7 * j as f64;
    }
    let all: Vec<usize> = (0..nominal.n_params()).collect();
    let meas = noisy(&nominal.points(&q), 0.02, 78);
    let certified = cholesky_certifies(&nominal, &q, None, &all, &opts);
    let fast = covariance(&nominal, &q, &meas, None, &all, &opts, 0.9).unwrap();
    let reference = covariance_reference(&nominal, &q, &meas, None, &all, &opts, 0.9).unwrap();
    match (fast, reference) {
        (Some(f), Some(r)) => {
            if certified {
                assert_cov_close(&f, &r, "near redundancy");
            } else {
                assert_eq!(f.parameters, r.parameters);
            }
        }
        (None, None) => {}
        other => panic!("{other:?}"),
    }
}

/// Reusing the solver's normal matrix gives the covariance assembled afresh, bit for bit.
#[test]
fn covariance_at_solution_equals_covariance() {
    let opts = IdentifiabilityOptions::default();
    let nominal = kr1000(TOOL);
    let all: Vec<usize> = (0..nominal.n_params()).collect();
    let truth = perturbed(&nominal, &all, 90);
    let q = poses(&nominal, 50, 91);
    let meas = noisy(&truth.points(&q), 0.02, 92);
    let other = noisy(&truth.points(&q), 0.05, 93);
    let minimal = ParamSet::Minimal
        .resolve(&nominal, &q, None, &opts)
        .unwrap();
    let weights: Vec<f64> = (0..150)
        .map(|r| 1.0 / (0.02 + 0.001 * (r % 3) as f64))
        .collect();
    for (free, weighted) in [(&all, false), (&minimal, false), (&minimal, true)] {
        let mut problem = Problem::new(&nominal, &q, &meas, free.clone()).unwrap();
        if weighted {
            problem = problem.with_weights(&weights).unwrap();
        }
        let sol = solve(&problem, &LmOptions::default()).unwrap();
        let w = weighted.then_some(&weights[..]);
        for points in [&meas, &other] {
            let direct = covariance(&sol.robot, &q, points, w, free, &opts, 0.9).unwrap();
            let reused = covariance_at_solution(&problem, &sol, points, &opts, 0.9).unwrap();
            assert_eq!(direct, reused);
        }
    }
}

/// The extended model (34 geometric + 6 compliance + 12 first-harmonic gear columns) on the
/// fast path: the lane kernels from the weights of `PoseTrig::for_robot`. The normal
/// equations, the solution and the covariance match the reference path's to rounding, and
/// every vector width gives the same bits.
#[test]
fn extended_model_fast_path_matches_the_reference() {
    let names: Vec<String> = (1..=6)
        .map(|j| format!("compliance_{j}"))
        .chain((1..=6).flat_map(|j| [format!("gear_{j}_h1_sin"), format!("gear_{j}_h1_cos")]))
        .collect();
    let geometric = kr1000(TOOL);
    let nominal = geometric.with_extended(&names, "kr1000").unwrap();
    let first = geometric.n_params();
    let all: Vec<usize> = (0..nominal.n_params()).collect();
    let opts = IdentifiabilityOptions::default();
    for seed in 0..3 {
        let truth_geo = perturbed(&geometric, &(0..first).collect::<Vec<_>>(), 70 + seed);
        let mut x = truth_geo.params();
        x.extend(std::iter::repeat_n(0.0, names.len()));
        for (k, v) in x[first..].iter_mut().enumerate() {
            let info = nominal.layout().get(first + k);
            // 0.03–1 µrad/(N·m) and up to ±10″: the paper scenario's sizes.
            let display = if info.unit == kinematics::Unit::MicroradPerNm {
                [0.03, 0.03, 0.05, 0.5, 0.5, 1.0][k]
            } else {
                10.0 * ((((k + seed as usize) * 5) % 7) as f64 - 3.0) / 3.0
            };
            *v = info.from_display(display);
        }
        let truth = nominal.with_params(&x).unwrap();
        let q = poses(&geometric, 50, 80 + seed);
        let meas = noisy(&truth.points(&q), 0.02, 90 + seed);
        let problem = Problem::new(&nominal, &q, &meas, all.clone()).unwrap();

        let (mut a, mut g) = (DMatrix::zeros(0, 0), DVector::zeros(0));
        let (mut ar, mut gr) = (DMatrix::zeros(0, 0), DVector::zeros(0));
        let cost = problem.normal_equations(&mut a, &mut g);
        let cost_ref = problem.normal_equations_reference(&mut ar, &mut gr);
        assert!(
            (cost - cost_ref).abs() <= 1e-12 * cost_ref,
            "seed {seed}: cost"
        );
        for l in 0..all.len() {
            for k in 0..all.len() {
                let scale = (ar[(k, k)] * ar[(l, l)]).sqrt();
                assert!(
                    (a[(k, l)] - ar[(k, l)]).abs() <= 1e-12 * scale,
                    "seed {seed}: ({k}, {l})"
                );
            }
            let scale = (ar[(l, l)] * cost_ref).sqrt();
            assert!((g[l] - gr[l]).abs() <= 1e-10 * scale, "seed {seed}: g {l}");
        }

        let lm = LmOptions::default();
        let fast = solve(&problem, &lm).unwrap();
        let reference = solve_reference(&problem, &lm).unwrap();
        assert_close(
            &fast,
            &reference,
            &problem,
            &format!("extended seed {seed}"),
        );
        // The zero columns (compliance of the vertical axes 1 and 6) are held by both.
        assert_eq!(fast.held, reference.held);

        let fit = &fast.robot;
        let solved: Vec<usize> = all
            .iter()
            .copied()
            .filter(|k| !fast.held.contains(k))
            .collect();
        let cf = covariance(fit, &q, &meas, None, &solved, &opts, 0.9)
            .unwrap()
            .unwrap();
        let cr = covariance_reference(fit, &q, &meas, None, &solved, &opts, 0.9)
            .unwrap()
            .unwrap();
        assert_cov_close(&cf, &cr, &format!("extended seed {seed}"));

        let levels: Vec<SimdLevel> = [SimdLevel::Portable, SimdLevel::Avx2, SimdLevel::Avx512]
            .into_iter()
            .filter(|l| *l <= SimdLevel::detect())
            .collect();
        let mut runs = Vec::new();
        for level in &levels {
            set_simd_level(Some(*level));
            runs.push(solve(&problem, &lm).unwrap());
        }
        set_simd_level(None);
        for (run, level) in runs.iter().zip(&levels).skip(1) {
            assert_eq!(run.params, runs[0].params, "{level:?}: parameters");
            assert_eq!(run.trace, runs[0].trace, "{level:?}: trace");
        }
    }
}
