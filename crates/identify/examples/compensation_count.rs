//! The compensation count of issue 29: N random KR1000 targets (uniform joints within the
//! limits) through [`identify::compensate_nearest`] for a calibrated-like robot (the nominal
//! KR1000 with seeded errors: lengths uniform ±1 mm, angles ±0.05°, base and tool included).
//! Prints how many rows move a joint by more than the flag threshold, their reasons, and the
//! unreachable ones with theirs.
//!
//! `cargo run --release -p identify --example compensation_count [-- N [THRESHOLD_DEG]]`
//! (N = 10000, threshold 2° by default).

use std::collections::BTreeMap;

use identify::{CompensationOptions, compensate_nearest};

/// The calibrated-like robot and the targets of the count (shared with the test).
#[path = "../tests/common/compensation_targets.rs"]
mod targets;

fn main() {
    let mut args = std::env::args().skip(1);
    let n: usize = args.next().map_or(10_000, |a| a.parse().expect("N"));
    let threshold: f64 = args
        .next()
        .map_or(2.0, |a| a.parse().expect("THRESHOLD_DEG"));
    let (nominal, identified) = targets::kr1000_pair();
    let poses = targets::random_poses(&nominal, n, 29);
    let opts = CompensationOptions {
        flag_change_deg: threshold,
        ..CompensationOptions::default()
    };
    let mut flagged = 0;
    let mut reasons: BTreeMap<&str, usize> = BTreeMap::new();
    let mut unreachable: BTreeMap<String, usize> = BTreeMap::new();
    let mut largest: f64 = 0.0;
    let mut over = [0usize; 4];
    for (k, q0) in poses.iter().enumerate() {
        let mut q = q0.clone();
        match compensate_nearest(&nominal, &identified, &mut q, &opts) {
            Ok(c) => {
                largest = largest.max(c.max_change_deg);
                for (i, t) in [1.0, 2.0, 5.0, 10.0].iter().enumerate() {
                    if c.max_change_deg > *t {
                        over[i] += 1;
                    }
                }
                if !c.flags.is_empty() {
                    flagged += 1;
                    *reasons.entry(c.flags[0].key()).or_default() += 1;
                    if std::env::var_os("VERBOSE").is_some() {
                        let s = identified.arm_singularity(q0).unwrap();
                        println!(
                            "target {k}: q{} {:+.2}°: {} (wrist {:.1}°, shoulder {:.0} mm, elbow {:.1}°, arm {:.0} mm)",
                            c.joint + 1,
                            c.max_change_deg,
                            c.flags
                                .iter()
                                .map(|f| f.to_string())
                                .collect::<Vec<_>>()
                                .join("; "),
                            s.wrist_deg,
                            s.shoulder_mm,
                            s.elbow_deg,
                            s.arm_mm
                        );
                    }
                }
            }
            Err(e) => {
                let key = match &e {
                    kinematics::IkUnreachable::BeyondLimit { joint, .. } => {
                        format!("beyond q{}'s limit", joint + 1)
                    }
                    kinematics::IkUnreachable::BeyondReach { .. } => "beyond reach".into(),
                    kinematics::IkUnreachable::Input(_) => "input".into(),
                };
                if std::env::var_os("VERBOSE").is_some() {
                    println!("target {k}: unreachable: {e}");
                }
                *unreachable.entry(key).or_default() += 1;
            }
        }
    }
    println!(
        "{n} random KR1000 targets, flag threshold {threshold}°: {flagged} flagged {reasons:?}; \
         unreachable {} {unreachable:?}; largest change {largest:.2}°; change > 1°/2°/5°/10°: {over:?}",
        unreachable.values().sum::<usize>()
    );
}
