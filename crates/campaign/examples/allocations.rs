//! Heap allocations of a campaign trial (issue 43, item 2): a counting global allocator
//! around the system's, the paper scenario (or the scenario files given) without the ISO
//! test and, where the scenario has it, with it; 20 trials of warm-up, then the allocations
//! and bytes of 200 trials, in all and a trial.
//!
//! `cargo run --release -p campaign --example allocations [-- SCENARIO.json ...]`; the
//! figures are in `docs/profile.md`.

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
    // The paper scenario, or the scenario files given as arguments.
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let mut paths: Vec<std::path::PathBuf> = std::env::args_os().skip(1).map(Into::into).collect();
    if paths.is_empty() {
        paths.push(root.join("scenarios/paper-kr1000.json"));
    }
    for path in &paths {
        // Without the ISO test, and with it where the scenario has it (its reference pose
        // is checked against the robot only then).
        let committed = Scenario::from_file(path).expect("scenario");
        let variants: &[bool] = if committed.scenario.iso.enabled {
            &[false, true]
        } else {
            &[false]
        };
        for &iso in variants {
            let mut loaded = Scenario::from_file(path).expect("scenario");
            let name = loaded.scenario.name.clone();
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
                "{name}, ISO test {}: {a} allocations and {:.1} kB in {trials} trials after 20 of warm-up ({:.2} and {:.2} kB a trial)",
                if iso { "on" } else { "off" },
                b as f64 / 1024.0,
                a as f64 / trials as f64,
                b as f64 / 1024.0 / trials as f64,
            );
        }
    }
}
