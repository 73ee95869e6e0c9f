//! Tracker-like noise: held-out prediction error at the noise floor, and reported standard
//! errors that match the spread of the estimates over many noise draws.

use crate::common::{TOOL, kr1000, noisy, perturbed, poses, rms_point_diff};
use identify::{Fit, IdentifyOptions, ParamSet, Problem, identify};
use nalgebra::DMatrix;

/// Per-axis tracker noise, mm (docs/model.md §10: σ ≈ ½ MPE ≈ 0.01–0.02 mm at 2–3 m).
const SIGMA_MM: f64 = 0.015;

/// Mean and standard deviation of the mean squared held-out point error implied by the
/// fit's covariance (a quadratic form in a Gaussian).
fn predicted_error_moments(fit: &Fit, poses: &[f64]) -> (f64, f64) {
    let cov = fit.covariance.as_ref().unwrap();
    let layout = fit.robot.layout();
    let (_, jac) = fit.robot.jacobian_batch(poses);
    let r = cov.indices.len();
    // Covariance in internal units (display → internal is 1/to_display(1)).
    let f: Vec<f64> = cov
        .indices
        .iter()
        .map(|&k| 1.0 / layout.get(k).to_display(1.0))
        .collect();
    let c = DMatrix::from_fn(r, r, |i, j| cov.covariance[(i, j)] * f[i] * f[j]);
    let jv = jac.select_columns(cov.indices.iter());
    let m = &jv * c * jv.transpose();
    let n = (poses.len() / fit.robot.n_joints()) as f64;
    (m.trace() / n, (2.0 * (&m * &m).trace()).sqrt() / n)
}

#[test]
fn held_out_prediction_error_is_at_the_noise_floor() {
    const DRAWS: u64 = 25;
    let nominal = kr1000(TOOL);
    let poses_id = poses(&nominal, 50, 1);
    let poses_val = poses(&nominal, 50, 2);
    let all: Vec<usize> = (0..34).collect();
    let truth = perturbed(&nominal, &all, 21);
    let clean = truth.points(&poses_id);
    let nominal_err = rms_point_diff(&nominal, &truth, &poses_val);

    for set in [ParamSet::Paper, ParamSet::Minimal] {
        let free = set
            .resolve(&nominal, &poses_id, None, &Default::default())
            .unwrap();
        // Theory: the parameter error δ ~ N(0, C) moves the held-out points by J_v δ, so the
        // mean squared held-out error ‖J_v δ‖²/m_v has mean tr(M)/m_v and standard deviation
        // √(2 tr(M²))/m_v, M = J_v C J_vᵀ, C the reported covariance. One draw is a skewed
        // (χ²-like) variable, so the check is on the mean over DRAWS draws, within 4 of its
        // standard deviations.
        let (mut sum_sq, mut sum_mean, mut sum_var) = (0.0, 0.0, 0.0);
        for draw in 0..DRAWS {
            let meas = noisy(&clean, SIGMA_MM, 500 + draw);
            let problem = Problem::new(&nominal, &poses_id, &meas, free.clone()).unwrap();
            let fit = identify(&problem, &IdentifyOptions::default()).unwrap();
            assert!(fit.stop.converged(), "{set:?}: {}", fit.stop);
            let (mean_sq, sd_sq) = predicted_error_moments(&fit, &poses_val);
            let err = rms_point_diff(&fit.robot, &truth, &poses_val);
            // Every draw at the noise floor: σ·√(r/m) ≈ 0.011 mm for r = 27, m = 50.
            assert!(err < 0.04, "{set:?} draw {draw}: {err} mm");
            assert!(err < nominal_err / 20.0, "nominal was {nominal_err:.3} mm");
            sum_sq += err * err;
            sum_mean += mean_sq;
            sum_var += sd_sq * sd_sq;
            // σ̂ estimates the per-axis noise: 3m − r = 123 dof ⇒ ±6 % (1 sd); allow ±25 %.
            let s = fit.sigma_hat.unwrap();
            assert!((s / SIGMA_MM - 1.0).abs() < 0.25, "σ̂ = {s}");

            if draw == 0 {
                // Against noisy held-out measurements: √(3σ² + err²) ≈ 0.028 mm (150
                // residuals: ±3 %); allow ±20 %.
                let val_meas = noisy(&truth.points(&poses_val), SIGMA_MM, 98);
                let pred = fit.robot.points(&poses_val);
                let rms_meas = (pred
                    .iter()
                    .zip(&val_meas)
                    .map(|(p, q)| (p - q).norm_squared())
                    .sum::<f64>()
                    / 50.0)
                    .sqrt();
                let floor = (3.0 * SIGMA_MM * SIGMA_MM + mean_sq).sqrt();
                assert!(
                    (rms_meas / floor - 1.0).abs() < 0.2,
                    "{set:?}: held-out RMS vs measured {rms_meas:.4} mm, noise floor {floor:.4}"
                );
            }
        }
        let n = DRAWS as f64;
        let (observed, expected, sd) = (sum_sq / n, sum_mean / n, sum_var.sqrt() / n);
        assert!(
            (observed - expected).abs() < 4.0 * sd,
            "{set:?}: mean squared held-out error {observed:.3e} mm², expected {expected:.3e} ± {sd:.1e}"
        );
        let rms = observed.sqrt();
        assert!(rms > 0.005 && rms < 0.03, "{set:?}: {rms} mm");
    }
}

/// The reported standard errors (√ of σ̂²(JᵀJ)⁻¹) against the empirical spread of the
/// estimates over independent noise draws. With n draws the sample standard deviation has a
/// relative standard error of 1/√(2(n−1)) ≈ 3.5 % for n = 400, so the 15 % per-parameter band
/// is > 4 sd wide. The aggregate (mean ratio over the 27 parameters) is far tighter (< 1 %),
/// so a 5 % band on it catches e.g. a wrong dof (σ̂² = RSS/3m would make every ratio ≈ 1.10).
#[test]
fn reported_standard_errors_match_the_spread_over_400_noise_draws() {
    const DRAWS: usize = 400;
    let nominal = kr1000(TOOL);
    let poses_id = poses(&nominal, 50, 1);
    let minimal = ParamSet::Minimal
        .resolve(&nominal, &poses_id, None, &Default::default())
        .unwrap();
    let truth = perturbed(&nominal, &minimal, 11);
    let clean = truth.points(&poses_id);
    let r = minimal.len();
    let mut estimates = vec![Vec::with_capacity(DRAWS); r];
    let mut reported_sq = vec![0.0; r];
    for draw in 0..DRAWS {
        let meas = noisy(&clean, SIGMA_MM, 10_000 + draw as u64);
        let problem = Problem::new(&nominal, &poses_id, &meas, minimal.clone()).unwrap();
        let fit = identify(&problem, &IdentifyOptions::default()).unwrap();
        assert!(fit.stop.converged(), "draw {draw}: {}", fit.stop);
        let cov = fit.covariance.as_ref().unwrap();
        assert_eq!(cov.parameters.len(), r);
        for (i, e) in fit.estimates.iter().enumerate() {
            estimates[i].push(e.value);
            reported_sq[i] += e.std_error.unwrap().powi(2) / DRAWS as f64;
        }
    }
    let truth_x = truth.params();
    let mut ratios = Vec::with_capacity(r);
    for i in 0..r {
        let info = nominal.layout().get(minimal[i]);
        let mean = estimates[i].iter().sum::<f64>() / DRAWS as f64;
        let sd = (estimates[i].iter().map(|v| (v - mean).powi(2)).sum::<f64>()
            / (DRAWS - 1) as f64)
            .sqrt();
        let reported = reported_sq[i].sqrt();
        let ratio = sd / reported;
        assert!(
            (ratio - 1.0).abs() < 0.15,
            "{}: empirical sd {sd:.3e} vs reported {reported:.3e} {} (ratio {ratio:.3})",
            info.name,
            info.unit.as_str()
        );
        // Unbiased: the mean is within 4 standard errors of the mean of the truth.
        let bias = mean - info.to_display(truth_x[minimal[i]]);
        assert!(
            bias.abs() < 4.0 * sd / (DRAWS as f64).sqrt(),
            "{}: bias {bias:.3e}",
            info.name
        );
        ratios.push(ratio);
    }
    let mean_ratio = ratios.iter().sum::<f64>() / r as f64;
    assert!(
        (mean_ratio - 1.0).abs() < 0.05,
        "mean ratio {mean_ratio:.4}"
    );
}
