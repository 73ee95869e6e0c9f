//! [`simulate()`]: one trial's measurement files and truth.

use std::path::Path;

use kinematics::Robot;
use measurements::{Measurement, MeasurementSet, to_csv_string, write_atomically};

use crate::config::VirtualRobotConfig;
use crate::error::SimError;
use crate::world::{Setup, Truth, World};

/// File name of the identification measurements.
pub const IDENTIFICATION_FILE: &str = "identification.csv";
/// File name of the validation measurements.
pub const VALIDATION_FILE: &str = "validation.csv";
/// File name of the truth.
pub const TRUTH_FILE: &str = "truth.json";

/// One simulated trial: the two measurement sets (`docs/model.md` §5; joints in degrees,
/// points in mm in the measurement frame) and the truth.
#[derive(Clone, Debug, PartialEq)]
pub struct Simulation {
    /// Identification poses and their measured points (ids `I001`, …).
    pub identification: MeasurementSet,
    /// Validation poses and their measured points (ids `V001`, …).
    pub validation: MeasurementSet,
    /// The truth (`truth.json`).
    pub truth: Truth,
}

/// Simulates trial `trial` of `seed`: builds the [`World`] and measures its identification
/// poses, then its validation poses, in order.
pub fn simulate(
    nominal: &Robot,
    cfg: &VirtualRobotConfig,
    seed: u64,
    trial: u64,
) -> Result<Simulation, SimError> {
    World::new(nominal, cfg, seed, trial)?.simulate()
}

impl Setup {
    /// Simulates trial `trial` ([`Setup::world`], then [`World::simulate`]).
    pub fn simulate(&self, trial: u64) -> Result<Simulation, SimError> {
        self.world(trial)?.simulate()
    }
}

impl World {
    /// Measures the identification poses, then the validation poses (counting moves, so
    /// drift grows over the run), and collects the truth afterwards.
    pub fn simulate(&mut self) -> Result<Simulation, SimError> {
        let identification = self.measure_set(
            "poses.identification",
            IDENTIFICATION_FILE,
            'I',
            self.identification_poses_deg().to_vec(),
        )?;
        let validation = self.measure_set(
            "poses.validation",
            VALIDATION_FILE,
            'V',
            self.validation_poses_deg().to_vec(),
        )?;
        Ok(Simulation {
            identification,
            validation,
            truth: self.truth(),
        })
    }

    fn measure_set(
        &mut self,
        field: &str,
        source: &str,
        prefix: char,
        poses_deg: Vec<f64>,
    ) -> Result<MeasurementSet, SimError> {
        let n = self.nominal().n_joints();
        let mut rows = Vec::with_capacity(poses_deg.len() / n);
        let mut q_rad = vec![0.0; n];
        for (index, q_deg) in poses_deg.chunks_exact(n).enumerate() {
            for (r, d) in q_rad.iter_mut().zip(q_deg) {
                *r = d.to_radians();
            }
            let p = self
                .measure(&q_rad)
                .map_err(|source| SimError::NotMeasurable {
                    field: field.to_string(),
                    index,
                    source,
                })?;
            rows.push(
                Measurement::new(q_deg.to_vec(), Some([p.x, p.y, p.z]))
                    .with_id(format!("{prefix}{:03}", index + 1)),
            );
        }
        Ok(MeasurementSet::new(source, n, rows))
    }
}

impl Simulation {
    fn header(&self, what: &str) -> String {
        format!(
            "kincal virtual robot — {what} measurements of {}\nseed {}, trial {}; q in degrees, \
             x y z in mm in the measurement frame",
            self.truth.nominal_robot.name, self.truth.seed, self.truth.trial
        )
    }

    /// `identification.csv` as text (`docs/model.md` §5).
    pub fn identification_csv(&self) -> Result<String, SimError> {
        Ok(to_csv_string(
            &self.identification,
            Some(&self.header("identification")),
        )?)
    }

    /// `validation.csv` as text (`docs/model.md` §5).
    pub fn validation_csv(&self) -> Result<String, SimError> {
        Ok(to_csv_string(
            &self.validation,
            Some(&self.header("validation")),
        )?)
    }

    /// `truth.json` as text: pretty JSON, deterministic for the same values.
    pub fn truth_json(&self) -> String {
        let mut s = serde_json::to_string_pretty(&self.truth)
            .unwrap_or_else(|e| format!("{{\"error\": \"{e}\"}}"));
        s.push('\n');
        s
    }

    /// Writes `identification.csv`, `validation.csv` and `truth.json` into `dir` (created
    /// if missing). All three texts are rendered before anything is written, and each file
    /// is written atomically ([`measurements::write_atomically`]): on error no file is
    /// half-written.
    pub fn write(&self, dir: &Path) -> Result<(), SimError> {
        let files = [
            (IDENTIFICATION_FILE, self.identification_csv()?),
            (VALIDATION_FILE, self.validation_csv()?),
            (TRUTH_FILE, self.truth_json()),
        ];
        std::fs::create_dir_all(dir).map_err(|source| SimError::Io {
            file: dir.to_path_buf(),
            source,
        })?;
        for (name, text) in &files {
            let path = dir.join(name);
            write_atomically(&path, text.as_bytes())
                .map_err(|source| SimError::Io { file: path, source })?;
        }
        Ok(())
    }
}
