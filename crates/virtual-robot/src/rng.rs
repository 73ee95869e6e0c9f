//! Reproducible random streams: one independent ChaCha8 stream per (trial, purpose).

use rand::SeedableRng;
use rand::rngs::ChaCha8Rng;

/// Trials are numbered with the low 56 bits of the ChaCha stream id.
pub const MAX_TRIAL: u64 = (1 << 56) - 1;

/// What a random stream is used for; its [`code`](Purpose::code) is the top byte of the
/// ChaCha stream id, so every purpose of every trial draws from its own stream and results
/// do not depend on call order or thread count.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Purpose {
    /// The injected geometric errors (code 1).
    Truth,
    /// The fixed pose set used to scale the errors to a target mean error (code 2; always
    /// drawn with trial 0, so it is the same for every trial of a seed).
    ScalePoses,
    /// The identification poses (code 3).
    IdentificationPoses,
    /// The validation poses (code 4).
    ValidationPoses,
    /// Laser-tracker noise (code 5).
    TrackerNoise,
    /// Per-move repeatability scatter (code 6).
    Repeatability,
    /// Random phases of the gear cyclic errors (code 7).
    GearPhases,
    /// For crates built on this one (ISO 9283 cycles, …): code `128 + (n & 127)`, disjoint
    /// from this crate's codes.
    External(u8),
}

impl Purpose {
    /// The stream-id byte of this purpose.
    pub fn code(self) -> u8 {
        match self {
            Purpose::Truth => 1,
            Purpose::ScalePoses => 2,
            Purpose::IdentificationPoses => 3,
            Purpose::ValidationPoses => 4,
            Purpose::TrackerNoise => 5,
            Purpose::Repeatability => 6,
            Purpose::GearPhases => 7,
            Purpose::External(n) => 128 | (n & 127),
        }
    }
}

/// The random stream of one trial and purpose:
/// `ChaCha8Rng::seed_from_u64(seed)` with `set_stream((purpose << 56) | trial)`.
///
/// `trial` is taken modulo 2⁵⁶ ([`MAX_TRIAL`]` + 1`); [`crate::World::new`] rejects larger
/// trial numbers instead of letting them alias.
pub fn stream(seed: u64, trial: u64, purpose: Purpose) -> ChaCha8Rng {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    rng.set_stream((u64::from(purpose.code()) << 56) | (trial & MAX_TRIAL));
    rng
}
