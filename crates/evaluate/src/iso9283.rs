//! ISO 9283 (= GB/T 12642-2013) position accuracy and repeatability.
//!
//! # Test cube and corner numbering
//!
//! The test cube is axis-aligned in the robot base frame, centre `c`, edge `a`,
//! half edge `h = a/2`. Corners (signs of the offsets from `c` in units of `h`):
//!
//! | corner | x | y | z |   | corner | x | y | z |
//! |---|---|---|---|---|---|---|---|---|
//! | C1 | − | − | − |   | C5 | − | − | + |
//! | C2 | + | − | − |   | C6 | + | − | + |
//! | C3 | + | + | − |   | C7 | + | + | + |
//! | C4 | − | + | − |   | C8 | − | + | + |
//!
//! C1…C4 go counter-clockwise round the bottom face seen from above, C5…C8 are the
//! corners straight above them. The measuring plane C1-C2-C7-C8 contains the bottom
//! edge C1C2 (at `y = −h`) and the opposite top edge C7C8 (at `y = +h`): it is the
//! diagonal plane `y − y_c = z − z_c`, a `a × a√2` rectangle through the centre, as in
//! ISO 9283 Fig. 2.
//!
//! # Test points
//!
//! `P1 = c`; `P2`, `P3`, `P4`, `P5` lie on the plane's diagonals C1–C7 and C2–C8 at 10 %
//! of the diagonal length (`0.1·a√3`) from the corners C1, C2, C7, C8 respectively:
//! `P2 = C1 + 0.1 (C7 − C1)`, `P3 = C2 + 0.1 (C8 − C2)`, `P4 = C7 + 0.1 (C1 − C7)`,
//! `P5 = C8 + 0.1 (C2 − C8)`. The measuring cycle is P1 → P5 → P4 → P3 → P2
//! ([`ISO_CYCLE_ORDER`]), repeated `n` (= 30) times with the same approach direction.
//!
//! # Per-point characteristics
//!
//! From the attained positions `x_j`, `j = 1 … n`, at commanded point `x_c`:
//! `x̄ = (1/n) Σ x_j`; `AP_p = ‖x̄ − x_c‖`, `(AP_x, AP_y, AP_z) = x̄ − x_c` (signed);
//! `l_j = ‖x_j − x̄‖`, `l̄ = (1/n) Σ l_j`, `S_l = √(Σ (l_j − l̄)² / (n − 1))`,
//! `RP_l = l̄ + 3 S_l`.

use serde::{Deserialize, Serialize};

use crate::stats::improvement_pct;
use crate::{EvalError, Result};

/// Resolution of the edge bisection in [`largest_cube`] (mm): the returned edge is
/// within this distance of the largest feasible edge (for a monotone predicate).
pub const CUBE_EDGE_TOLERANCE_MM: f64 = 1.0;

/// Fraction of the measuring plane's diagonal between a corner and the nearest test
/// point (ISO 9283: 10 %).
pub const TEST_POINT_DIAGONAL_FRACTION: f64 = 0.1;

/// Visiting order of one ISO 9283 cycle, P1 → P5 → P4 → P3 → P2, as 0-based indices
/// into [`IsoCube::test_points_mm`].
pub const ISO_CYCLE_ORDER: [usize; 5] = [0, 4, 3, 2, 1];

/// An axis-aligned test cube in the robot base frame (see the module doc for the
/// corner numbering and test points).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct IsoCube {
    /// Centre `c` of the cube (mm, base frame).
    pub center_mm: [f64; 3],
    /// Edge length `a` (mm).
    pub edge_mm: f64,
}

impl IsoCube {
    /// A cube with centre `c` and edge `a > 0`.
    ///
    /// # Errors
    /// [`EvalError::NonFinite`] for a non-finite centre, [`EvalError::InvalidArgument`]
    /// unless `edge_mm` is finite and positive.
    pub fn new(center_mm: [f64; 3], edge_mm: f64) -> Result<Self> {
        crate::stats::check_finite("cube centre", &center_mm)?;
        if !(edge_mm.is_finite() && edge_mm > 0.0) {
            return Err(EvalError::InvalidArgument {
                name: "edge_mm",
                value: edge_mm,
                reason: "cube edge must be finite and > 0",
            });
        }
        Ok(Self { center_mm, edge_mm })
    }

    /// Corners `[C1, …, C8]`: `C_k = c + h·s_k` with the sign pattern `s_k` of the
    /// module-level table and `h = a/2`.
    pub fn corners_mm(&self) -> [[f64; 3]; 8] {
        const SIGNS: [[f64; 3]; 8] = [
            [-1.0, -1.0, -1.0],
            [1.0, -1.0, -1.0],
            [1.0, 1.0, -1.0],
            [-1.0, 1.0, -1.0],
            [-1.0, -1.0, 1.0],
            [1.0, -1.0, 1.0],
            [1.0, 1.0, 1.0],
            [-1.0, 1.0, 1.0],
        ];
        SIGNS.map(|s| self.offset(s))
    }

    /// The measuring plane's corners `[C1, C2, C7, C8]` (in rectangle order
    /// C1 → C2 → C7 → C8): a rectangle of sides `a` and `a√2` through `c`.
    pub fn measuring_plane_mm(&self) -> [[f64; 3]; 4] {
        let c = self.corners_mm();
        [c[0], c[1], c[6], c[7]]
    }

    /// Test points `[P1, …, P5]`: `P1 = c`, and `P2…P5 = C + 0.1 (C_opp − C)` for
    /// `C = C1, C2, C7, C8` with `C_opp` the opposite end of the plane diagonal
    /// (C7, C8, C1, C2). Each of P2…P5 is `0.1·a√3` from its corner.
    pub fn test_points_mm(&self) -> [[f64; 3]; 5] {
        let c = self.corners_mm();
        let toward = |from: [f64; 3], to: [f64; 3]| lerp(from, to, TEST_POINT_DIAGONAL_FRACTION);
        [
            self.center_mm,
            toward(c[0], c[6]),
            toward(c[1], c[7]),
            toward(c[6], c[0]),
            toward(c[7], c[1]),
        ]
    }

    /// The points on which [`largest_cube`] evaluates its predicate, 31 in total, in
    /// this order: the 8 corners C1…C8; the 5 test points P1…P5; the 12 edge
    /// midpoints `c + h·s` with exactly one zero in `s ∈ {−1, 0, 1}³`; the 6 face
    /// centres `c ± h·e_k`. All lie in the closed cube.
    pub fn sampling_points_mm(&self) -> Vec<[f64; 3]> {
        let mut pts = Vec::with_capacity(31);
        pts.extend(self.corners_mm());
        pts.extend(self.test_points_mm());
        let mut edge_mids = Vec::with_capacity(12);
        let mut face_centres = Vec::with_capacity(6);
        for sx in [-1.0, 0.0, 1.0] {
            for sy in [-1.0, 0.0, 1.0] {
                for sz in [-1.0, 0.0, 1.0] {
                    let zeros = [sx, sy, sz].iter().filter(|&&s| s == 0.0).count();
                    match zeros {
                        1 => edge_mids.push(self.offset([sx, sy, sz])),
                        2 => face_centres.push(self.offset([sx, sy, sz])),
                        _ => {}
                    }
                }
            }
        }
        pts.extend(edge_mids);
        pts.extend(face_centres);
        pts
    }

    fn offset(&self, s: [f64; 3]) -> [f64; 3] {
        let h = 0.5 * self.edge_mm;
        [
            self.center_mm[0] + h * s[0],
            self.center_mm[1] + h * s[1],
            self.center_mm[2] + h * s[2],
        ]
    }
}

fn lerp(a: [f64; 3], b: [f64; 3], t: f64) -> [f64; 3] {
    [
        a[0] + t * (b[0] - a[0]),
        a[1] + t * (b[1] - a[1]),
        a[2] + t * (b[2] - a[2]),
    ]
}

fn dist(a: &[f64; 3], b: &[f64; 3]) -> f64 {
    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
}

/// The largest axis-aligned cube, over the candidate centres, on whose sampling points
/// ([`IsoCube::sampling_points_mm`]) `predicate(point_mm)` holds everywhere.
///
/// `predicate` is supplied by the caller (reachable, within joint limits, visible to
/// the tracker, …). For each candidate centre `c` in order, the feasible edge
/// `a*(c) = max { a ∈ [a_min, a_max] : predicate holds on the samples of cube(c, a) }`
/// is found by bisection to [`CUBE_EDGE_TOLERANCE_MM`] (assuming feasibility is
/// monotone in `a`: the result is feasible and within 1 mm below `a*(c)`). A
/// candidate that cannot hold the best edge found so far is skipped after one test;
/// ties keep the earlier candidate. Fully deterministic for a deterministic predicate.
///
/// # Errors
/// [`EvalError::Empty`] without candidates; [`EvalError::NonFinite`] for a non-finite
/// candidate; [`EvalError::InvalidArgument`] unless `0 < min_edge_mm ≤ max_edge_mm`
/// (both finite); [`EvalError::NoFeasibleCube`] if no candidate admits a cube of edge
/// `min_edge_mm`.
pub fn largest_cube<F>(
    center_candidates_mm: &[[f64; 3]],
    min_edge_mm: f64,
    max_edge_mm: f64,
    mut predicate: F,
) -> Result<IsoCube>
where
    F: FnMut(&[f64; 3]) -> bool,
{
    if center_candidates_mm.is_empty() {
        return Err(EvalError::Empty {
            what: "cube centre candidates",
        });
    }
    for (index, c) in center_candidates_mm.iter().enumerate() {
        if let Some(&value) = c.iter().find(|v| !v.is_finite()) {
            return Err(EvalError::NonFinite {
                what: "cube centre candidates",
                index,
                value,
            });
        }
    }
    if !(min_edge_mm.is_finite() && min_edge_mm > 0.0) {
        return Err(EvalError::InvalidArgument {
            name: "min_edge_mm",
            value: min_edge_mm,
            reason: "minimum edge must be finite and > 0",
        });
    }
    if !(max_edge_mm.is_finite() && max_edge_mm >= min_edge_mm) {
        return Err(EvalError::InvalidArgument {
            name: "max_edge_mm",
            value: max_edge_mm,
            reason: "maximum edge must be finite and >= min_edge_mm",
        });
    }

    let mut feasible = |center_mm: [f64; 3], edge_mm: f64| {
        IsoCube { center_mm, edge_mm }
            .sampling_points_mm()
            .iter()
            .all(&mut predicate)
    };

    let mut best: Option<IsoCube> = None;
    for &center in center_candidates_mm {
        let lo_start = best.map_or(min_edge_mm, |b| b.edge_mm);
        if !feasible(center, lo_start) {
            continue;
        }
        let edge = if feasible(center, max_edge_mm) {
            max_edge_mm
        } else {
            let (mut lo, mut hi) = (lo_start, max_edge_mm);
            while hi - lo > CUBE_EDGE_TOLERANCE_MM {
                let mid = 0.5 * (lo + hi);
                if feasible(center, mid) {
                    lo = mid;
                } else {
                    hi = mid;
                }
            }
            lo
        };
        if best.is_none_or(|b| edge > b.edge_mm) {
            best = Some(IsoCube {
                center_mm: center,
                edge_mm: edge,
            });
        }
    }
    best.ok_or(EvalError::NoFeasibleCube {
        min_edge_mm,
        candidates: center_candidates_mm.len(),
    })
}

/// ISO 9283 position characteristics of one commanded point from `n` cycles.
///
/// With attained positions `x_j` (mm) and commanded position `x_c`:
/// `x̄ = (1/n) Σ x_j`, `AP_p = ‖x̄ − x_c‖`, `AP_{x,y,z} = (x̄ − x_c)_{x,y,z}`,
/// `l_j = ‖x_j − x̄‖`, `l̄ = (1/n) Σ l_j`, `S_l = √(Σ (l_j − l̄)²/(n − 1))`,
/// `RP_l = l̄ + 3 S_l`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct PointStats {
    /// Number of cycles `n`.
    pub cycles: usize,
    /// Barycentre `x̄` of the attained positions (mm).
    pub mean_mm: [f64; 3],
    /// Position accuracy `AP_p = ‖x̄ − x_c‖` (mm).
    pub ap_p_mm: f64,
    /// `AP_x = x̄_x − x_{c,x}` (signed, mm).
    pub ap_x_mm: f64,
    /// `AP_y = x̄_y − x_{c,y}` (signed, mm).
    pub ap_y_mm: f64,
    /// `AP_z = x̄_z − x_{c,z}` (signed, mm).
    pub ap_z_mm: f64,
    /// Mean distance to the barycentre `l̄ = (1/n) Σ ‖x_j − x̄‖` (mm).
    pub l_mean_mm: f64,
    /// Sample standard deviation of the distances `S_l = √(Σ (l_j − l̄)²/(n − 1))` (mm).
    pub s_l_mm: f64,
    /// Position repeatability `RP_l = l̄ + 3 S_l` (mm).
    pub rp_l_mm: f64,
}

/// Computes [`PointStats`] for commanded point `x_c` from the attained positions
/// `x_j` (mm); see the type's doc for the formulas.
///
/// # Errors
/// [`EvalError::TooFew`] for fewer than 2 attained positions (`S_l` divides by
/// `n − 1`); [`EvalError::NonFinite`] for a non-finite coordinate (the commanded point
/// is reported with index 0 under `"commanded point"`).
pub fn point_stats(commanded_mm: [f64; 3], attained_mm: &[[f64; 3]]) -> Result<PointStats> {
    crate::stats::check_finite("commanded point", &commanded_mm)?;
    let n = attained_mm.len();
    if n < 2 {
        return Err(EvalError::TooFew {
            what: "attained positions",
            needed: 2,
            got: n,
        });
    }
    for (index, x) in attained_mm.iter().enumerate() {
        if let Some(&value) = x.iter().find(|v| !v.is_finite()) {
            return Err(EvalError::NonFinite {
                what: "attained positions",
                index,
                value,
            });
        }
    }
    let nf = n as f64;
    let mut mean = [0.0; 3];
    for x in attained_mm {
        for k in 0..3 {
            mean[k] += x[k];
        }
    }
    mean = mean.map(|s| s / nf);
    let ap = [
        mean[0] - commanded_mm[0],
        mean[1] - commanded_mm[1],
        mean[2] - commanded_mm[2],
    ];
    // The distances l_j, computed in each of the two passes (no buffer per point).
    let l = || attained_mm.iter().map(|x| dist(x, &mean));
    let l_mean = l().sum::<f64>() / nf;
    let s_l = (l().map(|v| (v - l_mean).powi(2)).sum::<f64>() / (nf - 1.0)).sqrt();
    Ok(PointStats {
        cycles: n,
        mean_mm: mean,
        ap_p_mm: (ap[0] * ap[0] + ap[1] * ap[1] + ap[2] * ap[2]).sqrt(),
        ap_x_mm: ap[0],
        ap_y_mm: ap[1],
        ap_z_mm: ap[2],
        l_mean_mm: l_mean,
        s_l_mm: s_l,
        rp_l_mm: l_mean + 3.0 * s_l,
    })
}

/// One test point of an [`IsoReport`]: its commanded position and its
/// characteristics before and after compensation.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct IsoPointRow {
    /// Commanded position `x_c` (mm, base frame).
    pub commanded_mm: [f64; 3],
    /// Characteristics before compensation.
    pub before: PointStats,
    /// Characteristics after compensation.
    pub after: PointStats,
}

/// ISO 9283 result on the five test points P1…P5 (`points[i]` is `P(i+1)`), before and
/// after compensation.
///
/// Summary: `mean AP_p = (1/5) Σ_i AP_p,i`, improvement
/// `100·(mean AP_p,before − mean AP_p,after) / mean AP_p,before` (%); likewise for
/// `RP_l`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct IsoReport {
    /// The test cube, if known.
    pub cube: Option<IsoCube>,
    /// P1…P5.
    pub points: [IsoPointRow; 5],
}

impl IsoReport {
    /// Builds the report for `cube` from the attained positions at P1…P5 (in
    /// [`IsoCube::test_points_mm`] order), before and after compensation, using the
    /// cube's test points as commanded positions.
    ///
    /// # Errors
    /// As [`point_stats`] for any of the ten series.
    pub fn from_attained(
        cube: IsoCube,
        before_mm: [&[[f64; 3]]; 5],
        after_mm: [&[[f64; 3]]; 5],
    ) -> Result<Self> {
        let targets = cube.test_points_mm();
        let row = |i: usize| -> Result<IsoPointRow> {
            Ok(IsoPointRow {
                commanded_mm: targets[i],
                before: point_stats(targets[i], before_mm[i])?,
                after: point_stats(targets[i], after_mm[i])?,
            })
        };
        let points = [row(0)?, row(1)?, row(2)?, row(3)?, row(4)?];
        Ok(Self {
            cube: Some(cube),
            points,
        })
    }

    /// `(1/5) Σ_i AP_p,i` before compensation (mm).
    pub fn mean_ap_p_before_mm(&self) -> f64 {
        self.points.iter().map(|p| p.before.ap_p_mm).sum::<f64>() / 5.0
    }

    /// `(1/5) Σ_i AP_p,i` after compensation (mm).
    pub fn mean_ap_p_after_mm(&self) -> f64 {
        self.points.iter().map(|p| p.after.ap_p_mm).sum::<f64>() / 5.0
    }

    /// Improvement of the mean `AP_p`, `100·(before − after)/before` (%); `None` if the
    /// mean before is zero (see [`improvement_pct`]).
    pub fn ap_p_improvement_pct(&self) -> Option<f64> {
        improvement_pct(self.mean_ap_p_before_mm(), self.mean_ap_p_after_mm())
    }

    /// `(1/5) Σ_i RP_l,i` before compensation (mm).
    pub fn mean_rp_l_before_mm(&self) -> f64 {
        self.points.iter().map(|p| p.before.rp_l_mm).sum::<f64>() / 5.0
    }

    /// `(1/5) Σ_i RP_l,i` after compensation (mm).
    pub fn mean_rp_l_after_mm(&self) -> f64 {
        self.points.iter().map(|p| p.after.rp_l_mm).sum::<f64>() / 5.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
        [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
    }
    fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
        a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
    }

    #[test]
    fn unit_cube_labelling_by_hand() {
        // Unit cube [0, 1]³: centre (0.5, 0.5, 0.5), edge 1.
        let cube = IsoCube::new([0.5; 3], 1.0).unwrap();
        let c = cube.corners_mm();
        assert_eq!(c[0], [0.0, 0.0, 0.0]); // C1
        assert_eq!(c[1], [1.0, 0.0, 0.0]); // C2
        assert_eq!(c[2], [1.0, 1.0, 0.0]); // C3
        assert_eq!(c[3], [0.0, 1.0, 0.0]); // C4
        assert_eq!(c[4], [0.0, 0.0, 1.0]); // C5
        assert_eq!(c[5], [1.0, 0.0, 1.0]); // C6
        assert_eq!(c[6], [1.0, 1.0, 1.0]); // C7
        assert_eq!(c[7], [0.0, 1.0, 1.0]); // C8

        // P2 = C1 + 0.1(C7 − C1) = (0.1, 0.1, 0.1)
        // P3 = C2 + 0.1(C8 − C2) = (1 − 0.1, 0.1, 0.1) = (0.9, 0.1, 0.1)
        // P4 = C7 + 0.1(C1 − C7) = (0.9, 0.9, 0.9)
        // P5 = C8 + 0.1(C2 − C8) = (0.1, 0.9, 0.9)
        let p = cube.test_points_mm();
        let expected = [
            [0.5, 0.5, 0.5],
            [0.1, 0.1, 0.1],
            [0.9, 0.1, 0.1],
            [0.9, 0.9, 0.9],
            [0.1, 0.9, 0.9],
        ];
        for (got, want) in p.iter().zip(expected) {
            for k in 0..3 {
                assert_relative_eq!(got[k], want[k], epsilon = 1e-12);
            }
        }
        // Each of P2…P5 is 10 % of the diagonal (√3) from its corner.
        for (pi, ci) in [(1, 0), (2, 1), (3, 6), (4, 7)] {
            assert_relative_eq!(dist(&p[pi], &c[ci]), 0.1 * 3f64.sqrt(), epsilon = 1e-12);
        }
    }

    #[test]
    fn measuring_plane_is_a_rectangle_through_the_centre() {
        let cube = IsoCube::new([1200.0, -300.0, 1500.0], 800.0).unwrap();
        let [c1, c2, c7, c8] = cube.measuring_plane_mm();
        let (s1, s2, s3, s4) = (sub(c2, c1), sub(c7, c2), sub(c8, c7), sub(c1, c8));
        // Right angles at every vertex and opposite sides equal: a rectangle a × a√2.
        for (u, v) in [(s1, s2), (s2, s3), (s3, s4), (s4, s1)] {
            assert_relative_eq!(dot(u, v), 0.0, epsilon = 1e-9);
        }
        assert_relative_eq!(dot(s1, s1).sqrt(), 800.0, epsilon = 1e-9);
        assert_relative_eq!(dot(s2, s2).sqrt(), 800.0 * 2f64.sqrt(), epsilon = 1e-9);
        assert_relative_eq!(dot(s3, s3), dot(s1, s1), epsilon = 1e-9);
        assert_relative_eq!(dot(s4, s4), dot(s2, s2), epsilon = 1e-9);
        // The diagonals bisect each other at the centre.
        let mid_a = lerp(c1, c7, 0.5);
        let mid_b = lerp(c2, c8, 0.5);
        for k in 0..3 {
            assert_relative_eq!(mid_a[k], cube.center_mm[k], epsilon = 1e-9);
            assert_relative_eq!(mid_b[k], cube.center_mm[k], epsilon = 1e-9);
        }
        // All test points are in the plane: normal n = s1 × s2.
        let n = [
            s1[1] * s2[2] - s1[2] * s2[1],
            s1[2] * s2[0] - s1[0] * s2[2],
            s1[0] * s2[1] - s1[1] * s2[0],
        ];
        for p in cube.test_points_mm() {
            assert_relative_eq!(dot(n, sub(p, c1)), 0.0, epsilon = 1e-6);
        }
    }

    #[test]
    fn sampling_points_are_31_distinct_points_in_the_cube() {
        let cube = IsoCube::new([0.0; 3], 2.0).unwrap();
        let pts = cube.sampling_points_mm();
        assert_eq!(pts.len(), 8 + 5 + 12 + 6);
        for (i, a) in pts.iter().enumerate() {
            assert!(a.iter().all(|v| v.abs() <= 1.0 + 1e-12));
            for b in &pts[i + 1..] {
                assert!(dist(a, b) > 1e-9, "duplicate sampling point {a:?}");
            }
        }
        // 12 edge midpoints have exactly one zero coordinate, 6 face centres two.
        let count_zeros = |p: &[f64; 3]| p.iter().filter(|v| v.abs() < 1e-12).count();
        assert_eq!(
            pts[13..25].iter().filter(|p| count_zeros(p) == 1).count(),
            12
        );
        assert_eq!(pts[25..].iter().filter(|p| count_zeros(p) == 2).count(), 6);
    }

    #[test]
    fn cube_rejects_bad_input() {
        assert!(matches!(
            IsoCube::new([0.0; 3], 0.0),
            Err(EvalError::InvalidArgument { .. })
        ));
        assert!(matches!(
            IsoCube::new([0.0; 3], f64::NAN),
            Err(EvalError::InvalidArgument { .. })
        ));
        assert!(matches!(
            IsoCube::new([0.0, f64::NAN, 0.0], 1.0),
            Err(EvalError::NonFinite { index: 1, .. })
        ));
    }

    #[test]
    fn largest_cube_in_a_sphere() {
        // Predicate: inside the ball of radius R about s. The best cube is centred at s
        // with its corners on the sphere: a = 2R/√3.
        let s = [1500.0, 200.0, 1800.0];
        let r = 1000.0;
        let in_ball = |p: &[f64; 3]| dist(p, &s) <= r;
        let candidates = [
            [1300.0, 200.0, 1800.0],
            s,
            [1500.0, 350.0, 1700.0],
            [1000.0, -300.0, 1500.0],
        ];
        let mut calls = 0usize;
        let cube = largest_cube(&candidates, 50.0, 3000.0, |p| {
            calls += 1;
            in_ball(p)
        })
        .unwrap();
        let exact = 2.0 * r / 3f64.sqrt(); // 1154.70 mm
        assert_eq!(cube.center_mm, s);
        assert!(cube.edge_mm <= exact, "{} > {exact}", cube.edge_mm);
        assert!(exact - cube.edge_mm <= CUBE_EDGE_TOLERANCE_MM);
        assert!(cube.sampling_points_mm().iter().all(in_ball));
        assert!(calls < 2000, "too many predicate calls: {calls}");

        // Deterministic.
        let again = largest_cube(&candidates, 50.0, 3000.0, in_ball).unwrap();
        assert_eq!(again, cube);
    }

    #[test]
    fn largest_cube_caps_ties_and_failures() {
        // Always feasible: the cap is returned, at the first candidate (tie-break).
        let cands = [[1.0, 2.0, 3.0], [4.0, 5.0, 6.0]];
        let cube = largest_cube(&cands, 10.0, 500.0, |_| true).unwrap();
        assert_eq!(cube, IsoCube::new([1.0, 2.0, 3.0], 500.0).unwrap());

        // Half-space z ≥ 0: the cube centred at height z0 has a* = 2·z0.
        let cands = [[0.0, 0.0, 100.0], [0.0, 0.0, 400.0], [0.0, 0.0, 250.0]];
        let cube = largest_cube(&cands, 10.0, 2000.0, |p| p[2] >= 0.0).unwrap();
        assert_eq!(cube.center_mm, [0.0, 0.0, 400.0]);
        assert!(cube.edge_mm <= 800.0 && 800.0 - cube.edge_mm <= CUBE_EDGE_TOLERANCE_MM);

        // Never feasible.
        assert_eq!(
            largest_cube(&cands, 10.0, 2000.0, |_| false),
            Err(EvalError::NoFeasibleCube {
                min_edge_mm: 10.0,
                candidates: 3
            })
        );
        // Only tiny cubes feasible (a* = 2 mm < a_min = 10 mm).
        assert!(matches!(
            largest_cube(&[[0.0, 0.0, 1.0]], 10.0, 2000.0, |p| p[2] >= 0.0),
            Err(EvalError::NoFeasibleCube { .. })
        ));
        // Argument errors.
        assert!(matches!(
            largest_cube(&[], 10.0, 20.0, |_| true),
            Err(EvalError::Empty { .. })
        ));
        assert!(matches!(
            largest_cube(&[[f64::NAN, 0.0, 0.0]], 10.0, 20.0, |_| true),
            Err(EvalError::NonFinite { .. })
        ));
        assert!(matches!(
            largest_cube(&[[0.0; 3]], 0.0, 20.0, |_| true),
            Err(EvalError::InvalidArgument {
                name: "min_edge_mm",
                ..
            })
        ));
        assert!(matches!(
            largest_cube(&[[0.0; 3]], 30.0, 20.0, |_| true),
            Err(EvalError::InvalidArgument {
                name: "max_edge_mm",
                ..
            })
        ));
    }

    #[test]
    fn point_stats_four_points_by_hand() {
        // Commanded x_c = (0, 0, 0). Attained: barycentre (10, 20, 30) plus offsets
        // (1,0,0), (−1,0,0), (0,3,0), (0,−3,0).
        //   x̄ = (10, 20, 30) → AP_x = 10, AP_y = 20, AP_z = 30, AP_p = √1400 = 37.41657…
        //   l_j = 1, 1, 3, 3 → l̄ = 2
        //   S_l = √(((−1)² + (−1)² + 1² + 1²)/3) = √(4/3) = 1.154700…
        //   RP_l = 2 + 3·1.154700 = 5.464102…
        let x = [
            [11.0, 20.0, 30.0],
            [9.0, 20.0, 30.0],
            [10.0, 23.0, 30.0],
            [10.0, 17.0, 30.0],
        ];
        let s = point_stats([0.0; 3], &x).unwrap();
        assert_eq!(s.cycles, 4);
        assert_eq!(s.mean_mm, [10.0, 20.0, 30.0]);
        assert_relative_eq!(s.ap_x_mm, 10.0, epsilon = 1e-12);
        assert_relative_eq!(s.ap_y_mm, 20.0, epsilon = 1e-12);
        assert_relative_eq!(s.ap_z_mm, 30.0, epsilon = 1e-12);
        assert_relative_eq!(s.ap_p_mm, 1400f64.sqrt(), epsilon = 1e-12);
        assert_relative_eq!(s.l_mean_mm, 2.0, epsilon = 1e-12);
        assert_relative_eq!(s.s_l_mm, (4.0f64 / 3.0).sqrt(), epsilon = 1e-12);
        assert_relative_eq!(s.rp_l_mm, 5.464_101_615_137_754, epsilon = 1e-12);

        // Signs of AP_x/y/z follow x̄ − x_c.
        let s = point_stats([20.0, 0.0, 40.0], &x).unwrap();
        assert_relative_eq!(s.ap_x_mm, -10.0, epsilon = 1e-12);
        assert_relative_eq!(s.ap_z_mm, -10.0, epsilon = 1e-12);
        assert_relative_eq!(s.ap_p_mm, 600f64.sqrt(), epsilon = 1e-12);
    }

    /// 30 attained points in 15 antipodal pairs ±r·u about the barycentre: 5 pairs at
    /// each radius 0.05, 0.10, 0.15 mm, directions on a deterministic spiral.
    fn thirty_cycles(barycentre: [f64; 3]) -> Vec<[f64; 3]> {
        let mut pts = Vec::new();
        for k in 0..15 {
            let r = [0.05, 0.10, 0.15][k % 3];
            let t = (k as f64 + 0.5) / 15.0;
            let polar = (1.0 - 2.0 * t).acos();
            let azimuth = k as f64 * 2.399_963_229_728_653; // golden angle
            let u = [
                polar.sin() * azimuth.cos(),
                polar.sin() * azimuth.sin(),
                polar.cos(),
            ];
            for sign in [1.0, -1.0] {
                pts.push([
                    barycentre[0] + sign * r * u[0],
                    barycentre[1] + sign * r * u[1],
                    barycentre[2] + sign * r * u[2],
                ]);
            }
        }
        pts
    }

    #[test]
    fn rp_l_thirty_cycles_known_scatter() {
        // l_j: ten each of 0.05, 0.10, 0.15 → l̄ = 0.10;
        // Σ(l_j − l̄)² = 20·0.05² = 0.05 → S_l = √(0.05/29) = 0.04152274…;
        // RP_l = 0.10 + 3·0.04152274 = 0.22456822…
        // Barycentre offset (0.3, −0.4, 0) from x_c → AP_p = 0.5.
        let xc = [1500.0, -250.0, 2000.0];
        let pts = thirty_cycles([1500.3, -250.4, 2000.0]);
        assert_eq!(pts.len(), 30);
        let s = point_stats(xc, &pts).unwrap();
        assert_eq!(s.cycles, 30);
        assert_relative_eq!(s.ap_p_mm, 0.5, epsilon = 1e-9);
        assert_relative_eq!(s.ap_x_mm, 0.3, epsilon = 1e-9);
        assert_relative_eq!(s.ap_y_mm, -0.4, epsilon = 1e-9);
        assert_relative_eq!(s.ap_z_mm, 0.0, epsilon = 1e-9);
        assert_relative_eq!(s.l_mean_mm, 0.10, epsilon = 1e-9);
        assert_relative_eq!(s.s_l_mm, (0.05f64 / 29.0).sqrt(), epsilon = 1e-9);
        assert_relative_eq!(s.rp_l_mm, 0.224_568_22, epsilon = 1e-8);
    }

    #[test]
    fn point_stats_errors() {
        assert!(matches!(
            point_stats([0.0; 3], &[]),
            Err(EvalError::TooFew { got: 0, .. })
        ));
        assert!(matches!(
            point_stats([0.0; 3], &[[1.0; 3]]),
            Err(EvalError::TooFew { got: 1, .. })
        ));
        assert!(matches!(
            point_stats([0.0; 3], &[[1.0; 3], [1.0, 1.0, f64::NAN]]),
            Err(EvalError::NonFinite { index: 1, .. })
        ));
        assert!(matches!(
            point_stats([f64::INFINITY, 0.0, 0.0], &[[1.0; 3], [1.0; 3]]),
            Err(EvalError::NonFinite {
                what: "commanded point",
                ..
            })
        ));
    }

    fn as_refs(v: &[Vec<[f64; 3]>]) -> [&[[f64; 3]]; 5] {
        [&v[0], &v[1], &v[2], &v[3], &v[4]]
    }

    #[test]
    fn iso_report_from_attained() {
        // Before: every point sits at x_c + (0.3, −0.4, 0) (AP_p = 0.5) with the 30-cycle
        // scatter; after: x_c + (0.03, 0, 0.04) (AP_p = 0.05). Improvement 90 %.
        let cube = IsoCube::new([1800.0, 0.0, 1500.0], 600.0).unwrap();
        let targets = cube.test_points_mm();
        let shifted = |d: [f64; 3]| -> Vec<Vec<[f64; 3]>> {
            targets
                .iter()
                .map(|t| thirty_cycles([t[0] + d[0], t[1] + d[1], t[2] + d[2]]))
                .collect()
        };
        let before = shifted([0.3, -0.4, 0.0]);
        let after = shifted([0.03, 0.0, 0.04]);
        let rep = IsoReport::from_attained(cube, as_refs(&before), as_refs(&after)).unwrap();
        assert_eq!(rep.cube, Some(cube));
        for (row, t) in rep.points.iter().zip(targets) {
            assert_eq!(row.commanded_mm, t);
            assert_relative_eq!(row.before.ap_p_mm, 0.5, epsilon = 1e-9);
            assert_relative_eq!(row.after.ap_p_mm, 0.05, epsilon = 1e-9);
        }
        assert_relative_eq!(rep.mean_ap_p_before_mm(), 0.5, epsilon = 1e-9);
        assert_relative_eq!(rep.mean_ap_p_after_mm(), 0.05, epsilon = 1e-9);
        assert_relative_eq!(rep.ap_p_improvement_pct().unwrap(), 90.0, epsilon = 1e-6);
        assert_relative_eq!(rep.mean_rp_l_before_mm(), 0.224_568_22, epsilon = 1e-8);
        assert_relative_eq!(rep.mean_rp_l_after_mm(), 0.224_568_22, epsilon = 1e-8);

        // A too-short series anywhere is an error.
        let short: Vec<[f64; 3]> = vec![targets[2]];
        let mut bad = as_refs(&after);
        bad[2] = &short;
        assert!(IsoReport::from_attained(cube, as_refs(&before), bad).is_err());
    }

    #[test]
    fn cycle_order_is_p1_p5_p4_p3_p2() {
        let labels: Vec<String> = ISO_CYCLE_ORDER
            .iter()
            .map(|i| format!("P{}", i + 1))
            .collect();
        assert_eq!(labels, ["P1", "P5", "P4", "P3", "P2"]);
    }
}
