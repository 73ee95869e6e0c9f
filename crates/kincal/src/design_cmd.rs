//! `kincal design`: choose which poses to measure (all logic in the `design` crate).

use std::path::PathBuf;

use anyhow::{Context, Result, bail};
use clap::{ArgGroup, Args};
use design::{Candidates, Criterion, DesignOptions, Measure, design_plan};
use identify::ParamSpec;
use kinematics::Robot;
use virtual_robot::World;

/// Arguments of `design`.
#[allow(rustdoc::broken_intra_doc_links, rustdoc::invalid_html_tags)] // clap help text
#[derive(Args, Debug)]
#[command(after_help = "Examples:
  kincal design --robot scenarios/robots/ur10.json \\
      --candidates data/ur10-ipa/series-b-joint-configurations.csv --poses 20 --criterion i
  kincal design --robot scenarios/robots/kr1000-titan.json \\
      --scenario scenarios/paper-kr1000.json --random 500 --poses 30 --out plan.csv
  kincal design --robot scenarios/robots/kr1000-titan.json \\
      --scenario scenarios/paper-kr1000.json --random 500 --poses 30 \\
      --params minimal+compliance+gears --criterion i --out plan-extended.csv
  kincal design --robot scenarios/robots/kr1000-titan.json \\
      --scenario scenarios/paper-kr1000.json --random 500 --poses 8 --measure frame
  Writes the plan (joints-only measurement file, candidate ids kept) and prints the criterion,
  condition number and O1–O5 beside the median of 100 random sets of the same size.")]
#[command(group(ArgGroup::new("pool").required(true).args(["candidates", "scenario"])))]
pub struct DesignArgs {
    /// Robot model file (JSON): the model the design is computed on.
    #[arg(long)]
    robot: PathBuf,
    /// Candidate poses: a joint CSV or a measurement file (q1…qN in degrees, optional id;
    /// points ignored).
    #[arg(long)]
    candidates: Option<PathBuf>,
    /// Scenario file: draw the candidates with its pose sampler (joint limits, floor,
    /// tracker window, wrist and condition limits), seed of the scenario, trial 0.
    #[arg(long, requires = "random")]
    scenario: Option<PathBuf>,
    /// Number of candidates to draw with --scenario.
    #[arg(long, value_name = "N")]
    random: Option<usize>,
    /// Number of poses to choose.
    #[arg(long)]
    poses: usize,
    /// Criterion: d, a, e, i, o1, o3, o5.
    #[arg(long, default_value = "d")]
    criterion: String,
    /// Workspace poses of the I criterion (joint CSV) [the candidates].
    #[arg(long)]
    workspace: Option<PathBuf>,
    /// Parameters: `minimal` (the minimal identifiable set), `paper` (all) or comma-separated
    /// names; `+compliance`, `+gears` or `+name,name` add non-geometric parameters
    /// (docs/extended-model.md), e.g. `minimal+compliance+gears`.
    #[arg(long, default_value = "minimal")]
    params: ParamSpec,
    /// What each pose measures: `point` (one reflector, 3 equations), `frame` (a 6-DoF
    /// probe: position and orientation, 6 equations, orientation weighted as identify does
    /// without σ) or `targets` (every target of the robot file's `targets`, 3 equations
    /// each) [point: the paper's measurement].
    #[arg(long, default_value = "point")]
    measure: String,
    /// Output plan (joints-only measurement file, candidate ids kept) [plan.csv]; `-`
    /// writes it to stdout (the report then goes to stderr).
    #[arg(long, default_value = "plan.csv")]
    out: PathBuf,
    /// Seed of restarts and of the random sets the report compares with.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Exchange restarts from random starting sets.
    #[arg(long, default_value_t = 0)]
    restarts: usize,
}

/// Runs `design`.
pub fn run(args: &DesignArgs) -> Result<()> {
    crate::check_file_out("--out", &args.out)?;
    let mut inputs = vec![("--robot", args.robot.as_path())];
    inputs.extend(args.candidates.as_deref().map(|p| ("--candidates", p)));
    inputs.extend(args.scenario.as_deref().map(|p| ("--scenario", p)));
    inputs.extend(args.workspace.as_deref().map(|p| ("--workspace", p)));
    crate::check_not_input("--out", &args.out, &inputs)?;
    let geometric = Robot::from_file(&args.robot)
        .with_context(|| format!("loading {}", args.robot.display()))?;
    let params_flag = || format!("--params {}", args.params);
    // The extended parameters after `+` join the geometric ones.
    let robot = args
        .params
        .apply(&geometric, &args.robot.display().to_string())
        .with_context(params_flag)?;
    let criterion: Criterion = args
        .criterion
        .parse()
        .map_err(|e: String| anyhow::anyhow!(e))?;
    let measure: Measure = args
        .measure
        .parse()
        .map_err(|e: String| anyhow::anyhow!(e))
        .context("--measure")?;
    let pool = match (&args.candidates, &args.scenario, args.random) {
        (Some(path), _, _) => {
            let pool = Candidates::from_file(&robot, path)?;
            // Read (about a row's memory each); designed, each needs a pose's.
            campaign::check_poses(pool.len())
                .with_context(|| format!("--candidates {}", path.display()))?;
            pool
        }
        (None, Some(path), Some(n)) => {
            campaign::check_poses(n).with_context(|| format!("--random {n}"))?;
            let loaded = campaign::Scenario::from_file(path)
                .with_context(|| format!("loading {}", path.display()))?;
            // The virtual robot samples on the geometric model (its physics beyond geometry
            // is the scenario's `unmodelled` section).
            let seed = loaded.scenario.seed;
            let q_deg =
                World::identification_pool_deg(&geometric, &loaded.virtual_robot(), seed, 0, n)
                    .with_context(|| format!("sampling candidates of {}", path.display()))?;
            let source = format!("sampler (seed {seed}, trial 0)");
            Candidates::from_poses_deg(source, geometric.n_joints(), q_deg)
        }
        _ => bail!("give --candidates FILE, or --scenario FILE with --random N"),
    };
    let workspace = args
        .workspace
        .as_ref()
        .map(|p| Candidates::from_file(&robot, p))
        .transpose()?;
    // `minimal` (of the extended robot, if extended) is decided by the design crate on the
    // candidates; `paper` and a list of names take the extended parameters along.
    let params = args.params.listed(&robot).with_context(params_flag)?;
    let mut opts = DesignOptions::new(criterion, args.poses);
    opts.seed = args.seed;
    opts.restarts = args.restarts;
    let (plan, report) = design_plan(
        &robot,
        &pool,
        workspace.as_ref(),
        params.as_deref(),
        measure,
        &opts,
        100,
    )
    .map_err(|e| match measure {
        Measure::Point => anyhow::Error::from(e),
        _ => anyhow::Error::from(e).context(format!("--measure {measure}")),
    })?;
    let csv = measurements::to_csv_string(&plan, Some("kincal design plan"))
        .with_context(|| format!("writing {}", crate::out_name(&args.out)))?;
    crate::write_file_out(&args.out, csv.as_bytes())?;
    if crate::is_stdout(&args.out) {
        // The plan is on stdout: the report goes to stderr.
        crate::errout!("{}", report.to_text());
        crate::errln!("plan: {} poses → standard output", plan.rows.len());
    } else {
        crate::out!("{}", report.to_text());
        crate::outln!("plan: {} poses → {}", plan.rows.len(), args.out.display());
    }
    Ok(())
}
