//! The learned residual model on the shipped UR10 recording (`data/ur10-ipa`, series B) and
//! the gate's decisions: the figures of `docs/residual-model.md`.
//!
//! ```sh
//! cargo run -p calibrate --example residual_ur10              # 100 200 400 700 training poses
//! cargo run -p calibrate --example residual_ur10 -- 100 400   # chosen sizes
//! cargo run -p calibrate --example residual_ur10 -- gate      # the gate's cases only
//! ```
//!
//! **Table** (`n` training poses): 5 interleaved folds over the 1,495 poses
//! (`residual::folds`: fold f holds out rows f, f+5, …); in each fold, `n` evenly spaced
//! poses of the other four folds identify the geometry (`calibrate::calibrate`, every option
//! at its default: paper parameters, registration, the robust screen) and the same poses'
//! residuals (the identification rows the final fit used) train the GP (defaults of
//! `residual::GpOptions` but `max_train_poses`, raised to hold all 700); the held-out fold is predicted by the geometry alone and by the
//! geometry + the GP's mean. 3-D errors of all five folds pooled (1,495 predictions), mm;
//! the coverage of the GP's standard deviation on them; and the gate's decision on the
//! first fold's `n` training poses (its own 5-fold cross-validation inside them, as
//! `identify --residual-model gp` runs it).
//!
//! **Gate cases**: a simulated noise floor (a UR10 with geometric errors only, measured at
//! the recording's joints with 0.05 mm of white noise: nothing is left for a GP to learn);
//! the same with heavy-tailed errors kept in the data (the GP chases them: the hybrid
//! hurts); and the recording's 60 and 100 evenly spaced poses.

use std::path::{Path, PathBuf};
use std::time::Instant;

use calibrate::residual::{CvOptions, GpOptions, ResidualModel, held_out};
use calibrate::{Calibration, IdentifyRequest, Inputs, calibrate, residuals};
use evaluate::AxisStats;
use measurements::{Measurement, MeasurementSet};
use rand::SeedableRng;
use rand::rngs::ChaCha8Rng;
use rand_distr::{Distribution, Normal, StudentT};

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn with_rows(inputs: &Inputs, rows: Vec<Measurement>, label: &str) -> Inputs {
    Inputs {
        data: MeasurementSet::new(label, inputs.data.n_joints, rows),
        validate: None,
        nominal: inputs.nominal.clone(),
    }
}

fn decision(cal: &mut Calibration) -> String {
    cal.fit_residual_model(&CvOptions::default()).expect("gate");
    let r = cal.residual().expect("outcome");
    let (m, p) = (&r.cv.mean_gain, &r.cv.p95_gain);
    format!(
        "{} (mean gain {:.3} ± {:.3} mm, p95 gain {:.3} ± {:.3} mm)",
        if r.cv.helps() { "used" } else { "declined" },
        m.mean_mm,
        m.scatter_mm,
        p.mean_mm,
        p.scatter_mm
    )
}

fn table(request: &IdentifyRequest, inputs: &Inputs, sizes: &[usize]) {
    let n = inputs.data.rows.len();
    let k = 5;
    println!(
        "{n} poses, {k} interleaved folds; 3-D error on the held-out poses, mm\n\n\
         | training poses | model | mean | RMS | p95 | max | 1σ / 2σ coverage | gate on fold 1's poses |\n\
         |---:|---|---:|---:|---:|---:|---:|---|"
    );
    for &n_train in sizes {
        let started = Instant::now();
        let (mut geo, mut hyb) = (Vec::new(), Vec::new());
        let (mut in1, mut in2, mut values) = (0, 0, 0);
        let mut gate = String::new();
        for (f, test) in calibrate::residual::folds(n, k).into_iter().enumerate() {
            let pool: Vec<usize> = (0..n).filter(|i| i % k != f).collect();
            let train: Vec<Measurement> = calibrate::residual::evenly_spaced(pool.len(), n_train)
                .into_iter()
                .map(|i| inputs.data.rows[pool[i]].clone())
                .collect();
            let mut cal = calibrate(request, with_rows(inputs, train, "series B, training"))
                .expect("calibration");
            let robot = cal.identified_robot();
            let used = &cal.points().expect("points").used;
            let q: Vec<Vec<f64>> = used.iter().map(|r| r.q_deg.clone()).collect();
            // Every training pose (the default cap, 600, would hold 600 of the 700).
            let every = GpOptions {
                max_train_poses: 1000,
                ..GpOptions::default()
            };
            let model = ResidualModel::fit(&q, &residuals(&robot, used), &every).expect("GP");
            let rows: Vec<Measurement> =
                test.iter().map(|&i| inputs.data.rows[i].clone()).collect();
            let qt: Vec<Vec<f64>> = rows.iter().map(|r| r.q_deg.clone()).collect();
            let fold = held_out(&model, &qt, &residuals(&robot, &rows)).expect("predict");
            geo.extend(fold.geometry_mm);
            hyb.extend(fold.hybrid_mm);
            in1 += fold.coverage.0;
            in2 += fold.coverage.1;
            values += fold.coverage.2;
            if f == 0 {
                gate = decision(&mut cal);
            }
        }
        let (g, h) = (
            AxisStats::from_values(&geo).unwrap(),
            AxisStats::from_values(&hyb).unwrap(),
        );
        println!(
            "| {n_train} | geometry | {:.3} | {:.3} | {:.3} | {:.3} | | |",
            g.mean_mm, g.rms_mm, g.p95_mm, g.max_mm
        );
        println!(
            "| {n_train} | geometry + GP | {:.3} | {:.3} | {:.3} | {:.3} | {:.1} % / {:.1} % | {gate} |",
            h.mean_mm,
            h.rms_mm,
            h.p95_mm,
            h.max_mm,
            100.0 * in1 as f64 / values as f64,
            100.0 * in2 as f64 / values as f64,
        );
        eprintln!(
            "({n_train} poses: {:.1} s)",
            started.elapsed().as_secs_f64()
        );
    }
}

/// The gate on a simulated noise floor and on too few real poses.
fn gate_cases(request: &IdentifyRequest, inputs: &Inputs) {
    // A UR10 with geometric errors only (≈0.02° on angles, ≈0.4 mm on lengths), in the
    // nominal's frame, measured at 400 of the recording's joints with 0.05 mm of noise.
    let nominal = &inputs.nominal.robot;
    let mut p = nominal.params();
    for (k, v) in p.iter_mut().enumerate() {
        *v += if nominal.layout().get(k).unit == kinematics::Unit::Deg {
            0.02f64.to_radians() * (((k * 7) % 5) as f64 - 2.0) / 2.0
        } else {
            0.4 * (((k * 3) % 5) as f64 - 2.0) / 2.0
        };
    }
    let truth = nominal.with_params(&p).expect("truth");
    let simulate = |n: usize, noise: &dyn Fn(&mut ChaCha8Rng) -> f64| -> Vec<Measurement> {
        let mut rng = ChaCha8Rng::seed_from_u64(1);
        calibrate::residual::evenly_spaced(inputs.data.rows.len(), n)
            .into_iter()
            .map(|i| {
                let q = inputs.data.rows[i].q_deg.clone();
                let rad: Vec<f64> = q.iter().map(|v| v.to_radians()).collect();
                let x = truth.point(&rad);
                let point = [x.x, x.y, x.z].map(|v| v + noise(&mut rng));
                Measurement::new(q, Some(point))
            })
            .collect()
    };
    let gaussian = Normal::new(0.0, 0.05).unwrap();
    let rows = simulate(400, &|rng| gaussian.sample(rng));
    let mut cal = calibrate(request, with_rows(inputs, rows, "simulated noise floor"))
        .expect("simulated calibration");
    println!(
        "simulated noise floor (400 poses, geometric errors only, σ = 0.05 mm): gate {}",
        decision(&mut cal)
    );
    // The same robot measured with heavy-tailed errors (Student t, 1.2 degrees of freedom,
    // scale 0.05 mm: a gross error every few poses), every row kept (`keep_outliers`):
    // a GP chases the gross errors of its training poses.
    let heavy = StudentT::new(1.2).unwrap();
    let rows = simulate(100, &|rng| 0.05 * heavy.sample(rng));
    let keep = IdentifyRequest {
        keep_outliers: true,
        ..request.clone()
    };
    let mut cal = calibrate(&keep, with_rows(inputs, rows, "simulated heavy tails"))
        .expect("simulated calibration");
    let r = {
        let d = decision(&mut cal);
        let cv = &cal.residual().expect("outcome").cv;
        format!(
            "{d}; held-out mean {:.3} → {:.3} mm, p95 {:.3} → {:.3} mm",
            cv.geometry.mean_mm, cv.hybrid.mean_mm, cv.geometry.p95_mm, cv.hybrid.p95_mm
        )
    };
    println!(
        "simulated heavy-tailed errors kept (100 poses, geometric errors only, Student t ν = \
         1.2, scale 0.05 mm, keep_outliers): gate {r}"
    );
    for n in [60, 100] {
        let rows: Vec<Measurement> = calibrate::residual::evenly_spaced(inputs.data.rows.len(), n)
            .into_iter()
            .map(|i| inputs.data.rows[i].clone())
            .collect();
        let mut cal =
            calibrate(request, with_rows(inputs, rows, "series B, few poses")).expect("few");
        println!(
            "UR10 recording, {n} evenly spaced poses: gate {}",
            decision(&mut cal)
        );
    }
}

fn main() {
    let request = IdentifyRequest::new(
        root().join("scenarios/robots/ur10.json"),
        root().join("data/ur10-ipa/series-b-joint-configurations.csv"),
    );
    let inputs = Inputs::load(&request).expect("UR10 data");
    let args: Vec<String> = std::env::args().skip(1).collect();
    if args.first().map(String::as_str) == Some("gate") {
        gate_cases(&request, &inputs);
        return;
    }
    let sizes: Vec<usize> = if args.is_empty() {
        vec![100, 200, 400, 700]
    } else {
        args.iter()
            .map(|a| a.parse().expect("a pose count"))
            .collect()
    };
    table(&request, &inputs, &sizes);
    println!();
    gate_cases(&request, &inputs);
}
