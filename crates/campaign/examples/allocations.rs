//! Heap allocations of a campaign trial (issue 43, item 2): a counting global allocator
//! around the system's, the paper scenario with and without the ISO test, 20 trials of
//! warm-up, then the allocations and bytes of 200 trials, per trial.
//!
//! `cargo run --release -p campaign --example allocations`; the figures are in
//! `docs/profile.md`.

// A global allocator is an `unsafe impl`: the one place this crate needs `unsafe`, in an
// example outside the library.
#![allow(unsafe_code)]

use std::alloc::{GlobalAlloc, Layout, System};
use std::path::Path;
use std::sync::atomic::{AtomicU64, Ordering};

use campaign::{Context, Scenario, run_trial};

/// The system allocator, counting.
struct Counting;

static ALLOCATIONS: AtomicU64 = AtomicU64::new(0);
static BYTES: AtomicU64 = AtomicU64::new(0);

// SAFETY: every call is forwarded unchanged to the system allocator; the counters are
// atomics, touched without allocating.
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        ALLOCATIONS.fetch_add(1, Ordering::Relaxed);
        BYTES.fetch_add(layout.size() as u64, Ordering::Relaxed);
        // SAFETY: the caller's contract is the system allocator's.
        unsafe { System.alloc(layout) }
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: `ptr` came from `alloc` / `realloc` above, i.e. from the system allocator.
        unsafe { System.dealloc(ptr, layout) }
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        ALLOCATIONS.fetch_add(1, Ordering::Relaxed);
        BYTES.fetch_add(new_size as u64, Ordering::Relaxed);
        // SAFETY: as `dealloc`, and the caller's contract for the new size.
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

fn main() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenarios/paper-kr1000.json");
    for iso in [false, true] {
        let mut loaded = Scenario::from_file(&path).expect("scenario");
        loaded.scenario.iso.enabled = iso;
        let ctx = Context::new(loaded).expect("context");
        for trial in 0..20 {
            run_trial(&ctx, trial).expect("trial");
        }
        let (a0, b0) = (
            ALLOCATIONS.load(Ordering::Relaxed),
            BYTES.load(Ordering::Relaxed),
        );
        let trials = 200;
        for trial in 20..20 + trials {
            std::hint::black_box(run_trial(&ctx, trial).expect("trial"));
        }
        let a = ALLOCATIONS.load(Ordering::Relaxed) - a0;
        let b = BYTES.load(Ordering::Relaxed) - b0;
        println!(
            "paper-kr1000, ISO test {}: {} allocations and {:.0} kB per trial (mean of {trials}, after 20 of warm-up)",
            if iso { "on" } else { "off" },
            a / trials,
            b as f64 / trials as f64 / 1024.0
        );
    }
}
