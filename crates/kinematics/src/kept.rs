//! What a thread keeps for its next solve or trial (issue 43: no allocation per trial in the
//! steady state): the size rule every kept buffer follows ([`keep_buffer`]), and the two
//! shapes of keeping, one value a thread ([`Kept`]) or a few ([`Pool`]), each declared in a
//! `thread_local!`, taken for a use and given back after it.
//!
//! ```
//! use kinematics::kept::{Kept, with_kept};
//!
//! thread_local! {
//!     static SERIES: Kept<Vec<f64>> = const { Kept::new() };
//! }
//!
//! fn mean_of_squares(x: &[f64]) -> f64 {
//!     with_kept(&SERIES, |sq: &mut Vec<f64>| {
//!         sq.clear(); // what it held must not reach the result
//!         sq.extend(x.iter().map(|v| v * v));
//!         sq.iter().sum::<f64>() / sq.len() as f64
//!     })
//! }
//! assert_eq!(mean_of_squares(&[1.0, 3.0]), 5.0);
//! assert_eq!(mean_of_squares(&[2.0]), 4.0); // the same buffer, refilled
//! ```
//!
//! Taking never blocks or panics: when the thread keeps nothing, is exiting (its
//! thread-locals being destroyed) or has its value out already (a nested use), the taker
//! gets `None`, or a fresh default, and works as if nothing were kept. Whatever a kept value
//! held must never reach a result: its users clear, zero or overwrite what they take
//! (ARCHITECTURE.md, the determinism invariant).

use std::cell::RefCell;
use std::thread::LocalKey;

/// The largest buffer (bytes) a thread keeps for reuse between solves and trials: 256 KiB, a
/// trial of about 2,700 poses of six joints. Larger ones are freed as before: their
/// allocation is negligible next to the work that fills them, and keeping them would raise
/// the peak memory of large identifications (a 200,000-pose trial's sines and cosines are
/// tens of MB). With about 150 buffers kept (`identify`'s pools of 24 and 24 and its typed
/// pools of 8, four `PoseTrig`s of four, a campaign's world and pose buffers, its results'
/// series, a few more), a thread holds at most about 40 MB this way, and in practice a
/// trial's sizes (hundreds of kB for the paper's scenario). The normal
/// equations' block buffers are the exception: kept at any size, four a thread, as before (a
/// large pose set's is reused by its next solve rather than allocated again).
pub const KEPT_BUFFER_MAX_BYTES: usize = 1 << 18;

/// Whether a thread keeps a buffer of `capacity` elements of `T` ([`KEPT_BUFFER_MAX_BYTES`]).
pub fn keep_buffer<T>(capacity: usize) -> bool {
    capacity > 0 && capacity.saturating_mul(std::mem::size_of::<T>()) <= KEPT_BUFFER_MAX_BYTES
}

/// One value a thread keeps (`static S: Kept<T> = const { Kept::new() };` in a
/// `thread_local!`): [`take_kept`], [`keep`] / [`keep_with`], or both around a use with
/// [`with_kept`].
#[derive(Debug, Default)]
pub struct Kept<T>(RefCell<Option<T>>);

impl<T> Kept<T> {
    /// Nothing kept.
    pub const fn new() -> Self {
        Kept(RefCell::new(None))
    }
}

/// The value `slot` keeps on this thread, taken out (`None` when there is none, the thread
/// is exiting or the value is out already).
pub fn take_kept<T: 'static>(slot: &'static LocalKey<Kept<T>>) -> Option<T> {
    slot.try_with(|s| s.0.try_borrow_mut().ok()?.take())
        .ok()
        .flatten()
}

/// Keeps `value` in `slot` for the thread's next take if the slot is free; drops it
/// otherwise (the thread is exiting, or keeps one already).
pub fn keep<T: 'static>(slot: &'static LocalKey<Kept<T>>, value: T) {
    keep_with(slot, || value);
}

/// Keeps what `make` gives in `slot` if the slot is free, and calls `make` only then: for a
/// `Drop` that keeps its own buffers (moved out only when they are kept, so dropping what
/// is not kept cannot come back here with them).
pub fn keep_with<T: 'static>(slot: &'static LocalKey<Kept<T>>, make: impl FnOnce() -> T) {
    let _ = slot.try_with(|s| {
        if let Ok(mut s) = s.0.try_borrow_mut()
            && s.is_none()
        {
            *s = Some(make());
        }
    });
}

/// Runs `f` on the value `slot` keeps on this thread (a default one when [`take_kept`] has
/// none), then keeps it again ([`keep`]; a use nested in `f` gets a default value, and
/// keeps it, so the outer one is dropped). `f` must not let what the value held reach its
/// result.
pub fn with_kept<T: Default + 'static, R>(
    slot: &'static LocalKey<Kept<T>>,
    f: impl FnOnce(&mut T) -> R,
) -> R {
    let mut value = take_kept(slot).unwrap_or_default();
    let r = f(&mut value);
    keep(slot, value);
    r
}

/// A few values a thread keeps, the last given back taken first (`static P: Pool<T> =
/// const { Pool::new() };` in a `thread_local!`): [`take_pooled`], [`give_pooled`].
#[derive(Debug, Default)]
pub struct Pool<T>(RefCell<Vec<T>>);

impl<T> Pool<T> {
    /// An empty pool.
    pub const fn new() -> Self {
        Pool(RefCell::new(Vec::new()))
    }
}

/// A value from `pool` (`None` when it is empty, the thread is exiting or the pool is in
/// use).
pub fn take_pooled<T: 'static>(pool: &'static LocalKey<Pool<T>>) -> Option<T> {
    pool.try_with(|p| p.0.try_borrow_mut().ok()?.pop())
        .ok()
        .flatten()
}

/// Gives what `make` gives to `pool` if it holds fewer than `max`, and calls `make` only
/// then (as [`keep_with`]).
pub fn give_pooled<T: 'static>(
    pool: &'static LocalKey<Pool<T>>,
    max: usize,
    make: impl FnOnce() -> T,
) {
    let _ = pool.try_with(|p| {
        if let Ok(mut p) = p.0.try_borrow_mut()
            && p.len() < max
        {
            p.push(make());
        }
    });
}

/// An empty vector from a pool of vectors (its room kept; cleared: what it held never
/// shows), or a new one.
pub fn take_vec<T: 'static>(pool: &'static LocalKey<Pool<Vec<T>>>) -> Vec<T> {
    let mut v = take_pooled(pool).unwrap_or_default();
    v.clear();
    v
}

/// Gives `v` to a pool of vectors holding at most `max` ([`give_pooled`]), unless it is
/// empty or larger than [`KEPT_BUFFER_MAX_BYTES`] ([`keep_buffer`]).
pub fn give_vec<T: 'static>(pool: &'static LocalKey<Pool<Vec<T>>>, max: usize, v: Vec<T>) {
    if keep_buffer::<T>(v.capacity()) {
        give_pooled(pool, max, || v);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    thread_local! {
        static SLOT: Kept<Vec<u8>> = const { Kept::new() };
        static POOL: Pool<u32> = const { Pool::new() };
    }

    /// A kept value comes back to the next take, once; a nested use gets a fresh one, and of
    /// the two given back the first (the nested one's) is kept; a full slot refuses (and
    /// `keep_with` does not make) a second value.
    #[test]
    fn a_slot_keeps_one_value_and_a_nested_use_gets_a_fresh_one() {
        assert_eq!(take_kept(&SLOT), None);
        keep(&SLOT, vec![1, 2]);
        keep_with(&SLOT, || panic!("made for a full slot"));
        let inner = with_kept(&SLOT, |outer| {
            assert_eq!(outer, &vec![1, 2]);
            outer.push(3);
            with_kept(&SLOT, |inner: &mut Vec<u8>| inner.clone())
        });
        assert!(inner.is_empty());
        assert_eq!(take_kept(&SLOT), Some(vec![]));
        assert_eq!(take_kept(&SLOT), None);
    }

    /// A pooled vector comes back empty with its room; an empty or an oversized one is
    /// not kept.
    #[test]
    fn a_pool_of_vectors_keeps_room_not_contents_nor_oversized_ones() {
        thread_local! {
            static VECS: Pool<Vec<u64>> = const { Pool::new() };
        }
        give_vec(&VECS, 2, Vec::new());
        give_vec(&VECS, 2, vec![0; KEPT_BUFFER_MAX_BYTES / 8 + 1]);
        assert_eq!(take_pooled(&VECS), None);
        give_vec(&VECS, 2, vec![7; 10]);
        let v = take_vec(&VECS);
        assert!(v.is_empty() && v.capacity() >= 10);
        assert_eq!(take_vec(&VECS).capacity(), 0);
    }

    /// A pool gives back the last value first and holds at most `max`.
    #[test]
    fn a_pool_holds_at_most_max_values() {
        for v in 0..5 {
            give_pooled(&POOL, 3, || v);
        }
        assert_eq!(take_pooled(&POOL), Some(2));
        assert_eq!(take_pooled(&POOL), Some(1));
        assert_eq!(take_pooled(&POOL), Some(0));
        assert_eq!(take_pooled(&POOL), None);
    }
}
