//! Fitting and predicting the residual model (`cargo bench -p residual`): a fit on 200 and
//! 400 poses of a six-joint arm (hyperparameters by marginal likelihood, then the factor)
//! and the prediction of 1,000 poses (mean and sd) from a 400-pose model, reported in
//! poses per second (criterion's `elem/s`). Synthetic residuals: a smooth function of q2, q3
//! plus 0.02 mm of noise, as in `tests/model.rs`.

use std::hint::black_box;
use std::time::Duration;

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use rand::rngs::ChaCha8Rng;
use rand::{RngExt, SeedableRng};
use rand_distr::{Distribution, Normal};
use residual::{GpOptions, ResidualModel};

fn data(n: usize, seed: u64) -> (Vec<Vec<f64>>, Vec<[f64; 3]>) {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let noise = Normal::new(0.0, 0.02).unwrap();
    let q: Vec<Vec<f64>> = (0..n)
        .map(|_| (0..6).map(|_| rng.random_range(-170.0..170.0)).collect())
        .collect();
    let r = q
        .iter()
        .map(|q| {
            let (a, b) = (q[1].to_radians(), q[2].to_radians());
            [0.25 * a.sin(), 0.2 * (a + b).cos(), 0.2 * (2.0 * b).sin()]
                .map(|v| v + noise.sample(&mut rng))
        })
        .collect();
    (q, r)
}

fn benches(c: &mut Criterion) {
    let quick = std::env::var_os("KINCAL_BENCH_QUICK").is_some();
    let mut g = c.benchmark_group("residual");
    g.sample_size(10)
        .warm_up_time(Duration::from_millis(if quick { 200 } else { 1000 }))
        .measurement_time(Duration::from_millis(if quick { 1000 } else { 5000 }));
    for n in [200, 400] {
        let (q, r) = data(n, 1);
        g.throughput(Throughput::Elements(n as u64));
        g.bench_function(format!("fit_{n}_poses"), |b| {
            b.iter(|| {
                ResidualModel::fit(black_box(&q), black_box(&r), &GpOptions::default()).unwrap()
            })
        });
    }
    let (q, r) = data(400, 1);
    let model = ResidualModel::fit(&q, &r, &GpOptions::default()).unwrap();
    let (queries, _) = data(1000, 2);
    g.throughput(Throughput::Elements(1000));
    g.bench_function("predict_1000_poses_from_400", |b| {
        b.iter(|| model.predict(black_box(&queries)).unwrap())
    });
    g.finish();
}

criterion_group!(residual_benches, benches);
criterion_main!(residual_benches);
