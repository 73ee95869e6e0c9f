//! Identifiability of the KR1000 (`docs/model.md` §6): computed rank, redundant parameters and
//! their confounded groups, the minimal set, and the lower rank with the ball on the flange axis.

use std::collections::BTreeSet;

use crate::common::{TOOL, kr1000, poses};
use identify::{IdentifiabilityOptions, ParamSet, analyze};

fn set(names: &[&str]) -> BTreeSet<String> {
    names.iter().map(|s| s.to_string()).collect()
}

#[test]
fn kr1000_off_axis_ball_rank_27_with_the_documented_redundancy_groups() {
    let robot = kr1000(TOOL);
    let poses = poses(&robot, 50, 1);
    let all: Vec<usize> = (0..robot.n_params()).collect();
    let rep = analyze(
        &robot,
        &poses,
        None,
        &all,
        &IdentifiabilityOptions::default(),
    )
    .unwrap();

    assert_eq!(rep.parameter_count, 34);
    assert_eq!(rep.rank, 27, "singular values {:?}", rep.singular_values);
    assert_eq!(rep.redundant.len(), 7);
    // A clear gap: the identifiable part is well above the tolerance, the rest is rounding.
    let s = &rep.singular_values;
    assert!(s[26] > 1e-3 * s[0], "smallest identifiable σ {:e}", s[26]);
    assert!(s[27] < 1e-12 * s[0], "largest redundant σ {:e}", s[27]);

    // The null space involves exactly the groups of docs/model.md §6 (basis-free: projector
    // components).
    let groups: BTreeSet<BTreeSet<String>> = rep
        .confounded_groups
        .iter()
        .map(|g| g.iter().cloned().collect())
        .collect();
    let expected: BTreeSet<BTreeSet<String>> = [
        set(&["d1", "base_dz"]),
        set(&["base_rz", "theta1"]),
        set(&["d2", "d3"]),
        set(&["theta6", "d6", "a6", "alpha6", "tool_x", "tool_y", "tool_z"]),
    ]
    .into_iter()
    .collect();
    assert_eq!(groups, expected);

    // With the keep priority of docs/model.md §6 the dropped ones are exactly its list.
    let redundant: BTreeSet<String> = rep.redundant.iter().cloned().collect();
    assert_eq!(
        redundant,
        set(&["d1", "base_rz", "d3", "theta6", "d6", "a6", "alpha6"])
    );
    // Each redundant parameter is confounded only with members of its own group.
    for r in &rep.redundancies {
        let group = expected.iter().find(|g| g.contains(&r.name)).unwrap();
        assert!(
            !r.confounded_with.is_empty(),
            "{} confounded with nothing",
            r.name
        );
        for t in &r.confounded_with {
            assert!(
                group.contains(&t.name),
                "{} confounded with {}",
                r.name,
                t.name
            );
        }
    }
    // d1 ≡ base_dz and d3 ≡ d2 exactly (same unit column up to sign).
    let d1 = rep.redundancies.iter().find(|r| r.name == "d1").unwrap();
    assert_eq!(d1.confounded_with.len(), 1);
    assert!((d1.confounded_with[0].weight.abs() - 1.0).abs() < 1e-9);

    let cond = rep.condition_number.unwrap();
    let obs = rep.observability.unwrap();
    assert!((cond - s[0] / s[26]).abs() < 1e-9 * cond);
    assert!((obs.o2 - 1.0 / cond).abs() < 1e-12);
    assert!(obs.o1 > 0.0 && obs.o3 > 0.0 && obs.o4 > 0.0 && obs.o5 > 0.0);
    assert!(obs.o5 <= obs.o3, "O5 ≤ σ_min");
}

#[test]
fn minimal_set_is_a_valid_minimal_set_of_the_computed_rank() {
    let robot = kr1000(TOOL);
    let poses = poses(&robot, 50, 1);
    let opts = IdentifiabilityOptions::default();
    let minimal = ParamSet::Minimal
        .resolve(&robot, &poses, None, &opts)
        .unwrap();
    assert_eq!(minimal.len(), 27);
    let rep = analyze(&robot, &poses, None, &minimal, &opts).unwrap();
    assert_eq!(rep.rank, 27, "the kept columns must be independent");
    assert!(rep.redundant.is_empty());
    assert!(rep.confounded_groups.is_empty());
    // Same on other pose sets.
    for seed in [2, 3, 4] {
        let p = crate::common::poses(&robot, 50, seed);
        let r = analyze(&robot, &p, None, &minimal, &opts).unwrap();
        assert_eq!(r.rank, 27, "seed {seed}");
    }
}

#[test]
fn ball_on_the_flange_axis_lowers_the_rank() {
    let robot = kr1000([0.0, 0.0, 150.0]);
    let poses = poses(&robot, 50, 1);
    let all: Vec<usize> = (0..robot.n_params()).collect();
    let rep = analyze(
        &robot,
        &poses,
        None,
        &all,
        &IdentifiabilityOptions::default(),
    )
    .unwrap();
    assert_eq!(rep.rank, 25, "singular values {:?}", rep.singular_values);
    assert_eq!(rep.redundant.len(), 9);
    // θ6 turns the ball about its own position: a zero column.
    assert_eq!(rep.zero_columns, vec!["theta6".to_string()]);
    let minimal = ParamSet::Minimal
        .resolve(&robot, &poses, None, &IdentifiabilityOptions::default())
        .unwrap();
    let r = analyze(&robot, &poses, None, &minimal, &Default::default()).unwrap();
    assert_eq!((minimal.len(), r.rank), (25, 25));
}

#[test]
fn fewer_equations_than_parameters_pads_the_decomposition() {
    let robot = kr1000(TOOL);
    let poses = poses(&robot, 5, 1);
    let all: Vec<usize> = (0..robot.n_params()).collect();
    let rep = analyze(&robot, &poses, None, &all, &Default::default()).unwrap();
    assert_eq!(rep.singular_values.len(), 34);
    assert!(rep.rank <= 15);
    assert_eq!(rep.redundant.len(), 34 - rep.rank);
}

#[test]
fn parameter_sets_resolve_and_unknown_names_are_named() {
    let robot = kr1000(TOOL);
    let poses = poses(&robot, 20, 1);
    let opts = IdentifiabilityOptions::default();
    let paper: ParamSet = "paper".parse().unwrap();
    assert_eq!(
        paper.resolve(&robot, &poses, None, &opts).unwrap().len(),
        34
    );
    let names: ParamSet = "a2, theta3,base_dx".parse().unwrap();
    assert_eq!(
        names.resolve(&robot, &poses, None, &opts).unwrap(),
        vec![6, 8, 28]
    );
    let bad: ParamSet = "a2,a7".parse().unwrap();
    let err = bad
        .resolve(&robot, &poses, None, &opts)
        .unwrap_err()
        .to_string();
    assert!(err.contains("unknown parameter `a7`"), "{err}");
    assert!(err.contains("theta1"), "lists the known names: {err}");
}
