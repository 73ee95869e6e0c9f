//! The residual model on data of known truth: a smooth function of the joints plus white
//! noise of known σ. Tolerances come from the noise: a model that learnt the function
//! predicts held-out poses to about σ; one that did not is off by the function's own size.

use rand::rngs::ChaCha8Rng;
use rand::{RngExt, SeedableRng};
use rand_distr::{Distribution, Normal};
use residual::{CvOptions, GpOptions, ResidualError, ResidualModel, cross_validate};

/// Noise of the synthetic residuals, mm per axis.
const SIGMA_MM: f64 = 0.02;

/// Random poses of a six-joint arm, degrees (±170°).
fn poses(n: usize, seed: u64) -> Vec<Vec<f64>> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    (0..n)
        .map(|_| (0..6).map(|_| rng.random_range(-170.0..170.0)).collect())
        .collect()
}

/// The structure: a gear-like and a compliance-like term, ≈0.3 mm, of q2, q3 (q1, q4–q6
/// do not matter).
fn truth(q: &[f64]) -> [f64; 3] {
    let (a, b) = (q[1].to_radians(), q[2].to_radians());
    [0.25 * a.sin(), 0.2 * (a + b).cos(), 0.2 * (2.0 * b).sin()]
}

fn noisy(q: &[Vec<f64>], seed: u64, structure: bool) -> Vec<[f64; 3]> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let noise = Normal::new(0.0, SIGMA_MM).unwrap();
    q.iter()
        .map(|q| {
            let t = if structure { truth(q) } else { [0.0; 3] };
            t.map(|v| v + noise.sample(&mut rng))
        })
        .collect()
}

#[test]
fn learns_a_smooth_function_to_the_noise() {
    let q = poses(150, 1);
    let r = noisy(&q, 2, true);
    let model = ResidualModel::fit(&q, &r, &GpOptions::default()).unwrap();
    assert!(model.optimiser().converged, "{:?}", model.optimiser());
    // The joints that do not matter get long length scales, q2 and q3 short ones.
    let ls = &model.hyperparameters().length_scales_rad;
    assert!(ls[1] < 3.0 && ls[2] < 3.0, "{ls:?}");
    assert!(ls[0] > 5.0 && ls[5] > 5.0, "{ls:?}");
    // The learnt noise is the true one (150·3 values: ±20 % is many standard errors).
    for s in model.noise_sd_mm() {
        assert!(
            (s / SIGMA_MM - 1.0).abs() < 0.3,
            "noise {:?} mm",
            model.noise_sd_mm()
        );
    }
    // Held out: the mean predicts the truth to well under the function's size (≈0.2 mm).
    let qt = poses(200, 3);
    let pred = model.predict(&qt).unwrap();
    let mut se = 0.0;
    for (q, p) in qt.iter().zip(&pred) {
        let t = truth(q);
        se += (0..3).map(|c| (p.mean_mm[c] - t[c]).powi(2)).sum::<f64>();
        let floor = model.noise_sd_mm();
        assert!((0..3).all(|c| p.sd_mm[c] >= floor[c]), "{p:?} {floor:?}");
    }
    let rms = (se / (3.0 * qt.len() as f64)).sqrt();
    assert!(rms < 2.0 * SIGMA_MM, "held-out RMS of the mean {rms} mm");
}

#[test]
fn same_bytes_twice_and_through_the_file() {
    let q = poses(60, 4);
    let r = noisy(&q, 5, true);
    let a = ResidualModel::fit(&q, &r, &GpOptions::default()).unwrap();
    let b = ResidualModel::fit(&q, &r, &GpOptions::default()).unwrap();
    assert_eq!(a.to_json_string(), b.to_json_string());
    let read = ResidualModel::from_json_str(&a.to_json_string(), "model.json").unwrap();
    assert_eq!(read.to_json_string(), a.to_json_string());
    let qt = poses(10, 6);
    let (pa, pr) = (a.predict(&qt).unwrap(), read.predict(&qt).unwrap());
    for (x, y) in pa.iter().zip(&pr) {
        assert_eq!(x.mean_mm.map(f64::to_bits), y.mean_mm.map(f64::to_bits));
        assert_eq!(x.sd_mm.map(f64::to_bits), y.sd_mm.map(f64::to_bits));
    }
}

#[test]
fn bad_inputs_are_named() {
    let q = poses(30, 7);
    let r = noisy(&q, 8, true);
    let e = ResidualModel::fit(&q[..10], &r[..10], &GpOptions::default()).unwrap_err();
    assert!(e.to_string().contains("at least 20"), "{e}");
    let e = ResidualModel::fit(&q, &r[..29], &GpOptions::default()).unwrap_err();
    assert!(e.to_string().contains("30 poses but 29 residuals"), "{e}");
    let mut bad = r.clone();
    bad[4][1] = f64::NAN;
    let e = ResidualModel::fit(&q, &bad, &GpOptions::default()).unwrap_err();
    assert!(matches!(e, ResidualError::NonFinite { row: 4, .. }), "{e}");
    let model = ResidualModel::fit(&q, &r, &GpOptions::default()).unwrap();
    let e = model.predict(&[vec![0.0; 5]]).unwrap_err();
    assert!(
        e.to_string().contains("5 joints") && e.to_string().contains("trained on 6"),
        "{e}"
    );

    let text = model.to_json_string();
    let e = ResidualModel::from_json_str(&text.replace("kincal-residual-model/1", "x/2"), "m.json")
        .unwrap_err();
    assert!(
        e.to_string().contains("m.json") && e.to_string().contains("format"),
        "{e}"
    );
    let e = ResidualModel::from_json_str(
        &text.replacen("\"kernel\"", "\"colour\": 1,\n  \"kernel\"", 1),
        "m.json",
    )
    .unwrap_err();
    assert!(e.to_string().contains("unknown field `colour`"), "{e}");
    let e = ResidualModel::from_json_str(
        &text.replace("\"noise_variance\": ", "\"noise_variance\": -"),
        "m.json",
    )
    .unwrap_err();
    assert!(e.to_string().contains("noise_variance"), "{e}");
}

/// The gate on data of known truth: with structure it uses the hybrid, on noise alone it
/// declines (the fold-to-fold scatter of a zero gain is never below the gain).
#[test]
fn the_gate_takes_structure_and_declines_noise() {
    let q = poses(150, 9);
    let opts = CvOptions::default();
    for (structure, helps) in [(true, true), (false, false)] {
        let r = noisy(&q, 10, structure);
        // The "geometry" here is fixed (residuals as given): the fit is the residual model's.
        let cv = cross_validate(&q, &opts, |_| Ok(r.clone())).unwrap();
        assert_eq!(cv.folds.len(), 5);
        assert_eq!(cv.helps(), helps, "structure {structure}: {cv:#?}");
        if structure {
            assert!(cv.hybrid.mean_mm < 0.5 * cv.geometry.mean_mm, "{cv:#?}");
        }
        // Coverage of a Gaussian model of Gaussian data: 68 % and 95 % (450 values: ±7 %).
        assert!(
            (cv.coverage.within_1sd - 0.683).abs() < 0.07,
            "{:?}",
            cv.coverage
        );
        assert!(
            (cv.coverage.within_2sd - 0.954).abs() < 0.04,
            "{:?}",
            cv.coverage
        );
    }
    let e = cross_validate(&q, &CvOptions { folds: 2, ..opts }, |_| Ok(vec![])).unwrap_err();
    assert!(e.to_string().contains("at least 3"), "{e}");
    let e = cross_validate(&q, &CvOptions::default(), |_| Ok(vec![[0.0; 3]; 3])).unwrap_err();
    assert!(
        e.to_string().contains("fold 1") && e.to_string().contains("3 residuals"),
        "{e}"
    );
}

/// A case where the hybrid hurts: heavy-tailed errors (Student t, ν = 1.2: a gross error
/// every few poses) with no structure. The GP chases its training poses' gross errors, the
/// held-out error grows, and the gate declines.
#[test]
fn the_gate_declines_a_model_that_hurts() {
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    let q: Vec<Vec<f64>> = (0..100)
        .map(|_| (0..6).map(|_| rng.random_range(-170.0..170.0)).collect())
        .collect();
    let t = rand_distr::StudentT::new(1.2).unwrap();
    let r: Vec<[f64; 3]> = (0..100)
        .map(|_| [0; 3].map(|_| 0.05 * t.sample(&mut rng)))
        .collect();
    let cv = cross_validate(&q, &CvOptions::default(), |_| Ok(r.clone())).unwrap();
    assert!(!cv.helps(), "{cv:#?}");
    assert!(cv.hybrid.mean_mm > 1.1 * cv.geometry.mean_mm, "{cv:#?}");
    assert!(
        cv.mean_gain.mean_mm < 0.0 && cv.p95_gain.mean_mm < 0.0,
        "{cv:#?}"
    );
}

/// 6-DoF data: the orientation part (the same GP on degrees) round-trips through its `/2`
/// file with `_deg` field names; the position part alone still writes `/1`, and a `/1`
/// file with an orientation part is refused.
#[test]
fn the_orientation_part_round_trips_as_format_2() {
    let q = poses(60, 11);
    let r = noisy(&q, 12, true);
    let o: Vec<[f64; 3]> = noisy(&q, 13, true)
        .iter()
        .map(|v| v.map(|c| 0.1 * c))
        .collect();
    let mut model = ResidualModel::fit(&q, &r, &GpOptions::default()).unwrap();
    let position_only = model.to_json_string();
    assert!(position_only.contains("\"format\": \"kincal-residual-model/1\""));
    assert!(!position_only.contains("orientation") && !model.has_orientation());
    model
        .fit_orientation(&q, &o, &GpOptions::default())
        .unwrap();
    let text = model.to_json_string();
    assert!(text.contains("\"format\": \"kincal-residual-model/2\""));
    for field in [
        "\"orientation\"",
        "\"residual_mean_deg\"",
        "\"residual_scale_deg\"",
        "\"training_residuals_deg\"",
    ] {
        assert!(text.contains(field), "{field}");
    }
    // The position part's bytes are unchanged by the orientation part.
    let read = ResidualModel::from_json_str(&text, "m.json").unwrap();
    assert_eq!(read.to_json_string(), text);
    let qt = poses(5, 14);
    let (a, b) = (
        model.predict_orientation(&qt).unwrap().unwrap(),
        read.predict_orientation(&qt).unwrap().unwrap(),
    );
    assert_eq!(a, b);
    assert_eq!(model.predict(&qt).unwrap(), read.predict(&qt).unwrap());
    let e = ResidualModel::from_json_str(
        &text.replace("kincal-residual-model/2", "kincal-residual-model/1"),
        "m.json",
    )
    .unwrap_err();
    assert!(e.to_string().contains("with the orientation part"), "{e}");
    let e = ResidualModel::from_json_str(
        &text.replacen(
            "\"training_residuals_deg\": [",
            "\"training_residuals_deg\": [[0,0,0],",
            1,
        ),
        "m.json",
    )
    .unwrap_err();
    assert!(e.to_string().contains("orientation"), "{e}");
    // Other poses than the position part's are refused.
    let e = model
        .fit_orientation(&poses(60, 15), &o, &GpOptions::default())
        .unwrap_err();
    assert!(e.to_string().contains("poses of the position part"), "{e}");
}
