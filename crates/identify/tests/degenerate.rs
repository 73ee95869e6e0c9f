//! Degenerate inputs give clear errors, never a result; weights behave as 1/σ.

use crate::common::{TOOL, kr1000, noisy, perturbed, poses};
use identify::{Damping, IdentifyError, IdentifyOptions, LmOptions, ParamSet, Problem, identify};
use nalgebra::Vector3;

#[test]
fn fewer_equations_than_free_parameters() {
    let robot = kr1000(TOOL);
    let p = poses(&robot, 11, 1); // 33 equations < 34 parameters
    let meas = robot.points(&p);
    let err = Problem::new(&robot, &p, &meas, (0..34).collect()).unwrap_err();
    assert!(matches!(
        err,
        IdentifyError::TooFewEquations {
            equations: 33,
            free: 34,
            ..
        }
    ));
    let msg = err.to_string();
    assert!(
        msg.contains("33 equations") && msg.contains("34 free parameters"),
        "{msg}"
    );
    assert!(msg.contains("12 poses"), "says how many would do: {msg}");
    // 12 poses are enough to set the problem up.
    let p = poses(&robot, 12, 1);
    let meas = robot.points(&p);
    assert!(Problem::new(&robot, &p, &meas, (0..34).collect()).is_ok());
}

#[test]
fn all_poses_identical() {
    let robot = kr1000(TOOL);
    let one = poses(&robot, 1, 1);
    let p: Vec<f64> = one.iter().copied().cycle().take(50 * 6).collect();
    let meas = robot.points(&p);
    let err = Problem::new(&robot, &p, &meas, (0..34).collect()).unwrap_err();
    assert!(matches!(
        err,
        IdentifyError::TooFewDistinctPoses {
            distinct: 1,
            poses: 50,
            ..
        }
    ));
    assert!(err.to_string().contains("only 1 distinct pose"), "{err}");
    // Eight distinct poses repeated are still too few for 27 parameters; nine are enough.
    let eight: Vec<f64> = poses(&robot, 8, 2)
        .iter()
        .copied()
        .cycle()
        .take(40 * 6)
        .collect();
    let meas = robot.points(&eight);
    let err = Problem::new(&robot, &eight, &meas, (0..27).collect()).unwrap_err();
    assert!(
        matches!(err, IdentifyError::TooFewDistinctPoses { distinct: 8, .. }),
        "{err}"
    );
}

#[test]
fn non_finite_inputs_are_named() {
    let robot = kr1000(TOOL);
    let p = poses(&robot, 20, 1);
    let mut meas = robot.points(&p);
    meas[17] = Vector3::new(1.0, f64::NAN, 2.0);
    let err = Problem::new(&robot, &p, &meas, (0..34).collect()).unwrap_err();
    assert!(matches!(
        err,
        IdentifyError::NonFinite {
            what: "measured point",
            index: 17,
            ..
        }
    ));
    assert_eq!(err.to_string(), "measured point 17 (y = NaN) is not finite");

    let meas = robot.points(&p);
    let mut bad = p.clone();
    bad[6 * 3 + 4] = f64::INFINITY;
    let err = Problem::new(&robot, &bad, &meas, (0..34).collect()).unwrap_err();
    assert_eq!(err.to_string(), "pose 3 (q5 = inf) is not finite");
}

#[test]
fn shape_and_set_errors() {
    let robot = kr1000(TOOL);
    let p = poses(&robot, 20, 1);
    let meas = robot.points(&p);
    let e = |r: Result<Problem, IdentifyError>| r.unwrap_err().to_string();
    assert!(e(Problem::new(&robot, &p[..p.len() - 1], &meas, vec![0])).contains("not a multiple"));
    assert!(e(Problem::new(&robot, &p, &meas[..19], vec![0])).contains("20 poses but 19"));
    assert!(e(Problem::new(&robot, &p, &meas, vec![])).contains("no free parameters"));
    assert!(e(Problem::new(&robot, &p, &meas, vec![3, 3])).contains("`alpha1` is listed twice"));
    assert!(e(Problem::new(&robot, &p, &meas, vec![34])).contains("out of range"));
    assert!(e(Problem::new(&robot, &[], &[], vec![0])).contains("no poses"));

    let problem = Problem::new(&robot, &p, &meas, vec![0, 1]).unwrap();
    let w = vec![1.0; 59];
    assert!(
        problem
            .clone()
            .with_weights(&w)
            .unwrap_err()
            .to_string()
            .contains("expected 60")
    );
    let mut w = vec![1.0; 60];
    w[7] = -2.0;
    assert!(
        problem
            .clone()
            .with_weights(&w)
            .unwrap_err()
            .to_string()
            .contains("row 7 is -2")
    );
    let bad = IdentifyOptions {
        lm: LmOptions::with_damping(Damping::Levenberg {
            mu0: -1.0,
            decrease: 10.0,
            increase: 10.0,
        }),
        ..Default::default()
    };
    let err = identify(&problem, &bad).unwrap_err();
    assert!(err.to_string().contains("damping.mu0"), "{err}");
    let err = ParamSet::Names(vec![]).resolve(&robot, &p, None, &Default::default());
    assert!(matches!(err, Err(IdentifyError::NoFreeParameters)));
}

/// Uniform weights 1/σ: the same estimate, σ̂ ≈ 1 (dimensionless) and the same standard
/// errors as unweighted (Cov = σ̂²(JᵀWᵀWJ)⁻¹ is invariant under a uniform weight).
#[test]
fn uniform_weights_are_invariant() {
    let sigma = 0.015;
    let robot = kr1000(TOOL);
    let p = poses(&robot, 50, 1);
    let truth = perturbed(&robot, &(0..34).collect::<Vec<_>>(), 5);
    let meas = noisy(&truth.points(&p), sigma, 3);
    let free = ParamSet::Minimal
        .resolve(&robot, &p, None, &Default::default())
        .unwrap();
    let plain = Problem::new(&robot, &p, &meas, free.clone()).unwrap();
    let fit = identify(&plain, &IdentifyOptions::default()).unwrap();
    let w = vec![1.0 / sigma; 150];
    let weighted = plain.clone().with_weights(&w).unwrap();
    let wfit = identify(&weighted, &IdentifyOptions::default()).unwrap();
    let worst = fit
        .robot
        .points(&p)
        .iter()
        .zip(wfit.robot.points(&p))
        .map(|(a, b)| (a - b).norm())
        .fold(0.0, f64::max);
    assert!(worst < 1e-9, "{worst:e}");
    let (s, ws) = (fit.sigma_hat.unwrap(), wfit.sigma_hat.unwrap());
    assert!((ws - s / sigma).abs() < 1e-6 * ws, "σ̂ {s} vs weighted {ws}");
    assert!(wfit.covariance.as_ref().unwrap().weighted);
    for (a, b) in fit.estimates.iter().zip(&wfit.estimates) {
        let (sa, sb) = (a.std_error.unwrap(), b.std_error.unwrap());
        assert!((sa - sb).abs() < 1e-6 * sa, "{}: {sa} vs {sb}", a.name);
    }
}

/// `covariance` refuses what `Problem::new` refuses: repeated or out-of-range free indices,
/// a point per pose missing, poses that are not whole joint vectors, wrong weight counts.
#[test]
fn covariance_checks_its_inputs() {
    let robot = kr1000(TOOL);
    let p = poses(&robot, 20, 3);
    let meas = noisy(&robot.points(&p), 0.02, 4);
    let opts = identify::IdentifiabilityOptions::default();
    let cov = |poses: &[f64], points: &[Vector3<f64>], w: Option<&[f64]>, free: &[usize]| {
        identify::covariance(&robot, poses, points, w, free, &opts, 0.9)
    };
    assert!(cov(&p, &meas, None, &[0, 5, 9]).unwrap().is_some());
    let err = cov(&p, &meas, None, &[0, 5, 5, 9]).unwrap_err();
    assert!(
        matches!(&err, IdentifyError::DuplicateFree { name } if name == "d2"),
        "{err}"
    );
    let err = cov(&p, &meas, None, &[0, 34]).unwrap_err();
    assert!(
        matches!(
            err,
            IdentifyError::FreeIndex {
                index: 34,
                n_params: 34
            }
        ),
        "{err}"
    );
    let err = cov(&p, &meas[..19], None, &[0]).unwrap_err();
    assert!(
        matches!(
            err,
            IdentifyError::PointCount {
                poses: 20,
                points: 19
            }
        ),
        "{err}"
    );
    assert!(matches!(
        cov(&p[..119], &meas, None, &[0]).unwrap_err(),
        IdentifyError::PoseLength { .. }
    ));
    let w = vec![1.0; 59];
    assert!(cov(&p, &meas, Some(&w), &[0]).is_err());
}
