//! `kincal urdf import|export`: URDF in and out (logic in the `urdf` crate,
//! `docs/urdf.md`).

use std::path::PathBuf;

use anyhow::{Context as _, Result, bail};
use kinematics::RobotSpec;

/// Arguments of `urdf`.
#[derive(clap::Args)]
#[command(after_help = "Examples (from the repository root):
  kincal urdf import crates/urdf/tests/fixtures/ur10.urdf --base base_link --tip tool0 \\
      --tool-mm 0,0,109 --out ur10-from-urdf.json
  kincal urdf export ur10-cal/identified.json --out ur10-calibrated.urdf --offsets offsets.json \\
      --nominal ur10-cal/registered-nominal.json")]
pub struct UrdfArgs {
    /// `import` or `export`.
    #[command(subcommand)]
    pub cmd: UrdfCmd,
}

#[allow(rustdoc::broken_intra_doc_links, rustdoc::invalid_html_tags)] // clap help text
/// The `urdf` subcommands.
#[derive(clap::Subcommand)]
pub enum UrdfCmd {
    /// A plain URDF (expand xacro first) → a robot file for the serial chain from --base to
    /// --tip: revolute joints with their limits, fixed joints folded in, exact for any chain.
    Import {
        /// The URDF file (plain XML; run `xacro` on a .xacro first).
        urdf: PathBuf,
        /// The base link: its frame becomes the measurement frame of the robot file.
        #[arg(long)]
        base: String,
        /// The tip link (e.g. tool0 or flange).
        #[arg(long)]
        tip: String,
        /// The measured point (ball, probe) in the tip link's frame, mm: `x,y,z`.
        #[arg(
            long,
            value_delimiter = ',',
            default_value = "0,0,0",
            allow_negative_numbers = true
        )]
        tool_mm: Vec<f64>,
        /// The robot file's name [default: the URDF's robot name].
        #[arg(long)]
        name: Option<String>,
        /// Pass over a check: `length-units` imports a robot whose reach (the measured point
        /// from the base at q = 0 or mid-limits) is outside 20 mm … 50 m (refused by default:
        /// a URDF written in millimetres instead of metres gives a robot a thousand times too
        /// large).
        #[arg(long, value_name = "CHECK", value_parser = ["length-units"])]
        allow: Vec<String>,
        /// Output robot file (JSON); `-` writes it to stdout.
        #[arg(long)]
        out: PathBuf,
    },
    /// A robot file (e.g. identified.json) → URDF: root link `measurement` (the measurement
    /// frame), one revolute joint per robot joint, a fixed link `tool` at the measured point.
    Export {
        /// The robot file (JSON).
        robot: PathBuf,
        /// Output URDF file; `-` writes it to stdout.
        #[arg(long)]
        out: PathBuf,
        /// Also write the joint-angle offsets θ to this JSON file (`-`: stdout, after the
        /// URDF).
        #[arg(long)]
        offsets: Option<PathBuf>,
        /// Nominal robot file: the offsets file then also has θ − θ nominal.
        #[arg(long, requires = "offsets")]
        nominal: Option<PathBuf>,
        /// Joint names, comma-separated, base to tip [default: joint_1 … joint_N].
        #[arg(long, value_delimiter = ',')]
        joint_names: Option<Vec<String>>,
    },
}

/// Runs `urdf import` or `urdf export`.
pub fn run(args: &UrdfArgs) -> Result<()> {
    match &args.cmd {
        UrdfCmd::Import {
            urdf: path,
            base,
            tip,
            tool_mm,
            name,
            allow,
            out,
        } => {
            crate::check_file_out("--out", out)?;
            crate::check_not_input("--out", out, &[("the URDF", path)])?;
            let [x, y, z] = tool_mm[..] else {
                bail!(
                    "--tool-mm takes three values x,y,z (mm), got {}",
                    tool_mm.len()
                );
            };
            let opts = urdf::ImportOptions {
                tool_in_tip_mm: [x, y, z],
                name: name.clone(),
                allow_implausible_size: allow.iter().any(|a| a == "length-units"),
            };
            let imported = urdf::import_file(path, base, tip, &opts).map_err(|e| match e {
                e @ urdf::UrdfError::ImplausibleSize { .. } => {
                    anyhow::Error::new(e).context("refused (override: --allow length-units)")
                }
                e => e.into(),
            })?;
            crate::write_file_out(out, imported.spec.to_json_string().as_bytes())?;
            // With `--out -` the robot file is on stdout: the notes go to stderr.
            let note = |line: String| {
                if crate::is_stdout(out) {
                    crate::errln!("{line}");
                } else {
                    crate::outln!("{line}");
                }
            };
            note(format!(
                "{}: {} → {}: {} revolute joints ({}), {} fixed joints folded in",
                path.display(),
                base,
                tip,
                imported.joint_names.len(),
                imported.joint_names.join(", "),
                imported.fixed_joints.len()
            ));
            note(format!("→ {}", crate::out_name(out)));
        }
        UrdfCmd::Export {
            robot,
            out,
            offsets,
            nominal,
            joint_names,
        } => {
            crate::check_file_out("--out", out)?;
            let mut inputs = vec![("the robot file", robot.as_path())];
            inputs.extend(nominal.as_deref().map(|p| ("--nominal", p)));
            crate::check_not_input("--out", out, &inputs)?;
            if let Some(path) = offsets {
                crate::check_file_out("--offsets", path)?;
                inputs.push(("--out", out.as_path()));
                crate::check_not_input("--offsets", path, &inputs)?;
            }
            let spec = RobotSpec::from_file(robot)?;
            let opts = urdf::ExportOptions {
                joint_names: joint_names.clone(),
                robot_name: None,
            };
            let text = urdf::export(&spec, &opts)?;
            // Everything rendered before anything is written.
            let offsets_text = match offsets {
                Some(_) => {
                    let nom = nominal
                        .as_ref()
                        .map(|p| RobotSpec::from_file(p))
                        .transpose()?;
                    Some(urdf::offsets_json(&spec, nom.as_ref(), &opts)?)
                }
                None => None,
            };
            if let (Some(path), Some(t)) = (offsets, &offsets_text)
                && !crate::is_stdout(path)
            {
                measurements::write_atomically(path, t.as_bytes())
                    .with_context(|| format!("writing {}", path.display()))?;
            }
            crate::write_file_out(out, text.as_bytes())?;
            if let (Some(path), Some(t)) = (offsets, &offsets_text)
                && crate::is_stdout(path)
            {
                crate::write_file_out(path, t.as_bytes())?;
            }
            // With `--out -` the URDF is on stdout: the notes go to stderr.
            let note = |line: String| {
                if crate::is_stdout(out) {
                    crate::errln!("{line}");
                } else {
                    crate::outln!("{line}");
                }
            };
            note(format!(
                "{}: {} joints → {} (root link \"measurement\", measured point at link \"tool\")",
                robot.display(),
                spec.joints.len(),
                crate::out_name(out)
            ));
            if let Some(path) = offsets {
                note(format!("joint offsets → {}", crate::out_name(path)));
            }
            if let Some(r) = spec
                .provenance
                .as_ref()
                .and_then(|p| p.residual_model.as_ref())
            {
                note(format!(
                    "note: {} names a learned residual model ({}): it cannot be expressed in \
                     URDF (a URDF holds rigid joint transforms only), so the URDF is the \
                     geometric robot alone; `kincal predict --robot {}` applies the model \
                     (docs/residual-model.md)",
                    robot.display(),
                    r.file,
                    robot.display()
                ));
            }
        }
    }
    Ok(())
}
