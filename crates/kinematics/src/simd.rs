//! Run-time choice of the vector width of the lane kernels (sines and cosines here, the
//! normal equations in the `identify` crate).
//!
//! The kernels are written once as plain Rust loops over fixed-size lane arrays and compiled
//! three times: for the x86-64 baseline (SSE2, two doubles per instruction), with AVX2
//! (four) and with AVX-512F (eight). The widest one the CPU supports is chosen at run time
//! ([`SimdLevel::detect`]); other architectures use the portable build.
//!
//! **No FMA** is used, on purpose: every value is computed by the same sequence of IEEE
//! multiplications and additions whatever the width, so all three builds give bit-identical
//! results and a campaign's output does not depend on which one ran (tests check this).
//! The wider builds only do more values per instruction.
//!
//! `KINCAL_SIMD=portable|avx2|avx512` (read once) forces a level, e.g. to time the portable
//! path on a machine with AVX-512; a level the CPU does not support falls back to the best
//! supported one below it. [`set_simd_level`] does the same from code (benchmarks).

use std::sync::OnceLock;
use std::sync::atomic::{AtomicU8, Ordering};

/// A vector width of the normal-equation kernels.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum SimdLevel {
    /// Baseline build (SSE2 on x86-64; whatever the target offers elsewhere).
    Portable,
    /// AVX2 (four doubles per instruction), x86-64 only.
    Avx2,
    /// AVX-512F (eight doubles per instruction), x86-64 only.
    Avx512,
}

impl SimdLevel {
    /// The widest level this CPU supports.
    pub fn detect() -> SimdLevel {
        #[cfg(target_arch = "x86_64")]
        {
            if std::arch::is_x86_feature_detected!("avx512f") {
                return SimdLevel::Avx512;
            }
            if std::arch::is_x86_feature_detected!("avx2") {
                return SimdLevel::Avx2;
            }
        }
        SimdLevel::Portable
    }

    /// `"portable"`, `"avx2"` or `"avx512"`.
    pub fn name(self) -> &'static str {
        match self {
            SimdLevel::Portable => "portable",
            SimdLevel::Avx2 => "avx2",
            SimdLevel::Avx512 => "avx512",
        }
    }

    fn from_name(s: &str) -> Option<SimdLevel> {
        match s.trim().to_ascii_lowercase().as_str() {
            "portable" | "off" | "scalar" | "sse2" => Some(SimdLevel::Portable),
            "avx2" => Some(SimdLevel::Avx2),
            "avx512" | "avx512f" => Some(SimdLevel::Avx512),
            _ => None,
        }
    }
}

const UNSET: u8 = u8::MAX;
static FORCED: AtomicU8 = AtomicU8::new(UNSET);
static FROM_ENV: OnceLock<SimdLevel> = OnceLock::new();

fn encode(level: SimdLevel) -> u8 {
    level as u8
}

fn decode(v: u8) -> SimdLevel {
    match v {
        0 => SimdLevel::Portable,
        1 => SimdLevel::Avx2,
        _ => SimdLevel::Avx512,
    }
}

/// The level the kernels use: the one forced by [`set_simd_level`], else `KINCAL_SIMD`,
/// else [`SimdLevel::detect`] — never above what the CPU supports.
pub fn simd_level() -> SimdLevel {
    let best = *FROM_ENV.get_or_init(|| {
        let detected = SimdLevel::detect();
        std::env::var("KINCAL_SIMD")
            .ok()
            .and_then(|s| SimdLevel::from_name(&s))
            .map_or(detected, |wanted| wanted.min(detected))
    });
    match FORCED.load(Ordering::Relaxed) {
        UNSET => best,
        v => decode(v).min(SimdLevel::detect()),
    }
}

/// Forces a level for the whole process (`None`: back to the default). Results do not
/// depend on it; only speed does.
pub fn set_simd_level(level: Option<SimdLevel>) {
    FORCED.store(level.map_or(UNSET, encode), Ordering::Relaxed);
}

/// Runs `f` with its body compiled for the run-time [`simd_level`]: how a kernel written
/// once is built three times (see the module docs). `f` should be a closure that calls an
/// `#[inline(always)]` kernel: it is inlined into a function built for AVX-512F, for AVX2,
/// or the baseline, and so vectorised at that width. (Kernels whose code differs by level,
/// such as the normal-equation products written with AVX-512 intrinsics, dispatch
/// themselves.)
#[inline(always)]
pub fn vectorised<R>(f: impl FnOnce() -> R) -> R {
    at_level(simd_level(), f)
}

/// [`vectorised`] at `level`, lowered to what the CPU supports (tests compare the levels).
#[inline(always)]
pub fn at_level<R>(level: SimdLevel, f: impl FnOnce() -> R) -> R {
    match level.min(SimdLevel::detect()) {
        #[cfg(target_arch = "x86_64")]
        // SAFETY: the CPU supports AVX-512F (checked just above).
        SimdLevel::Avx512 => unsafe { run_avx512(f) },
        #[cfg(target_arch = "x86_64")]
        // SAFETY: the CPU supports AVX2 (checked just above).
        SimdLevel::Avx2 => unsafe { run_avx2(f) },
        _ => f(),
    }
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
fn run_avx512<R>(f: impl FnOnce() -> R) -> R {
    f()
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn run_avx2<R>(f: impl FnOnce() -> R) -> R {
    f()
}
