//! The residual budget (issue 19): what the after-calibration error of `paper-kr1000` is made
//! of, computed by rerunning the same trials with each source outside the model switched off
//! in turn and alone.

use crate::common::{load_edited, scenario_path};

use campaign::{BudgetSource as Source, budget_runs, budget_trials};
use campaign::{
    CampaignSummary, Context, LoadedScenario, Scenario, ShardFile, ShardManifest, merge_shards,
    residual_budget, run_range, shard_budget, shard_range,
};

const TRIALS: u64 = 16;

fn paper(trials: u64) -> LoadedScenario {
    load_edited("paper-kr1000", |v| {
        v["trials"] = trials.into();
    })
}

#[test]
fn paper_budget_explains_the_residual() {
    let loaded = paper(TRIALS);
    assert!(loaded.scenario.residual_budget.enabled, "committed on");
    assert_eq!(
        budget_trials(&loaded.scenario),
        TRIALS,
        "capped at the trials"
    );
    // Compliance, gears, repeatability, tracker noise (drift is off): 2 + 2·4 runs.
    assert_eq!(budget_runs(&loaded.scenario), 10);
    let b = residual_budget(&loaded, &|_| {}, &|| false)
        .unwrap()
        .expect("enabled");
    let sources: Vec<Source> = b.sources.iter().map(|r| r.source).collect();
    assert_eq!(
        sources,
        [
            Source::Compliance,
            Source::Gears,
            Source::Repeatability,
            Source::TrackerNoise
        ]
    );

    // "every source" is the campaign itself, to the bit, although the campaign runs the ISO
    // test and the budget does not: the streams are keyed by purpose.
    let ctx = Context::new(loaded.clone()).unwrap();
    assert!(ctx.iso.is_some());
    let agg = run_range(&ctx, 0..TRIALS, &|_| {});
    let all = b.all.after_mean_mm.as_ref().unwrap().mean;
    assert_eq!(all, agg.metrics["after_mean_mm"].summary().unwrap().mean);

    // Geometric errors only: the model contains them, so nothing but the solver's and the
    // IK's tolerance remains.
    let none = b.none.after_mean_mm.as_ref().unwrap().mean;
    assert!(none < 1e-6, "geometric-only after error {none} mm");

    // Every source switched off lowers the error; with it alone the error is below the
    // total; the sources add roughly in quadrature.
    for r in &b.sources {
        let without = r.without.after_mean_mm.as_ref().unwrap().mean;
        let alone = r.alone.after_mean_mm.as_ref().unwrap().mean;
        assert!(
            without < all,
            "{:?}: without {without} vs all {all}",
            r.source
        );
        assert!(alone < all, "{:?}: alone {alone} vs all {all}", r.source);
        assert!(alone > none, "{:?}", r.source);
    }
    let q = b.quadrature_mm().unwrap();
    assert!((q - all).abs() < 0.1 * all, "quadrature {q} vs {all}");
    // The paper's residual is mostly compliance: switching it off removes more than half.
    let c = &b.sources[0];
    let without_c = c.without.after_mean_mm.as_ref().unwrap().mean;
    assert!(all - without_c > 0.5 * all, "{without_c} of {all}");

    // The summary says it, and a summary without a budget says nothing of it.
    let summary = CampaignSummary::new(&loaded.scenario, &agg);
    assert!(summary.residual_budget.is_none());
    assert!(!summary.to_markdown().contains("Residual budget"));
    assert!(
        !summary
            .to_json()
            .contains("residual_budget\": {\n    \"trials")
    );
    let files = |s: &CampaignSummary| -> Vec<(String, Vec<u8>)> {
        campaign::render_outputs(s, &agg).unwrap()
    };
    assert!(
        !files(&summary)
            .iter()
            .any(|(n, _)| n == "residual-budget.svg")
    );
    let summary = summary.with_budget(Some(b));
    let out = files(&summary);
    let svg = out
        .iter()
        .find(|(n, _)| n == "residual-budget.svg")
        .map(|(_, s)| String::from_utf8_lossy(s).into_owned())
        .expect("a budget plot");
    for label in [
        "no compliance",
        "tracker noise only",
        "none",
        "paper, mean after",
    ] {
        assert!(svg.contains(label), "{label}");
    }
    let html = out.iter().find(|(n, _)| n == "report.html").unwrap();
    assert!(String::from_utf8_lossy(&html.1).contains("no compliance"));
    let md = summary.to_markdown();
    assert!(md.contains("## Residual budget"), "{md}");
    assert!(md.contains("| without joint compliance under self-weight |"));
    assert!(md.contains("switching off joint compliance under self-weight removes the most"));
}

#[test]
fn budget_is_deterministic_across_thread_counts() {
    let loaded = paper(6);
    let on = |threads: usize| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| residual_budget(&loaded, &|_| {}, &|| false).unwrap())
    };
    let one = serde_json::to_string(&on(1)).unwrap();
    assert_eq!(one, serde_json::to_string(&on(3)).unwrap());
}

#[test]
fn budget_off_or_without_sources() {
    let off = load_edited("paper-kr1000", |v| {
        v["residual_budget"]["enabled"] = false.into();
    });
    assert_eq!(budget_runs(&off.scenario), 0);
    assert!(residual_budget(&off, &|_| {}, &|| false).unwrap().is_none());
    // noise-floor has no source outside the model but the tracker noise: one line.
    let nf = load_edited("noise-floor", |v| {
        v["trials"] = 2.into();
        v["residual_budget"] = serde_json::json!({ "enabled": true, "trials": 50 });
    });
    assert_eq!(budget_trials(&nf.scenario), 2);
    let b = residual_budget(&nf, &|_| {}, &|| false).unwrap().unwrap();
    let sources: Vec<Source> = b.sources.iter().map(|r| r.source).collect();
    assert_eq!(sources, [Source::TrackerNoise]);
}

#[test]
fn bad_budget_sections_name_the_field() {
    let path = scenario_path("paper-kr1000");
    let text = std::fs::read_to_string(&path).unwrap();
    let mut v: serde_json::Value = serde_json::from_str(&text).unwrap();
    v["residual_budget"] = serde_json::json!({ "enabled": true, "trials": 0 });
    let err = Scenario::from_value(v.clone(), "b.json")
        .unwrap()
        .load(path.parent().unwrap(), "b.json")
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("b.json") && err.contains("residual_budget.trials"),
        "{err}"
    );
    v["residual_budget"] = serde_json::json!({ "enabled": true, "trails": 5 });
    let err = Scenario::from_value(v, "b.json").unwrap_err().to_string();
    assert!(
        err.contains("residual_budget") && err.contains("trails"),
        "{err}"
    );
}

#[test]
fn shards_carry_the_budget_in_shard_zero_only() {
    let loaded = paper(4);
    let ctx = Context::new(loaded.clone()).unwrap();
    let budget = residual_budget(&loaded, &|_| {}, &|| false).unwrap();
    assert!(budget.is_some());
    let shard = |k: u64, with_budget: bool| {
        let range = shard_range(4, k, 2);
        ShardFile {
            manifest: ShardManifest {
                scenario: loaded.scenario.clone(),
                version: "test".into(),
                shard: k,
                shards: 2,
                first_trial: range.start,
                end_trial: range.end,
            },
            aggregate: run_range(&ctx, range, &|_| {}),
            residual_budget: if with_budget { budget.clone() } else { None },
            digest: None,
        }
    };
    let good = [shard(1, false), shard(0, true)];
    merge_shards(&good).unwrap();
    assert_eq!(shard_budget(&good), budget);
    let err = merge_shards(&[shard(0, false), shard(1, false)])
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("shard 0 of 2") && err.contains("has none"),
        "{err}"
    );
    let err = merge_shards(&[shard(0, true), shard(1, true)])
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("shard 1 of 2") && err.contains("only shard 0"),
        "{err}"
    );
}
