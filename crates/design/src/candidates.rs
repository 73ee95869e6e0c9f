//! Candidate pools: poses drawn by the caller (the virtual robot's sampler, in the front end
//! and the campaign), a joint CSV (ids kept), or the joint columns of a measurement file.

use std::path::Path;

use kinematics::Robot;
use measurements::{Measurement, MeasurementSet, ReadOptions};

use crate::error::DesignError;

/// A candidate pool: joints (radians, flat, stride N) with optional ids and source lines.
#[derive(Clone, Debug, PartialEq)]
pub struct Candidates {
    /// Where they came from (file or label).
    pub source: String,
    /// Joints per pose.
    pub n_joints: usize,
    /// Joints, radians, flat with stride N.
    pub q_rad: Vec<f64>,
    /// Joints as given, degrees (kept so a plan reproduces the input bits).
    pub q_deg: Vec<f64>,
    /// Ids (from the file's `id` column), per candidate.
    pub ids: Vec<Option<String>>,
    /// Source lines (0 when not from a file).
    pub lines: Vec<usize>,
}

impl Candidates {
    /// Number of candidates.
    pub fn len(&self) -> usize {
        self.ids.len()
    }

    /// True when there are none.
    pub fn is_empty(&self) -> bool {
        self.ids.is_empty()
    }

    /// The candidates of a measurement set (its joints only; points are ignored).
    pub fn from_set(set: &MeasurementSet) -> Candidates {
        let q_deg: Vec<f64> = set.rows.iter().flat_map(|r| r.q_deg.clone()).collect();
        Candidates {
            source: set.source.clone(),
            n_joints: set.n_joints,
            q_rad: q_deg.iter().map(|d| d.to_radians()).collect(),
            q_deg,
            ids: set.rows.iter().map(|r| r.id.clone()).collect(),
            lines: set.rows.iter().map(|r| r.line).collect(),
        }
    }

    /// Reads a joint CSV or a measurement file (joints-only form accepted; `x, y, z` ignored)
    /// with the robot's joint limits: a value outside them, a NaN or a malformed line is an
    /// error naming the file, line and column.
    pub fn from_file(robot: &Robot, path: &Path) -> Result<Candidates, DesignError> {
        let opts = read_options(robot);
        let set = measurements::read_file(path, &opts)?;
        Ok(Candidates::from_set(&set))
    }

    /// [`Candidates::from_file`] on text (`source` names it in errors).
    pub fn from_str(robot: &Robot, text: &str, source: &str) -> Result<Candidates, DesignError> {
        let set = measurements::read_str(text, source, &read_options(robot))?;
        Ok(Candidates::from_set(&set))
    }

    /// A pool of poses drawn by the caller (e.g. the virtual robot's identification poses
    /// of a trial: joint limits, floor, tracker window and range, wrist and condition
    /// limits): joints in degrees, flat with stride `n_joints`, converted with `to_radians`
    /// (the bits the sampler drew them from). `source` labels the pool; ids are `c0001`,
    /// `c0002`, … (at least four digits).
    pub fn from_poses_deg(
        source: impl Into<String>,
        n_joints: usize,
        q_deg: Vec<f64>,
    ) -> Candidates {
        let count = q_deg.len() / n_joints.max(1);
        let width = count.to_string().len().max(4);
        Candidates {
            source: source.into(),
            n_joints,
            q_rad: q_deg.iter().map(|d| d.to_radians()).collect(),
            q_deg,
            ids: (1..=count).map(|i| Some(format!("c{i:0width$}"))).collect(),
            lines: vec![0; count],
        }
    }

    /// The chosen candidates as a joints-only measurement set (ids kept, input order of
    /// `indices`), ready for [`measurements::write_file`]. A candidate read from a file
    /// without an `id` column is named by its source line (`line-857`), so every planned pose
    /// can be traced back to the candidate file.
    pub fn plan(&self, indices: &[usize], source: &str) -> MeasurementSet {
        let n = self.n_joints;
        let rows = indices
            .iter()
            .map(|&i| {
                let mut m = Measurement::new(self.q_deg[i * n..(i + 1) * n].to_vec(), None);
                m.id = self.ids[i]
                    .clone()
                    .or_else(|| (self.lines[i] > 0).then(|| format!("line-{}", self.lines[i])));
                m
            })
            .collect();
        MeasurementSet::new(source, n, rows)
    }
}

fn read_options(robot: &Robot) -> ReadOptions {
    let limits = (0..robot.n_joints())
        .map(|i| {
            let [lo, hi] = robot.limits_rad(i);
            [lo.to_degrees(), hi.to_degrees()]
        })
        .collect();
    ReadOptions::new(robot.n_joints())
        .joints_only()
        .with_limits_deg(limits)
}
