//! The design's comparison with random sets: the design's criterion value, condition number and O1–O5 beside the
//! median of the same figures over random sets of the same size from the same pool.

use std::fmt::Write as _;

use rand::SeedableRng;
use rand::rngs::ChaCha8Rng;
use rand::seq::index::sample;
use serde::{Deserialize, Serialize};

use crate::criterion::{Criterion, condition_number, dense_value, observability};
use crate::measure::Measure;
use crate::model::InfoModel;
use crate::select::Design;

/// The figures of one pose set.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct SetFigures {
    /// The design criterion's value.
    pub value: f64,
    /// σ_max/σ_min of the unit-norm-column Jacobian of the minimal set.
    pub condition_number: f64,
    /// O1–O5.
    pub o: [f64; 5],
}

impl SetFigures {
    /// The figures of candidates `set` of `model` (NaN where M is singular).
    pub fn of(model: &InfoModel, criterion: Criterion, set: &[usize]) -> SetFigures {
        let m = model.information(set);
        let value = dense_value(criterion, &m, Some(&model.workspace), set.len());
        let o = observability(&m, set.len());
        SetFigures {
            value: value.unwrap_or(f64::NAN),
            condition_number: condition_number(&m).unwrap_or(f64::NAN),
            o: o.map_or([f64::NAN; 5], |o| [o.o1, o.o2, o.o3, o.o4, o.o5]),
        }
    }
}

/// What [`compare`] finds.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct DesignComparison {
    /// The criterion.
    pub criterion: Criterion,
    /// Poses chosen.
    pub poses: usize,
    /// Candidates in the pool.
    pub candidates: usize,
    /// The minimal set designed for.
    pub parameters: Vec<String>,
    /// The design's figures.
    pub design: SetFigures,
    /// Median of each figure over the random sets (taken figure by figure).
    pub random_median: SetFigures,
    /// Number of random sets.
    pub random_sets: usize,
    /// Exchange passes and swaps of the design.
    pub passes: usize,
    /// Swaps.
    pub swaps: usize,
    /// The greedy design's value, before the exchange.
    pub greedy_value: f64,
    /// What each pose measures.
    #[serde(default)]
    pub measure: Measure,
    /// Equations per pose (3 point, 6 frame, 3k targets).
    #[serde(default = "three")]
    pub rows_per_pose: usize,
    /// The fewest poses that can determine the unknowns ([`InfoModel::min_poses`]).
    #[serde(default)]
    pub min_poses: usize,
    /// For a frame or targets: the unknowns a single reflector's identification would have
    /// (set by [`crate::design_plan`]), for the "how many poses" comparison.
    #[serde(default)]
    pub point_unknowns: Option<usize>,
}

fn three() -> usize {
    3
}

fn median(mut v: Vec<f64>) -> f64 {
    v.retain(|x| !x.is_nan());
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(|a, b| a.total_cmp(b));
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

/// The figures of `design` and the medians over `random_sets` random subsets of the pool of
/// the same size (ChaCha8 from `seed`, stream 1000 + k for set k).
pub fn compare(
    model: &InfoModel,
    design: &Design,
    random_sets: usize,
    seed: u64,
) -> DesignComparison {
    let n = design.selected.len();
    let figures: Vec<SetFigures> = (0..random_sets)
        .map(|k| {
            let mut rng = ChaCha8Rng::seed_from_u64(seed);
            rng.set_stream(1000 + k as u64);
            let set = sample(&mut rng, model.n_candidates, n).into_vec();
            SetFigures::of(model, design.criterion, &set)
        })
        .collect();
    let med = |f: &dyn Fn(&SetFigures) -> f64| median(figures.iter().map(f).collect());
    let random_median = SetFigures {
        value: med(&|s| s.value),
        condition_number: med(&|s| s.condition_number),
        o: [0, 1, 2, 3, 4].map(|k| med(&|s: &SetFigures| s.o[k])),
    };
    DesignComparison {
        criterion: design.criterion,
        poses: n,
        candidates: model.n_candidates,
        parameters: model.names.clone(),
        design: SetFigures::of(model, design.criterion, &design.selected),
        random_median,
        random_sets,
        passes: design.passes,
        swaps: design.swaps,
        greedy_value: design.greedy_value,
        measure: model.measure,
        rows_per_pose: model.rows,
        min_poses: model.min_poses(),
        point_unknowns: None,
    }
}

impl DesignComparison {
    /// The report as text (a few lines for a terminal).
    pub fn to_text(&self) -> String {
        let mut s = String::new();
        let _ = writeln!(
            s,
            "design: {} of {} candidates, criterion {}",
            self.poses,
            self.candidates,
            self.criterion.describe()
        );
        let _ = writeln!(
            s,
            "minimal set ({} parameters): {}",
            self.parameters.len(),
            self.parameters.join(", ")
        );
        if self.measure != Measure::Point {
            let p = self.parameters.len();
            let _ = write!(
                s,
                "measurement {}: {} equations per pose ({}), {p} unknowns: at least {} poses",
                self.measure,
                self.rows_per_pose,
                if self.measure == Measure::Frame {
                    format!(
                        "3 position, 3 orientation with 1° weighing as {} mm",
                        identify::frames::DEFAULT_MM_PER_DEG
                    )
                } else {
                    format!("{} targets × 3", self.rows_per_pose / 3)
                },
                self.min_poses
            );
            match self.point_unknowns {
                Some(q) => {
                    let _ = writeln!(
                        s,
                        "; a single reflector: 3 per pose, {q} unknowns: at least {} poses",
                        q.div_ceil(3)
                    );
                }
                None => s.push('\n'),
            }
        }
        let _ = writeln!(
            s,
            "greedy {:.6e}, after exchange {:.6e} ({} passes, {} swaps)",
            self.greedy_value, self.design.value, self.passes, self.swaps
        );
        let _ = writeln!(
            s,
            "{:<22} {:>14} {:>14}",
            "",
            "design",
            format!("random (median of {})", self.random_sets)
        );
        let row = |s: &mut String, name: &str, a: f64, b: f64| {
            let _ = writeln!(s, "{name:<22} {a:>14.6e} {b:>14.6e}");
        };
        row(
            &mut s,
            &format!("criterion {}", self.criterion),
            self.design.value,
            self.random_median.value,
        );
        row(
            &mut s,
            "condition number",
            self.design.condition_number,
            self.random_median.condition_number,
        );
        for k in 0..5 {
            row(
                &mut s,
                &format!("O{}", k + 1),
                self.design.o[k],
                self.random_median.o[k],
            );
        }
        s
    }
}
