//! The outlier table of `docs/calibrating-real-data.md` ("Robust screening"): the README's
//! UR10 example (every 15th row of `data/ur10-ipa/series-b-joint-configurations.csv`
//! identifies, the other 1,395 validate) with 0 / 5 / 15 / 30 / 40 % of its 100
//! identification rows moved 10 or 100 mm in random directions
//! ([`calibrate::contamination::contaminate`], seed 38), calibrated with the default robust
//! screen and, for comparison, with `keep_outliers` (every row kept, the screen before
//! robust screening only lists).
//!
//! ```text
//! cargo run -p calibrate --example outlier_table
//! ```

use calibrate::{
    CalibrateError, Calibration, IdentifyRequest, Inputs, Refusal, Split, calibrate as run,
};

fn root() -> std::path::PathBuf {
    std::path::PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/../.."))
}

/// Held-out mean and max (mm) and the rows excluded, or the refusal: the check's name and
/// its evidence without the file's name.
fn outcome(
    request: &IdentifyRequest,
    inputs: Inputs,
) -> Result<(f64, f64, Vec<usize>), (String, String)> {
    match run(request, inputs) {
        Ok(Calibration::Points(c)) => {
            let v = c.validation.as_ref().expect("the other rows validate");
            let excluded = c
                .robust
                .as_ref()
                .map_or_else(Vec::new, |r| r.excluded.clone());
            Ok((
                v.table.after.norm.mean_mm,
                v.table.after.norm.max_mm,
                excluded,
            ))
        }
        Ok(_) => Err(("kind".into(), "not a point calibration".into())),
        Err(CalibrateError::Refused(Refusal::Implausible {
            check, evidence, ..
        })) => {
            let evidence = evidence.split(".csv: ").last().unwrap_or(&evidence);
            Err((check.name().to_string(), evidence.to_string()))
        }
        Err(e) => Err(("error".into(), e.to_string())),
    }
}

fn main() {
    std::env::set_current_dir(root()).expect("the repository root");
    let request = IdentifyRequest {
        split: Split::Every {
            every: 15,
            offset: 0,
        },
        ..IdentifyRequest::new(
            "scenarios/robots/ur10.json",
            "data/ur10-ipa/series-b-joint-configurations.csv",
        )
    };
    let keep = IdentifyRequest {
        keep_outliers: true,
        ..request.clone()
    };
    let clean = Inputs::load(&request).expect("the README example loads");
    let id_rows: Vec<usize> = (0..clean.data.rows.len()).step_by(15).collect();
    println!(
        "| contaminated rows | magnitude | default: rows excluded (of them contaminated) | \
         default: held out mean / max mm | keep_outliers: held out mean / max mm |"
    );
    println!("|---|---|---|---|---|");
    for pct in [0usize, 5, 15, 30, 40] {
        for magnitude_mm in [10.0, 100.0] {
            let mut inputs = Inputs::load(&request).expect("loads");
            let count = pct * id_rows.len() / 100;
            let moved = calibrate::contamination::contaminate(
                &mut inputs.data,
                &id_rows,
                count,
                magnitude_mm,
                38,
            );
            // Indices of the moved rows among the identification rows.
            let truth: Vec<usize> = moved.iter().map(|r| r / 15).collect();
            let kept_inputs = Inputs {
                nominal: inputs.nominal.clone(),
                data: inputs.data.clone(),
                validate: None,
            };
            let default = match outcome(&request, inputs) {
                Ok((mean, max, excluded)) => {
                    let found = excluded
                        .iter()
                        .filter(|i| truth.binary_search(i).is_ok())
                        .count();
                    format!("{} ({found}) | {mean:.3} / {max:.3}", excluded.len())
                }
                Err((_, evidence)) => {
                    format!(
                        "refused: {} | —",
                        evidence.split(" — ").next().unwrap_or(&evidence)
                    )
                }
            };
            let kept = match outcome(&keep, kept_inputs) {
                Ok((mean, max, _)) => format!("{mean:.3} / {max:.3}"),
                Err((check, _)) => format!("refused by the {check} check"),
            };
            println!("| {count} of 100 ({pct} %) | {magnitude_mm} mm | {default} | {kept} |");
        }
    }
}
