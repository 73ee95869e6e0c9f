//! A campaign's summary: `summary.json` ([`CampaignSummary`], which depends only on the
//! scenario, its seed and the code) and `summary.md` (our numbers beside the paper's).

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

use crate::run::aggregate::Summary;
use crate::run::budget::ResidualBudget;
use crate::run::range::Aggregate;
use crate::scenario::Scenario;
use report::fmt::{self, Quantity};

/// Version of the `summary.json` layout.
pub const SCHEMA_VERSION: u32 = 1;

/// The paper's Table 4 (Li et al. 2023), mm and %.
pub const PAPER: PaperFigures = PaperFigures {
    before_mean_mm: 1.122,
    after_mean_mm: 0.340,
    before_max_mm: 2.557,
    after_max_mm: 0.973,
    improvement_pct: 69.7,
};

/// Reference figures from the paper.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct PaperFigures {
    /// Mean 3-D error before calibration, mm.
    pub before_mean_mm: f64,
    /// Mean 3-D error after, mm.
    pub after_mean_mm: f64,
    /// Max 3-D error before, mm.
    pub before_max_mm: f64,
    /// Max 3-D error after, mm.
    pub after_max_mm: f64,
    /// Improvement of the mean, %.
    pub improvement_pct: f64,
}

/// Recovery summary of one parameter.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RecoverySummary {
    /// Display unit.
    pub unit: String,
    /// estimate − truth over trials.
    pub error: Option<Summary>,
    /// |estimate − truth|.
    pub abs_error: Option<Summary>,
    /// z-score over trials (mean ≈ 0, sd ≈ 1 when the standard errors are honest).
    pub z: Option<Summary>,
    /// Reported standard error over trials.
    pub std_error: Option<Summary>,
}

/// Who produced a summary.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Tool {
    /// Always "kincal".
    pub name: String,
    /// Crate version.
    pub version: String,
}

/// `summary.json`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CampaignSummary {
    /// [`SCHEMA_VERSION`].
    pub schema_version: u32,
    /// Producer.
    pub tool: Tool,
    /// The scenario as run (trial count included).
    pub scenario: Scenario,
    /// Trials attempted.
    pub trials: u64,
    /// Trials that failed, by cause.
    pub failed_trials: BTreeMap<String, u64>,
    /// Per-metric statistics over successful trials.
    pub metrics: BTreeMap<String, Option<Summary>>,
    /// Recovery per minimal-set parameter.
    pub recovery: BTreeMap<String, RecoverySummary>,
    /// Categorical outcomes.
    pub counts: BTreeMap<String, BTreeMap<String, u64>>,
    /// The paper's figures for comparison: only when the scenario simulates the paper's robot
    /// (`is_paper_robot`); absent for any other robot, whose summary shows no paper column.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub paper: Option<PaperFigures>,
    /// The residual budget, when the scenario asks for it ([`crate::residual_budget`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub residual_budget: Option<ResidualBudget>,
}

impl CampaignSummary {
    /// Summarises an aggregate.
    pub fn new(scenario: &Scenario, agg: &Aggregate) -> Self {
        CampaignSummary {
            schema_version: SCHEMA_VERSION,
            tool: Tool {
                name: "kincal".into(),
                version: env!("CARGO_PKG_VERSION").into(),
            },
            scenario: scenario.clone(),
            trials: agg.trials,
            failed_trials: agg.failures.0.clone(),
            metrics: agg
                .metrics
                .iter()
                .map(|(k, v)| (k.clone(), v.summary()))
                .collect(),
            recovery: agg
                .recovery
                .iter()
                .map(|(k, v)| {
                    (
                        k.clone(),
                        RecoverySummary {
                            unit: v.unit.clone(),
                            error: v.error.summary(),
                            abs_error: v.abs_error.summary(),
                            z: v.z.summary(),
                            std_error: v.std_error.summary(),
                        },
                    )
                })
                .collect(),
            counts: agg
                .counts
                .iter()
                .map(|(k, v)| (k.clone(), v.0.clone()))
                .collect(),
            paper: is_paper_robot_file(&scenario.robot).then_some(PAPER),
            residual_budget: None,
        }
    }

    /// The summary for the nominal robot the scenario loaded: the paper's figures are kept
    /// only when its geometry is the paper's KR1000 (`is_paper_robot`; [`Self::new`] decides
    /// from the robot file's name alone, which is all a merge of shards knows).
    pub fn with_robot(mut self, nominal: &kinematics::Robot) -> Self {
        if !is_paper_robot(nominal) {
            self.paper = None;
        }
        self
    }

    /// The summary with its residual budget.
    pub fn with_budget(mut self, budget: Option<ResidualBudget>) -> Self {
        self.residual_budget = budget;
        self
    }

    /// The summary of metric `name`, if any trial produced it.
    pub fn metric(&self, name: &str) -> Option<&Summary> {
        self.metrics.get(name).and_then(|s| s.as_ref())
    }

    /// Pretty JSON, byte-deterministic.
    pub fn to_json(&self) -> String {
        let mut s = serde_json::to_string_pretty(self).expect("summary serialises");
        s.push('\n');
        s
    }

    /// The "What was run" paragraph of `summary.md`: the robot file, the pose counts each
    /// trial used, the trials and the mass model of the simulated compliance, from the
    /// scenario as run (never its description, which is the author's text).
    pub fn what_was_run(&self) -> String {
        let sc = &self.scenario;
        let tool = sc.tool_mm.map_or(String::new(), |t| {
            format!(" with the tool at ({}, {}, {}) mm", t[0], t[1], t[2])
        });
        let selection = match sc.pose_selection.method {
            crate::scenario::SelectionMethod::Random => "random".to_string(),
            m => format!(
                "chosen by the {} criterion from {} candidates",
                serde_json::to_value(m)
                    .ok()
                    .and_then(|v| v.as_str().map(str::to_string))
                    .unwrap_or_default(),
                sc.pose_selection.candidates
            ),
        };
        let c = &sc.unmodelled.compliance;
        let compliance = if c.enabled {
            let masses: Vec<String> = c.links.iter().map(|l| l.mass_kg.to_string()).collect();
            format!(
                "joint compliance simulated with link masses {} kg (Σ {} kg; the robot file's \
                 `mass_model` unless the scenario lists `unmodelled.compliance.links`), payload \
                 {} kg",
                masses.join(", "),
                fmt::significant(c.links.iter().map(|l| l.mass_kg).sum::<f64>()),
                c.payload_kg
            )
        } else {
            "no joint compliance simulated".to_string()
        };
        format!(
            "What was run: robot file `{}`{tool}; per trial {} identification poses ({selection}) \
             and {} validation poses; {} trials; {compliance}.\n\n",
            sc.robot.display(),
            sc.poses.identification.len(),
            sc.poses.validation.len(),
            self.trials,
        )
    }

    /// The human table (Markdown).
    pub fn to_markdown(&self) -> String {
        let mut o = String::new();
        let sc = &self.scenario;
        o.push_str(&format!("# Campaign `{}`\n\n", sc.name));
        if !sc.description.is_empty() {
            o.push_str(&format!("{}\n\n", sc.description.trim()));
        }
        let failed: u64 = self.failed_trials.values().sum();
        o.push_str(&format!(
            "Trials: {} ({} failed), seed {}. Values are mean ± sd over trials [p5, p95].\n\n",
            self.trials, failed, sc.seed
        ));
        o.push_str(&self.what_was_run());
        let paper_col = self.paper.is_some();
        if paper_col {
            o.push_str("## Table 4: validation error, ours beside the paper's\n\n");
            o.push_str("| metric | kincal | paper |\n|---|---:|---:|\n");
        } else {
            // The paper's figures are a KR1000's: another robot is compared with nothing.
            o.push_str("## Validation error (Table 4's metrics)\n\n");
            o.push_str("| metric | kincal |\n|---|---:|\n");
        }
        let fmt = |m: Option<&Summary>, q: Quantity| match m {
            Some(s) => q.mean_sd_range(s.mean, s.sd, s.p5, s.p95),
            None => "n/a".into(),
        };
        const MM: Quantity = Quantity::LengthMm;
        const PCT: Quantity = Quantity::Percent;
        let rows: [(&str, &str, Option<f64>, Quantity); 10] = [
            (
                "mean 3-D before (mm)",
                "before_mean_mm",
                Some(PAPER.before_mean_mm),
                MM,
            ),
            (
                "mean 3-D after (mm)",
                "after_mean_mm",
                Some(PAPER.after_mean_mm),
                MM,
            ),
            (
                "max 3-D before (mm)",
                "before_max_mm",
                Some(PAPER.before_max_mm),
                MM,
            ),
            (
                "max 3-D after (mm)",
                "after_max_mm",
                Some(PAPER.after_max_mm),
                MM,
            ),
            (
                "improvement of mean (%)",
                "improvement_pct",
                Some(PAPER.improvement_pct),
                PCT,
            ),
            (
                "improvement of max (%)",
                "improvement_max_pct",
                Some(61.9),
                PCT,
            ),
            ("mean \\|x\\| before → after (mm)", "", None, MM),
            ("mean \\|y\\| before → after (mm)", "", None, MM),
            ("mean \\|z\\| before → after (mm)", "", None, MM),
            ("RMS 3-D after (mm)", "after_rms_mm", None, MM),
        ];
        let paper_axes = [
            ("x", 0.703, 0.262),
            ("y", 0.601, 0.169),
            ("z", 0.635, 0.136),
        ];
        let mut axis = 0;
        for (label, key, paper, d) in rows {
            if key.is_empty() {
                let (a, pb, pa) = paper_axes[axis];
                axis += 1;
                let b = self.metric(&format!("before_mean_{a}_mm")).map(|s| s.mean);
                let af = self.metric(&format!("after_mean_{a}_mm")).map(|s| s.mean);
                let ours = match (b, af) {
                    (Some(b), Some(af)) => format!("{} → {}", fmt::mm(b), fmt::mm(af)),
                    _ => "n/a".into(),
                };
                if paper_col {
                    o.push_str(&format!(
                        "| {label} | {ours} | {} → {} |\n",
                        fmt::mm(pb),
                        fmt::mm(pa)
                    ));
                } else {
                    o.push_str(&format!("| {label} | {ours} |\n"));
                }
                continue;
            }
            let ours = fmt(self.metric(key), d);
            if paper_col {
                let p = paper.map_or_else(|| "–".to_string(), |v| d.format(v));
                o.push_str(&format!("| {label} | {ours} | {p} |\n"));
            } else {
                o.push_str(&format!("| {label} | {ours} |\n"));
            }
        }
        o.push('\n');
        if self.metric("iso_ap_before_mm").is_some() {
            o.push_str(if paper_col {
                "## ISO 9283 (mean over P1–P5)\n\n| metric | kincal | paper |\n|---|---:|---:|\n"
            } else {
                "## ISO 9283 (mean over P1–P5)\n\n| metric | kincal |\n|---|---:|\n"
            });
            for (label, key, paper, q) in [
                ("AP_p before (mm)", "iso_ap_before_mm", "–", MM),
                ("AP_p after (mm)", "iso_ap_after_mm", "–", MM),
                (
                    "AP_p improvement (%)",
                    "iso_ap_improvement_pct",
                    "≈ 87",
                    PCT,
                ),
                ("RP_l before (mm)", "iso_rp_before_mm", "–", MM),
                ("RP_l after (mm)", "iso_rp_after_mm", "–", MM),
                (
                    "P1–P5 the identified model could not reach",
                    "iso_compensation_failures",
                    "–",
                    Quantity::MeanCount,
                ),
            ] {
                let ours = fmt(self.metric(key), q);
                if paper_col {
                    o.push_str(&format!("| {label} | {ours} | {paper} |\n"));
                } else {
                    o.push_str(&format!("| {label} | {ours} |\n"));
                }
            }
            o.push('\n');
        }
        if let Some(kept) = self.metric("residual_used") {
            o.push_str(&format!(
                "## Learned residual model (docs/residual-model.md)\n\nEach trial cross-validates \
                 a Gaussian process on the geometry's residuals ({}-fold) and keeps the hybrid \
                 when its mean and p95 gains exceed their fold-to-fold scatter; the table above \
                 is what the gate chose. Kept in {} % of the trials.\n\n| metric | kincal |\n|---|---:|\n",
                self.scenario.residual_model.folds,
                Quantity::Percent.format(100.0 * kept.mean)
            ));
            for (label, key, q) in [
                (
                    "mean 3-D after, geometry (mm)",
                    "geometry_after_mean_mm",
                    MM,
                ),
                ("mean 3-D after, hybrid (mm)", "hybrid_after_mean_mm", MM),
                ("max 3-D after, geometry (mm)", "geometry_after_max_mm", MM),
                ("max 3-D after, hybrid (mm)", "hybrid_after_max_mm", MM),
                (
                    "cross-validated gain of the mean (mm)",
                    "residual_cv_mean_gain_mm",
                    MM,
                ),
                (
                    "cross-validated gain of the p95 (mm)",
                    "residual_cv_p95_gain_mm",
                    MM,
                ),
                (
                    "share of validation values within 1 sd (0.683 if calibrated)",
                    "residual_coverage_1sd",
                    Quantity::Index,
                ),
                (
                    "share of validation values within 2 sd (0.954 if calibrated)",
                    "residual_coverage_2sd",
                    Quantity::Index,
                ),
                (
                    "validation targets the hybrid could not reach",
                    "hybrid_compensation_failures",
                    Quantity::MeanCount,
                ),
            ] {
                o.push_str(&format!("| {label} | {} |\n", fmt(self.metric(key), q)));
            }
            o.push('\n');
        }
        if let Some(b) = &self.residual_budget {
            o.push_str(&b.to_markdown());
        }
        o.push_str("## Identification\n\n| metric | value |\n|---|---:|\n");
        const N: Quantity = Quantity::MeanCount;
        const IX: Quantity = Quantity::Index;
        for (label, key, q, scale) in [
            (
                "geometry error on validation poses (mm)",
                "predicted_error_mm",
                MM,
                1.0,
            ),
            ("fit RMS residual (mm)", "fit_rms_mm", MM, 1.0),
            ("LM iterations", "lm_iterations", N, 1.0),
            (
                "unreachable validation targets per trial",
                "compensation_failures",
                N,
                1.0,
            ),
            (
                "rejected candidate poses (%)",
                "pose_rejection_rate",
                PCT,
                100.0,
            ),
            ("O1 (Borm–Menq), minimal set", "observability_o1", IX, 1.0),
            (
                "O2 = σ_min/σ_max (1/condition)",
                "observability_o2",
                IX,
                1.0,
            ),
            ("O3 = σ_min", "observability_o3", IX, 1.0),
            ("O4 = σ_min²/σ_max", "observability_o4", IX, 1.0),
            ("O5 = (Σ 1/σ_i)⁻¹", "observability_o5", IX, 1.0),
        ] {
            let cell = match self.metric(key) {
                Some(s) => {
                    q.mean_sd_range(s.mean * scale, s.sd * scale, s.p5 * scale, s.p95 * scale)
                }
                None => "n/a".into(),
            };
            o.push_str(&format!("| {label} | {cell} |\n"));
        }
        for (name, counts) in &self.counts {
            o.push_str(&format!(
                "| {} | {} |\n",
                count_title(name),
                count_values(name, counts, self.trials)
            ));
        }
        o.push('\n');
        if !self.recovery.is_empty() {
            o.push_str("## Parameter recovery (minimal identifiable set)\n\n");
            o.push_str(
                "Error = estimate − truth, both re-expressed in the minimal identifiable set; \
                 lengths in mm, angles in arcseconds (″). Parameters in kinematic order.",
            );
            if self
                .recovery
                .values()
                .any(|r| r.unit == "arcsec" || r.unit == "urad/Nm")
            {
                o.push_str(
                    " The non-geometric parameters of the extended model follow: joint \
                     compliances in µrad/(N·m) and gear terms in ″, their truth the injected \
                     compliance (1 − c)/k and the injected harmonic A·sin(k q + φ) = \
                     A cos φ · sin(k q) + A sin φ · cos(k q).",
                );
            }
            o.push_str("\n\n");
            o.push_str("| parameter | unit | mean error | sd of error | mean std error | z mean | z sd |\n|---|---|---:|---:|---:|---:|---:|\n");
            for name in kinematic_order(self.recovery.keys().map(String::as_str)) {
                let r = &self.recovery[name];
                let (unit, q) = match r.unit.as_str() {
                    "deg" => ("″", Quantity::AngleArcsecFromDeg),
                    "arcsec" => ("″", Quantity::Index),
                    "urad/Nm" => ("µrad/(N·m)", Quantity::Index),
                    "mm/mm" => ("mm/mm", Quantity::Index),
                    other => (other, MM),
                };
                let g = |s: &Option<Summary>, f: fn(&Summary) -> f64, q: Quantity| {
                    s.as_ref().map_or("n/a".into(), |s| q.format(f(s)))
                };
                o.push_str(&format!(
                    "| {name} | {unit} | {} | {} | {} | {} | {} |\n",
                    g(&r.error, |s| s.mean, q),
                    g(&r.error, |s| s.sd, q),
                    g(&r.std_error, |s| s.mean, q),
                    g(&r.z, |s| s.mean, Quantity::ZScore),
                    g(&r.z, |s| s.sd, Quantity::ZScore),
                ));
            }
            o.push_str(
                "\nz = (estimate − truth) / the standard error the fit reports. If the residuals \
                 were tracker noise alone, z would have mean 0 and sd 1 over trials (as in \
                 `noise-floor`), so |z| > 3 would be rare. Errors outside the identified model \
                 (joint compliance, gear errors, repeatability, as in `paper-kr1000`) are \
                 partly absorbed by the geometric parameters: a bias that the standard errors, \
                 which see only the scatter, do not contain. Large |z| (such as base_dz's) \
                 therefore measures that absorbed error, not a failure of the solver.\n",
            );
            o.push('\n');
        }
        if !self.failed_trials.is_empty() {
            o.push_str("## Failed trials\n\n");
            for (cause, n) in &self.failed_trials {
                o.push_str(&format!("- {n} × {cause}\n"));
            }
            o.push('\n');
        }
        o
    }
}

/// Parameter names sorted in the kinematic order of `kinematics::ParamLayout` (per joint θ, d,
/// a, α; then the β's; then the axis scales; then the base rx … dz; then the tool x, y, z). Unknown names go last,
/// alphabetically.
pub fn kinematic_order<'a>(names: impl IntoIterator<Item = &'a str>) -> Vec<&'a str> {
    // Sixteen joints with zero nominal twists: every joint parameter and every β exists, in
    // the same relative order as in any smaller chain.
    // Every joint prismatic too: the axis scales sit after the β's (absent from revolute
    // chains, so their order is unchanged).
    let layout = kinematics::ParamLayout::for_chain(&[0.0; 16], &[true; 16]);
    let mut v: Vec<&str> = names.into_iter().collect();
    // The non-geometric parameters of an extended model follow, compliances first, then the
    // gear terms by joint and harmonic.
    let extended = |n: &str| {
        kinematics::ExtendedKind::parse(n).map(|k| match k {
            kinematics::ExtendedKind::Compliance(j) => j,
            kinematics::ExtendedKind::GearSin { joint, harmonic } => {
                100 + 100 * joint + 2 * harmonic as usize
            }
            kinematics::ExtendedKind::GearCos { joint, harmonic } => {
                101 + 100 * joint + 2 * harmonic as usize
            }
        })
    };
    v.sort_by_key(|n| {
        let k = layout
            .index_of(n)
            .ok()
            .or_else(|| extended(n).map(|e| layout.len() + e))
            .unwrap_or(usize::MAX);
        (k, *n)
    });
    v
}

/// The paper's robot: the KUKA KR1000 Titan of `scenarios/robots/kr1000-titan.json`, as
/// (θ°, d mm, a mm, α°) per joint. Li et al.'s figures (Table 4, ISO 9283) were measured on
/// it; for any other robot they mean nothing.
const PAPER_ROBOT_DH: [[f64; 4]; 6] = [
    [0.0, 1100.0, 600.0, -90.0],
    [-90.0, 0.0, 1400.0, 0.0],
    [0.0, 0.0, 65.0, -90.0],
    [0.0, 1200.0, 0.0, 90.0],
    [0.0, 0.0, 0.0, -90.0],
    [0.0, 372.0, 0.0, 0.0],
];

/// Whether `nominal` is the paper's robot: six joints whose nominal θ, d, a, α are the
/// KR1000 Titan's [to 1 mm and 0.1°: a robot file of the same arm with rounded or slightly
/// corrected values is still that arm; another robot differs by metres or tens of degrees].
pub fn is_paper_robot(nominal: &kinematics::Robot) -> bool {
    let spec = nominal.to_spec();
    spec.joints.len() == PAPER_ROBOT_DH.len()
        && spec.joints.iter().zip(&PAPER_ROBOT_DH).all(|(j, r)| {
            (j.theta_deg - r[0]).abs() <= 0.1
                && (j.d_mm - r[1]).abs() <= 1.0
                && (j.a_mm - r[2]).abs() <= 1.0
                && (j.alpha_deg - r[3]).abs() <= 0.1
        })
}

/// Whether a scenario's robot file is the paper's by its name (`kr1000-titan.json`), what a
/// summary knows without the robot (a merge of shards); [`CampaignSummary::with_robot`]
/// checks the geometry where the robot is loaded.
pub fn is_paper_robot_file(robot: &std::path::Path) -> bool {
    robot
        .file_name()
        .is_some_and(|n| n.eq_ignore_ascii_case("kr1000-titan.json"))
}

/// Whether a campaign reproduces the paper (its Table 4 is the reference).
pub fn is_paper(scenario_name: &str) -> bool {
    scenario_name.starts_with("paper")
}

/// A categorical outcome's name in words.
fn count_title(name: &str) -> String {
    match name {
        "rank" => "numerical rank of the identification Jacobian".into(),
        "stop_reason" => "LM stop reason".into(),
        "convergence" => "LM convergence".into(),
        other => other.replace('_', " "),
    }
}

/// A categorical outcome's counts in words: `27: 200 of 200 trials`, zero-padded ranks
/// printed as numbers, `small_cost_change` as `small cost change`.
fn count_values(name: &str, counts: &BTreeMap<String, u64>, trials: u64) -> String {
    let list: Vec<String> = counts
        .iter()
        .map(|(k, v)| {
            let key = if name == "rank" {
                k.trim_start_matches('0').to_string()
            } else {
                k.replace('_', " ")
            };
            format!("{key}: {}", fmt::whole(*v as f64))
        })
        .collect();
    format!(
        "{} (of {} trials)",
        list.join(", "),
        fmt::whole(trials as f64)
    )
}
