//! What the robot files a calibration writes are, and where they came from
//! ([`kinematics::Provenance`]): `identified.json` and `registered-nominal.json` say their
//! role, the run that wrote them (one digest for both) and the data's digest, so that a
//! reader of the pair ([`check_pair`], `compensate`) refuses the files swapped or from
//! different runs instead of writing the anti-compensation.

use kinematics::{FileRole, Provenance, ResidualModelRef, RobotSpec};
use sha2::{Digest, Sha256};

use crate::error::Refusal;
use crate::files::LoadedRobot;
use crate::workflow::Calibration;

/// SHA-256 of `bytes`, hex.
pub(crate) fn sha256_hex(bytes: &[u8]) -> String {
    Sha256::digest(bytes)
        .iter()
        .map(|b| format!("{b:02x}"))
        .collect()
}

/// SHA-256 (hex) of rows as read (measurement rows, or the 6-DoF fit's rows): every field of
/// every row (joints, points, orientation, σ, id, target, line) in their shortest round-trip
/// form, so that the same rows give the same digest from a file or from memory.
pub fn rows_sha256<R: std::fmt::Debug>(rows: &[R]) -> String {
    sha256_hex(format!("{rows:?}").as_bytes())
}

impl Calibration {
    /// The identification rows of the calibration, as screened (before any were rejected).
    fn identification_rows_sha256(&self) -> String {
        match self {
            Calibration::Points(c) => rows_sha256(&c.screened_rows),
            Calibration::ToolFrame(c) => rows_sha256(&c.screened.rows),
        }
    }

    /// The run's digest: SHA-256 of the data's digest and both robots (as specs without
    /// provenance), hex, first 16 bytes.
    fn run_digest(&self, identified: &RobotSpec, registered: &RobotSpec) -> String {
        sha256_hex(
            format!(
                "{}\n{}\n{}",
                self.identification_rows_sha256(),
                identified.to_json_string(),
                registered.to_json_string()
            )
            .as_bytes(),
        )[..32]
            .to_string()
    }

    /// The robot files as written: `identified.json` and `registered-nominal.json`, each with
    /// its [`Provenance`] (its role, the run's digest — SHA-256 of the data's digest and both
    /// robots — and the data's name and digest); `identified.json`'s names the residual model
    /// and its SHA-256 when one is written ([`Calibration::written_residual_model`]).
    pub fn written_specs(&self) -> (RobotSpec, RobotSpec) {
        let (mut identified, mut registered) = (
            self.identified_robot().to_spec(),
            self.registered_robot().to_spec(),
        );
        let data_sha256 = self.identification_rows_sha256();
        let run = self.run_digest(&identified, &registered);
        let residual_model = self.written_residual_model().map(|text| ResidualModelRef {
            file: crate::residual::MODEL_FILE.to_string(),
            sha256: sha256_hex(text.as_bytes()),
        });
        let provenance = |role, residual_model| Provenance {
            role,
            run: run.clone(),
            data: self.data_source().to_string(),
            data_sha256: data_sha256.clone(),
            residual_model,
        };
        identified.provenance = Some(provenance(FileRole::Identified, residual_model));
        registered.provenance = Some(provenance(FileRole::RegisteredNominal, None));
        (identified, registered)
    }

    /// The residual model file as written (`residual-model.json`, `crate::residual`), when the
    /// gate kept one: the model with the calibration run it corrects (`fitted_for`).
    pub fn written_residual_model(&self) -> Option<String> {
        let mut model = self.residual()?.model.clone()?;
        let run = self.run_digest(
            &self.identified_robot().to_spec(),
            &self.registered_robot().to_spec(),
        );
        model.set_fitted_for(run);
        Some(model.to_json_string())
    }
}

/// The pair `compensate` takes: `calibrated` (`--robot`, the calibrated robot) and `nominal`
/// (`--nominal`, the nominal robot in the same frame). Files without provenance (written by
/// hand, or by an older kincal) are taken as given.
///
/// # Errors
/// [`Refusal::MismatchedPair`] when `calibrated` is a registered nominal or `nominal` an
/// identified robot (swapped), or when both come from calibrations and from different runs.
pub fn check_pair(calibrated: &LoadedRobot, nominal: &LoadedRobot) -> Result<(), Refusal> {
    let (c, n) = (
        calibrated.spec.provenance.as_ref(),
        nominal.spec.provenance.as_ref(),
    );
    let refuse = |reason: String| Refusal::MismatchedPair {
        robot: calibrated.path.display().to_string(),
        nominal: nominal.path.display().to_string(),
        reason,
    };
    if let Some(p) = c.filter(|p| p.role != FileRole::Identified) {
        return Err(refuse(format!(
            "the calibrated robot (--robot) is {} of a calibration on {}: swapped with \
             --nominal?",
            p.role, p.data
        )));
    }
    if let Some(p) = n.filter(|p| p.role != FileRole::RegisteredNominal) {
        return Err(refuse(format!(
            "the nominal robot (--nominal) is {} of a calibration on {}: swapped with \
             --robot?",
            p.role, p.data
        )));
    }
    if let (Some(c), Some(n)) = (c, n)
        && c.run != n.run
    {
        return Err(refuse(format!(
            "they come from different calibration runs (run {} on {}, data SHA-256 {}…; run \
             {} on {}, data SHA-256 {}…): the registered nominal of one run is in its own \
             measurement frame",
            c.run,
            c.data,
            &c.data_sha256[..12.min(c.data_sha256.len())],
            n.run,
            n.data,
            &n.data_sha256[..12.min(n.data_sha256.len())]
        )));
    }
    Ok(())
}
