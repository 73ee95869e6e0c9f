//! Timing of the solver on the paper's problem size (50 poses, 34 or 27 parameters).
//! `cargo run --release -p identify --example lm_timing`

use std::time::Instant;

use identify::{
    IdentifyOptions, LmOptions, ParamSet, Problem, RegistrationPolicy, analyze, identify, solve,
};
use kinematics::{PoseSampler, Robot, RobotSpec};
use rand::SeedableRng;
use rand::rngs::ChaCha8Rng;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../scenarios/robots/kr1000-titan.json"
    );
    let nominal = Robot::from_spec(&RobotSpec::from_json_str(
        &std::fs::read_to_string(path)?,
        path,
    )?)?;
    let poses = PoseSampler::default()
        .sample(&nominal, 50, &mut ChaCha8Rng::seed_from_u64(1))?
        .rad;
    let mut x = nominal.params();
    for (k, v) in x.iter_mut().enumerate() {
        *v += 1e-3 * ((k as f64) * 0.7).sin();
    }
    let truth = nominal.with_params(&x)?;
    let meas = truth.points(&poses);
    let all: Vec<usize> = (0..nominal.n_params()).collect();
    let minimal = ParamSet::Minimal.resolve(&nominal, &poses, None, &Default::default())?;
    let reps = 2000;
    let t = Instant::now();
    for _ in 0..reps {
        std::hint::black_box(nominal.jacobian_batch(&poses));
    }
    println!("jacobian_batch (50 poses): {:?}", t.elapsed() / reps);
    let (_, j) = nominal.jacobian_batch(&poses);
    let t = Instant::now();
    for _ in 0..reps {
        std::hint::black_box(j.transpose() * &j);
    }
    println!("JᵀJ by gemm (150 × 34): {:?}", t.elapsed() / reps);
    let t = Instant::now();
    for _ in 0..reps {
        std::hint::black_box(nominal.points(&poses));
    }
    println!("points (50 poses): {:?}", t.elapsed() / reps);
    for (name, free) in [("paper (34)", &all), ("minimal (27)", &minimal)] {
        let problem = Problem::new(&nominal, &poses, &meas, free.clone())?;
        // One iteration: assembly at the start, one damped solve, one trial evaluation.
        let one = LmOptions {
            max_iterations: 1,
            ..LmOptions::default()
        };
        let t = Instant::now();
        for _ in 0..reps {
            std::hint::black_box(solve(&problem, &one)?);
        }
        let per_iter = t.elapsed() / reps;
        let t = Instant::now();
        let mut iters = 0;
        for _ in 0..reps {
            iters = solve(&problem, &LmOptions::default())?.iterations;
        }
        let full = t.elapsed() / reps;
        let opts = IdentifyOptions {
            registration: RegistrationPolicy::Never,
            ..Default::default()
        };
        let t = Instant::now();
        for _ in 0..reps / 10 {
            std::hint::black_box(identify(&problem, &opts)?);
        }
        let with_cov = t.elapsed() / (reps / 10);
        println!(
            "{name}: first iteration (assemble + solve + trial) {per_iter:?}; full solve \
             {full:?} ({iters} iterations); identify with covariance {with_cov:?}"
        );
    }
    let t = Instant::now();
    for _ in 0..reps / 10 {
        std::hint::black_box(analyze(&nominal, &poses, None, &all, &Default::default())?);
    }
    println!(
        "identifiability analysis (34): {:?}",
        t.elapsed() / (reps / 10)
    );
    Ok(())
}
