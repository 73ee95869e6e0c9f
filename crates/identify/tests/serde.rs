//! Scenario-file forms of the options, and serialisable reports.

use crate::common::{TOOL, kr1000, perturbed, poses};
use identify::{
    Damping, IdentifyOptions, LmOptions, Problem, RegistrationPolicy, StopReason, identify,
};

#[test]
fn damping_reads_the_scenario_form_with_defaults() {
    let d: Damping = serde_json::from_str(r#"{"kind": "levenberg", "mu0": 0.001}"#).unwrap();
    assert_eq!(d, Damping::levenberg());
    let d: Damping = serde_json::from_str(r#"{"kind": "marquardt", "mu0": 0.01}"#).unwrap();
    assert_eq!(
        d,
        Damping::Marquardt {
            mu0: 0.01,
            decrease: 10.0,
            increase: 10.0
        }
    );
    let d: Damping = serde_json::from_str(r#"{"kind": "nielsen"}"#).unwrap();
    assert_eq!(d, Damping::nielsen());
    let err = serde_json::from_str::<Damping>(r#"{"kind": "levenberg", "tau": 1}"#).unwrap_err();
    assert!(err.to_string().contains("unknown field `tau`"), "{err}");
    assert!(serde_json::from_str::<Damping>(r#"{"kind": "gauss"}"#).is_err());
    let text = serde_json::to_string(&Damping::nielsen()).unwrap();
    assert_eq!(text, r#"{"kind":"nielsen","tau":0.001,"nu0":2.0}"#);
}

#[test]
fn options_default_from_empty_objects_and_reject_unknown_fields() {
    let o: IdentifyOptions = serde_json::from_str("{}").unwrap();
    assert_eq!(o, IdentifyOptions::default());
    let o: IdentifyOptions = serde_json::from_str(
        r#"{"lm": {"damping": {"kind": "nielsen"}, "column_scaling": false},
            "registration": {"kind": "auto", "threshold_mm": 5}}"#,
    )
    .unwrap();
    assert_eq!(o.lm.damping, Damping::nielsen());
    assert!(!o.lm.column_scaling);
    assert_eq!(o.lm.max_iterations, LmOptions::default().max_iterations);
    assert_eq!(
        o.registration,
        RegistrationPolicy::Auto { threshold_mm: 5.0 }
    );
    assert!(serde_json::from_str::<LmOptions>(r#"{"max_iter": 3}"#).is_err());
    assert_eq!(
        serde_json::to_string(&StopReason::TooManyRejections).unwrap(),
        r#""too_many_rejections""#
    );
}

#[test]
fn a_fit_serialises_without_nan() {
    let robot = kr1000(TOOL);
    let p = poses(&robot, 30, 1);
    let truth = perturbed(&robot, &(0..34).collect::<Vec<_>>(), 2);
    let meas = truth.points(&p);
    let problem = Problem::new(&robot, &p, &meas, (0..34).collect()).unwrap();
    let fit = identify(&problem, &IdentifyOptions::default()).unwrap();
    let v: serde_json::Value = serde_json::to_value(&fit).unwrap();
    assert_eq!(v["robot"]["name"], "KUKA KR1000 Titan");
    assert_eq!(v["free"].as_array().unwrap().len(), 34);
    assert!(v["stop"].is_string());
    let text = serde_json::to_string(&fit).unwrap();
    assert!(!text.contains("NaN") && !text.contains("inf"));
    // Redundant parameters carry no standard error, identifiable ones do.
    let cov = fit.covariance.as_ref().unwrap();
    assert_eq!(cov.parameters.len(), 27);
    assert_eq!(cov.omitted.len(), 7);
    assert!(fit.estimate("d1").unwrap().std_error.is_none());
    assert!(fit.estimate("a2").unwrap().std_error.is_some());
}
