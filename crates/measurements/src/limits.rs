//! Sizes from input checked before anything is allocated: a count of poses, candidates or
//! trials that a file or an option asks for is compared with a stated limit and with the
//! memory of the machine, and refused with a clear error ([`SizeError`]) instead of an
//! allocation failure or a capacity-overflow panic.
//!
//! The limits and the memory figures per item are listed in `docs/scale.md` ("Sizes and
//! memory").

/// Why a size asked for by the input is refused.
///
/// # When this error occurs
/// A count (poses, candidates, …) above its stated limit, or one whose estimated memory
/// exceeds the memory available on this machine.
///
/// # How to handle
/// Report it; the message names the field or option, the limit and the memory estimate.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum SizeError {
    /// Above the stated limit.
    #[error(
        "{what}: {count} is more than the limit of {limit} (about {per_item} per item; see docs/scale.md)"
    )]
    AboveLimit {
        /// What was counted, e.g. "poses.identification".
        what: String,
        /// The count asked for.
        count: u128,
        /// The limit.
        limit: u64,
        /// The memory per item, in words.
        per_item: String,
    },
    /// Within the limit but more than this machine's available memory.
    #[error(
        "{what}: {count} would need about {need} of memory ({per_item} each), but this machine has {available} available"
    )]
    OutOfMemory {
        /// What was counted.
        what: String,
        /// The count asked for.
        count: u64,
        /// The memory needed, in words.
        need: String,
        /// The memory per item, in words.
        per_item: String,
        /// The memory available, in words.
        available: String,
    },
}

/// The memory one row of joints (and its measured point) takes from being read to being
/// identified on, validated on or predicted, in bytes: `docs/timings.md` ("A measurement
/// file of many rows": the peak of `identify` on 10⁶ rows divided by the rows, 785 B when
/// this was set, with the system allocator; the `kincal` binary's mimalloc takes about
/// 860 B). Arrays handed over by the Python package (the system allocator) are checked with
/// it.
pub const BYTES_PER_ROW: u64 = 800;

/// [`check_size`] for data rows that have no limit but the machine's memory:
/// [`BYTES_PER_ROW`] each, or `bytes_per_row` where a use of the rows costs less
/// (forward kinematics of an array keeps only its joints and points).
pub fn check_rows(what: &str, rows: usize, bytes_per_row: u64) -> Result<(), SizeError> {
    check_size(what, rows as u64, u64::MAX, bytes_per_row)
}

/// `1.5 GB`, `12 kB`, `640 B` (decimal units).
pub fn bytes_in_words(bytes: u128) -> String {
    const UNITS: [&str; 6] = ["B", "kB", "MB", "GB", "TB", "PB"];
    let mut v = bytes as f64;
    let mut u = 0;
    while v >= 1000.0 && u + 1 < UNITS.len() {
        v /= 1000.0;
        u += 1;
    }
    if u == 0 {
        format!("{bytes} B")
    } else {
        format!("{v:.1} {}", UNITS[u])
    }
}

/// The memory available to a new allocation on this machine, in bytes: `MemAvailable` of
/// `/proc/meminfo` (`None` where there is no such file: then only the limits apply).
pub fn available_memory() -> Option<u64> {
    let text = std::fs::read_to_string("/proc/meminfo").ok()?;
    let line = text.lines().find(|l| l.starts_with("MemAvailable:"))?;
    let kb: u64 = line
        .trim_start_matches("MemAvailable:")
        .trim()
        .trim_end_matches("kB")
        .trim()
        .parse()
        .ok()?;
    kb.checked_mul(1024)
}

/// Checks a count from input before anything is allocated for it: at most `limit`, and
/// `count × bytes_per_item` within the machine's available memory ([`available_memory`]).
/// `what` names the field or option in the error; `count` is taken as `u128` so that any
/// integer read from input (a `u64`, a `usize`) converts without loss.
///
/// ```
/// use measurements::check_size;
/// assert!(check_size("poses", 50u64, 1_000_000, 4096).is_ok());
/// let e = check_size("poses", 100_000_000u64, 1_000_000, 4096).unwrap_err();
/// assert!(e.to_string().contains("more than the limit of 1000000"), "{e}");
/// ```
pub fn check_size(
    what: &str,
    count: impl Into<u128>,
    limit: u64,
    bytes_per_item: u64,
) -> Result<(), SizeError> {
    let count: u128 = count.into();
    let per_item = bytes_in_words(u128::from(bytes_per_item));
    if count > u128::from(limit) {
        return Err(SizeError::AboveLimit {
            what: what.to_string(),
            count,
            limit,
            per_item,
        });
    }
    let need = count * u128::from(bytes_per_item);
    if let Some(available) = available_memory()
        && need > u128::from(available)
    {
        return Err(SizeError::OutOfMemory {
            what: what.to_string(),
            count: count as u64,
            need: bytes_in_words(need),
            per_item,
            available: bytes_in_words(u128::from(available)),
        });
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sizes_above_the_limit_or_the_memory_are_refused() {
        assert!(check_size("x", 10u64, 10, 8).is_ok());
        let e = check_size("x", 11u64, 10, 8).unwrap_err();
        assert!(matches!(e, SizeError::AboveLimit { count: 11, .. }), "{e}");
        // 1e18 and u64::MAX convert and are refused, not overflowed.
        for n in [1_000_000_000_000_000_000u64, u64::MAX] {
            let e = check_size("poses", n, 1_000_000, 4096).unwrap_err();
            assert!(e.to_string().starts_with("poses: "), "{e}");
        }
        // Rows: no limit but the memory; 10¹⁵ rows of 800 B fit in no machine.
        assert!(check_rows("q_deg", 10, BYTES_PER_ROW).is_ok());
        if available_memory().is_some() {
            let e = check_rows("q_deg", 1_000_000_000_000_000, BYTES_PER_ROW).unwrap_err();
            assert!(matches!(e, SizeError::OutOfMemory { .. }), "{e}");
        }
        // Within a huge limit but beyond any machine's memory (16 EB).
        if available_memory().is_some() {
            let e = check_size("x", 1u64 << 40, u64::MAX, 1 << 24).unwrap_err();
            assert!(matches!(e, SizeError::OutOfMemory { .. }), "{e}");
            assert!(e.to_string().contains("available"), "{e}");
        }
    }

    #[test]
    fn bytes_are_written_in_decimal_units() {
        assert_eq!(bytes_in_words(640), "640 B");
        assert_eq!(bytes_in_words(4_800_000_000), "4.8 GB");
    }
}
