//! Per-thread pools of buffers (issue 43: no allocation per solve in the steady state). A
//! solve takes its buffers here, and the parts of its result that only the next steps of
//! the same identification read (the final system kept for the covariance) come back here
//! when they are dropped, for the next solve on the thread to refill. A buffer taken is
//! empty or cleared and resized with zeros, as a new one would be: what it held before
//! never reaches a result.
//!
//! The results a solve hands back (an [`crate::LmSolution`], a [`crate::Fit`], a
//! [`crate::Covariance`]) are built from the same pools, and a caller that runs many solves
//! (a campaign's trials) gives them back with their `recycle` (dropping one instead is
//! always correct, and only costs the next solve its allocations).

use std::cell::RefCell;
use std::thread::LocalKey;

use kinematics::kept::{Pool as Pool2, give_pooled, take_pooled, take_vec};
use kinematics::{ParamName, Robot, Unit};
use nalgebra::{DMatrix, DVector};

use crate::{CorrelatedPair, ParamEstimate, TraceEntry};

/// Buffers a pool keeps at most (a trial's solves hold about ten at once).
const POOL_SIZE: usize = 24;

type Pool<T> = RefCell<Vec<Vec<T>>>;

thread_local! {
    static F64: Pool<f64> = const { RefCell::new(Vec::new()) };
    static USIZE: Pool<usize> = const { RefCell::new(Vec::new()) };
}

/// An empty buffer with room for `len` if the pool has one (the smallest that fits, else
/// the largest, which grows), a new one otherwise.
fn take<T>(pool: &'static LocalKey<Pool<T>>, len: usize) -> Vec<T> {
    if !kinematics::keep_buffer::<T>(len.max(1)) {
        // Too large to be kept (see `give`): a fresh one.
        return Vec::with_capacity(len);
    }
    let mut v = pool
        .try_with(|p| {
            let mut p = p.try_borrow_mut().ok()?;
            let fits = (0..p.len())
                .filter(|&i| p[i].capacity() >= len)
                .min_by_key(|&i| p[i].capacity());
            let i = fits.or_else(|| (0..p.len()).max_by_key(|&i| p[i].capacity()))?;
            Some(p.swap_remove(i))
        })
        .ok()
        .flatten()
        .unwrap_or_default();
    v.clear();
    // (Exactly: doubling could take a buffer past what `give` keeps.)
    v.reserve_exact(len);
    v
}

/// Gives `v` back to the pool (dropped when the pool is full or gone, or `v` larger than
/// [`kinematics::KEPT_BUFFER_MAX_BYTES`]).
fn give<T>(pool: &'static LocalKey<Pool<T>>, v: Vec<T>) {
    if !kinematics::keep_buffer::<T>(v.capacity()) {
        return;
    }
    let _ = pool.try_with(|p| {
        if let Ok(mut p) = p.try_borrow_mut()
            && p.len() < POOL_SIZE
        {
            p.push(v);
        }
    });
}

/// `len` zeros.
pub(crate) fn zeros(len: usize) -> Vec<f64> {
    let mut v = take(&F64, len);
    v.resize(len, 0.0);
    v
}

/// An empty buffer with room for `len` values.
pub(crate) fn with_capacity(len: usize) -> Vec<f64> {
    take(&F64, len)
}

/// A copy of `src`.
pub(crate) fn copy(src: &[f64]) -> Vec<f64> {
    let mut v = take(&F64, src.len());
    v.extend_from_slice(src);
    v
}

/// A copy of the indices `src`.
pub(crate) fn copy_indices(src: &[usize]) -> Vec<usize> {
    let mut v = take(&USIZE, src.len());
    v.extend_from_slice(src);
    v
}

/// An empty index buffer with room for `len`.
pub(crate) fn indices(len: usize) -> Vec<usize> {
    take(&USIZE, len)
}

/// An `r × c` matrix of zeros.
pub(crate) fn zero_matrix(r: usize, c: usize) -> DMatrix<f64> {
    DMatrix::from_vec(r, c, zeros(r * c))
}

/// A vector of `n` zeros.
pub(crate) fn zero_vector(n: usize) -> DVector<f64> {
    DVector::from_vec(zeros(n))
}

/// Gives a buffer back.
pub(crate) fn give_back(v: Vec<f64>) {
    give(&F64, v);
}

/// Gives an index buffer back.
pub(crate) fn give_back_indices(v: Vec<usize>) {
    give(&USIZE, v);
}

/// Gives a matrix's buffer back.
pub(crate) fn give_back_matrix(m: DMatrix<f64>) {
    give(&F64, m.data.into());
}

/// Gives a vector's buffer back.
pub(crate) fn give_back_vector(v: DVector<f64>) {
    give(&F64, v.data.into());
}

/// Robots, names, units, traces, estimates and correlation lists a thread keeps at most,
/// each (what a trial's results hold at once: the fit's, the recovery's two solves', their
/// covariances').
const TYPED_POOL_SIZE: usize = 8;

thread_local! {
    static ROBOTS: Pool2<Robot> = const { Pool2::new() };
    static NAMES: Pool2<Vec<ParamName>> = const { Pool2::new() };
    static UNITS: Pool2<Vec<Unit>> = const { Pool2::new() };
    static TRACES: Pool2<Vec<TraceEntry>> = const { Pool2::new() };
    static ESTIMATES: Pool2<Vec<ParamEstimate>> = const { Pool2::new() };
    static CORRELATIONS: Pool2<Vec<CorrelatedPair>> = const { Pool2::new() };
}

/// Gives `v` back to `pool` (of [`TYPED_POOL_SIZE`]).
fn give_vec<T: 'static>(pool: &'static LocalKey<Pool2<Vec<T>>>, v: Vec<T>) {
    kinematics::kept::give_vec(pool, TYPED_POOL_SIZE, v);
}

/// A copy of `src` in a robot the thread kept ([`Robot`]'s `clone_from`: no allocation when
/// it has the room), or a new copy.
pub(crate) fn robot_like(src: &Robot) -> Robot {
    match take_pooled(&ROBOTS) {
        Some(mut r) => {
            r.clone_from(src);
            r
        }
        None => src.clone(),
    }
}

/// Gives a robot back.
pub(crate) fn give_back_robot(r: Robot) {
    give_pooled(&ROBOTS, TYPED_POOL_SIZE, || r);
}

/// An empty list of parameter names.
pub(crate) fn names() -> Vec<ParamName> {
    take_vec(&NAMES)
}

/// Gives a list of names back.
pub(crate) fn give_back_names(v: Vec<ParamName>) {
    give_vec(&NAMES, v);
}

/// An empty list of units.
pub(crate) fn units() -> Vec<Unit> {
    take_vec(&UNITS)
}

/// Gives a list of units back.
pub(crate) fn give_back_units(v: Vec<Unit>) {
    give_vec(&UNITS, v);
}

/// An empty trace.
pub(crate) fn trace() -> Vec<TraceEntry> {
    take_vec(&TRACES)
}

/// Gives a trace back.
pub(crate) fn give_back_trace(v: Vec<TraceEntry>) {
    give_vec(&TRACES, v);
}

/// An empty list of estimates.
pub(crate) fn estimates() -> Vec<ParamEstimate> {
    take_vec(&ESTIMATES)
}

/// Gives a list of estimates back.
pub(crate) fn give_back_estimates(v: Vec<ParamEstimate>) {
    give_vec(&ESTIMATES, v);
}

/// An empty list of correlated pairs.
pub(crate) fn correlations() -> Vec<CorrelatedPair> {
    take_vec(&CORRELATIONS)
}

/// Gives a list of correlated pairs back.
pub(crate) fn give_back_correlations(v: Vec<CorrelatedPair>) {
    give_vec(&CORRELATIONS, v);
}
