//! Identification cost per 6-DoF pose against per point pose (issue 31): the residual and
//! Jacobian of [`identify::frames`] and a whole fit on 100 KR1000 poses, measured as points
//! (3 rows a pose) and as frames (6 rows a pose), from the same start. `cargo bench -p
//! identify --bench frames`; divide by 100 for the cost per pose.

use std::hint::black_box;
use std::path::Path;
use std::time::Duration;

use criterion::{Criterion, criterion_group, criterion_main};
use identify::frames::{
    FrameData, FrameModel, FrameRow, closed_form_tool, fit_frames, residual_jacobian, select_free,
};
use kinematics::rotation::exp_so3;
use kinematics::{PoseSampler, Robot};
use nalgebra::{DMatrix, Vector3};
use rand::SeedableRng;
use rand::rngs::ChaCha8Rng;

fn data(truth: &FrameModel, poses: &[f64], orientation: bool) -> FrameData {
    let n = truth.robot.n_joints();
    let rows = poses
        .chunks_exact(n)
        .enumerate()
        .map(|(j, q)| {
            let f = truth.robot.flange(q);
            // Deterministic tracker-sized noise: ±0.02 mm, ±0.005°.
            let u = |k: usize| (((j * 6 + k) * 2_654_435_761) % 1000) as f64 / 500.0 - 1.0;
            let dp = Vector3::new(u(0), u(1), u(2)) * 0.02;
            let dr = Vector3::new(u(3), u(4), u(5)) * 0.005f64.to_radians();
            FrameRow {
                pose: j,
                target: 0,
                point_mm: f.rot * truth.targets_mm[0] + f.pos_mm + dp,
                rotation: orientation.then(|| exp_so3(&dr) * f.rot * truth.tool_rotation),
                w_pos: [1.0; 3],
                w_rot: 5.0f64.to_degrees(),
            }
        })
        .collect();
    FrameData {
        poses_rad: poses.to_vec(),
        n_joints: n,
        target_names: vec![String::new()],
        rows,
    }
}

fn benches(c: &mut Criterion) {
    let path =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenarios/robots/kr1000-titan.json");
    let nominal = Robot::from_file(&path).expect("robot");
    let poses = PoseSampler::default()
        .sample(&nominal, 100, &mut ChaCha8Rng::seed_from_u64(3))
        .expect("poses")
        .rad;
    let mut x = nominal.params();
    for (k, v) in x.iter_mut().enumerate() {
        *v += 1e-4 * (((k * 7) % 5) as f64 - 2.0);
    }
    let truth = FrameModel {
        robot: nominal.with_params(&x).unwrap(),
        tool_rotation: exp_so3(&Vector3::new(0.2, -0.1, 0.4)),
        targets_mm: vec![Vector3::new(60.0, 20.0, 150.0)],
    };
    let mut g = c.benchmark_group("frames");
    g.measurement_time(Duration::from_secs(3));
    for (label, orientation) in [("point", false), ("6dof", true)] {
        let d = data(&truth, &poses, orientation);
        let start = closed_form_tool(&nominal, &d, None, &[None]);
        let all: Vec<usize> = (0..nominal.n_params()).collect();
        let (free, _) = select_free(&start, &d, &all).unwrap();
        let mut j = DMatrix::zeros(0, 0);
        g.bench_function(format!("residual_jacobian_100_{label}"), |b| {
            b.iter(|| black_box(residual_jacobian(&start, &d, &free, Some(&mut j))))
        });
        let fit = fit_frames(&start, &d, &free, &identify::LmOptions::default()).unwrap();
        eprintln!(
            "{label}: {} unknowns, {} iterations",
            free.len(),
            fit.iterations
        );
        g.bench_function(format!("fit_100_{label}"), |b| {
            b.iter(|| {
                black_box(fit_frames(&start, &d, &free, &identify::LmOptions::default()).unwrap())
            })
        });
    }
    g.finish();
}

criterion_group!(frames_benches, benches);
criterion_main!(frames_benches);
