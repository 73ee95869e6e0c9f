//! The rotation conversions the writers use (`measurements::EulerConvention::KUKA_ABC`,
//! `quaternion_to_rotvec`, `rotvec_to_quaternion`) against SciPy's `Rotation`: the committed
//! fixture `fixtures/rotation_reference.csv`, written by `scripts/rotation_reference.py`
//! (SciPy 1.17.1), always; the script run again and compared, in the ignored test (`.ci/run`
//! runs it in the Python package's venv, which has SciPy).

use std::path::{Path, PathBuf};

use measurements::{EulerConvention, quaternion_to_rotvec, rotvec_to_quaternion};

/// One fixture row.
struct Row {
    label: String,
    q: [f64; 4],
    abc: [f64; 3],
    rotvec: [f64; 3],
}

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn fixture_path() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/rotation_reference.csv")
}

fn rows(text: &str) -> Vec<Row> {
    let mut lines = text.lines();
    assert_eq!(
        lines.next(),
        Some("label,qw,qx,qy,qz,a_deg,b_deg,c_deg,rx,ry,rz")
    );
    lines
        .map(|l| {
            let f: Vec<&str> = l.split(',').collect();
            assert_eq!(f.len(), 11, "{l}");
            let v: Vec<f64> = f[1..].iter().map(|s| s.parse().unwrap()).collect();
            Row {
                label: f[0].to_owned(),
                q: [v[0], v[1], v[2], v[3]],
                abc: [v[4], v[5], v[6]],
                rotvec: [v[7], v[8], v[9]],
            }
        })
        .collect()
}

/// The angle between two rotations given as quaternions, rad (q and −q are one rotation).
pub fn rotation_angle(a: [f64; 4], b: [f64; 4]) -> f64 {
    // ‖a − ±b‖ = 2·sin(θ/4) for unit quaternions: accurate near 0, where 2·acos(a·b) is not.
    let s = if (0..4).map(|k| a[k] * b[k]).sum::<f64>() < 0.0 {
        -1.0
    } else {
        1.0
    };
    let d = (0..4)
        .map(|k| (a[k] - s * b[k]).powi(2))
        .sum::<f64>()
        .sqrt();
    4.0 * (d / 2.0).min(1.0).asin()
}

/// Degrees apart on the circle.
fn angle_diff_deg(a: f64, b: f64) -> f64 {
    let d = (a - b).rem_euclid(360.0);
    d.min(360.0 - d)
}

#[test]
fn conversions_match_scipy() {
    let text = std::fs::read_to_string(fixture_path()).unwrap();
    let rows = rows(&text);
    assert_eq!(rows.len(), 218);
    let kuka = EulerConvention::KUKA_ABC;
    let mut worst = [0.0f64; 4];
    for r in &rows {
        // Quaternion → A, B, C: SciPy's angles (away from gimbal lock, and at it too: the
        // same rule, C = 0), to 1e-9°.
        let abc = kuka.angles_deg(r.q);
        for k in 0..3 {
            let d = angle_diff_deg(abc[k], r.abc[k]);
            worst[0] = worst[0].max(d);
            assert!(d < 1e-7, "{}: {abc:?} vs SciPy {:?}", r.label, r.abc);
        }
        // A, B, C → quaternion: the same rotation.
        let back = kuka.to_quaternion(r.abc);
        let e = rotation_angle(back, r.q);
        worst[1] = worst[1].max(e);
        assert!(e < 1e-12, "{}: {e:e}", r.label);
        // Quaternion → rotation vector: SciPy's, but at a half turn (either sign).
        let v = quaternion_to_rotvec(r.q);
        let d = (0..3)
            .map(|k| (v[k] - r.rotvec[k]).abs())
            .fold(0.0, f64::max);
        let d_flip = (0..3)
            .map(|k| (v[k] + r.rotvec[k]).abs())
            .fold(0.0, f64::max);
        let half_turn = r.q[0].abs() < 1e-12;
        let d = if half_turn { d.min(d_flip) } else { d };
        worst[2] = worst[2].max(d);
        assert!(d < 1e-12, "{}: {v:?} vs SciPy {:?}", r.label, r.rotvec);
        // Rotation vector → quaternion: the same rotation.
        let e = rotation_angle(rotvec_to_quaternion(r.rotvec), r.q);
        worst[3] = worst[3].max(e);
        assert!(e < 1e-12, "{}: {e:e}", r.label);
    }
    println!(
        "worst vs SciPy: ABC {:e}°, from ABC {:e} rad, rotvec {:e}, from rotvec {:e} rad",
        worst[0], worst[1], worst[2], worst[3]
    );
}

/// Every fixture rotation written as a KRL E6POS, a RAPID robtarget and a URScript pose and
/// read back is the same rotation to the printed precision (A, B, C to 1e-4°: at most
/// 3·0.5e-4° apart; a quaternion to 1e-9; a rotation vector to 1e-7 rad).
#[test]
fn fixture_rotations_survive_every_format() {
    let text = std::fs::read_to_string(fixture_path()).unwrap();
    let robot = crate::round_trip::robot("kr1000-titan.json");
    let targets: Vec<controller::Target> = rows(&text)
        .iter()
        .map(|r| controller::Target {
            name: r.label.clone(),
            joints_deg: vec![10.0, 20.0, -30.0, 40.0, 50.0, 60.0],
            position_mm: [1000.0, -200.0, 1500.0],
            orientation_wxyz: Some(r.q),
        })
        .collect();
    let decl = controller::declare(&robot, &targets).unwrap();
    for (format, tol_rad) in [
        (controller::Format::KukaKrl, 2.7e-6),
        (controller::Format::AbbRapid, 3e-9),
        (controller::Format::Urscript, 2e-7),
        (controller::Format::Csv, 3e-9),
    ] {
        let out = controller::write(format, "t", &[], &decl).unwrap();
        let back = controller::read(format, &out, "t").unwrap();
        assert_eq!(back.len(), decl.len());
        for (d, b) in decl.iter().zip(&back) {
            assert_eq!(d.name, b.name);
            let e = rotation_angle(d.orientation_wxyz, b.orientation_wxyz.unwrap());
            assert!(e < tol_rad, "{format} {}: {e:e} rad", d.name);
        }
    }
}

/// The Python environment with SciPy: `$KINCAL_SCIPY_PYTHON`, else `target/py-venv`
/// (`.ci/run`'s Python package venv: scikit-learn brings SciPy).
fn python() -> Option<PathBuf> {
    let p = std::env::var_os("KINCAL_SCIPY_PYTHON")
        .map(PathBuf::from)
        .unwrap_or_else(|| root().join("target/py-venv/bin/python"));
    p.exists().then_some(p)
}

#[test]
#[ignore = "needs SciPy: $KINCAL_SCIPY_PYTHON or target/py-venv (.ci/run runs it)"]
fn fixture_is_what_scipy_computes_now() {
    let py =
        python().expect("no Python with SciPy: set KINCAL_SCIPY_PYTHON or create target/py-venv");
    let dir = std::env::temp_dir().join(format!("kincal-rotation-ref-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let out = dir.join("rotation_reference.csv");
    let status = std::process::Command::new(py)
        .arg(root().join("scripts/rotation_reference.py"))
        .arg(&out)
        .status()
        .unwrap();
    assert!(status.success());
    let (now, committed) = (
        rows(&std::fs::read_to_string(&out).unwrap()),
        rows(&std::fs::read_to_string(fixture_path()).unwrap()),
    );
    std::fs::remove_dir_all(&dir).ok();
    assert_eq!(now.len(), committed.len());
    for (a, b) in now.iter().zip(&committed) {
        assert_eq!(a.label, b.label);
        let close =
            |x: &[f64], y: &[f64], tol: f64| x.iter().zip(y).all(|(u, v)| (u - v).abs() <= tol);
        assert!(
            close(&a.q, &b.q, 1e-12)
                && close(&a.abc, &b.abc, 1e-9)
                && close(&a.rotvec, &b.rotvec, 1e-12),
            "{}: SciPy now differs from the committed fixture",
            a.label
        );
    }
}
