//! Known-answer tests of the design crate: exhaustive search on a small pool, determinism,
//! the exchange never making the criterion worse, and every bad input.

use design::{
    Candidates, Criterion, DesignError, DesignOptions, InfoModel, Measure, Scale, compare, select,
    select_rows,
};
use kinematics::{PoseSampler, Robot};
use proptest::prelude::*;
use rand::SeedableRng;
use rand::rngs::ChaCha8Rng;

/// `k` admissible random poses of `robot` (the workspace's one sampler, seeded).
fn random_poses(robot: &Robot, k: usize, seed: u64) -> Vec<f64> {
    PoseSampler::default()
        .sample(robot, k, &mut ChaCha8Rng::seed_from_u64(seed))
        .unwrap()
        .rad
}

fn kr1000() -> Robot {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../scenarios/robots/kr1000-titan.json");
    Robot::from_file(&path).unwrap()
}

/// Ten parameters, so that four poses (12 equations) determine them.
const SMALL: [&str; 10] = [
    "theta2", "theta3", "a2", "a3", "d4", "alpha2", "alpha3", "tool_x", "tool_y", "tool_z",
];

fn small_model(robot: &Robot, k: usize, seed: u64) -> InfoModel {
    let pool = random_poses(robot, k, seed);
    let params = robot.layout().select(&SMALL).unwrap();
    InfoModel::new(robot, &pool, None, Some(&params), &Scale::default()).unwrap()
}

/// Every 4-subset of 12: the best utility.
fn exhaustive(model: &InfoModel, crit: Criterion) -> (Vec<usize>, f64) {
    let mut best = (Vec::new(), f64::NEG_INFINITY);
    for a in 0..12 {
        for b in a + 1..12 {
            for c in b + 1..12 {
                for d in c + 1..12 {
                    let set = [a, b, c, d];
                    if let Some(v) = model.value(crit, &set) {
                        let u = crit.utility(v);
                        if u > best.1 {
                            best = (set.to_vec(), u);
                        }
                    }
                }
            }
        }
    }
    best
}

/// Greedy + exchange (with ten seeded restarts) finds the exhaustive optimum of 4 of 12
/// for every criterion, on several pools.
#[test]
fn greedy_and_exchange_match_exhaustive_search_on_4_of_12() {
    let robot = kr1000();
    let mut exact_without_restarts = 0;
    let mut cases = 0;
    for seed in [1, 2, 3, 4] {
        let model = small_model(&robot, 12, seed);
        for crit in Criterion::ALL {
            let (set, u) = exhaustive(&model, crit);
            let mut opts = DesignOptions::new(crit, 4);
            let plain = select(&model, &opts).unwrap();
            cases += 1;
            if plain.selected == set {
                exact_without_restarts += 1;
            }
            opts.restarts = 10;
            opts.seed = 11;
            let d = select(&model, &opts).unwrap();
            let ud = crit.utility(d.value);
            assert!(
                (ud - u).abs() <= 1e-9 * u.abs(),
                "seed {seed} {crit}: design {:?} {ud} vs exhaustive {set:?} {u}",
                d.selected
            );
        }
    }
    // 4 of 12 for 10 parameters is the hardest case for the greedy start (N = ⌈p/3⌉: every
    // pose is chosen in the rank-building phase, by D): without restarts it finds 13 of the
    // 28 optima; the restarts find the rest.
    assert!(
        exact_without_restarts >= 10,
        "{exact_without_restarts}/{cases}"
    );
}

/// The same inputs give the same design, bit for bit, with and without restarts.
#[test]
fn designs_are_deterministic() {
    let robot = kr1000();
    let pool = random_poses(&robot, 150, 21);
    for crit in [Criterion::D, Criterion::I, Criterion::E] {
        let mut opts = DesignOptions::new(crit, 14);
        opts.restarts = 2;
        opts.seed = 5;
        let a = select(
            &InfoModel::new(&robot, &pool, None, None, &Scale::default()).unwrap(),
            &opts,
        )
        .unwrap();
        let b = select(
            &InfoModel::new(&robot, &pool, None, None, &Scale::default()).unwrap(),
            &opts,
        )
        .unwrap();
        assert_eq!(a.selected, b.selected);
        assert_eq!(a.value.to_bits(), b.value.to_bits());
        assert_eq!(a.trace.len(), b.trace.len());
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 12, .. ProptestConfig::default() })]

    /// The exchange never makes the criterion worse: the utility after every swap is at
    /// least the one before, and the final design is at least as good as the greedy one.
    #[test]
    fn the_exchange_never_makes_the_criterion_worse(
        seed in 0u64..1000,
        k in 30usize..70,
        n in 10usize..16,
        c in 0usize..5,
    ) {
        let crit = [Criterion::D, Criterion::A, Criterion::I, Criterion::O1, Criterion::E][c];
        let robot = kr1000();
        let pool = random_poses(&robot, k, seed);
        let model = InfoModel::new(&robot, &pool, None, None, &Scale::default()).unwrap();
        let d = select(&model, &DesignOptions::new(crit, n)).unwrap();
        for w in d.trace.windows(2) {
            prop_assert!(w[1] >= w[0], "{crit}: {:?}", d.trace);
        }
        let (ug, uf) = (crit.utility(d.greedy_value), crit.utility(d.value));
        prop_assert!(uf >= ug - 1e-9 * ug.abs(), "{crit}: greedy {ug} final {uf}");
        prop_assert!(d.converged);
    }
}

/// Designed sets beat the median of random sets of the same size on their own criterion.
#[test]
fn the_report_compares_with_random_sets() {
    let robot = kr1000();
    let pool = random_poses(&robot, 300, 4);
    let model = InfoModel::new(&robot, &pool, None, None, &Scale::default()).unwrap();
    for crit in [Criterion::D, Criterion::I] {
        let d = select(&model, &DesignOptions::new(crit, 20)).unwrap();
        let r = compare(&model, &d, 100, 1);
        assert!(crit.utility(r.design.value) > crit.utility(r.random_median.value));
        assert!(r.design.condition_number < r.random_median.condition_number);
        let text = r.to_text();
        assert!(
            text.contains("condition number") && text.contains("O5"),
            "{text}"
        );
    }
}

#[test]
fn too_few_poses_and_candidates_are_refused() {
    let robot = kr1000();
    let pool = random_poses(&robot, 10, 3);
    let model = InfoModel::new(&robot, &pool, None, None, &Scale::default()).unwrap();
    let e = select(&model, &DesignOptions::new(Criterion::D, 8)).unwrap_err();
    assert!(
        matches!(
            e,
            DesignError::TooFewPoses {
                poses: 8,
                rank: 27,
                rows_per_pose: 3
            }
        ),
        "{e}"
    );
    assert!(e.to_string().contains("need at least 9 poses"), "{e}");
    let e = select(&model, &DesignOptions::new(Criterion::D, 12)).unwrap_err();
    assert!(
        matches!(
            e,
            DesignError::TooFewCandidates {
                candidates: 10,
                poses: 12
            }
        ),
        "{e}"
    );
}

#[test]
fn bad_candidate_files_name_the_line() {
    let robot = kr1000();
    let ok = "id,q1,q2,q3,q4,q5,q6\na,10,20,-20,0,60,0\n";
    let c = Candidates::from_str(&robot, ok, "c.csv").unwrap();
    assert_eq!(c.ids, vec![Some("a".to_string())]);
    let nan = "id,q1,q2,q3,q4,q5,q6\na,10,20,-20,0,60,0\nb,10,NaN,-20,0,60,0\n";
    let e = Candidates::from_str(&robot, nan, "c.csv").unwrap_err();
    assert!(e.to_string().starts_with("c.csv:3:"), "{e}");
    let out = "q1,q2,q3,q4,q5,q6\n10,20,-20,0,60,0\n10,20,-20,0,60,999\n";
    let e = Candidates::from_str(&robot, out, "c.csv").unwrap_err();
    assert!(e.to_string().starts_with("c.csv:3:"), "{e}");
    // In memory: index and joint.
    let mut pool = random_poses(&robot, 20, 3);
    pool[6 * 5 + 2] = f64::NAN;
    let e = InfoModel::new(&robot, &pool, None, None, &Scale::default()).unwrap_err();
    assert_eq!(e.to_string(), "candidate 5: q3 is not a number (NaN)");
    pool[6 * 5 + 2] = 4.0;
    let e = InfoModel::new(&robot, &pool, None, None, &Scale::default()).unwrap_err();
    assert!(e.to_string().starts_with("candidate 5: q3 = 229.18"), "{e}");
}

/// A pool with axis 1 never moving cannot separate link 1 from the base: the error names
/// the parameters it cannot observe.
#[test]
fn a_rank_deficient_pool_names_what_it_cannot_observe() {
    let robot = kr1000();
    let mut pool = random_poses(&robot, 200, 8);
    for q in pool.chunks_exact_mut(6) {
        q[0] = 0.3;
    }
    let e = InfoModel::new(&robot, &pool, None, None, &Scale::default()).unwrap_err();
    let DesignError::RankDeficientPool { names, .. } = &e else {
        panic!("{e}");
    };
    assert!(!names.is_empty());
    assert!(e.to_string().contains("cannot observe"), "{e}");
    eprintln!("{e}");
}

/// The real-data entry point returns distinct ascending row indices.
#[test]
fn select_rows_returns_row_indices() {
    let robot = kr1000();
    let pool = random_poses(&robot, 60, 2);
    let deg: Vec<f64> = pool.iter().map(|r| r.to_degrees()).collect();
    let rows = select_rows(&robot, &deg, 15, Criterion::D, None).unwrap();
    assert_eq!(rows.len(), 15);
    assert!(rows.windows(2).all(|w| w[0] < w[1]) && rows[14] < 60);
}

/// `JᵀJ` of the rows `identify::frames` fits, columns scaled by the model's scale: the
/// reference the frame and target information matrices must equal.
fn identify_normal_matrix(
    model: &InfoModel,
    robot: &Robot,
    pool: &[f64],
    measure: Measure,
) -> nalgebra::DMatrix<f64> {
    use identify::frames::{DEFAULT_MM_PER_DEG, FrameData, FrameFree, FrameModel, FrameRow};
    let (names, targets): (Vec<String>, Vec<nalgebra::Vector3<f64>>) = match measure {
        Measure::Frame => (vec![String::new()], vec![robot.tool_mm()]),
        _ => robot.targets().unwrap().iter().cloned().unzip(),
    };
    let fm = FrameModel {
        robot: robot.clone(),
        tool_rotation: robot.tool_rotation(),
        targets_mm: targets.clone(),
    };
    let mut rows = Vec::new();
    for (j, q) in pool.chunks_exact(6).enumerate() {
        let f = robot.flange(q);
        for (k, t) in targets.iter().enumerate() {
            rows.push(FrameRow {
                pose: j,
                target: k,
                point_mm: f.rot * t + f.pos_mm,
                rotation: (measure == Measure::Frame).then(|| f.rot * fm.tool_rotation),
                w_pos: [1.0; 3],
                // 1° weighs as DEFAULT_MM_PER_DEG mm: the weight per radian.
                w_rot: DEFAULT_MM_PER_DEG * 180.0 / std::f64::consts::PI,
            });
        }
    }
    let data = FrameData {
        poses_rad: pool.to_vec(),
        n_joints: 6,
        target_names: names.clone(),
        rows,
    };
    let free = FrameFree {
        robot: model.params.clone(),
        rotation: measure == Measure::Frame,
        n_targets: names.len(),
    };
    let mut j = nalgebra::DMatrix::zeros(0, 0);
    identify::frames::residual_jacobian(&fm, &data, &free, Some(&mut j));
    let s = nalgebra::DMatrix::from_diagonal(&nalgebra::DVector::from_vec(model.scale.clone()));
    let js = j * s;
    js.transpose() * js
}

fn assert_close(a: &nalgebra::DMatrix<f64>, b: &nalgebra::DMatrix<f64>) {
    let scale = b.amax();
    let d = (a - b).amax();
    assert!(d <= 1e-12 * scale, "max difference {d} of {scale}");
}

/// The information matrix of 6-DoF poses is `S·JᵀWJ·S` of identify's own frame rows (the
/// orientation rows weighted by identify's default ratio), on the unknowns identify's
/// `select_free` keeps: tool orientation and tool point beside the robot's.
#[test]
fn frame_information_is_identify_normal_matrix() {
    let robot = kr1000();
    let pool = random_poses(&robot, 25, 31);
    let model =
        InfoModel::with_measure(&robot, &pool, None, None, &Scale::default(), Measure::Frame)
            .unwrap();
    assert_eq!((model.measure, model.rows), (Measure::Frame, 6));
    assert_eq!(model.p, model.params.len() + 6);
    let tail: Vec<&str> = model.names[model.params.len()..]
        .iter()
        .map(String::as_str)
        .collect();
    assert_eq!(
        tail,
        [
            "tool_rx", "tool_ry", "tool_rz", "tool_x", "tool_y", "tool_z"
        ]
    );
    let all: Vec<usize> = (0..25).collect();
    let reference = identify_normal_matrix(&model, &robot, &pool, Measure::Frame);
    assert_close(&model.information(&all), &reference);
    // The point model of the same robot: the same pool, 3 rows.
    let point = InfoModel::new(&robot, &pool, None, None, &Scale::default()).unwrap();
    assert_eq!(point.rows, 3);
    assert_eq!(
        InfoModel::with_measure(&robot, &pool, None, None, &Scale::default(), Measure::Point)
            .unwrap()
            .information(&all),
        point.information(&all)
    );
}

/// Three reflectors: 9 rows per pose, one point per target among the unknowns, the same
/// `JᵀJ` as identify's multi-target rows; a robot file without targets is refused.
#[test]
fn target_information_is_identify_normal_matrix() {
    let mut robot = kr1000();
    let pool = random_poses(&robot, 20, 32);
    let e = InfoModel::with_measure(
        &robot,
        &pool,
        None,
        None,
        &Scale::default(),
        Measure::Targets,
    )
    .unwrap_err();
    assert!(e.to_string().contains("names no targets"), "{e}");
    robot.set_targets(Some(vec![
        ("r1".into(), nalgebra::Vector3::new(120.0, 0.0, 250.0)),
        ("r2".into(), nalgebra::Vector3::new(-60.0, 104.0, 250.0)),
        ("r3".into(), nalgebra::Vector3::new(-60.0, -104.0, 250.0)),
    ]));
    let model = InfoModel::with_measure(
        &robot,
        &pool,
        None,
        None,
        &Scale::default(),
        Measure::Targets,
    )
    .unwrap();
    assert_eq!(model.rows, 9);
    assert_eq!(model.p, model.params.len() + 9);
    assert_eq!(model.names.last().unwrap(), "r3_z");
    let all: Vec<usize> = (0..20).collect();
    let reference = identify_normal_matrix(&model, &robot, &pool, Measure::Targets);
    assert_close(&model.information(&all), &reference);
    // Rank of N poses: 6 per pose (one rigid motion) + 3 for the triangle's shape, so
    // 4 poses (36 equations) determine 27 of the 33 unknowns and 5 are the fewest.
    assert_eq!(model.rank_per_pose(), (6, 3));
    assert_eq!(model.min_poses(), 5);
    for (n, rank) in [(3, 21), (4, 27), (5, 33)] {
        let set: Vec<usize> = (0..n).collect();
        assert_eq!(numerical_rank(&model.information(&set)), rank, "{n} poses");
    }
    let e = select(&model, &DesignOptions::new(Criterion::D, 4)).unwrap_err();
    assert!(e.to_string().contains("need at least 5 poses"), "{e}");
    assert_eq!(
        select(&model, &DesignOptions::new(Criterion::D, 5))
            .unwrap()
            .selected
            .len(),
        5
    );
}

/// Eigenvalues of the unit-diagonal matrix above 10⁻¹⁰ of the largest.
fn numerical_rank(m: &nalgebra::DMatrix<f64>) -> usize {
    let d: Vec<f64> = (0..m.nrows()).map(|k| m[(k, k)].sqrt()).collect();
    let u = nalgebra::DMatrix::from_fn(m.nrows(), m.ncols(), |i, j| m[(i, j)] / (d[i] * d[j]));
    let ev = u.symmetric_eigenvalues();
    let max = ev.max();
    ev.iter().filter(|&&v| v > 1e-10 * max).count()
}

/// A 6-DoF probe reaches full rank with fewer poses than a single reflector: ⌈p/6⌉ frame
/// poses give a design (full rank, finite condition number) where the same number of point
/// poses is refused as too few equations.
#[test]
fn frames_reach_full_rank_with_fewer_poses_than_points() {
    let robot = kr1000();
    let pool = random_poses(&robot, 120, 33);
    let point = InfoModel::new(&robot, &pool, None, None, &Scale::default()).unwrap();
    let frame =
        InfoModel::with_measure(&robot, &pool, None, None, &Scale::default(), Measure::Frame)
            .unwrap();
    let n_frame = frame.p.div_ceil(6);
    assert_eq!(frame.min_poses(), n_frame);
    let set: Vec<usize> = (0..n_frame - 1).collect();
    assert_eq!(numerical_rank(&frame.information(&set)), 6 * (n_frame - 1));
    let n_point = point.p.div_ceil(3);
    assert!(n_frame < n_point, "{n_frame} vs {n_point}");
    let d = select(&frame, &DesignOptions::new(Criterion::D, n_frame)).unwrap();
    let m = frame.information(&d.selected);
    assert!(design::condition_number(&m).unwrap().is_finite());
    let e = select(&point, &DesignOptions::new(Criterion::D, n_frame)).unwrap_err();
    assert!(
        matches!(
            e,
            DesignError::TooFewPoses {
                rows_per_pose: 3,
                ..
            }
        ),
        "{e}"
    );
}

/// The dense scoring of 6-row blocks (every criterion, on the utility scale of the rank-3
/// path) finds the exhaustive optimum of 3 of 12 frame poses (with restarts).
#[test]
fn frame_designs_match_exhaustive_search() {
    let robot = kr1000();
    let params = robot.layout().select(&SMALL[..7]).unwrap();
    for seed in [1, 2] {
        let pool = random_poses(&robot, 12, seed);
        let model = InfoModel::with_measure(
            &robot,
            &pool,
            None,
            Some(&params),
            &Scale::default(),
            Measure::Frame,
        )
        .unwrap();
        assert_eq!(model.p, 13);
        for crit in Criterion::ALL {
            let mut best = (Vec::new(), f64::NEG_INFINITY);
            for a in 0..12 {
                for b in a + 1..12 {
                    for c in b + 1..12 {
                        if let Some(v) = model.value(crit, &[a, b, c])
                            && crit.utility(v) > best.1
                        {
                            best = (vec![a, b, c], crit.utility(v));
                        }
                    }
                }
            }
            let mut opts = DesignOptions::new(crit, 3);
            opts.restarts = 10;
            opts.seed = 5;
            let d = select(&model, &opts).unwrap();
            let ud = crit.utility(d.value);
            assert!(
                (ud - best.1).abs() <= 1e-9 * best.1.abs(),
                "seed {seed} {crit}: {:?} {ud} vs {:?} {}",
                d.selected,
                best.0,
                best.1
            );
        }
    }
}
