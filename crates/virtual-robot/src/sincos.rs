//! Sines and cosines of short vectors through [`kinematics::trig::sin_cos_slice`] in whole
//! blocks of eight: a joint vector (and the gear terms' arguments) is copied into a padded
//! lane array first, so the kernel never takes its partial-block path. Every value is
//! [`kinematics::trig::sin_cos`] of its argument, bit for bit, wherever it sits in a block
//! (the kernel works lane by lane), so this changes no result, only the cost.

use kinematics::MAX_JOINTS;

/// Lanes of one kernel block.
const BLOCK: usize = 8;

/// Largest padded length handled in one call (two blocks).
const WIDE: usize = 2 * BLOCK;

/// `[sin q_i, cos q_i]` of a joint vector into `sc[..q.len()]` (what
/// [`kinematics::joint_sin_cos`] gives, bit for bit).
#[inline]
pub(crate) fn joint_trig(q: &[f64], sc: &mut [[f64; 2]; MAX_JOINTS]) {
    let n = q.len();
    if n <= BLOCK {
        let mut x = [0.0; BLOCK];
        x[..n].copy_from_slice(q);
        let (s, c) = block::<BLOCK>(&x);
        for i in 0..n {
            sc[i] = [s[i], c[i]];
        }
    } else if n <= WIDE {
        let mut x = [0.0; WIDE];
        x[..n].copy_from_slice(q);
        let (s, c) = block::<WIDE>(&x);
        for i in 0..n {
            sc[i] = [s[i], c[i]];
        }
    } else {
        kinematics::joint_sin_cos(q, &mut sc[..]);
    }
}

/// `sin_cos` of `x` (padded lanes are zero).
#[inline(always)]
pub(crate) fn block<const B: usize>(x: &[f64; B]) -> ([f64; B], [f64; B]) {
    let mut s = [0.0; B];
    let mut c = [0.0; B];
    kinematics::trig::sin_cos_slice(x, &mut s, &mut c);
    (s, c)
}
