//! Run-time choice of the vector width of the normal-equation kernels: the level is shared
//! with the kinematics crate's lane kernels (see [`kinematics::simd`]). All levels give
//! bit-identical results (no FMA); `KINCAL_SIMD=portable|avx2|avx512` or
//! [`set_simd_level`] force one, e.g. to time the portable path.

pub use kinematics::simd::{SimdLevel, set_simd_level, simd_level};
