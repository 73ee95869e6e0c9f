//! Issue 38, item 6: random contamination of the README's UR10 example never hands out a
//! worse robot. Every 15th row identifies (100 rows) and the other 1,395 validate, given as a
//! separate validation set; a property draws gross errors on the identification rows
//! (fraction 0–30 %, magnitude 3–200 mm), a tracker scale on every point of both files
//! (1 in half the cases, else 0.95–1.05) and a unit or frame corruption of either file (in
//! half the cases). Every run either refuses (a typed refusal naming its check) or validates
//! within 0.02 mm of the fit on the rows left clean (the oracle that knew the moved rows: a
//! fit on fewer rows validates a little worse, 0.474 mm on 74 of the 100, so the clean fit's
//! 0.452 mm is no fair bar for 26 % dropped).
//!
//! Below 3 mm (6.5 σ̂₃ of this recording, σ̂₃ = 0.46 mm) errors are not gross: most draws are
//! still separated or refused, but not all — 5 % of the rows moved 2.5 mm moved the held-out
//! mean by +0.035 mm, 21 % moved 2.1 mm by +0.056 mm, 26 % moved 2.3 mm by +0.124 mm
//! (σ̂/σ̃ = 1.89, under the outliers check's 2, which the clean 6-DoF UR10 series reaches at
//! 1.51). `docs/calibrating-real-data.md` ("Robust screening") states this limit.

use std::path::PathBuf;
use std::sync::OnceLock;

use calibrate::contamination::{Corruption, contaminate};
use calibrate::{CalibrateError, IdentifyRequest, Inputs, LoadedRobot, Refusal, Split};
use measurements::{Measurement, MeasurementSet, ReadOptions, read_file};
use proptest::prelude::*;
use proptest::test_runner::{RngAlgorithm, TestRng, TestRunner};

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// The robot, the identification rows (every 15th) and the validation rows (the others).
fn ur10() -> &'static (LoadedRobot, Vec<Measurement>, Vec<Measurement>) {
    static DATA: OnceLock<(LoadedRobot, Vec<Measurement>, Vec<Measurement>)> = OnceLock::new();
    DATA.get_or_init(|| {
        let robot = LoadedRobot::load(&root().join("scenarios/robots/ur10.json"), "robot").unwrap();
        let path = root().join("data/ur10-ipa/series-b-joint-configurations.csv");
        let rows = read_file(&path, &ReadOptions::new(6)).unwrap().rows;
        let (id, val) = rows
            .into_iter()
            .enumerate()
            .partition::<Vec<_>, _>(|(i, _)| i % 15 == 0);
        let strip = |v: Vec<(usize, Measurement)>| v.into_iter().map(|(_, r)| r).collect();
        (robot, strip(id), strip(val))
    })
}

/// The held-out mean (mm) of a calibration of `id` validated on `val`, or its error.
fn held_out(id: Vec<Measurement>, val: Vec<Measurement>) -> Result<f64, Box<CalibrateError>> {
    let (robot, _, _) = ur10();
    let inputs = Inputs {
        nominal: robot.clone(),
        data: MeasurementSet::new("id.csv", 6, id),
        validate: Some(MeasurementSet::new("val.csv", 6, val)),
    };
    let request = IdentifyRequest {
        split: Split::All,
        ..IdentifyRequest::new("ur10.json", "id.csv")
    };
    let cal = calibrate::calibrate(&request, inputs).map_err(Box::new)?;
    Ok(cal
        .points()
        .unwrap()
        .validation
        .as_ref()
        .unwrap()
        .table
        .after
        .norm
        .mean_mm)
}

fn clean() -> f64 {
    static CLEAN: OnceLock<f64> = OnceLock::new();
    *CLEAN.get_or_init(|| {
        let (_, id, val) = ur10();
        held_out(id.clone(), val.clone()).unwrap()
    })
}

fn corruption() -> impl Strategy<Value = Option<(Corruption, bool)>> {
    let c = prop_oneof![
        Just(Corruption::Radians),
        Just(Corruption::Metres),
        Just(Corruption::Centimetres),
        Just(Corruption::Inches),
        (0..3usize, 1..3usize).prop_map(|(a, d)| Corruption::Swap(a, (a + d) % 3)),
        (0..3usize).prop_map(Corruption::Negate),
    ];
    prop_oneof![Just(None), (c, any::<bool>()).prop_map(Some)]
}

/// One draw: gross errors (fraction, magnitude mm, seed), the tracker's scale, a corruption
/// of the identification (`true`) or the validation file.
type Draw = ((f64, f64, u64), f64, Option<(Corruption, bool)>);

fn draw() -> impl Strategy<Value = Draw> {
    (
        (0.0..=0.3f64, 3.0..=200.0f64, any::<u64>()),
        prop_oneof![Just(1.0), 0.95..=1.05f64],
        corruption(),
    )
}

/// What happened to one draw: refused (the check's name) or the held-out mean, with the
/// oracle's: the same draw's fit on the rows left uncontaminated (what a screen that knew the
/// moved rows would give: fewer rows validate a little worse, e.g. 0.474 mm on 74 rows).
fn outcome(((fraction, magnitude, seed), scale, corrupt): Draw) -> Result<(f64, f64), String> {
    let (_, id, val) = ur10();
    let mut set = MeasurementSet::new("id.csv", 6, id.clone());
    let among: Vec<usize> = (0..id.len()).collect();
    let count = (fraction * id.len() as f64).round() as usize;
    let moved = contaminate(&mut set, &among, count, magnitude, seed);
    let (mut id, mut val) = (set.rows, val.clone());
    for r in id.iter_mut().chain(val.iter_mut()) {
        let p = r.point_mm.as_mut().unwrap();
        p.iter_mut().for_each(|v| *v *= scale);
    }
    if let Some((c, in_id)) = corrupt {
        c.apply(if in_id { &mut id } else { &mut val });
    }
    let kept: Vec<Measurement> = (0..id.len())
        .filter(|i| moved.binary_search(i).is_err())
        .map(|i| id[i].clone())
        .collect();
    let result = held_out(id, val.clone()).map_err(|e| match &*e {
        CalibrateError::Refused(Refusal::Implausible { check, .. }) => check.name().to_string(),
        CalibrateError::Refused(r) => format!("refused: {r}"),
        other => panic!("not a refusal: {other}"),
    })?;
    let oracle = if moved.is_empty() {
        result
    } else {
        held_out(kept, val).map_err(|e| format!("the oracle: {e}"))?
    };
    Ok((result, oracle))
}

#[test]
fn random_contamination_is_refused_or_harmless() {
    let clean = clean();
    assert!((clean - 0.452).abs() < 0.0005, "{clean}");
    let config = ProptestConfig {
        cases: 64,
        max_shrink_iters: 0,
        failure_persistence: None,
        ..ProptestConfig::default()
    };
    // A fixed seed: the same draws on every run (a failure is reproducible as it stands).
    let rng = TestRng::from_seed(RngAlgorithm::ChaCha, &[38; 32]);
    let mut runner = TestRunner::new_with_rng(config, rng);
    let tally = std::cell::RefCell::new(std::collections::BTreeMap::<String, usize>::new());
    runner
        .run(&draw(), |d| {
            let what = outcome(d);
            eprintln!("{d:?} → {what:?}");
            match &what {
                Ok((mm, oracle)) => {
                    *tally.borrow_mut().entry("calibrated".into()).or_default() += 1;
                    prop_assert!(
                        (mm - oracle).abs() <= 0.02,
                        "{d:?}: held out {mm:.4} mm against {oracle:.4} mm on the clean rows"
                    );
                }
                Err(check) => *tally.borrow_mut().entry(check.clone()).or_default() += 1,
            }
            Ok(())
        })
        .unwrap();
    eprintln!("outcomes: {:?}", tally.borrow());
}
