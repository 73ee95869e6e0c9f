//! The real UR10 series B (`data/ur10-ipa/`, 1,495 poses measured by a laser tracker): N rows
//! chosen by design (their joints only, on the nominal model) against the median of 20 random
//! sets of N rows, each identified (base registration into the tracker frame first, then
//! the minimal set by LM) and validated on all the other rows.
//!
//! `cargo run --release -p design --example ur10_series_b`

use std::path::Path;

use design::{Criterion, select_rows};
use identify::{IdentifyOptions, ParamSet, Problem, RegistrationPolicy, identify, register_base};
use kinematics::Robot;
use measurements::ReadOptions;
use nalgebra::Vector3;
use rand::SeedableRng;
use rand::rngs::ChaCha8Rng;
use rand::seq::index::sample;

/// Identifies on `rows` and returns (mean, max) 3-D error on every other row, mm.
fn identify_and_validate(
    robot: &Robot,
    poses: &[f64],
    points: &[Vector3<f64>],
    rows: &[usize],
) -> (f64, f64) {
    let n = robot.n_joints();
    let mut chosen = vec![false; points.len()];
    let (mut p, mut x) = (Vec::new(), Vec::new());
    for &r in rows {
        chosen[r] = true;
        p.extend_from_slice(&poses[r * n..(r + 1) * n]);
        x.push(points[r]);
    }
    let (start, _) = register_base(robot, &p, &x).expect("registration");
    let free = ParamSet::Minimal
        .resolve(&start, &p, None, &Default::default())
        .expect("minimal set");
    let problem = Problem::new(&start, &p, &x, free).expect("problem");
    let opts = IdentifyOptions {
        registration: RegistrationPolicy::Never,
        ..IdentifyOptions::default()
    };
    let fit = identify(&problem, &opts).expect("identification");
    let errs: Vec<f64> = (0..points.len())
        .filter(|&r| !chosen[r])
        .map(|r| (fit.robot.point(&poses[r * n..(r + 1) * n]) - points[r]).norm())
        .collect();
    let mean = errs.iter().sum::<f64>() / errs.len() as f64;
    let max = errs.iter().copied().fold(0.0, f64::max);
    (mean, max)
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(|a, b| a.total_cmp(b));
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

fn main() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let robot = Robot::from_file(&root.join("scenarios/robots/ur10.json")).expect("robot");
    let data = measurements::read_file(
        &root.join("data/ur10-ipa/series-b-joint-configurations.csv"),
        &ReadOptions::new(robot.n_joints()),
    )
    .expect("data");
    let q_deg: Vec<f64> = data.rows.iter().flat_map(|r| r.q_deg.clone()).collect();
    let poses: Vec<f64> = q_deg.iter().map(|d| d.to_radians()).collect();
    let points: Vec<Vector3<f64>> = data
        .rows
        .iter()
        .map(|r| Vector3::from(r.point_mm.expect("points")))
        .collect();
    let rows = points.len();
    println!(
        "| poses | D-optimal mean / max (mm) | I-optimal mean / max (mm) | random, median of 20: mean / max (mm) |"
    );
    println!("|---:|---:|---:|---:|");
    for n in [20, 30, 50] {
        let mut cells = Vec::new();
        for crit in [Criterion::D, Criterion::I] {
            let chosen = select_rows(&robot, &q_deg, n, crit, None).expect("design");
            let (mean, max) = identify_and_validate(&robot, &poses, &points, &chosen);
            cells.push(format!("{mean:.3} / {max:.3}"));
        }
        let (mut means, mut maxes) = (Vec::new(), Vec::new());
        for k in 0..20u64 {
            let mut rng = ChaCha8Rng::seed_from_u64(2026);
            rng.set_stream(k);
            let mut set = sample(&mut rng, rows, n).into_vec();
            set.sort_unstable();
            let (mean, max) = identify_and_validate(&robot, &poses, &points, &set);
            means.push(mean);
            maxes.push(max);
        }
        println!(
            "| {n} | {} | {} | {:.3} / {:.3} |",
            cells[0],
            cells[1],
            median(means),
            median(maxes)
        );
    }
}
