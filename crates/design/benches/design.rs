//! Choosing 50 of 10,000 candidates for the 34-parameter KR1000 (minimal set of 27),
//! candidate blocks included (the Jacobians of the pool, the pool's rank check and W),
//! greedy + exchange to convergence. Target ≤ 0.5 s on one core. The dense criteria (E, O3:
//! a spectrum test per trial matrix) on 50 of 1,000, the pool size they are meant for.
//! `cargo bench -p design`.

use std::hint::black_box;
use std::path::Path;
use std::time::Duration;

use criterion::{Criterion as Bench, criterion_group, criterion_main};
use design::{Criterion, DesignOptions, InfoModel, Scale, select};
use kinematics::{PoseSampler, Robot};
use rand::SeedableRng;
use rand::rngs::ChaCha8Rng;

fn benches(c: &mut Bench) {
    let path =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenarios/robots/kr1000-titan.json");
    let robot = Robot::from_file(&path).expect("robot");
    let pool = PoseSampler::default()
        .sample(&robot, 10_000, &mut ChaCha8Rng::seed_from_u64(1))
        .expect("pool")
        .rad;
    let mut g = c.benchmark_group("design");
    g.sample_size(10).measurement_time(Duration::from_secs(10));
    for crit in [Criterion::D, Criterion::I] {
        g.bench_function(format!("choose_50_of_10000_{crit}"), |b| {
            b.iter(|| {
                let model = InfoModel::new(&robot, black_box(&pool), None, None, &Scale::default())
                    .expect("model");
                select(&model, &DesignOptions::new(crit, 50)).expect("design")
            })
        });
    }
    let small = &pool[..1_000 * robot.n_joints()];
    for crit in [Criterion::E, Criterion::O3] {
        g.bench_function(format!("choose_50_of_1000_{crit}"), |b| {
            b.iter(|| {
                let model = InfoModel::new(&robot, black_box(small), None, None, &Scale::default())
                    .expect("model");
                select(&model, &DesignOptions::new(crit, 50)).expect("design")
            })
        });
    }
    g.finish();
}

criterion_group!(design_benches, benches);
criterion_main!(design_benches);
