use design::{Criterion, DesignOptions, InfoModel, Scale, select};
use kinematics::Robot;
use std::time::Instant;
fn main() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../scenarios/robots/kr1000-titan.json");
    let robot = Robot::from_file(&path).unwrap();
    let k: usize = std::env::args()
        .nth(1)
        .map(|s| s.parse().unwrap())
        .unwrap_or(1000);
    let n: usize = std::env::args()
        .nth(2)
        .map(|s| s.parse().unwrap())
        .unwrap_or(50);
    let pool = identify::random_poses(&robot, k, 1).unwrap();
    for crit in Criterion::ALL {
        let t = Instant::now();
        let model = InfoModel::new(&robot, &pool, None, None, &Scale::default()).unwrap();
        let t1 = t.elapsed();
        let d = select(&model, &DesignOptions::new(crit, n)).unwrap();
        let first: Vec<usize> = (0..n).collect();
        println!(
            "{crit}: model {:?} total {:?} greedy {:.6e} final {:.6e} random-first-n {:.6e} passes {} swaps {}",
            t1,
            t.elapsed(),
            d.greedy_value,
            d.value,
            model.value(crit, &first).unwrap(),
            d.passes,
            d.swaps
        );
    }
}
