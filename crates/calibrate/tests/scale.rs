//! Issue 38, item 2: the measurements' scale. A tracker scale or temperature-compensation
//! error makes every measured distance s times too large; the calibration absorbs it into
//! the lengths (a 2 % scale moved the UR10's a2 by −13.8 mm and a3 by −11.5 mm, exit 0). The
//! `scale` check sees every identified length move in proportion to itself and refuses;
//! `fit_scale` identifies the factor, divides the points by it and identifies again.

use std::path::PathBuf;

use calibrate::{CalibrateError, Calibration, Check, IdentifyRequest, Inputs, Refusal, Split};

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// The README's UR10 example: every 15th row identifies, the other 1,395 validate.
fn request() -> IdentifyRequest {
    IdentifyRequest {
        split: Split::Every {
            every: 15,
            offset: 0,
        },
        ..IdentifyRequest::new(
            root().join("scenarios/robots/ur10.json"),
            root().join("data/ur10-ipa/series-b-joint-configurations.csv"),
        )
    }
}

/// The inputs with every point (identification and validation rows alike: one tracker)
/// multiplied by `s`.
fn scaled(inputs: &Inputs, s: f64) -> Inputs {
    let mut i = inputs.clone();
    for r in &mut i.data.rows {
        if let Some(p) = &mut r.point_mm {
            p.iter_mut().for_each(|v| *v *= s);
        }
    }
    i
}

fn held_out_mm(c: &Calibration) -> f64 {
    c.points()
        .unwrap()
        .validation
        .as_ref()
        .unwrap()
        .table
        .after
        .norm
        .mean_mm
}

#[test]
fn a_scaled_tracker_is_refused_and_fit_scale_identifies_the_factor() {
    let req = request();
    let inputs = Inputs::load(&req).unwrap();
    let clean = calibrate::calibrate(&req, inputs.clone()).unwrap();
    let e = clean.scale_evidence().unwrap();
    eprintln!(
        "clean: ε̂ {:+.4} % ± {:.4} % — {}",
        100.0 * e.error(),
        100.0 * e.sd,
        e.lengths_text()
    );
    assert!(!e.significant());
    let clean_mm = held_out_mm(&clean);
    assert!((clean_mm - 0.452).abs() < 0.0005, "{clean_mm}");
    for s in [1.02, 0.98, 1.005] {
        let err = calibrate::calibrate(&req, scaled(&inputs, s)).unwrap_err();
        let CalibrateError::Refused(Refusal::Implausible { check, .. }) = &err else {
            panic!("×{s}: {err}")
        };
        assert_eq!(*check, Check::Scale, "×{s}: {err}");
        let text = err.to_string();
        assert!(
            text.contains("scaled by") && text.contains("fit_scale=True") && text.contains("a2"),
            "{text}"
        );
        eprintln!("×{s}: {text}");
        // --fit-scale: the factor identified, the fit as good as the clean one on points
        // measured by the same tracker.
        let fit = IdentifyRequest {
            fit_scale: true,
            ..req.clone()
        };
        let c = calibrate::calibrate(&fit, scaled(&inputs, s)).unwrap();
        let f = c.measurement_scale().expect("a significant scale").factor;
        let mm = held_out_mm(&c);
        eprintln!("×{s} --fit-scale: factor {f:.5}, held out {mm:.4} mm (clean {clean_mm:.4})");
        assert!((f / s - 1.0).abs() < 0.002, "factor {f} for ×{s}");
        assert!((mm - clean_mm).abs() < 0.01, "{mm} vs {clean_mm}");
        assert!(c.notices().iter().any(|n| n.contains("--fit-scale")));
    }
    // Below what the lengths resolve (0.1 %), nothing is said, and --fit-scale leaves the
    // points as measured.
    let c = calibrate::calibrate(&req, scaled(&inputs, 1.001)).unwrap();
    assert!(!c.scale_evidence().unwrap().significant());
    let fit = IdentifyRequest {
        fit_scale: true,
        ..req
    };
    let c = calibrate::calibrate(&fit, inputs).unwrap();
    assert!(c.measurement_scale().is_none());
    assert_eq!(held_out_mm(&c), clean_mm);
}
