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

/// What the tracker reads at each pose of a simulated trial (a scenario's `measurement`).
#[derive(Clone, Debug, Default, PartialEq)]
pub enum Probe {
    /// The tool point: one row per pose with `x,y,z` (the paper's measurement).
    #[default]
    Point,
    /// A 6-DoF probe at the tool: one row per pose with `x,y,z` and its orientation
    /// `qw,qx,qy,qz` ([`World::measure_tool`] with the orientation).
    Frame,
    /// Several reflectors: one row per reflector and pose, named in the `target` column, the
    /// rows of a pose sharing its id. Each is `(name, offset from the tool point in the
    /// flange frame, mm)`; the first is usually the tool point itself (offset zero).
    Targets(Vec<(String, nalgebra::Vector3<f64>)>),
}

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

/// [`simulate()`] with what the tracker reads at each pose ([`Probe`]): [`Probe::Point`]
/// gives [`simulate()`]'s sets, byte for byte.
pub fn simulate_with(
    nominal: &Robot,
    cfg: &VirtualRobotConfig,
    seed: u64,
    trial: u64,
    probe: &Probe,
) -> Result<Simulation, SimError> {
    World::new(nominal, cfg, seed, trial)?.simulate_with(probe)
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
        self.simulate_with(&Probe::Point)
    }

    /// [`World::simulate`] reading each pose with `probe`.
    pub fn simulate_with(&mut self, probe: &Probe) -> Result<Simulation, SimError> {
        let identification = self.measure_set(
            "poses.identification",
            IDENTIFICATION_FILE,
            'I',
            self.identification_poses_deg().to_vec(),
            probe,
        )?;
        let validation = self.measure_set(
            "poses.validation",
            VALIDATION_FILE,
            'V',
            self.validation_poses_deg().to_vec(),
            probe,
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
        probe: &Probe,
    ) -> Result<MeasurementSet, SimError> {
        let n = self.nominal().n_joints();
        let mut rows = Vec::with_capacity(poses_deg.len() / n);
        let mut q_rad = vec![0.0; n];
        let (offsets, names): (Vec<nalgebra::Vector3<f64>>, Vec<&str>) = match probe {
            Probe::Point | Probe::Frame => (vec![nalgebra::Vector3::zeros()], vec![]),
            Probe::Targets(t) => t.iter().map(|(name, o)| (*o, name.as_str())).unzip(),
        };
        for (index, q_deg) in poses_deg.chunks_exact(n).enumerate() {
            for (r, d) in q_rad.iter_mut().zip(q_deg) {
                *r = d.to_radians();
            }
            let unmeasurable = |source| SimError::NotMeasurable {
                field: field.to_string(),
                index,
                source,
            };
            let id = format!("{prefix}{:03}", index + 1);
            if *probe == Probe::Point {
                let p = self.measure(&q_rad).map_err(unmeasurable)?;
                rows.push(Measurement::new(q_deg.to_vec(), Some([p.x, p.y, p.z])).with_id(id));
                continue;
            }
            let (points, rotation) = self
                .measure_tool(&q_rad, &offsets, *probe == Probe::Frame)
                .map_err(unmeasurable)?;
            for (k, p) in points.iter().enumerate() {
                let mut row =
                    Measurement::new(q_deg.to_vec(), Some([p.x, p.y, p.z])).with_id(id.clone());
                if let Some(name) = names.get(k) {
                    row = row.with_target(*name);
                }
                if let (0, Some(r)) = (k, rotation) {
                    row = row.with_orientation(kinematics::rotation::unit_quaternion(&r));
                }
                rows.push(row);
            }
        }
        Ok(MeasurementSet::new(source, n, rows))
    }
}

impl Simulation {
    /// The comment header of `set`'s file (`what`: identification or validation).
    fn header(&self, what: &str, set: &MeasurementSet) -> String {
        let mut h = format!(
            "kincal virtual robot — {what} measurements of {}\nseed {}, trial {}; q in degrees, \
             x y z in mm in the measurement frame",
            self.truth.nominal_robot.name, self.truth.seed, self.truth.trial
        );
        if set.has_orientation() {
            h.push_str("; qw qx qy qz the probe's orientation in the measurement frame");
        }
        if set.has_targets() {
            h.push_str("; one row per target, the rows with the same id are one pose");
        }
        h
    }

    /// `identification.csv` as text (`docs/model.md` §5).
    pub fn identification_csv(&self) -> Result<String, SimError> {
        Ok(to_csv_string(
            &self.identification,
            Some(&self.header("identification", &self.identification)),
        )?)
    }

    /// `validation.csv` as text (`docs/model.md` §5).
    pub fn validation_csv(&self) -> Result<String, SimError> {
        Ok(to_csv_string(
            &self.validation,
            Some(&self.header("validation", &self.validation)),
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
