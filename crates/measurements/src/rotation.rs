//! The rotation arithmetic of the orientation columns: Euler angles to a unit quaternion,
//! and a quaternion's rotation matrix. Pure rotation math, no kinematics.

use std::fmt;
use std::str::FromStr;

use crate::EulerConventionError;

/// Largest accepted deviation of a quaternion's norm from 1: `|‖q‖ − 1| ≤ 1e-6`. A tracker
/// export with six or more significant digits per component passes; anything further off
/// is not a rotation and is refused ([`MeasurementError::NotUnitQuaternion`](crate::MeasurementError::NotUnitQuaternion)).
pub const QUATERNION_NORM_TOLERANCE: f64 = 1e-6;

/// An Euler-angle convention: three rotation axes and whether they are intrinsic (about the
/// axes of the rotating frame, written upper case, `XYZ`) or extrinsic (about the fixed
/// measurement axes, written lower case, `xyz`) — the notation of SciPy's
/// `Rotation.from_euler`.
///
/// All 12 sequences are accepted in both forms: the six Tait–Bryan sequences (`XYZ`, `XZY`,
/// `YXZ`, `YZX`, `ZXY`, `ZYX`) and the six proper Euler sequences (`XYX`, `XZX`, `YXY`,
/// `YZY`, `ZXZ`, `ZYZ`). With angles (a, b, c) about axes (A, B, C), the rotation is
/// `R = R_A(a)·R_B(b)·R_C(c)` for the intrinsic form and `R = R_C(c)·R_B(b)·R_A(a)` for the
/// extrinsic one, so intrinsic `XYZ` and extrinsic `zyx` with the angles reversed are the
/// same rotation.
///
/// ```
/// use measurements::EulerConvention;
/// let xyz: EulerConvention = "XYZ".parse().unwrap();
/// assert!(xyz.is_intrinsic());
/// assert_eq!(xyz.to_string(), "XYZ");
/// // 90° about z: (cos 45°, 0, 0, sin 45°).
/// let q = xyz.to_quaternion([0.0, 0.0, 90.0]);
/// assert!((q[0] - q[3]).abs() < 1e-15 && q[1] == 0.0 && q[2] == 0.0);
/// assert!("XXY".parse::<EulerConvention>().is_err());
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct EulerConvention {
    /// Axis indices, 0 = x, 1 = y, 2 = z.
    axes: [usize; 3],
    intrinsic: bool,
}

impl EulerConvention {
    /// The convention named by three axis letters: `XYZ` (intrinsic) … `zyz` (extrinsic).
    pub fn parse(text: &str) -> Result<Self, EulerConventionError> {
        let err = |reason: &'static str| EulerConventionError {
            text: text.to_owned(),
            reason,
        };
        let chars: Vec<char> = text.chars().collect();
        if chars.len() != 3 {
            return Err(err("it must be three axis letters"));
        }
        let upper = chars.iter().all(|c| matches!(c, 'X' | 'Y' | 'Z'));
        let lower = chars.iter().all(|c| matches!(c, 'x' | 'y' | 'z'));
        if !upper && !lower {
            return Err(err(
                "the letters must be all X, Y, Z (intrinsic) or all x, y, z (extrinsic)",
            ));
        }
        let axes = [0, 1, 2].map(|i| match chars[i].to_ascii_lowercase() {
            'x' => 0,
            'y' => 1,
            _ => 2,
        });
        if axes[0] == axes[1] || axes[1] == axes[2] {
            return Err(err("an axis follows itself"));
        }
        Ok(Self {
            axes,
            intrinsic: upper,
        })
    }

    /// True for an intrinsic convention (upper case, rotating axes).
    pub fn is_intrinsic(&self) -> bool {
        self.intrinsic
    }

    /// The rotation of the Euler angles `angles_deg` (degrees, in the order of the
    /// convention's letters) as a unit quaternion `[w, x, y, z]`, scalar first, with `w ≥ 0`
    /// (the sign is fixed so that conversions are deterministic).
    pub fn to_quaternion(&self, angles_deg: [f64; 3]) -> [f64; 4] {
        let [qa, qb, qc] = [0, 1, 2].map(|i| axis_quaternion(self.axes[i], angles_deg[i]));
        let q = if self.intrinsic {
            quaternion_product(quaternion_product(qa, qb), qc)
        } else {
            quaternion_product(quaternion_product(qc, qb), qa)
        };
        if q[0] < 0.0 { q.map(|v| -v) } else { q }
    }
}

impl FromStr for EulerConvention {
    type Err = EulerConventionError;

    fn from_str(text: &str) -> Result<Self, Self::Err> {
        Self::parse(text)
    }
}

impl fmt::Display for EulerConvention {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let letters = if self.intrinsic { "XYZ" } else { "xyz" }.as_bytes();
        for &a in &self.axes {
            write!(f, "{}", letters[a] as char)?;
        }
        Ok(())
    }
}

/// The rotation by `angle_deg` about coordinate axis `axis` (0 = x, 1 = y, 2 = z).
fn axis_quaternion(axis: usize, angle_deg: f64) -> [f64; 4] {
    let (s, c) = (0.5 * angle_deg.to_radians()).sin_cos();
    let mut q = [c, 0.0, 0.0, 0.0];
    q[1 + axis] = s;
    q
}

/// The Hamilton product `a·b` of two quaternions `[w, x, y, z]` (the rotation `b`, then `a`).
pub fn quaternion_product(a: [f64; 4], b: [f64; 4]) -> [f64; 4] {
    let [aw, ax, ay, az] = a;
    let [bw, bx, by, bz] = b;
    [
        aw * bw - ax * bx - ay * by - az * bz,
        aw * bx + ax * bw + ay * bz - az * by,
        aw * by - ax * bz + ay * bw + az * bx,
        aw * bz + ax * by - ay * bx + az * bw,
    ]
}

/// The rotation matrix of the quaternion `q = [w, x, y, z]` (normalised first), rows then
/// columns: its columns are the rotated frame's axes in the fixed frame's coordinates.
pub fn quaternion_to_matrix(q: [f64; 4]) -> [[f64; 3]; 3] {
    let n = q.iter().map(|v| v * v).sum::<f64>().sqrt();
    let [w, x, y, z] = q.map(|v| v / n);
    [
        [
            1.0 - 2.0 * (y * y + z * z),
            2.0 * (x * y - w * z),
            2.0 * (x * z + w * y),
        ],
        [
            2.0 * (x * y + w * z),
            1.0 - 2.0 * (x * x + z * z),
            2.0 * (y * z - w * x),
        ],
        [
            2.0 * (x * z - w * y),
            2.0 * (y * z + w * x),
            1.0 - 2.0 * (x * x + y * y),
        ],
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rx(a: f64) -> [[f64; 3]; 3] {
        let (s, c) = a.to_radians().sin_cos();
        [[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]]
    }
    fn ry(a: f64) -> [[f64; 3]; 3] {
        let (s, c) = a.to_radians().sin_cos();
        [[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]]
    }
    fn rz(a: f64) -> [[f64; 3]; 3] {
        let (s, c) = a.to_radians().sin_cos();
        [[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]]
    }
    fn mul(a: [[f64; 3]; 3], b: [[f64; 3]; 3]) -> [[f64; 3]; 3] {
        let mut m = [[0.0; 3]; 3];
        for i in 0..3 {
            for j in 0..3 {
                m[i][j] = (0..3).map(|k| a[i][k] * b[k][j]).sum();
            }
        }
        m
    }
    fn close(a: [[f64; 3]; 3], b: [[f64; 3]; 3]) -> bool {
        (0..3).all(|i| (0..3).all(|j| (a[i][j] - b[i][j]).abs() < 1e-14))
    }

    /// Intrinsic = product of elementary matrices in letter order; extrinsic = reversed.
    #[test]
    fn matches_elementary_rotation_matrices() {
        let e = [rx, ry, rz];
        let angles = [30.0, -45.0, 60.0];
        for text in [
            "XYZ", "XZY", "YXZ", "YZX", "ZXY", "ZYX", "XYX", "XZX", "YXY", "YZY", "ZXZ", "ZYZ",
        ] {
            for conv in [text.to_owned(), text.to_lowercase()] {
                let c: EulerConvention = conv.parse().unwrap();
                assert_eq!(c.to_string(), conv);
                let [ma, mb, mc] = [0, 1, 2].map(|i| e[c.axes[i]](angles[i]));
                let want = if c.is_intrinsic() {
                    mul(mul(ma, mb), mc)
                } else {
                    mul(mul(mc, mb), ma)
                };
                let q = c.to_quaternion(angles);
                assert!(q[0] >= 0.0);
                let norm = q.iter().map(|v| v * v).sum::<f64>().sqrt();
                assert!((norm - 1.0).abs() < 1e-15, "{conv}: {norm}");
                assert!(close(quaternion_to_matrix(q), want), "{conv}");
            }
        }
    }

    /// A hand-computed case: intrinsic XYZ (30°, −45°, 60°), R = Rx(30)·Ry(−45)·Rz(60)
    /// multiplied out on paper with cos 30° = sin 60° = √3/2, cos 45° = √2/2 (SciPy's
    /// `as_matrix()` prints the same to 8 digits).
    #[test]
    fn hand_computed_matrix() {
        let q = EulerConvention::parse("XYZ")
            .unwrap()
            .to_quaternion([30.0, -45.0, 60.0]);
        let m = quaternion_to_matrix(q);
        let (h2, h3) = (0.5 * 2f64.sqrt(), 0.5 * 3f64.sqrt());
        let want = [
            [h2 / 2.0, -h2 * h3, -h2],
            [0.75 - h2 / 4.0, h3 / 2.0 + h2 * h3 / 2.0, -h2 / 2.0],
            [h3 / 2.0 + h2 * h3 / 2.0, 0.25 - 0.75 * h2, h3 * h2],
        ];
        for i in 0..3 {
            for j in 0..3 {
                assert!((m[i][j] - want[i][j]).abs() < 1e-15, "{i}{j}");
            }
        }
    }

    #[test]
    fn bad_conventions() {
        for bad in ["", "XY", "XYZX", "XyZ", "XXY", "XYY", "abc", "X Y", "ÄYZ"] {
            let e = EulerConvention::parse(bad).unwrap_err();
            assert!(e.to_string().contains(&format!("\"{bad}\"")), "{e}");
            assert!(e.to_string().contains("XYZ"), "{e}");
        }
        // XYX is a proper Euler sequence, not a repeat.
        assert!(EulerConvention::parse("XYX").is_ok());
    }
    /// SciPy 1.17.1 `Rotation.from_euler(seq, angles, degrees=True).as_quat()`, reordered
    /// scalar first and signed so that w ≥ 0 (generated once; the numbers are committed).
    const SCIPY: &[(&str, [f64; 3], [f64; 4])] = &[
        (
            "XYZ",
            [30.0, -45.0, 60.0],
            [
                0.8223631719059994,
                0.022260026714733816,
                -0.43967973954090955,
                0.3604234056503559,
            ],
        ),
        (
            "XYZ",
            [-170.0, 80.0, 15.5],
            [
                0.15250599411734905,
                -0.7486042063936703,
                0.15841962631290452,
                -0.6254893171964345,
            ],
        ),
        (
            "xyz",
            [30.0, -45.0, 60.0],
            [
                0.7233174113647118,
                0.3919038373291199,
                -0.20056212114657512,
                0.5319756951821668,
            ],
        ),
        (
            "xyz",
            [-170.0, 80.0, 15.5],
            [
                0.02019532915354018,
                0.7637136143557989,
                0.047397796140951805,
                -0.6434960084172728,
            ],
        ),
        (
            "XZY",
            [30.0, -45.0, 60.0],
            [
                0.7233174113647118,
                0.3919038373291199,
                0.5319756951821668,
                -0.20056212114657512,
            ],
        ),
        (
            "XZY",
            [-170.0, 80.0, 15.5],
            [
                0.02019532915354018,
                0.7637136143557989,
                -0.6434960084172728,
                0.047397796140951805,
            ],
        ),
        (
            "xzy",
            [30.0, -45.0, 60.0],
            [
                0.8223631719059994,
                0.022260026714733816,
                0.3604234056503559,
                -0.43967973954090955,
            ],
        ),
        (
            "xzy",
            [-170.0, 80.0, 15.5],
            [
                0.15250599411734905,
                -0.7486042063936703,
                -0.6254893171964345,
                0.15841962631290452,
            ],
        ),
        (
            "YXZ",
            [30.0, -45.0, 60.0],
            [
                0.7233174113647118,
                -0.20056212114657512,
                0.3919038373291199,
                0.5319756951821668,
            ],
        ),
        (
            "YXZ",
            [-170.0, 80.0, 15.5],
            [
                0.02019532915354018,
                0.047397796140951805,
                0.7637136143557989,
                -0.6434960084172728,
            ],
        ),
        (
            "yxz",
            [30.0, -45.0, 60.0],
            [
                0.8223631719059994,
                -0.43967973954090955,
                0.022260026714733816,
                0.3604234056503559,
            ],
        ),
        (
            "yxz",
            [-170.0, 80.0, 15.5],
            [
                0.15250599411734905,
                0.15841962631290452,
                -0.7486042063936703,
                -0.6254893171964345,
            ],
        ),
        (
            "YZX",
            [30.0, -45.0, 60.0],
            [
                0.8223631719059994,
                0.3604234056503559,
                0.022260026714733816,
                -0.43967973954090955,
            ],
        ),
        (
            "YZX",
            [-170.0, 80.0, 15.5],
            [
                0.15250599411734905,
                -0.6254893171964345,
                -0.7486042063936703,
                0.15841962631290452,
            ],
        ),
        (
            "yzx",
            [30.0, -45.0, 60.0],
            [
                0.7233174113647118,
                0.5319756951821668,
                0.3919038373291199,
                -0.20056212114657512,
            ],
        ),
        (
            "yzx",
            [-170.0, 80.0, 15.5],
            [
                0.02019532915354018,
                -0.6434960084172728,
                0.7637136143557989,
                0.047397796140951805,
            ],
        ),
        (
            "ZXY",
            [30.0, -45.0, 60.0],
            [
                0.8223631719059994,
                -0.43967973954090955,
                0.3604234056503559,
                0.022260026714733816,
            ],
        ),
        (
            "ZXY",
            [-170.0, 80.0, 15.5],
            [
                0.15250599411734905,
                0.15841962631290452,
                -0.6254893171964345,
                -0.7486042063936703,
            ],
        ),
        (
            "zxy",
            [30.0, -45.0, 60.0],
            [
                0.7233174113647118,
                -0.20056212114657512,
                0.5319756951821668,
                0.3919038373291199,
            ],
        ),
        (
            "zxy",
            [-170.0, 80.0, 15.5],
            [
                0.02019532915354018,
                0.047397796140951805,
                -0.6434960084172728,
                0.7637136143557989,
            ],
        ),
        (
            "ZYX",
            [30.0, -45.0, 60.0],
            [
                0.7233174113647118,
                0.5319756951821668,
                -0.20056212114657512,
                0.3919038373291199,
            ],
        ),
        (
            "ZYX",
            [-170.0, 80.0, 15.5],
            [
                0.02019532915354018,
                -0.6434960084172728,
                0.047397796140951805,
                0.7637136143557989,
            ],
        ),
        (
            "zyx",
            [30.0, -45.0, 60.0],
            [
                0.8223631719059994,
                0.3604234056503559,
                -0.43967973954090955,
                0.022260026714733816,
            ],
        ),
        (
            "zyx",
            [-170.0, 80.0, 15.5],
            [
                0.15250599411734905,
                -0.6254893171964345,
                0.15841962631290452,
                -0.7486042063936703,
            ],
        ),
        (
            "XYX",
            [30.0, -45.0, 60.0],
            [
                0.6532814824381884,
                0.6532814824381882,
                -0.3696438106143861,
                0.0990457605412876,
            ],
        ),
        (
            "XYX",
            [-170.0, 80.0, 15.5],
            [
                0.1690640437088326,
                -0.7471555647643154,
                -0.03083974654946827,
                -0.642047366787918,
            ],
        ),
        (
            "xyx",
            [30.0, -45.0, 60.0],
            [
                0.6532814824381884,
                0.6532814824381882,
                -0.3696438106143861,
                -0.0990457605412876,
            ],
        ),
        (
            "xyx",
            [-170.0, 80.0, 15.5],
            [
                0.1690640437088326,
                -0.7471555647643154,
                -0.03083974654946827,
                0.642047366787918,
            ],
        ),
        (
            "XZX",
            [30.0, -45.0, 60.0],
            [
                0.6532814824381884,
                0.6532814824381882,
                -0.0990457605412876,
                -0.3696438106143861,
            ],
        ),
        (
            "XZX",
            [-170.0, 80.0, 15.5],
            [
                0.1690640437088326,
                -0.7471555647643154,
                0.642047366787918,
                -0.03083974654946827,
            ],
        ),
        (
            "xzx",
            [30.0, -45.0, 60.0],
            [
                0.6532814824381884,
                0.6532814824381882,
                0.0990457605412876,
                -0.3696438106143861,
            ],
        ),
        (
            "xzx",
            [-170.0, 80.0, 15.5],
            [
                0.1690640437088326,
                -0.7471555647643154,
                -0.642047366787918,
                -0.03083974654946827,
            ],
        ),
        (
            "YXY",
            [30.0, -45.0, 60.0],
            [
                0.6532814824381884,
                -0.3696438106143861,
                0.6532814824381882,
                -0.0990457605412876,
            ],
        ),
        (
            "YXY",
            [-170.0, 80.0, 15.5],
            [
                0.1690640437088326,
                -0.03083974654946827,
                -0.7471555647643154,
                0.642047366787918,
            ],
        ),
        (
            "yxy",
            [30.0, -45.0, 60.0],
            [
                0.6532814824381884,
                -0.3696438106143861,
                0.6532814824381882,
                0.0990457605412876,
            ],
        ),
        (
            "yxy",
            [-170.0, 80.0, 15.5],
            [
                0.1690640437088326,
                -0.03083974654946827,
                -0.7471555647643154,
                -0.642047366787918,
            ],
        ),
        (
            "YZY",
            [30.0, -45.0, 60.0],
            [
                0.6532814824381884,
                0.0990457605412876,
                0.6532814824381882,
                -0.3696438106143861,
            ],
        ),
        (
            "YZY",
            [-170.0, 80.0, 15.5],
            [
                0.1690640437088326,
                -0.642047366787918,
                -0.7471555647643154,
                -0.03083974654946827,
            ],
        ),
        (
            "yzy",
            [30.0, -45.0, 60.0],
            [
                0.6532814824381884,
                -0.0990457605412876,
                0.6532814824381882,
                -0.3696438106143861,
            ],
        ),
        (
            "yzy",
            [-170.0, 80.0, 15.5],
            [
                0.1690640437088326,
                0.642047366787918,
                -0.7471555647643154,
                -0.03083974654946827,
            ],
        ),
        (
            "ZXZ",
            [30.0, -45.0, 60.0],
            [
                0.6532814824381884,
                -0.3696438106143861,
                0.0990457605412876,
                0.6532814824381882,
            ],
        ),
        (
            "ZXZ",
            [-170.0, 80.0, 15.5],
            [
                0.1690640437088326,
                -0.03083974654946827,
                -0.642047366787918,
                -0.7471555647643154,
            ],
        ),
        (
            "zxz",
            [30.0, -45.0, 60.0],
            [
                0.6532814824381884,
                -0.3696438106143861,
                -0.0990457605412876,
                0.6532814824381882,
            ],
        ),
        (
            "zxz",
            [-170.0, 80.0, 15.5],
            [
                0.1690640437088326,
                -0.03083974654946827,
                0.642047366787918,
                -0.7471555647643154,
            ],
        ),
        (
            "ZYZ",
            [30.0, -45.0, 60.0],
            [
                0.6532814824381884,
                -0.0990457605412876,
                -0.3696438106143861,
                0.6532814824381882,
            ],
        ),
        (
            "ZYZ",
            [-170.0, 80.0, 15.5],
            [
                0.1690640437088326,
                0.642047366787918,
                -0.03083974654946827,
                -0.7471555647643154,
            ],
        ),
        (
            "zyz",
            [30.0, -45.0, 60.0],
            [
                0.6532814824381884,
                0.0990457605412876,
                -0.3696438106143861,
                0.6532814824381882,
            ],
        ),
        (
            "zyz",
            [-170.0, 80.0, 15.5],
            [
                0.1690640437088326,
                -0.642047366787918,
                -0.03083974654946827,
                -0.7471555647643154,
            ],
        ),
    ];

    #[test]
    fn matches_scipy() {
        for &(conv, angles, want) in SCIPY {
            let q = EulerConvention::parse(conv).unwrap().to_quaternion(angles);
            for k in 0..4 {
                assert!(
                    (q[k] - want[k]).abs() < 1e-15,
                    "{conv} {angles:?}: {q:?} vs {want:?}"
                );
            }
        }
    }
}
