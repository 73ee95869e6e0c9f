//! `kincal identifiability`: the identifiability report of a robot model on a pose set.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use clap::{ArgGroup, Args};
use identify::{IdentifiabilityOptions, ParamSpec, analyze};
use kinematics::{PoseSampler, Robot};
use measurements::{ReadOptions, read_file};
use nalgebra::Vector3;
use rand::{SeedableRng, rngs::ChaCha8Rng};

/// Arguments of `identifiability`.
#[allow(rustdoc::broken_intra_doc_links, rustdoc::invalid_html_tags)] // clap help text
#[derive(Args, Debug)]
#[command(after_help = "Examples:
  kincal identifiability --robot scenarios/robots/kr1000-titan.json --random-poses 50
  kincal identifiability --robot scenarios/robots/ur10.json \\
      --data data/ur10-ipa/series-b-joint-configurations.csv --params minimal --json
  kincal identifiability --robot scenarios/robots/kr1000-titan.json --random-poses 50 \\
      --params paper+compliance+gears")]
#[command(group(ArgGroup::new("poses").required(true).args(["data", "scenario", "random_poses"])))]
pub struct IdentifiabilityArgs {
    /// Robot model file (JSON).
    #[arg(long)]
    robot: PathBuf,
    /// Measurement file (docs/model.md §5 CSV): the poses; measured points are optional here.
    #[arg(long)]
    data: Option<PathBuf>,
    /// Scenario file (JSON): its identification poses (trial 0) are analysed. The robot file
    /// still comes from --robot (and --tool), so a scenario can be checked against another model.
    #[arg(long)]
    scenario: Option<PathBuf>,
    /// Draw N random admissible poses (uniform in the joint limits, |q5| ≥ 10°, geometric
    /// Jacobian condition ≤ 100) instead of reading them.
    #[arg(long, value_name = "N")]
    random_poses: Option<usize>,
    /// Seed of --random-poses (ChaCha8).
    #[arg(long, default_value_t = 1, requires = "random_poses")]
    seed: u64,
    /// Parameters to analyse: `paper` (all), `minimal`, or comma-separated names; `+compliance`,
    /// `+gears` or `+name,name` add non-geometric parameters (docs/extended-model.md), e.g.
    /// `paper+compliance+gears`.
    #[arg(long, default_value = "paper")]
    params: ParamSpec,
    /// Override the measured point (ball) in the flange frame, mm: `x,y,z`.
    #[arg(long, value_name = "X,Y,Z", value_parser = parse_tool, allow_hyphen_values = true)]
    tool: Option<Vector3<f64>>,
    /// Print the report as JSON.
    #[arg(long)]
    json: bool,
}

fn parse_tool(s: &str) -> Result<Vector3<f64>, String> {
    let v: Vec<f64> = s
        .split(',')
        .map(|t| {
            t.trim()
                .parse::<f64>()
                .map_err(|e| format!("`{}`: {e}", t.trim()))
        })
        .collect::<Result<_, _>>()?;
    match v.as_slice() {
        [x, y, z] if v.iter().all(|c| c.is_finite()) => Ok(Vector3::new(*x, *y, *z)),
        [_, _, _] => Err("the offset must be finite".into()),
        _ => Err(format!(
            "expected three comma-separated numbers, got {}",
            v.len()
        )),
    }
}

/// Runs the command.
pub fn run(args: &IdentifiabilityArgs) -> Result<()> {
    let mut robot = Robot::from_file(&args.robot)
        .with_context(|| format!("loading robot {}", args.robot.display()))?;
    if let Some(t) = args.tool {
        robot.set_tool_mm(t);
    }
    let (poses, source) = if let Some(path) = &args.data {
        (read_poses(&robot, path)?, path.display().to_string())
    } else if let Some(path) = &args.scenario {
        // The scenario's own pose sampling: trial 0's identification poses.
        let loaded = campaign::Scenario::from_file(path)
            .with_context(|| format!("loading scenario {}", path.display()))?;
        if let (None, Some(t)) = (args.tool, loaded.scenario.tool_mm) {
            robot.set_tool_mm(t.into());
        }
        let world = virtual_robot::Setup::new(
            &loaded.nominal,
            &loaded.virtual_robot(),
            loaded.scenario.seed,
        )
        .and_then(|setup| setup.world(0))
        .with_context(|| format!("sampling the poses of {}", path.display()))?;
        (
            world.identification_poses_rad().to_vec(),
            format!(
                "identification poses of {} (seed {}, trial 0)",
                path.display(),
                loaded.scenario.seed
            ),
        )
    } else {
        let n = args.random_poses.expect("clap requires one pose source");
        campaign::check_poses(n).with_context(|| format!("--random-poses {n}"))?;
        let mut rng = ChaCha8Rng::seed_from_u64(args.seed);
        let sampled = PoseSampler::default()
            .sample(&robot, n, &mut rng)
            .with_context(|| format!("drawing {n} random poses"))?;
        (sampled.rad, format!("{n} random poses, seed {}", args.seed))
    };

    // The extended parameters after `+` join the geometric ones.
    let params_flag = || format!("--params {}", args.params);
    let robot = args
        .params
        .apply(&robot, &args.robot.display().to_string())
        .with_context(params_flag)?;
    let opts = IdentifiabilityOptions::default();
    let free = args
        .params
        .resolve(&robot, &poses, None, &opts)
        .with_context(params_flag)?;
    let report = analyze(&robot, &poses, None, &free, &opts)
        .with_context(|| format!("analysing {} on {source}", robot.name()))?;
    if args.json {
        crate::outln!("{}", serde_json::to_string_pretty(&report)?);
    } else {
        crate::out!(
            "{}",
            report::identifiability::console(
                &report,
                &args.params.to_string(),
                &source,
                robot.tool_mm()
            )
        );
    }
    Ok(())
}

/// Reads the joint values of a measurement file (points optional), in radians.
fn read_poses(robot: &Robot, path: &Path) -> Result<Vec<f64>> {
    let n = robot.n_joints();
    let limits = (0..n)
        .map(|i| robot.limits_rad(i).map(f64::to_degrees))
        .collect();
    let set = read_file(
        path,
        &ReadOptions::new(n).joints_only().with_limits_deg(limits),
    )
    .with_context(|| format!("reading poses from {}", path.display()))?;
    for notice in &set.notices {
        crate::errln!("note: {notice}");
    }
    Ok(set
        .rows
        .iter()
        .flat_map(|r| r.q_deg.iter().map(|q| q.to_radians()))
        .collect())
}

#[cfg(test)]
mod tests {
    use super::parse_tool;

    #[test]
    fn tool_offsets_parse() {
        assert_eq!(
            parse_tool("60, 20,-150").unwrap(),
            nalgebra::Vector3::new(60.0, 20.0, -150.0)
        );
        assert!(parse_tool("1,2").unwrap_err().contains("three"));
        assert!(parse_tool("1,x,2").unwrap_err().contains("`x`"));
        assert!(parse_tool("1,inf,2").unwrap_err().contains("finite"));
    }
}
