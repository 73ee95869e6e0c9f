//! Heap allocations of a campaign trial (issue 43, item 2): a counting global allocator
//! around the system's, the paper scenario with and without the ISO test, 20 trials of
//! warm-up, then the allocations and bytes of 200 trials, per trial.
//!
//! `cargo run --release -p campaign --example allocations`; the figures are in
//! `docs/profile.md`.

// A global allocator is an `unsafe impl`: the one place this crate needs `unsafe`, in an
// example outside the library.
#![allow(unsafe_code)]

use std::path::Path;

use campaign::{Context, Scenario, run_trial};

#[path = "../tests/allocations/counting.rs"]
mod counting;

#[global_allocator]
static GLOBAL: counting::Counting = counting::Counting;

fn main() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenarios/paper-kr1000.json");
    for iso in [false, true] {
        let mut loaded = Scenario::from_file(&path).expect("scenario");
        loaded.scenario.iso.enabled = iso;
        let ctx = Context::new(loaded).expect("context");
        for trial in 0..20 {
            run_trial(&ctx, trial).expect("trial").recycle();
        }
        let (a0, b0) = counting::counts();
        let trials = 200;
        for trial in 20..20 + trials {
            std::hint::black_box(run_trial(&ctx, trial).expect("trial")).recycle();
        }
        let (a1, b1) = counting::counts();
        let (a, b) = (a1 - a0, b1 - b0);
        println!(
            "paper-kr1000, ISO test {}: {} allocations and {:.0} kB per trial (mean of {trials}, after 20 of warm-up)",
            if iso { "on" } else { "off" },
            a / trials,
            b as f64 / trials as f64 / 1024.0
        );
    }
}
