//! The console text of `kincal identifiability`: rank, singular values, observability,
//! redundant and identifiable sets of an [`IdentifiabilityReport`]. Numbers follow
//! [`crate::fmt`].

use std::fmt::Write as _;

use identify::{IdentifiabilityReport, Observability, Redundancy};
use nalgebra::Vector3;

use crate::fmt::{fixed, plus, ratio, sci, setting, setting_sci};

/// The text `kincal identifiability` prints for `r` (the parameter spec `params` as written,
/// the poses' `source`, the measured point `tool` in the flange frame, mm).
pub fn console(
    r: &IdentifiabilityReport,
    params: &str,
    source: &str,
    tool: Vector3<f64>,
) -> String {
    let mut out = String::new();
    let _ = writeln!(out, "{} — {source}", r.robot);
    let _ = writeln!(
        out,
        "{} poses ({} equations), {} parameters ({params}), ball at ({}, {}, {}) mm in the \
         flange frame",
        r.n_poses,
        r.n_equations,
        r.parameter_count,
        setting(tool.x),
        setting(tool.y),
        setting(tool.z)
    );
    let _ = writeln!(out, "scaling: {}", r.scaling);
    let _ = writeln!(
        out,
        "rank {} of {} (σ_i > {}·σ_max = {})",
        r.rank,
        r.parameter_count,
        setting_sci(r.rank_rtol),
        sci(r.rank_tolerance, 3)
    );
    let sv = &r.singular_values;
    if r.rank > 0 {
        let _ = write!(
            out,
            "singular values: σ_max {}, σ_r {}",
            fixed(sv[0], 4),
            sci(sv[r.rank - 1], 4)
        );
        if let Some(next) = sv.get(r.rank) {
            let _ = write!(out, ", next {}", sci(*next, 3));
        }
        out.push('\n');
    }
    if let (Some(c), Some(o)) = (r.condition_number, &r.observability) {
        let _ = writeln!(out, "condition number (identifiable part): {}", ratio(c));
        let _ = writeln!(
            out,
            "observability (on σ_1..σ_r of the scaled Jacobian, m = {}): {}",
            r.n_poses,
            indices(o, "  ")
        );
    }
    if !r.zero_columns.is_empty() {
        let _ = writeln!(
            out,
            "no effect on the point (zero columns): {}",
            r.zero_columns.join(", ")
        );
    }
    let _ = writeln!(out, "redundant ({}):", r.redundant.len());
    for red in &r.redundancies {
        let with = confounded_with(red, "nothing (zero column)");
        let _ = writeln!(out, "  {:<10} confounded with {with}", red.name);
    }
    if !r.confounded_groups.is_empty() {
        let groups: Vec<String> = r
            .confounded_groups
            .iter()
            .map(|g| format!("{{{}}}", g.join(", ")))
            .collect();
        let _ = writeln!(out, "confounded groups: {}", groups.join(" "));
    }
    let _ = writeln!(
        out,
        "identifiable ({}): {}",
        r.identifiable.len(),
        r.identifiable.join(", ")
    );
    let all: Vec<String> = sv.iter().map(|s| sci(*s, 3)).collect();
    let _ = writeln!(out, "all singular values: {}", all.join(" "));
    out
}

/// O1 … O5 of `o`, separated by `sep` (`O1 1.8591e-2, O2 …`).
pub(crate) fn indices(o: &Observability, sep: &str) -> String {
    [o.o1, o.o2, o.o3, o.o4, o.o5]
        .iter()
        .enumerate()
        .map(|(i, v)| format!("O{} {}", i + 1, sci(*v, 4)))
        .collect::<Vec<_>>()
        .join(sep)
}

/// What a redundant parameter is confounded with, with the weights (`d2 (-1.000), a2
/// (+0.001)`), or `none` when it does not move the point.
pub(crate) fn confounded_with(red: &Redundancy, none: &str) -> String {
    if red.confounded_with.is_empty() {
        return none.to_string();
    }
    red.confounded_with
        .iter()
        .map(|t| format!("{} ({})", t.name, plus(t.weight, 3)))
        .collect::<Vec<_>>()
        .join(", ")
}
