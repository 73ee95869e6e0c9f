//! Prints each criterion's design of 50 of K random KR1000 poses with timings:
//! `cargo run --release -p design --example smoke -- K N`.
use design::{Criterion, DesignOptions, InfoModel, Scale, select};
use kinematics::{PoseSampler, Robot};
use rand::SeedableRng;
use rand::rngs::ChaCha8Rng;
use std::time::Instant;
fn main() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../scenarios/robots/kr1000-titan.json");
    let robot = Robot::from_file(&path).unwrap();
    let k: usize = std::env::args().nth(1).map_or(1000, |s| s.parse().unwrap());
    let n: usize = std::env::args().nth(2).map_or(50, |s| s.parse().unwrap());
    let pool = PoseSampler::default()
        .sample(&robot, k, &mut ChaCha8Rng::seed_from_u64(1))
        .unwrap()
        .rad;
    for crit in [
        Criterion::D,
        Criterion::A,
        Criterion::I,
        Criterion::O1,
        Criterion::E,
    ] {
        let t = Instant::now();
        let model = InfoModel::new(&robot, &pool, None, None, &Scale::default()).unwrap();
        let t1 = t.elapsed();
        let d = select(&model, &DesignOptions::new(crit, n)).unwrap();
        println!(
            "{crit}: model {t1:?} total {:?} greedy {:.6e} final {:.6e} ({:x}) passes {} swaps {} set {:?}",
            t.elapsed(),
            d.greedy_value,
            d.value,
            d.value.to_bits(),
            d.passes,
            d.swaps,
            &d.selected[..8]
        );
    }
}
