//! One campaign trial end to end without ISO 9283: simulate the identification and
//! validation poses, identify, score recovery, compensate the validation poses by IK,
//! Table 4. On `scenarios/paper-kr1000.json` (falling back to `noise-floor.json` where that
//! scenario does not exist yet). `cargo bench -p campaign`.

use std::hint::black_box;
use std::path::Path;
use std::time::Duration;

use campaign::{Context, Scenario, run_trial};
use criterion::{Criterion, criterion_group, criterion_main};

fn benches(c: &mut Criterion) {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenarios");
    let path = ["paper-kr1000.json", "noise-floor.json"]
        .iter()
        .map(|f| dir.join(f))
        .find(|p| p.exists())
        .expect("a scenario");
    let mut loaded = Scenario::from_file(&path).expect("scenario");
    loaded.scenario.iso.enabled = false;
    let name = loaded.scenario.name.clone();
    let ctx = Context::new(loaded).expect("context");

    // `cargo xtask bench --quick` sets KINCAL_BENCH_QUICK: shorter measurements.
    let quick = std::env::var_os("KINCAL_BENCH_QUICK").is_some();
    let mut g = c.benchmark_group("campaign");
    g.sample_size(if quick { 10 } else { 20 })
        .warm_up_time(Duration::from_millis(if quick { 200 } else { 500 }))
        .measurement_time(Duration::from_millis(if quick { 1500 } else { 3000 }));
    let mut trial = 0u64;
    g.bench_function(format!("trial_{name}_no_iso"), |b| {
        b.iter(|| {
            trial += 1;
            run_trial(black_box(&ctx), trial).expect("trial")
        })
    });
    g.finish();
}

criterion_group!(campaign_benches, benches);
criterion_main!(campaign_benches);
