//! Independent check: the same problem solved by the `levenberg-marquardt` crate (MINPACK's
//! trust-region LM with QR; nalgebra 0.34, bridged through slices) agrees on the predicted
//! points and the cost.

use crate::common::{TOOL, kr1000, noisy, perturbed, poses};
use identify::{IdentifyOptions, ParamSet, Problem, RegistrationPolicy, identify};
use kinematics::Robot;
use levenberg_marquardt::{LeastSquaresProblem, LevenbergMarquardt};
use nalgebra::Vector3;
use nalgebra034::{DMatrix as DMatrix34, DVector as DVector34, Dyn, storage::Owned};

/// r(x) = p(x; q) − p^meas on the free parameters, internal units.
struct Oracle<'a> {
    robot: Robot,
    poses: &'a [f64],
    meas: &'a [Vector3<f64>],
    free: &'a [usize],
}

impl LeastSquaresProblem<f64, Dyn, Dyn> for Oracle<'_> {
    type ResidualStorage = Owned<f64, Dyn>;
    type JacobianStorage = Owned<f64, Dyn, Dyn>;
    type ParameterStorage = Owned<f64, Dyn>;

    fn set_params(&mut self, x: &DVector34<f64>) {
        let mut all = self.robot.params();
        for (c, &k) in self.free.iter().enumerate() {
            all[k] = x[c];
        }
        self.robot.set_params(&all).unwrap();
    }

    fn params(&self) -> DVector34<f64> {
        let all = self.robot.params();
        DVector34::from_iterator(self.free.len(), self.free.iter().map(|&k| all[k]))
    }

    fn residuals(&self) -> Option<DVector34<f64>> {
        let pred = self.robot.points(self.poses);
        let r: Vec<f64> = pred
            .iter()
            .zip(self.meas)
            .flat_map(|(p, m)| (p - m).iter().copied().collect::<Vec<_>>())
            .collect();
        Some(DVector34::from_vec(r))
    }

    fn jacobian(&self) -> Option<DMatrix34<f64>> {
        // Bridge nalgebra 0.35 → 0.34 through the column-major slice.
        let (_, jac) = self.robot.jacobian_batch(self.poses);
        let sel = jac.select_columns(self.free.iter());
        Some(DMatrix34::from_column_slice(
            sel.nrows(),
            sel.ncols(),
            sel.as_slice(),
        ))
    }
}

#[test]
fn levenberg_marquardt_crate_agrees_on_the_predicted_points() {
    let nominal = kr1000(TOOL);
    let poses_id = poses(&nominal, 50, 1);
    let poses_val = poses(&nominal, 50, 2);
    let all: Vec<usize> = (0..34).collect();
    let truth = perturbed(&nominal, &all, 41);
    let meas = noisy(&truth.points(&poses_id), 0.015, 7);

    for set in [ParamSet::Minimal, ParamSet::Paper] {
        let free = set
            .resolve(&nominal, &poses_id, None, &Default::default())
            .unwrap();
        let problem = Problem::new(&nominal, &poses_id, &meas, free.clone()).unwrap();
        let opts = IdentifyOptions {
            registration: RegistrationPolicy::Never,
            ..Default::default()
        };
        let fit = identify(&problem, &opts).unwrap();
        assert!(fit.stop.converged());

        let oracle = Oracle {
            robot: nominal.clone(),
            poses: &poses_id,
            meas: &meas,
            free: &free,
        };
        let (solved, report) = LevenbergMarquardt::new()
            .with_ftol(1e-14)
            .with_xtol(1e-14)
            .with_gtol(1e-14)
            .minimize(oracle);
        assert!(
            report.termination.was_successful()
                || matches!(
                    report.termination,
                    levenberg_marquardt::TerminationReason::NoImprovementPossible(_)
                ),
            "{:?}",
            report.termination
        );
        // Both sit at the same least-squares minimum: the cost agrees to rounding, the
        // predictions far below the statistical uncertainty σ·√(r/m) ≈ 0.011 mm.
        let oracle_rss = 2.0 * report.objective_function;
        assert!(
            (oracle_rss - fit.rss_mm2).abs() < 1e-9 * fit.rss_mm2,
            "{set:?}: RSS {oracle_rss} vs {}",
            fit.rss_mm2
        );
        for p in [&poses_id, &poses_val] {
            let a = fit.robot.points(p);
            let b = solved.robot.points(p);
            let worst = a
                .iter()
                .zip(&b)
                .map(|(x, y)| (x - y).norm())
                .fold(0.0, f64::max);
            assert!(worst < 1e-6, "{set:?}: predictions differ by {worst:e} mm");
        }
    }
}
