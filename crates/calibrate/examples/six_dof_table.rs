//! The real-data table of `docs/calibrating-real-data.md` ("6-DoF and several targets"):
//! calibration poses 10/15/25/50/100 of the UR10 series B with the T-Mac's orientation
//! (`data/ur10-ipa/series-b-6dof.csv`), identified from the points only, from the full
//! frames (6-DoF), and from three synthetic targets per pose derived from the measured frame
//! (at 120° on a 100 mm circle in the probe's xy plane: `p + R_meas·o_k`); every other pose
//! validates. Medians over 7 random draws of the calibration poses.
//!
//! ```text
//! cargo run -p calibrate --example six_dof_table
//! ```
//!
//! All three fits use the same solver ([`identify::frames`]), the same registration (the
//! base from the position rows) and the same rule for the identifiable set (every geometric
//! parameter a candidate, the confounded ones held), with the default weighting (1/mm,
//! 5 mm per degree).

use calibrate::Weighting;
use calibrate::contamination::next;
use calibrate::tool_frame::{frame_data, start_model};
use identify::frames::{FrameData, FrameModel, FrameRow, fit_frames, select_free};
use kinematics::Robot;
use measurements::{ReadOptions, read_file};
use nalgebra::Vector3;

/// `n` distinct poses of `m` (partial Fisher–Yates), ascending.
fn draw(m: usize, n: usize, seed: u64) -> Vec<usize> {
    let mut idx: Vec<usize> = (0..m).collect();
    let mut s = seed;
    for i in 0..n {
        let j = i + (next(&mut s) % (m - i) as u64) as usize;
        idx.swap(i, j);
    }
    let mut v = idx[..n].to_vec();
    v.sort_unstable();
    v
}

fn points_only(d: &FrameData) -> FrameData {
    let mut d = d.clone();
    for r in &mut d.rows {
        r.rotation = None;
    }
    d
}

/// Three targets per pose at `p + R_meas·o_k`, no orientation.
fn three_targets(d: &FrameData) -> FrameData {
    let offsets: Vec<Vector3<f64>> = [0.0_f64, 120.0, 240.0]
        .iter()
        .map(|a| {
            Vector3::new(
                100.0 * a.to_radians().cos(),
                100.0 * a.to_radians().sin(),
                0.0,
            )
        })
        .collect();
    let mut rows = Vec::new();
    for r in &d.rows {
        let m = r.rotation.expect("6-DoF data");
        for (k, o) in offsets.iter().enumerate() {
            rows.push(FrameRow {
                target: k,
                point_mm: r.point_mm + m * o,
                rotation: None,
                ..r.clone()
            });
        }
    }
    FrameData {
        rows,
        target_names: vec!["T1".into(), "T2".into(), "T3".into()],
        ..d.clone()
    }
}

/// Held-out position errors of the measured point (for targets: of their centroid, which
/// is the probe's origin) and orientation errors, means and max.
fn held_out(model: &FrameModel, val: &FrameData, kind: usize) -> (f64, f64, f64) {
    let n = val.n_poses();
    let mut pos = Vec::with_capacity(n);
    let mut ori = Vec::new();
    let centroid = model.targets_mm.iter().sum::<Vector3<f64>>() / model.targets_mm.len() as f64;
    for r in &val.rows {
        let f = model.robot.flange(val.pose(r.pose));
        let t = if kind == 2 {
            centroid
        } else {
            model.targets_mm[0]
        };
        pos.push((r.point_mm - (f.rot * t + f.pos_mm)).norm());
        if kind == 1
            && let Some(m) = r.rotation
        {
            let e = kinematics::rotation::log_so3(&((f.rot * model.tool_rotation).transpose() * m));
            ori.push(e.norm().to_degrees());
        }
    }
    let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len().max(1) as f64;
    (
        mean(&pos),
        pos.iter().copied().fold(0.0, f64::max),
        if ori.is_empty() { f64::NAN } else { mean(&ori) },
    )
}

fn fit(nominal: &Robot, id: &FrameData) -> Option<FrameModel> {
    let mut sum = vec![Vector3::zeros(); id.n_poses()];
    let mut cnt = vec![0.0; id.n_poses()];
    for r in &id.rows {
        sum[r.pose] += r.point_mm;
        cnt[r.pose] += 1.0;
    }
    let pts: Vec<Vector3<f64>> = sum.iter().zip(&cnt).map(|(s, c)| s / *c).collect();
    let (reg, _) = identify::register_base(nominal, &id.poses_rad, &pts).ok()?;
    let (start, _, _) = start_model(&reg, id);
    let all: Vec<usize> = (0..nominal.n_params()).collect();
    let (free, _) = select_free(&start, id, &all).ok()?;
    fit_frames(&start, id, &free, &identify::LmOptions::default())
        .ok()
        .map(|f| f.model)
}

fn median(mut v: Vec<f64>) -> f64 {
    v.retain(|x| x.is_finite());
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(f64::total_cmp);
    let k = v.len();
    if k % 2 == 1 {
        v[k / 2]
    } else {
        0.5 * (v[k / 2 - 1] + v[k / 2])
    }
}

fn main() {
    let root = concat!(env!("CARGO_MANIFEST_DIR"), "/../..");
    let nominal = Robot::from_file(std::path::Path::new(&format!(
        "{root}/scenarios/robots/ur10.json"
    )))
    .expect("robot");
    let set = read_file(
        std::path::Path::new(&format!("{root}/data/ur10-ipa/series-b-6dof.csv")),
        &ReadOptions::new(6),
    )
    .expect("data");
    let (all, weighting) = frame_data(&set, &Weighting::default());
    let m = all.n_poses();
    let draws = 7;
    println!("weighting: {weighting}; {m} poses; medians of {draws} draws\n");
    println!(
        "| calibration poses | point: mean / max mm | 6-DoF: mean / max mm, orientation mean ° | \
         3 targets: mean / max mm |"
    );
    println!("|---|---|---|---|");
    for n in [10usize, 15, 25, 50, 100] {
        let mut res = vec![(Vec::new(), Vec::new(), Vec::new()); 3];
        for d in 0..draws {
            let sel = draw(m, n, 1000 * n as u64 + d);
            let rest: Vec<usize> = (0..m).filter(|i| sel.binary_search(i).is_err()).collect();
            let (id, val) = (all.subset(&sel), all.subset(&rest));
            let sets = [points_only(&id), id.clone(), three_targets(&id)];
            for (kind, data) in sets.iter().enumerate() {
                let (a, b, c) = fit(&nominal, data).map_or((f64::NAN, f64::NAN, f64::NAN), |mo| {
                    held_out(&mo, &val, kind)
                });
                res[kind].0.push(a);
                res[kind].1.push(b);
                res[kind].2.push(c);
            }
        }
        let f = |v: &Vec<f64>, d: usize| {
            let x = median(v.clone());
            if x.is_finite() {
                format!("{x:.*}", d)
            } else {
                "—".into()
            }
        };
        println!(
            "| {n} | {} / {} | {} / {}, {} | {} / {} |",
            f(&res[0].0, 3),
            f(&res[0].1, 2),
            f(&res[1].0, 3),
            f(&res[1].1, 2),
            f(&res[1].2, 4),
            f(&res[2].0, 3),
            f(&res[2].1, 2),
        );
    }
}
