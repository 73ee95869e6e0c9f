//! Mutation fuzzing of the readers of outside input, on stable Rust with proptest: shared
//! by the fuzz tests of `measurements`, `kinematics` and `campaign` (included with
//! `#[path]`). A case is a valid file with 1 to 4 mutations: a byte flipped, inserted or the
//! file truncated, a line deleted or duplicated, a number or string swapped for a hostile
//! token (NaN, inf, 1e308, 1e999, empty, non-UTF-8, huge integers, wrong JSON types).
#![allow(dead_code)]

use proptest::prelude::*;
use proptest::test_runner::TestCaseError;

/// Tokens a number or a value is swapped for.
pub const TOKENS: &[&[u8]] = &[
    b"NaN",
    b"nan",
    b"inf",
    b"-inf",
    b"Infinity",
    b"1e308",
    b"-1e308",
    b"1e999",
    b"",
    b"\xff\xfe",
    b"\xc3",
    b"0",
    b"-0",
    b"18446744073709551616",
    b"99999999999999999999999",
    b"-1",
    b"1e12",
    b"null",
    b"\"x\"",
    b"[]",
    b"{}",
    b"true",
    b",",
    b"\"",
];

/// One mutation; positions are taken modulo the current length.
#[derive(Clone, Debug)]
pub enum Mutation {
    /// XOR a byte with a non-zero mask.
    Flip(usize, u8),
    /// Insert a byte.
    Insert(usize, u8),
    /// Cut the file short.
    Truncate(usize),
    /// Delete a line.
    DeleteLine(usize),
    /// Duplicate a line.
    DuplicateLine(usize),
    /// Swap the k-th number (or, in JSON, string) for a token.
    Token(usize, usize),
}

/// 1 to 4 mutations.
pub fn mutations() -> impl Strategy<Value = Vec<Mutation>> {
    let one = prop_oneof![
        (any::<usize>(), 1u8..=255).prop_map(|(p, m)| Mutation::Flip(p, m)),
        (any::<usize>(), any::<u8>()).prop_map(|(p, b)| Mutation::Insert(p, b)),
        any::<usize>().prop_map(Mutation::Truncate),
        any::<usize>().prop_map(Mutation::DeleteLine),
        any::<usize>().prop_map(Mutation::DuplicateLine),
        (any::<usize>(), 0..TOKENS.len()).prop_map(|(k, t)| Mutation::Token(k, t)),
        (any::<usize>(), 0..TOKENS.len()).prop_map(|(k, t)| Mutation::Token(k, t)),
    ];
    prop::collection::vec(one, 1..=4)
}

/// Byte ranges of the tokens `Token` swaps: runs of number characters, and JSON strings.
fn tokens(b: &[u8]) -> Vec<(usize, usize)> {
    let mut v = Vec::new();
    let mut i = 0;
    let num = |c: u8| c.is_ascii_digit() || b"+-.eE".contains(&c);
    while i < b.len() {
        if b[i].is_ascii_digit() || b[i] == b'-' {
            let s = i;
            while i < b.len() && num(b[i]) {
                i += 1;
            }
            v.push((s, i));
        } else if b[i] == b'"' {
            let s = i;
            i += 1;
            while i < b.len() && b[i] != b'"' {
                i += 1;
            }
            i = (i + 1).min(b.len());
            v.push((s, i));
        } else {
            i += 1;
        }
    }
    v
}

/// Line ranges, each with its newline.
fn lines(b: &[u8]) -> Vec<(usize, usize)> {
    let mut v = Vec::new();
    let mut s = 0;
    for (i, c) in b.iter().enumerate() {
        if *c == b'\n' {
            v.push((s, i + 1));
            s = i + 1;
        }
    }
    if s < b.len() {
        v.push((s, b.len()));
    }
    v
}

/// `seed` with `muts` applied in order.
pub fn apply(seed: &[u8], muts: &[Mutation]) -> Vec<u8> {
    let mut b = seed.to_vec();
    for m in muts {
        match *m {
            Mutation::Flip(p, x) if !b.is_empty() => {
                let n = b.len();
                b[p % n] ^= x;
            }
            Mutation::Insert(p, x) => {
                let p = p % (b.len() + 1);
                b.insert(p, x);
            }
            Mutation::Truncate(p) => b.truncate(p % (b.len() + 1)),
            Mutation::DeleteLine(k) | Mutation::DuplicateLine(k) => {
                let ls = lines(&b);
                if ls.is_empty() {
                    continue;
                }
                let (s, e) = ls[k % ls.len()];
                if matches!(m, Mutation::DeleteLine(_)) {
                    b.drain(s..e);
                } else {
                    let line = b[s..e].to_vec();
                    b.splice(e..e, line);
                }
            }
            Mutation::Token(k, t) => {
                let ts = tokens(&b);
                if ts.is_empty() {
                    continue;
                }
                let (s, e) = ts[k % ts.len()];
                b.splice(s..e, TOKENS[t].iter().copied());
            }
            Mutation::Flip(..) => {}
        }
    }
    b
}

/// Outcomes of a fuzz run, for the report.
#[derive(Debug, Default)]
pub struct Tally {
    /// Cases run.
    pub cases: u64,
    /// Accepted (the mutation left a valid file).
    pub accepted: u64,
    /// Rejected with an error that names the file and a line or field.
    pub rejected: u64,
    /// Slowest case, seconds.
    pub slowest_s: f64,
}

/// Most a single case may take before it counts as a hang.
pub const HANG_SECONDS: f64 = 2.0;

impl Tally {
    /// Records one case: `run` returns `Ok(())` or the error message; a panic is caught and
    /// reported with the input. `check` says what is wrong with a message (or `None`).
    pub fn case(
        &mut self,
        input: &[u8],
        run: impl FnOnce() -> Result<(), String> + std::panic::UnwindSafe,
        check: impl Fn(&str) -> Option<String>,
    ) -> Result<(), TestCaseError> {
        let t = std::time::Instant::now();
        let outcome = std::panic::catch_unwind(run);
        let s = t.elapsed().as_secs_f64();
        self.cases += 1;
        self.slowest_s = self.slowest_s.max(s);
        let show = || String::from_utf8_lossy(&input[..input.len().min(2000)]).into_owned();
        prop_assert!(s < HANG_SECONDS, "took {s:.2} s on:\n{}", show());
        match outcome {
            Err(_) => Err(TestCaseError::fail(format!("panicked on:\n{}", show()))),
            Ok(Ok(())) => {
                self.accepted += 1;
                Ok(())
            }
            Ok(Err(msg)) => {
                self.rejected += 1;
                if let Some(why) = check(&msg) {
                    return Err(TestCaseError::fail(format!(
                        "unclear rejection ({why}): {msg}\non:\n{}",
                        show()
                    )));
                }
                Ok(())
            }
        }
    }
}

/// Whether a JSON reader's message names the file and a line or a field.
pub fn names_file_and_place(msg: &str, file: &str) -> Option<String> {
    if !msg.contains(file) {
        return Some(format!("does not name {file}"));
    }
    // Numbers are shown short (1e308, not 309 digits).
    if msg.contains("0000000000000000000000000000000000000000") {
        return Some("a number written out in full".into());
    }
    if false {
        return Some(format!("does not name {file}"));
    }
    // A field is named `like.this` (or `.` for the whole document, with a line).
    if !(msg.contains('`') || msg.contains("line ") || msg.contains("UTF-8")) {
        return Some("names no line or field".into());
    }
    None
}

/// The runner configuration of every fuzz test: `cases` cases, no persistence files, and a
/// **fixed seed**, so that CI explores the same cases on every run and a failure reproduces
/// (`PROPTEST_RNG_SEED=<u64>` explores others; a case found that way goes into the crate's
/// regression corpus).
#[allow(dead_code)]
pub fn config(cases: u32) -> proptest::test_runner::Config {
    use proptest::test_runner::{Config, RngSeed};
    let base = Config::default();
    let rng_seed = match base.rng_seed {
        RngSeed::Random => RngSeed::Fixed(0x6b69_6e63_616c_0019),
        fixed => fixed,
    };
    Config {
        cases,
        failure_persistence: None,
        rng_seed,
        ..base
    }
}
