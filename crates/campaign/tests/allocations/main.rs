//! Heap allocations of a campaign trial in the steady state (issue 43, item 2;
//! `docs/profile.md`, "Allocations"): the paper scenario, ISO test on, one thread, after
//! warm-up trials, allocates nothing — every buffer a trial needs is the thread's, kept from
//! its last trial — and keeps nothing beyond the thread's bounded buffers
//! (`kinematics::KEPT_BUFFER_MAX_BYTES`; they reach their size in the warm-up, trials of one
//! scenario being alike): the thread's live heap is the same after 20 more trials as after
//! the warm-up.

#![allow(unsafe_code)]

mod counting;

use std::path::Path;

use campaign::{Context, Scenario, run_trial};

#[global_allocator]
static GLOBAL: counting::Counting = counting::Counting;

// At the start of issue 43's second pass a trial allocated 696 times in release
// (`examples/allocations`; the recovery cloned the fit's covariance, LM allocated its
// parameter vector per step, Table 4 and the ISO test grew or copied their series, every
// copy of a robot copied its model file's names, controller and mass model, the covariance
// held its two matrices as rows of vectors, and every parameter name in the fit, its
// covariance and the recovery rows was an owned `String`: now an interned
// `kinematics::ParamName`); 281 at the start of the third, which gave the solvers' scratch to
// the thread (the normal equations' buffers, the poses' sines and cosines, the rank test's
// greedy Cholesky and the covariance's inverse, the damped system, the final system kept for
// the covariance, observability's matrices, the ISO test's series: reused by the next solve
// or trial) and screened the sampled poses' condition on a fixed-size Jacobian; 85 at the
// start of the fourth, which kept the trial's virtual robot with the thread
// (`virtual_robot::Setup::world_into`), built its problems on free sets from the thread's
// buffers, built the solvers' results from them and had the trial give them back
// (`identify::Fit::recycle`, `LmSolution::recycle`, `Covariance::recycle`,
// `TrialResult::recycle`): 8; the fifth computed observability's eigenvalues on a
// fixed-size matrix (`trial::eigenvalues`, 5), kept the measured validation poses and the
// covariance's list of correlated pairs, and left the trial's fit unboxed: 0.

/// Trials before the count: the thread's pools fill (up to their size) with the buffers
/// trials give back, then stay as they are.
const WARM_UP: u64 = 30;

#[test]
fn a_trial_allocates_nothing_and_keeps_nothing() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenarios/paper-kr1000.json");
    let loaded = Scenario::from_file(&path).unwrap();
    assert!(loaded.scenario.iso.enabled);
    let ctx = Context::new(loaded).unwrap();
    for trial in 0..WARM_UP {
        run_trial(&ctx, trial).unwrap().recycle();
    }
    let (a0, _) = counting::counts();
    let live0 = counting::live_bytes();
    let trials = 20;
    for trial in WARM_UP..WARM_UP + trials {
        std::hint::black_box(run_trial(&ctx, trial).unwrap()).recycle();
    }
    let (a1, _) = counting::counts();
    assert_eq!(
        a1 - a0,
        0,
        "heap allocations in {trials} trials after {WARM_UP} of warm-up (none expected)"
    );
    // Every trial's result was recycled: nothing a trial allocated is still held but the
    // thread's kept buffers, at their size since the warm-up.
    assert_eq!(
        counting::live_bytes(),
        live0,
        "live heap grew over {trials} trials"
    );
}
