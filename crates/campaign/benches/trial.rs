//! A campaign trial against the identification inside it, in one run (issue 43): on
//! `scenarios/paper-kr1000.json`,
//! - `identification_<scenario>`: the trial's identification alone (the free set resolved
//!   on the measured poses, LM with covariance: what `run_trial` calls), on trial 1's
//!   measured identification poses;
//! - `trial_<scenario>_no_iso`: one trial end to end without ISO 9283 (simulate the
//!   identification and validation poses, identify, observability, recovery, compensate the
//!   validation poses by IK, Table 4);
//! - `trial_<scenario>_iso`: the same with the ISO 9283 test (the scenario as committed).
//!
//! With the `kincal` binary's allocator (mimalloc, `docs/profile.md`, "The allocator"), so
//! that the figures are the CLI's. `cargo bench -p campaign`; the ratios are in
//! `docs/profile.md`.

use std::hint::black_box;
use std::path::Path;
use std::time::Duration;

use campaign::{Context, Scenario, run_trial};
use criterion::{Criterion, criterion_group, criterion_main};
use identify::Problem;
use nalgebra::Vector3;

#[global_allocator]
static GLOBAL: mimalloc::MiMalloc = mimalloc::MiMalloc;

fn context(iso: bool) -> Context {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenarios/paper-kr1000.json");
    let mut loaded = Scenario::from_file(&path).expect("scenario");
    loaded.scenario.iso.enabled = iso;
    Context::new(loaded).expect("context")
}

fn benches(c: &mut Criterion) {
    let with_iso = context(true);
    let ctx = context(false);
    let name = ctx.loaded.scenario.name.clone();

    // `cargo xtask bench --quick` sets KINCAL_BENCH_QUICK: shorter measurements.
    let quick = std::env::var_os("KINCAL_BENCH_QUICK").is_some();
    let mut g = c.benchmark_group("campaign");
    g.sample_size(if quick { 10 } else { 20 })
        .warm_up_time(Duration::from_millis(if quick { 200 } else { 500 }))
        .measurement_time(Duration::from_millis(if quick { 1500 } else { 3000 }));

    // Trial 1's identification poses, measured as the trial measures them.
    let mut world = ctx.setup.world(1).expect("world");
    let (mut poses, mut points) = (Vec::new(), Vec::<Vector3<f64>>::new());
    let n = ctx.nominal().n_joints();
    let all: Vec<f64> = world.identification_poses_rad().to_vec();
    for q in all.chunks_exact(n) {
        if let Ok(p) = world.measure(q) {
            poses.extend_from_slice(q);
            points.push(p);
        }
    }
    let id = &ctx.loaded.scenario.identification;
    g.bench_function(format!("identification_{name}"), |b| {
        b.iter(|| {
            let free = id
                .params
                .resolve(&ctx.id_nominal, &poses, None, &id.identifiability)
                .expect("free set");
            let problem =
                Problem::new(&ctx.id_nominal, black_box(&poses), &points, free).expect("problem");
            identify::identify(&problem, &ctx.id_options).expect("fit")
        })
    });
    for (label, ctx) in [("no_iso", &ctx), ("iso", &with_iso)] {
        let mut trial = 0u64;
        g.bench_function(format!("trial_{name}_{label}"), |b| {
            b.iter(|| {
                trial += 1;
                run_trial(black_box(ctx), trial).expect("trial")
            })
        });
    }
    g.finish();
}

criterion_group!(campaign_benches, benches);
criterion_main!(campaign_benches);
