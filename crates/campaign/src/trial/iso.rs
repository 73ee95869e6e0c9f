//! The ISO 9283 position test of a trial: the plan fixed for a campaign ([`IsoPlan`]: the
//! largest cube in the reachable, tracker-visible workspace and the nominal joints of P1…P5)
//! and the test of one trial's identified model on it.

use evaluate::{IsoCube, IsoReport};
use kinematics::kept::{Kept, with_kept};
use kinematics::{IkTarget, Robot};
use nalgebra::Vector3;
use virtual_robot::{Tracker, World};

use crate::error::CampaignError;
use crate::scenario::LoadedScenario;

/// The ISO 9283 test plan, fixed for a campaign (nominal model, tracker placement).
#[derive(Clone, Debug)]
pub struct IsoPlan {
    /// The cube.
    pub cube: IsoCube,
    /// Targets P1…P5 (nominal point position, reference flange orientation).
    pub targets: [IkTarget; 5],
    /// Commanded joints reaching P1…P5 on the nominal model, rad.
    pub q_cmd_rad: [Vec<f64>; 5],
}

/// Finds the largest cube in the reachable, tracker-visible workspace around the ISO
/// reference pose, and the nominal joints of P1…P5.
pub(crate) fn iso_plan(
    loaded: &LoadedScenario,
    tracker_cfg: &virtual_robot::TrackerConfig,
) -> Result<IsoPlan, CampaignError> {
    let iso = &loaded.scenario.iso;
    let nominal = &loaded.nominal;
    let tracker =
        Tracker::new(tracker_cfg).map_err(|source| CampaignError::IsoTracker { source })?;
    let q_ref: Vec<f64> = iso.reference_q_deg.iter().map(|v| v.to_radians()).collect();
    let reference = nominal.flange(&q_ref);
    let p_ref = reference.transform_point(&nominal.tool_mm());
    let ik = loaded.scenario.compensation.ik_options();
    let min_q5 = loaded.scenario.poses.min_abs_q5_deg.to_radians();
    let max_cond = loaded.scenario.poses.max_condition.unwrap_or(f64::INFINITY);
    let solve = |p: &[f64; 3]| -> Option<Vec<f64>> {
        let target = IkTarget {
            point_in_flange_mm: nominal.tool_mm(),
            position_mm: Vector3::from(*p),
            rotation: reference.rot,
        };
        let mut q = q_ref.clone();
        nominal.solve_ik(&target, &mut q, &ik).ok()?;
        let ok = q.get(4).is_none_or(|q5| q5.abs() >= min_q5)
            && nominal.singularity_condition(&q, 1000.0) <= max_cond
            && tracker.check_visible(&Vector3::from(*p)).is_ok();
        ok.then_some(q)
    };
    let h = iso.centre_half_count as i64;
    let mut centres = Vec::new();
    for i in -h..=h {
        for j in -h..=h {
            for k in -h..=h {
                let s = iso.centre_step_mm;
                centres.push([
                    p_ref.x + s * i as f64,
                    p_ref.y + s * j as f64,
                    p_ref.z + s * k as f64,
                ]);
            }
        }
    }
    // Nearest centres first, so ties go to the cube closest to the reference pose.
    centres.sort_by(|a, b| {
        let d = |c: &[f64; 3]| (Vector3::from(*c) - p_ref).norm_squared();
        d(a).total_cmp(&d(b))
    });
    let cube = evaluate::largest_cube(&centres, iso.min_edge_mm, iso.max_edge_mm, |p| {
        solve(p).is_some()
    })
    .map_err(|source| CampaignError::IsoCube { source })?;
    let points = cube.test_points_mm();
    let mut targets = Vec::with_capacity(5);
    let mut q_cmd = Vec::with_capacity(5);
    for p in &points {
        let q = solve(p).ok_or(CampaignError::IsoUnreachable { point_mm: *p })?;
        targets.push(IkTarget {
            point_in_flange_mm: nominal.tool_mm(),
            position_mm: Vector3::from(*p),
            rotation: reference.rot,
        });
        q_cmd.push(q);
    }
    let targets: [IkTarget; 5] = targets.try_into().expect("five test points");
    let q_cmd_rad: [Vec<f64>; 5] = q_cmd.try_into().expect("five test points");
    Ok(IsoPlan {
        cube,
        targets,
        q_cmd_rad,
    })
}

/// The ISO 9283 position test of one trial; also returns how many of P1–P5 the identified
/// model could not reach (commanded uncompensated instead, and counted).
pub(super) fn iso_trial(
    plan: &IsoPlan,
    (identified, model): (&Robot, Option<&calibrate::residual::ResidualModel>),
    world: &mut World,
    scenario: &crate::scenario::Scenario,
    trial: u64,
) -> Result<(IsoReport, usize), CampaignError> {
    thread_local! {
        static BUFFERS: Kept<IsoBuffers> = const { Kept::new() };
    }
    with_kept(&BUFFERS, |b| {
        iso_measure(plan, (identified, model), world, scenario, trial, b)
    })
}

/// [`iso_trial`]'s buffers (compensated joints, attained points), kept by a thread between
/// trials (issue 43: no allocation per trial for the test's series).
#[derive(Default)]
struct IsoBuffers {
    q_after: [Vec<f64>; 5],
    before: [Vec<[f64; 3]>; 5],
    after: [Vec<[f64; 3]>; 5],
}

/// [`iso_trial`] in the buffers `b`.
fn iso_measure(
    plan: &IsoPlan,
    (identified, model): (&Robot, Option<&calibrate::residual::ResidualModel>),
    world: &mut World,
    scenario: &crate::scenario::Scenario,
    trial: u64,
    b: &mut IsoBuffers,
) -> Result<(IsoReport, usize), CampaignError> {
    let ik = scenario.compensation.ik_options();
    // Compensated joints of P1…P5; a target the identified model cannot reach keeps its
    // commanded joints and is counted.
    let mut failures = 0;
    let IsoBuffers {
        q_after,
        before,
        after,
    } = b;
    for ((t, q), qc) in plan
        .targets
        .iter()
        .zip(&plan.q_cmd_rad)
        .zip(q_after.iter_mut())
    {
        qc.clone_from(q);
        let target = IkTarget {
            point_in_flange_mm: identified.tool_mm(),
            ..*t
        };
        // Without compensation the "after" cycles command the same joints.
        let reached = !scenario.compensation.enabled
            || match model {
                None => identified.solve_ik(&target, qc, &ik).is_ok(),
                // The hybrid the gate kept (scenario `residual_model`).
                Some(m) => super::hybrid::compensate(identified, m, &target, qc, &ik),
            };
        if !reached {
            failures += 1;
            qc.clone_from(q);
        }
    }
    let cycles = scenario.iso.cycles;
    for series in before.iter_mut().chain(after.iter_mut()) {
        series.clear();
        series.reserve(cycles);
    }
    for (joints, out) in [
        (&plan.q_cmd_rad[..], &mut *before),
        (&q_after[..], &mut *after),
    ] {
        for _ in 0..cycles {
            for &i in &evaluate::ISO_CYCLE_ORDER {
                let p =
                    world
                        .measure(&joints[i])
                        .map_err(|source| CampaignError::IsoMeasurement {
                            trial,
                            point: i + 1,
                            source,
                        })?;
                out[i].push(p.into());
            }
        }
    }
    let report = IsoReport::from_attained(
        plan.cube,
        [&before[0], &before[1], &before[2], &before[3], &before[4]],
        [&after[0], &after[1], &after[2], &after[3], &after[4]],
    )
    .map_err(|source| CampaignError::Evaluate { trial, source })?;
    Ok((report, failures))
}
