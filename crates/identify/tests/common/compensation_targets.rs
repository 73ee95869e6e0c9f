//! The robots and targets of the compensation count (issue 29), shared by the test
//! `compensation::nearest_*` and the example `compensation_count`.

use kinematics::{Robot, RobotSpec, Unit};

/// Small deterministic generator (xorshift64*), uniform in [0, 1).
pub struct Rng(pub u64);

impl Rng {
    /// The next value in [0, 1).
    pub fn unit(&mut self) -> f64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        (self.0.wrapping_mul(0x2545_f491_4f6c_dd1d) >> 11) as f64 / (1u64 << 53) as f64
    }
    /// Uniform in [lo, hi).
    pub fn range(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.unit()
    }
}

/// The nominal KR1000 (`scenarios/robots/kr1000-titan.json`) and a calibrated-like robot:
/// every parameter moved uniformly by up to ±1 mm (lengths) or ±0.05° (angles), seeded —
/// the size of the errors a calibration of this arm identifies (the paper's Table 3).
pub fn kr1000_pair() -> (Robot, Robot) {
    let text = include_str!("../../../../scenarios/robots/kr1000-titan.json");
    let nominal = Robot::from_spec(&RobotSpec::from_json_str(text, "kr1000").unwrap()).unwrap();
    let mut rng = Rng(0x2929_2929_2929_2929);
    let mut p = nominal.params();
    for (k, v) in p.iter_mut().enumerate() {
        *v += if nominal.layout().get(k).unit == Unit::Deg {
            rng.range(-0.05, 0.05).to_radians()
        } else {
            rng.range(-1.0, 1.0)
        };
    }
    let identified = nominal.with_params(&p).unwrap();
    (nominal, identified)
}

/// `n` joint vectors (radians) uniform within the limits of `robot`, seeded.
pub fn random_poses(robot: &Robot, n: usize, seed: u64) -> Vec<Vec<f64>> {
    let mut rng = Rng(seed.wrapping_mul(0x9e37_79b9_7f4a_7c15) | 1);
    (0..n)
        .map(|_| {
            (0..robot.n_joints())
                .map(|i| {
                    let [lo, hi] = robot.limits_rad(i);
                    rng.range(lo, hi)
                })
                .collect()
        })
        .collect()
}
