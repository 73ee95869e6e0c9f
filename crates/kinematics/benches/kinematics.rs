//! Forward kinematics of 50 poses (one by one, and with their sines and cosines prepared as
//! an identification does), the 50 × 34 identification Jacobian and IK of one pose (a
//! compensation: nominal target, perturbed model, start at the commanded joints).
//! `cargo bench -p kinematics` (or `cargo xtask bench`).

use std::hint::black_box;
use std::time::Duration;

use criterion::{Criterion, criterion_group, criterion_main};
use kinematics::{IkOptions, IkTarget, PoseTrig, Robot, RobotSpec};
use nalgebra::{DMatrix, Vector3};

fn kr1000() -> Robot {
    let text = include_str!("../../../scenarios/robots/kr1000-titan.json");
    let mut spec = RobotSpec::from_json_str(text, "kr1000").expect("model");
    spec.tool_mm = [60.0, 20.0, 150.0];
    Robot::from_spec(&spec).expect("robot")
}

/// Deterministic poses within 80 % of the joint limits, |q5| ≥ 10°.
fn poses(robot: &Robot, m: usize) -> Vec<f64> {
    let n = robot.n_joints();
    let mut state = 0x9e37_79b9_7f4a_7c15_u64;
    let mut next = || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state >> 11) as f64 / (1u64 << 53) as f64
    };
    let mut out = Vec::with_capacity(m * n);
    while out.len() < m * n {
        let q: Vec<f64> = (0..n)
            .map(|i| {
                let [lo, hi] = robot.limits_rad(i);
                0.8 * (lo + (hi - lo) * next())
            })
            .collect();
        if n >= 5 && q[4].abs() < 10f64.to_radians() {
            continue;
        }
        out.extend_from_slice(&q);
    }
    out
}

/// The nominal model with errors of calibration size (0.02° on angles, 0.4 mm on lengths).
fn perturbed(nominal: &Robot) -> Robot {
    let mut p = nominal.params();
    for (k, v) in p.iter_mut().enumerate() {
        *v += if nominal.layout().get(k).unit == kinematics::Unit::Deg {
            0.02f64.to_radians() * ((k % 3) as f64 - 1.0)
        } else {
            0.4 * ((k % 5) as f64 - 2.0)
        };
    }
    nominal.with_params(&p).expect("perturbed")
}

fn benches(c: &mut Criterion) {
    let robot = kr1000();
    let n = robot.n_joints();
    let poses = poses(&robot, 50);
    // `cargo xtask bench --quick` sets KINCAL_BENCH_QUICK: shorter measurements.
    let quick = std::env::var_os("KINCAL_BENCH_QUICK").is_some();
    let mut g = c.benchmark_group("kinematics");
    g.sample_size(if quick { 10 } else { 30 })
        .warm_up_time(Duration::from_millis(if quick { 200 } else { 500 }))
        .measurement_time(Duration::from_millis(if quick { 700 } else { 2000 }));

    g.bench_function("fk_50_poses", |b| {
        b.iter(|| {
            let mut s = Vector3::zeros();
            for q in black_box(&poses).chunks_exact(n) {
                s += robot.point(q);
            }
            s
        })
    });

    let trig = PoseTrig::new(n, &poses);
    g.bench_function("fk_50_poses_prepared", |b| {
        b.iter(|| {
            let mut s = [0.0; 3];
            for k in 0..trig.n_blocks() {
                let p = robot.point_lanes(black_box(trig.lanes(k)));
                s[0] += p[0][0];
                s[1] += p[1][1];
                s[2] += p[2][2];
            }
            s
        })
    });

    let mut points = vec![Vector3::zeros(); 50];
    let mut jac = DMatrix::zeros(150, robot.n_params());
    g.bench_function("jacobian_50x34", |b| {
        b.iter(|| robot.jacobian_batch_into(black_box(&poses), &mut points, &mut jac))
    });

    // Compensation IK: the target is the nominal point and flange orientation at the
    // commanded joints; the perturbed ("identified") model solves from those joints.
    let identified = perturbed(&robot);
    let opts = IkOptions::default();
    // Targets the model can reach within its limits (a few random poses sit at a limit).
    let cases: Vec<(&[f64], IkTarget)> = poses
        .chunks_exact(n)
        .map(|q| {
            let f = robot.flange(q);
            let target = IkTarget {
                point_in_flange_mm: identified.tool_mm(),
                position_mm: f.transform_point(&robot.tool_mm()),
                rotation: f.rot,
            };
            (q, target)
        })
        .filter(|(q, t)| identified.solve_ik(t, &mut q.to_vec(), &opts).is_ok())
        .collect();
    assert!(cases.len() >= 40, "{} reachable targets", cases.len());
    let mut k = 0;
    let mut q = vec![0.0; n];
    g.bench_function("ik_one_pose", |b| {
        b.iter(|| {
            k = (k + 1) % cases.len();
            let (q0, target) = &cases[k];
            q.copy_from_slice(q0);
            identified.solve_ik(black_box(target), &mut q, &opts)
        })
    });
    g.finish();
}

criterion_group!(kinematics_benches, benches);
criterion_main!(kinematics_benches);
