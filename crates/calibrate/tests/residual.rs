//! The learned residual model in the calibration workflow (`calibrate::residual`), on
//! simulated UR10s of known truth measured at the real recording's joints: with geometric
//! errors only (the noise floor) the gate declines and nothing is written; with a smooth
//! non-geometric error the gate keeps the model, the written pair reads back, predicts the
//! truth better than the geometry, and a tampered or foreign model file is refused.

use std::path::{Path, PathBuf};

use calibrate::residual::{CvOptions, load_model};
use calibrate::{CalibrateError, IdentifyRequest, Inputs, LoadedRobot, calibrate};
use kinematics::Robot;
use measurements::{Measurement, MeasurementSet};
use rand::SeedableRng;
use rand::rngs::ChaCha8Rng;
use rand_distr::{Distribution, Normal};

/// Tracker noise of the simulations, mm per axis.
const SIGMA_MM: f64 = 0.05;

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn request() -> IdentifyRequest {
    IdentifyRequest::new(
        root().join("scenarios/robots/ur10.json"),
        root().join("data/ur10-ipa/series-b-joint-configurations.csv"),
    )
}

/// The nominal UR10 with geometric errors (≈0.02° on angles, ≈0.4 mm on lengths).
fn truth(nominal: &Robot) -> Robot {
    let mut p = nominal.params();
    for (k, v) in p.iter_mut().enumerate() {
        *v += if nominal.layout().get(k).unit == kinematics::Unit::Deg {
            0.02f64.to_radians() * (((k * 7) % 5) as f64 - 2.0) / 2.0
        } else {
            0.4 * (((k * 3) % 5) as f64 - 2.0) / 2.0
        };
    }
    nominal.with_params(&p).unwrap()
}

/// A smooth error no geometric parameter models, ≈0.4 mm: a gear-like term of q2 and a
/// sag-like term of q2 + q3.
fn unmodelled(q_deg: &[f64]) -> [f64; 3] {
    let (a, b) = (q_deg[1].to_radians(), q_deg[2].to_radians());
    [
        0.4 * (3.0 * a).sin(),
        0.3 * (2.0 * a).cos(),
        0.4 * (a + b).sin(),
    ]
}

/// `n` of the recording's poses (evenly spaced), measured on the simulated truth with
/// noise, plus the unmodelled error when `structure`.
fn simulated(n: usize, structure: bool) -> (Inputs, Robot) {
    let inputs = Inputs::load(&request()).unwrap();
    let truth = truth(&inputs.nominal.robot);
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let noise = Normal::new(0.0, SIGMA_MM).unwrap();
    let rows: Vec<Measurement> = calibrate::residual::evenly_spaced(inputs.data.rows.len(), n)
        .into_iter()
        .map(|i| {
            let q = inputs.data.rows[i].q_deg.clone();
            let rad: Vec<f64> = q.iter().map(|v| v.to_radians()).collect();
            let x = truth.point(&rad);
            let u = if structure { unmodelled(&q) } else { [0.0; 3] };
            let p = [x.x + u[0], x.y + u[1], x.z + u[2]].map(|v| v + noise.sample(&mut rng));
            Measurement::new(q, Some(p))
        })
        .collect();
    let data = MeasurementSet::new("simulated.csv", 6, rows);
    (
        Inputs {
            data,
            validate: None,
            nominal: inputs.nominal,
        },
        truth,
    )
}

#[test]
fn the_noise_floor_is_declined_and_nothing_is_written() {
    let (inputs, _) = simulated(150, false);
    let mut cal = calibrate(&request(), inputs).unwrap();
    cal.fit_residual_model(&CvOptions::default()).unwrap();
    let r = cal.residual().unwrap();
    assert!(!r.cv.helps(), "{:#?}", r.cv);
    assert!(r.model.is_none());
    // Nothing structured is left: the held-out mean of the geometry is the noise's
    // (√(8/π)·σ ≈ 1.6σ for a 3-D Gaussian), and the GP does not move it by more than 3 %.
    assert!(
        r.cv.geometry.mean_mm < 2.0 * SIGMA_MM,
        "{:?}",
        r.cv.geometry
    );
    assert!(
        (r.cv.hybrid.mean_mm / r.cv.geometry.mean_mm - 1.0).abs() < 0.03,
        "{:?} {:?}",
        r.cv.geometry,
        r.cv.hybrid
    );
    assert!(cal.written_residual_model().is_none());
    let (identified, _) = cal.written_specs();
    assert!(identified.provenance.unwrap().residual_model.is_none());
}

#[test]
fn structure_is_kept_written_read_back_and_checked() {
    let (inputs, truth) = simulated(200, true);
    let rows = inputs.data.rows.clone();
    let mut cal = calibrate(&request(), inputs).unwrap();
    cal.fit_residual_model(&CvOptions::default()).unwrap();
    let r = cal.residual().unwrap();
    assert!(r.cv.helps(), "{:#?}", r.cv);
    // The hybrid's held-out error approaches the noise floor; the geometry's is the
    // unmodelled error's size.
    assert!(
        r.cv.hybrid.mean_mm < 0.6 * r.cv.geometry.mean_mm,
        "{:#?}",
        r.cv
    );
    // Coverage of the predicted sd (600 values: ±6 % around 68 %, ±4 % around 95 %).
    assert!(
        (r.cv.coverage.within_1sd - 0.683).abs() < 0.08,
        "{:?}",
        r.cv.coverage
    );
    assert!(
        (r.cv.coverage.within_2sd - 0.954).abs() < 0.05,
        "{:?}",
        r.cv.coverage
    );

    // The pair as `identify` writes it, read back as `predict` reads it.
    let dir = tempfile::tempdir().unwrap();
    let (identified, _) = cal.written_specs();
    let model_text = cal.written_residual_model().unwrap();
    // Same bytes again (deterministic fit).
    assert_eq!(cal.written_residual_model().unwrap(), model_text);
    let reference = identified
        .provenance
        .clone()
        .unwrap()
        .residual_model
        .unwrap();
    assert_eq!(reference.file, calibrate::residual::MODEL_FILE);
    let robot_path = dir.path().join("identified.json");
    std::fs::write(&robot_path, identified.to_json_string()).unwrap();
    let model_path = dir.path().join(&reference.file);
    std::fs::write(&model_path, &model_text).unwrap();
    let robot = LoadedRobot::load(&robot_path, "robot").unwrap();
    let model = load_model(&robot).unwrap().unwrap();

    // On fresh poses of the same robot, the hybrid predicts the truth better.
    let fresh: Vec<Vec<f64>> = calibrate::residual::evenly_spaced(1495, 300)
        .into_iter()
        .map(|i| {
            let mut q = rows[i % rows.len()].q_deg.clone();
            q[1] += 3.0 + (i % 7) as f64;
            q
        })
        .collect();
    let pred = model.predict(&fresh).unwrap();
    let (mut geo, mut hyb) = (0.0, 0.0);
    for (q, p) in fresh.iter().zip(&pred) {
        let rad: Vec<f64> = q.iter().map(|v| v.to_radians()).collect();
        let t = truth.point(&rad);
        let u = unmodelled(q);
        let g = robot.robot.point(&rad);
        let e = [t.x + u[0] - g.x, t.y + u[1] - g.y, t.z + u[2] - g.z];
        geo += e.iter().map(|v| v * v).sum::<f64>();
        hyb += (0..3).map(|c| (e[c] - p.mean_mm[c]).powi(2)).sum::<f64>();
    }
    assert!(
        hyb < 0.25 * geo,
        "hybrid {hyb} vs geometry {geo} (sums of squares)"
    );

    // Compensation with the kept model (the same files, as `kincal compensate` reads them).
    let (_, registered) = cal.written_specs();
    let nominal_path = dir.path().join("registered-nominal.json");
    std::fs::write(&nominal_path, registered.to_json_string()).unwrap();
    let nominal = LoadedRobot::load(&nominal_path, "nominal").unwrap();
    compensation_lands_closer(&robot, &nominal, &model, &truth, &fresh[..120]);
    let trained: Vec<Vec<f64>> = rows
        .iter()
        .skip(1)
        .step_by(19)
        .map(|r| r.q_deg.clone())
        .collect();
    fixed_point_that_does_not_converge_is_refused(&robot, &nominal, &model_text, &trained);

    // A model file changed after the fact is refused, naming both files.
    std::fs::write(&model_path, model_text.replacen("0.", "1.", 1)).unwrap();
    let e = load_model(&robot).unwrap_err();
    assert!(matches!(e, CalibrateError::ResidualMismatch(_)), "{e}");
    assert!(
        e.to_string().contains("SHA-256") && e.to_string().contains("identified.json"),
        "{e}"
    );
    // A missing one too.
    std::fs::remove_file(&model_path).unwrap();
    let e = load_model(&robot).unwrap_err();
    assert!(e.to_string().contains("cannot be read"), "{e}");
}

/// Compensates the joint targets `targets` (degrees) of `nominal` on `robot` with the
/// geometry alone and with `model`: the simulation's truth (`truth` plus the unmodelled error)
/// at the joints to command lands closer to the targets with the model (mean and max, mm);
/// each compensated target satisfies `FK_geom(q) + r(q) = target` to 1e-6 mm (the fixed
/// point converged); the header says the model was applied; without a model the result is
/// `compensate_rows`'s, byte for byte; the same run gives the same bytes.
fn compensation_lands_closer(
    robot: &LoadedRobot,
    nominal: &LoadedRobot,
    model: &calibrate::residual::ResidualModel,
    truth: &Robot,
    targets: &[Vec<f64>],
) {
    let set = joint_targets(targets);
    let opts = identify::CompensationOptions::default();
    let run = |m: Option<&calibrate::residual::ResidualModel>| {
        calibrate::compensate_rows_with((robot, m), nominal, set.clone(), true, &opts, "out")
            .unwrap()
    };
    let geometric = run(None);
    let plain = calibrate::compensate_rows(robot, nominal, set.clone(), true, &opts, "out");
    assert_eq!(plain.unwrap().csv, geometric.csv);
    assert!(geometric.residual_model.is_none() && !geometric.csv.contains("residual model"));
    let hybrid = run(Some(model));
    assert_eq!(run(Some(model)).csv, hybrid.csv, "the same bytes every run");
    let applied = hybrid.residual_model.as_ref().unwrap();
    assert!(
        hybrid
            .csv
            .contains("residual model: applied (residual-model.json"),
        "{}",
        &hybrid.csv[..600]
    );
    assert!(applied.max_steps <= 4, "{applied:?}");
    // The same targets reached both ways (a few of the recording's poses are beyond the
    // calibrated UR10's reach with the flange orientation held: a wrist at its singularity).
    assert_eq!(hybrid.unreachable, geometric.unreachable);
    assert!(hybrid.compensated >= 100, "{:?}", hybrid.unreachable);
    let rad = |q: &[f64]| -> Vec<f64> { q.iter().map(|v| v.to_radians()).collect() };
    // Where the true robot lands at the joints to command, and the fixed point's residual.
    let landed = |c: &calibrate::Compensation| -> (f64, f64) {
        let (mut sum, mut max) = (0.0, 0.0_f64);
        for t in &c.corrected {
            let (q, q_cmd) = (&t.joints_deg, &t.nominal_joints_deg);
            let target = nominal.robot.point(&rad(q_cmd));
            let u = unmodelled(q);
            let p = truth.point(&rad(q)) + nalgebra::Vector3::from(u);
            let e = (p - target).norm();
            sum += e;
            max = max.max(e);
        }
        (sum / c.compensated as f64, max)
    };
    let predicted = model.predict(&hybrid.joints_deg).unwrap();
    for (t, r) in hybrid.corrected.iter().zip(&predicted) {
        let (q, q_cmd) = (&t.joints_deg, &t.nominal_joints_deg);
        let target = nominal.robot.point(&rad(q_cmd));
        let p = robot.robot.point(&rad(q)) + nalgebra::Vector3::from(r.mean_mm);
        assert!(
            (p - target).norm() < 1e-6,
            "{q_cmd:?}: {:e} mm",
            (p - target).norm()
        );
    }
    // Cartesian targets (the nominal TCP poses in the measurement frame, each solved from
    // its commanded joints): the same fixed point, the same joints.
    for t in hybrid.corrected.iter().take(20) {
        let f = nominal.robot.flange(&rad(&t.nominal_joints_deg));
        let p = f.transform_point(&nominal.robot.tool_mm());
        let row = Measurement {
            line: 2,
            id: Some(t.id.clone()),
            point_mm: Some([p.x, p.y, p.z]),
            orientation: Some(kinematics::rotation::unit_quaternion(&f.rot)),
            ..Default::default()
        };
        let cartesian = calibrate::CartesianOptions {
            frame: calibrate::TargetFrame::Measurement,
            start_deg: Some(t.nominal_joints_deg.clone()),
            ..Default::default()
        };
        let c = calibrate::compensate_poses_with(
            (robot, Some(model)),
            nominal,
            MeasurementSet::new("poses.csv", 0, vec![row]),
            false,
            (&opts, &cartesian),
            "out",
        )
        .unwrap();
        assert!(c.csv.contains("residual model: applied"), "{}", c.csv);
        for (a, b) in c.joints_deg[0].iter().zip(&t.joints_deg) {
            assert!((a - b).abs() < 1e-6, "{}: {a} vs {b}", t.id);
        }
    }

    let (g, h) = (landed(&geometric), landed(&hybrid));
    eprintln!(
        "true robot at the compensated joints of {} of {} targets: geometry only mean {:.4} mm, max \
         {:.4} mm; with the residual model mean {:.4} mm, max {:.4} mm",
        hybrid.compensated,
        targets.len(),
        g.0,
        g.1,
        h.0,
        h.1
    );
    assert!(
        h.0 < 0.5 * g.0 && h.1 < g.1,
        "hybrid {h:?} vs geometry {g:?}"
    );
}

/// A model whose mean moves faster with the joints than the point does (the kept model's
/// residuals ×200, ~50 mm, over length scales of 0.02 rad
/// around its training poses, where the UR10's point moves ~1 mm per milliradian) has no
/// fixed point to converge to at those poses (`targets`):
/// compensation refuses the targets, naming each and why; `--allow-unreachable` (here
/// `allow_unreachable`) leaves them out.
fn fixed_point_that_does_not_converge_is_refused(
    robot: &LoadedRobot,
    nominal: &LoadedRobot,
    model_text: &str,
    targets: &[Vec<f64>],
) {
    let mut json: serde_json::Value = serde_json::from_str(model_text).unwrap();
    json["hyperparameters"]["length_scales_rad"] = serde_json::json!(vec![0.02; 6]);
    for key in [
        "residual_mean_mm",
        "residual_scale_mm",
        "training_residuals_mm",
    ] {
        scale(&mut json[key], 200.0);
    }
    let wild =
        calibrate::residual::ResidualModel::from_json_str(&json.to_string(), "wild").unwrap();
    let set = joint_targets(targets);
    let opts = identify::CompensationOptions::default();
    let run = |allow| {
        calibrate::compensate_rows_with(
            (robot, Some(&wild)),
            nominal,
            set.clone(),
            allow,
            &opts,
            "o",
        )
        .map_err(|e| e.to_string())
    };
    let e = run(false).unwrap_err();
    assert!(e.contains("targets.csv:0: t0: unreachable: "), "{e}");
    assert!(
        e.contains("the residual model's fixed point did not converge in 10 steps"),
        "{e}"
    );
    match run(true) {
        Ok(c) => {
            assert!(
                c.unreachable.iter().all(|u| u.contains("residual model")),
                "{c:?}"
            );
            assert!(c.compensated < targets.len() / 2, "{:?}", c.unreachable);
        }
        Err(e) => {
            assert!(e.contains("no target in targets.csv is reachable"), "{e}");
            assert_eq!(e.matches("did not converge").count(), targets.len(), "{e}");
        }
    }
}

/// The joint targets `q` (degrees) as a targets file read, ids `t0`, `t1`, ….
fn joint_targets(q: &[Vec<f64>]) -> MeasurementSet {
    let rows = q
        .iter()
        .enumerate()
        .map(|(k, q)| Measurement::new(q.clone(), None).with_id(format!("t{k}")))
        .collect();
    MeasurementSet::new("targets.csv", 6, rows)
}

/// Every number in `v` times `factor`.
fn scale(v: &mut serde_json::Value, factor: f64) {
    match v {
        serde_json::Value::Number(n) => *v = serde_json::json!(n.as_f64().unwrap() * factor),
        serde_json::Value::Array(a) => a.iter_mut().for_each(|x| scale(x, factor)),
        _ => {}
    }
}

/// Orientation residuals are not modelled: a 6-DoF calibration is refused, with the way to
/// a model of its position residuals.
#[test]
fn six_dof_data_are_refused() {
    let mut request = IdentifyRequest::new(
        root().join("scenarios/robots/ur10.json"),
        root().join("data/ur10-ipa/series-b-6dof.csv"),
    );
    request.split = calibrate::Split::Every {
        every: 15,
        offset: 0,
    };
    let mut cal = calibrate::run(&request).unwrap();
    let e = cal.fit_residual_model(&CvOptions::default()).unwrap_err();
    assert!(matches!(e, CalibrateError::ResidualMismatch(_)), "{e}");
    assert!(e.to_string().contains("points_only"), "{e}");
    assert!(cal.residual().is_none() && cal.written_residual_model().is_none());
}
