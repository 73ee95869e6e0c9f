//! Normal equations, LM solves and whole identifications on the paper's problem size (50
//! poses, 34 parameters, tracker-like noise, from the nominal model), and the real UR10 data
//! set (100 poses, 35 parameters, registration first). `cargo bench -p identify`.

use std::hint::black_box;
use std::path::{Path, PathBuf};
use std::time::Duration;

use criterion::{Criterion, criterion_group, criterion_main};
use identify::{
    Damping, IdentifyOptions, LmOptions, ParamSet, Problem, RegistrationPolicy, SimdLevel,
    identify, set_simd_level, solve,
};
use kinematics::{PoseSampler, Robot, RobotSpec};
use nalgebra::{DMatrix, DVector, Vector3};
use rand::SeedableRng;
use rand::rngs::ChaCha8Rng;
use rand_distr::{Distribution, Normal};

fn workspace() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn robot(file: &str, tool_mm: Option<[f64; 3]>) -> Robot {
    let path = workspace().join("scenarios/robots").join(file);
    let text = std::fs::read_to_string(&path).expect("robot file");
    let mut spec = RobotSpec::from_json_str(&text, &path.display().to_string()).expect("model");
    if let Some(t) = tool_mm {
        spec.tool_mm = t;
    }
    Robot::from_spec(&spec).expect("robot")
}

/// The nominal model with errors of the paper's size (≈0.02° on angles, ≈0.4 mm on lengths).
fn perturbed(nominal: &Robot) -> Robot {
    let mut p = nominal.params();
    for (k, v) in p.iter_mut().enumerate() {
        *v += if nominal.layout().get(k).unit == kinematics::Unit::Deg {
            0.02f64.to_radians() * (((k * 7) % 5) as f64 - 2.0) / 2.0
        } else {
            0.4 * (((k * 3) % 5) as f64 - 2.0) / 2.0
        };
    }
    nominal.with_params(&p).expect("perturbed")
}

/// The real UR10 series (Fraunhofer IPA), if present: every 15th row → 100 poses.
fn ur10_data() -> Option<(Vec<f64>, Vec<Vector3<f64>>)> {
    let candidates = [
        std::env::var_os("KINCAL_UR10_CSV").map(PathBuf::from),
        Some(workspace().join("data/ur10-ipa/series-b-joint-configurations.csv")),
    ];
    let path = candidates.into_iter().flatten().find(|p| p.exists())?;
    let set =
        measurements::read_file(&path, &measurements::ReadOptions::new(6)).expect("UR10 data");
    let mut poses = Vec::new();
    let mut points = Vec::new();
    for row in set.rows.iter().step_by(15).take(100) {
        poses.extend(row.q_deg.iter().map(|v| v.to_radians()));
        points.push(Vector3::from(row.point_mm.expect("measured point")));
    }
    Some((poses, points))
}

fn benches(c: &mut Criterion) {
    let nominal = robot("kr1000-titan.json", Some([60.0, 20.0, 150.0]));
    let truth = perturbed(&nominal);
    let poses = PoseSampler::default()
        .sample(&nominal, 50, &mut ChaCha8Rng::seed_from_u64(1))
        .expect("poses")
        .rad;
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let noise = Normal::new(0.0, 0.02).expect("normal");
    let measured: Vec<Vector3<f64>> = truth
        .points(&poses)
        .iter()
        .map(|p| {
            p + Vector3::new(
                noise.sample(&mut rng),
                noise.sample(&mut rng),
                noise.sample(&mut rng),
            )
        })
        .collect();
    let all: Vec<usize> = (0..nominal.n_params()).collect();
    let problem = Problem::new(&nominal, &poses, &measured, all).expect("problem");

    // `cargo xtask bench --quick` sets KINCAL_BENCH_QUICK: shorter measurements.
    let quick = std::env::var_os("KINCAL_BENCH_QUICK").is_some();
    let mut g = c.benchmark_group("identify");
    g.sample_size(if quick { 10 } else { 30 })
        .warm_up_time(Duration::from_millis(if quick { 200 } else { 500 }))
        .measurement_time(Duration::from_millis(if quick { 700 } else { 2000 }));

    let mut a = DMatrix::zeros(0, 0);
    let mut v = DVector::zeros(0);
    g.bench_function("normal_equations_50x34", |b| {
        b.iter(|| black_box(&problem).normal_equations(&mut a, &mut v))
    });
    for damping in [Damping::levenberg(), Damping::nielsen()] {
        let lm = LmOptions::with_damping(damping);
        g.bench_function(format!("lm_{}_50x34", damping.name()), |b| {
            b.iter(|| solve(black_box(&problem), &lm).expect("solves"))
        });
        let opts = IdentifyOptions {
            lm,
            registration: RegistrationPolicy::Never,
            ..IdentifyOptions::default()
        };
        g.bench_function(format!("identify_{}_50x34", damping.name()), |b| {
            b.iter(|| identify(black_box(&problem), &opts).expect("identifies"))
        });
    }

    // The same on the portable build of the vector kernels (SSE2 on x86-64), for
    // comparison with machines without AVX2/AVX-512 (results are bit-identical).
    if SimdLevel::detect() > SimdLevel::Portable {
        set_simd_level(Some(SimdLevel::Portable));
        g.bench_function("normal_equations_50x34_portable", |b| {
            b.iter(|| black_box(&problem).normal_equations(&mut a, &mut v))
        });
        let lm = LmOptions::default();
        let opts = IdentifyOptions {
            lm,
            registration: RegistrationPolicy::Never,
            ..IdentifyOptions::default()
        };
        g.bench_function("identify_levenberg_50x34_portable", |b| {
            b.iter(|| identify(black_box(&problem), &opts).expect("identifies"))
        });
        set_simd_level(None);
    }

    // Issue 19: the extended model (34 geometric + 6 compliance + 12 first-harmonic gear
    // columns, 50 poses), on the lane kernels like the geometric model (weights cached per
    // pose by PoseTrig::for_robot); its target is ≤ 2× identify_levenberg_50x34.
    {
        let names: Vec<String> = (1..=6)
            .map(|j| format!("compliance_{j}"))
            .chain((1..=6).flat_map(|j| [format!("gear_{j}_h1_sin"), format!("gear_{j}_h1_cos")]))
            .collect();
        let ext_nominal = nominal.with_extended(&names, "bench").expect("extended");
        let mut x = truth
            .with_extended(&names, "bench")
            .expect("extended")
            .params();
        let first = nominal.n_params();
        for (k, v) in x[first..].iter_mut().enumerate() {
            let info = ext_nominal.layout().get(first + k);
            // 0.03–0.5 µrad/(N·m) and ±10″: the sizes of the paper scenario's truth.
            let display = if info.unit == kinematics::Unit::MicroradPerNm {
                [0.03, 0.03, 0.05, 0.5, 0.5, 1.0][k % 6]
            } else {
                10.0 * (((k * 5) % 7) as f64 - 3.0) / 3.0
            };
            *v = info.from_display(display);
        }
        let ext_truth = ext_nominal.with_params(&x).expect("truth");
        let mut rng = ChaCha8Rng::seed_from_u64(8);
        let ext_measured: Vec<Vector3<f64>> = ext_truth
            .points(&poses)
            .iter()
            .map(|p| {
                p + Vector3::new(
                    noise.sample(&mut rng),
                    noise.sample(&mut rng),
                    noise.sample(&mut rng),
                )
            })
            .collect();
        let all: Vec<usize> = (0..ext_nominal.n_params()).collect();
        let ext_problem =
            Problem::new(&ext_nominal, &poses, &ext_measured, all).expect("extended problem");
        let opts = IdentifyOptions {
            lm: LmOptions::default(),
            registration: RegistrationPolicy::Never,
            ..IdentifyOptions::default()
        };
        g.bench_function("identify_levenberg_50x52_extended", |b| {
            b.iter(|| identify(black_box(&ext_problem), &opts).expect("identifies"))
        });
    }

    if let Some((ur_poses, ur_points)) = ur10_data() {
        let ur10 = robot("ur10.json", None);
        let free = ParamSet::Paper
            .resolve(&ur10, &ur_poses, None, &Default::default())
            .expect("free set");
        let ur_problem = Problem::new(&ur10, &ur_poses, &ur_points, free).expect("problem");
        let opts = IdentifyOptions::default();
        g.bench_function("identify_ur10_real_100x35", |b| {
            b.iter(|| identify(black_box(&ur_problem), &opts).expect("identifies"))
        });
        // The paper set above reaches the iteration cap on these data (a nearly flat
        // direction); the minimal set converges in a few iterations.
        let minimal = ParamSet::Minimal
            .resolve(&ur10, &ur_poses, None, &Default::default())
            .expect("minimal set");
        let name = format!("identify_ur10_real_100x{}_minimal", minimal.len());
        let ur_min = Problem::new(&ur10, &ur_poses, &ur_points, minimal).expect("problem");
        g.bench_function(name, |b| {
            b.iter(|| identify(black_box(&ur_min), &opts).expect("identifies"))
        });
    } else {
        eprintln!("UR10 data not found (set KINCAL_UR10_CSV): skipping identify_ur10_real_100x35");
    }
    g.finish();
}

criterion_group!(identify_benches, benches);
criterion_main!(identify_benches);
