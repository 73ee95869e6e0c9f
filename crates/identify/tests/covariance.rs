//! The covariance against a direct computation: σ̂²(JᵀJ)⁻¹ by plain inversion of the
//! unscaled normal matrix, in display units; correlations and flags.

use crate::common::{TOOL, kr1000, noisy, perturbed, poses};
use identify::{IdentifyOptions, ParamSet, Problem, identify};

#[test]
fn covariance_matches_a_direct_computation() {
    let nominal = kr1000(TOOL);
    let p = poses(&nominal, 50, 1);
    let truth = perturbed(&nominal, &(0..34).collect::<Vec<_>>(), 4);
    let meas = noisy(&truth.points(&p), 0.015, 4);

    for set in [ParamSet::Minimal, ParamSet::Paper] {
        let free = set
            .resolve(&nominal, &p, None, &Default::default())
            .unwrap();
        let problem = Problem::new(&nominal, &p, &meas, free.clone()).unwrap();
        let fit = identify(&problem, &IdentifyOptions::default()).unwrap();
        let cov = fit.covariance.as_ref().unwrap();
        assert_eq!(cov.parameters.len(), 27, "{set:?}");
        assert_eq!(cov.omitted.len(), free.len() - 27);
        assert_eq!(cov.dof, 150 - 27);
        assert_eq!(fit.dof, cov.dof);

        // Direct: J on the covered parameters at the solution, (JᵀJ)⁻¹ by LU.
        let (pred, jac) = fit.robot.jacobian_batch(&p);
        let rss: f64 = pred
            .iter()
            .zip(&meas)
            .map(|(a, b)| (a - b).norm_squared())
            .sum();
        assert!((rss - fit.rss_mm2).abs() < 1e-9 * rss);
        let s2 = rss / cov.dof as f64;
        assert!((s2.sqrt() - cov.sigma_hat).abs() < 1e-12);
        let j = jac.select_columns(cov.indices.iter());
        let inv = (j.transpose() * &j).try_inverse().unwrap();
        let layout = fit.robot.layout();
        for (i, &k) in cov.indices.iter().enumerate() {
            let f = layout.get(k).to_display(1.0);
            let se = (s2 * inv[(i, i)]).sqrt() * f;
            let rel = (se - cov.std_errors[i]).abs() / se;
            assert!(
                rel < 1e-6,
                "{}: {se:e} vs {:e}",
                layout.get(k).name,
                cov.std_errors[i]
            );
            assert_eq!(
                fit.estimate(&layout.get(k).name).unwrap().std_error,
                Some(cov.std_errors[i])
            );
        }

        // Correlations: symmetric, unit diagonal, |ρ| ≤ 1; flags are exactly |ρ| > 0.9.
        let r = cov.parameters.len();
        let mut flagged = 0;
        for i in 0..r {
            assert!((cov.correlation[(i, i)] - 1.0).abs() < 1e-12);
            for jj in 0..r {
                let rho = cov.correlation[(i, jj)];
                assert!((rho - cov.correlation[(jj, i)]).abs() < 1e-12);
                assert!(rho.abs() <= 1.0 + 1e-9);
                if jj > i && rho.abs() > cov.correlation_flag {
                    flagged += 1;
                }
            }
        }
        assert_eq!(flagged, cov.high_correlations.len());
        for pair in &cov.high_correlations {
            assert!(pair.rho.abs() > 0.9, "{pair:?}");
        }
    }
}
