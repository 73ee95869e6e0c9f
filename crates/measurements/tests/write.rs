//! Writer and atomic-write tests; output targets and output sets in `write/output.rs`.

#[path = "write/output.rs"]
mod output;

use std::path::{Path, PathBuf};

use measurements::{
    Measurement, MeasurementError, MeasurementSet, ReadOptions, read_file, read_str, to_csv_string,
    write_all_atomically, write_atomically, write_file,
};

/// A fresh, empty scratch directory for one test.
fn scratch(name: &str) -> PathBuf {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join(format!("measurements-write-{name}"));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn entries(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

fn awkward_set() -> MeasurementSet {
    let awkward = [
        0.1 + 0.2,
        1e-17,
        -0.0,
        f64::MIN_POSITIVE,
        f64::MAX,
        -123.456_789_012_345_67,
        5e-324,
        1.0 / 3.0,
    ];
    let rows = (0..6)
        .map(|i| {
            let q: Vec<f64> = (0..3).map(|j| awkward[(i + j) % awkward.len()]).collect();
            let p = [
                awkward[(i + 3) % 8],
                awkward[(i + 4) % 8],
                awkward[(i + 5) % 8],
            ];
            let m = Measurement::new(q, Some(p));
            if i % 2 == 0 {
                m.with_id(format!("pose {i}"))
            } else {
                m
            }
        })
        .collect();
    MeasurementSet::new("awkward", 3, rows)
}

fn bits(set: &MeasurementSet) -> Vec<u64> {
    set.rows
        .iter()
        .flat_map(|r| r.q_deg.iter().chain(r.point_mm.iter().flatten()))
        .map(|v| v.to_bits())
        .collect()
}

#[test]
fn round_trip_is_bit_exact() {
    let dir = scratch("roundtrip");
    let path = dir.join("out.csv");
    let set = awkward_set();
    write_file(&path, &set, Some("awkward values\n\nsecond line")).unwrap();
    let back = read_file(&path, &ReadOptions::new(3)).unwrap();
    assert_eq!(back.rows.len(), set.rows.len());
    assert_eq!(bits(&back), bits(&set));
    for (a, b) in set.rows.iter().zip(&back.rows) {
        assert_eq!(a.id, b.id);
    }
    // -0.0 keeps its sign.
    assert!(
        back.rows
            .iter()
            .any(|r| r.q_deg.iter().any(|v| v.to_bits() == (-0.0f64).to_bits()))
    );
    // Comment lines (3) + header: first row is on line 5.
    assert_eq!(back.rows[0].line, 5);
    assert!(back.notices.is_empty());

    // Byte-deterministic: writing what was read gives the same bytes.
    let bytes = std::fs::read_to_string(&path).unwrap();
    assert_eq!(
        to_csv_string(&back, Some("awkward values\n\nsecond line")).unwrap(),
        bytes
    );
    assert!(bytes.starts_with("# awkward values\n#\n# second line\nid,q1,q2,q3,x,y,z\n"));
    assert!(bytes.contains("0.30000000000000004"), "{bytes}");
    assert!(!bytes.contains('\r'));
    assert_eq!(entries(&dir), vec!["out.csv"]);
}

#[test]
fn header_shape_follows_the_data() {
    let rows = vec![
        Measurement::new(vec![1.5, -2.0], None),
        Measurement::new(vec![0.1 + 0.2, 1e-17], None),
    ];
    let set = MeasurementSet::new("j", 2, rows);
    let text = to_csv_string(&set, None).unwrap();
    assert_eq!(
        text,
        "q1,q2\n1.5,-2\n0.30000000000000004,0.00000000000000001\n"
    );
    let back = read_str(&text, "j", &ReadOptions::new(2).joints_only()).unwrap();
    assert_eq!(bits(&back), bits(&set));

    let set = MeasurementSet::new(
        "p",
        1,
        vec![Measurement::new(vec![-0.0], Some([1.0, 2.0, 3.0])).with_id("a")],
    );
    assert_eq!(
        to_csv_string(&set, None).unwrap(),
        "id,q1,x,y,z\na,-0,1,2,3\n"
    );
}

#[test]
fn unwritable_sets_are_rejected() {
    let good = || Measurement::new(vec![1.0, 2.0], Some([1.0, 2.0, 3.0]));
    let cases: Vec<(Vec<Measurement>, &str)> = vec![
        (
            vec![good(), Measurement::new(vec![1.0], Some([1.0, 2.0, 3.0]))],
            "1 joint values",
        ),
        (
            vec![good(), Measurement::new(vec![1.0, 2.0], None)],
            "some rows have a measured point",
        ),
        (
            vec![
                good(),
                Measurement::new(vec![1.0, f64::NAN], Some([1.0, 2.0, 3.0])),
            ],
            "column \"q2\" is NaN",
        ),
        (
            vec![
                good(),
                Measurement::new(vec![1.0, 2.0], Some([1.0, f64::INFINITY, 3.0])),
            ],
            "column \"y\" is inf",
        ),
        (vec![good(), good().with_id("a,b")], "comma"),
        (vec![good(), good().with_id("#1")], "comment"),
        (vec![good(), good().with_id(" a")], "whitespace"),
        (vec![good(), good().with_id("")], "empty"),
        (vec![good(), good().with_id("a\nb")], "control"),
    ];
    let dir = scratch("unwritable");
    let path = dir.join("bad.csv");
    for (rows, why) in cases {
        let set = MeasurementSet::new("label", 2, rows);
        let err = to_csv_string(&set, None).unwrap_err();
        assert!(
            matches!(err, MeasurementError::Unwritable { row: 2, .. }),
            "{err:?}"
        );
        let msg = err.to_string();
        assert!(msg.starts_with("label: cannot write row 2: "), "{msg}");
        assert!(msg.contains(why), "{msg} lacks {why}");
        // write_file names the target and writes nothing.
        let err = write_file(&path, &set, None).unwrap_err();
        assert!(
            err.to_string()
                .starts_with(&format!("{}: ", path.display())),
            "{err}"
        );
        assert!(entries(&dir).is_empty());
    }
}

#[test]
fn write_into_missing_directory_fails_and_leaves_nothing() {
    let dir = scratch("missing-dir");
    let path = dir.join("no-such-dir").join("out.csv");
    let err = write_file(&path, &awkward_set(), None).unwrap_err();
    match &err {
        MeasurementError::Io { source, .. } => {
            assert_eq!(source.kind(), std::io::ErrorKind::NotFound)
        }
        other => panic!("{other:?}"),
    }
    assert!(
        err.to_string()
            .starts_with(&format!("{}: ", path.display())),
        "{err}"
    );
    assert!(entries(&dir).is_empty());

    let err = write_atomically(&path, b"x").unwrap_err();
    assert_eq!(err.kind(), std::io::ErrorKind::NotFound);
    assert!(
        err.to_string().contains(&path.display().to_string()),
        "{err}"
    );
    assert!(entries(&dir).is_empty());
}

#[test]
fn failed_rename_removes_the_temp_file() {
    // The target is an existing non-empty directory: the temp file is created and written,
    // the rename fails, and the temp file must be gone afterwards.
    let dir = scratch("rename-fails");
    let target = dir.join("out.csv");
    std::fs::create_dir(&target).unwrap();
    std::fs::write(target.join("keep"), b"keep").unwrap();
    let err = write_atomically(&target, b"new contents").unwrap_err();
    assert!(err.to_string().contains("out.csv"), "{err}");
    assert_eq!(entries(&dir), vec!["out.csv"]);
    assert_eq!(std::fs::read(target.join("keep")).unwrap(), b"keep");
}

#[test]
fn write_atomically_replaces_an_existing_file() {
    let dir = scratch("replace");
    let path = dir.join("report.json");
    std::fs::write(&path, b"old contents that are longer than the new ones").unwrap();
    write_atomically(&path, b"new").unwrap();
    assert_eq!(std::fs::read(&path).unwrap(), b"new");
    write_atomically(&path, b"").unwrap();
    assert_eq!(std::fs::read(&path).unwrap(), b"");
    assert_eq!(entries(&dir), vec!["report.json"]);
}

#[test]
fn write_atomically_relative_path_without_directory() {
    // A bare file name is written in the current directory (the package root under cargo test);
    // use a unique name and clean up.
    let name = format!("measurements-test-{}.tmp-out", std::process::id());
    write_atomically(Path::new(&name), b"ok").unwrap();
    assert_eq!(std::fs::read(&name).unwrap(), b"ok");
    std::fs::remove_file(&name).unwrap();
}

#[test]
fn write_atomically_rejects_a_path_without_file_name() {
    let err = write_atomically(Path::new("/"), b"x").unwrap_err();
    assert_eq!(err.kind(), std::io::ErrorKind::InvalidInput);
}

/// A set of outputs is written all or nothing: when one file cannot be written, none of the
/// others replaces its previous version and no temporary file is left.
#[test]
fn write_all_atomically_writes_all_or_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("a.txt"), "old a").unwrap();
    // The second file's directory does not exist: its write fails after the first is staged.
    let files = [
        ("a.txt", "new a"),
        ("missing/b.txt", "new b"),
        ("c.txt", "new c"),
    ];
    let err = write_all_atomically(d, &files).unwrap_err();
    assert!(err.to_string().contains("missing/b.txt"), "{err}");
    assert_eq!(std::fs::read_to_string(d.join("a.txt")).unwrap(), "old a");
    assert!(!d.join("c.txt").exists());
    let names: Vec<String> = std::fs::read_dir(d)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    assert_eq!(names, ["a.txt"], "temporaries left behind");
    // And when every write succeeds, every file is replaced.
    write_all_atomically(d, &[("a.txt", "new a"), ("c.txt", "new c")]).unwrap();
    assert_eq!(std::fs::read_to_string(d.join("a.txt")).unwrap(), "new a");
    assert_eq!(std::fs::read_to_string(d.join("c.txt")).unwrap(), "new c");
}

/// The optional columns of issue 31: written when present, byte-deterministic, exact.
mod six_dof_and_targets {
    use measurements::{
        EulerConvention, Measurement, MeasurementError, MeasurementSet, ReadOptions, read_str,
        to_csv_string,
    };
    use proptest::prelude::*;

    fn row(q: f64) -> Measurement {
        Measurement::new(vec![q, 2.0], Some([1.0, 2.0, 3.0]))
    }

    #[test]
    fn header_order_and_bytes() {
        let h = 0.5f64.sqrt();
        let rows = vec![
            row(1.0)
                .with_id("p1")
                .with_target("A")
                .with_orientation([h, 0.0, 0.0, -h])
                .with_sigma_mm([0.01, 0.02, 0.03])
                .with_sigma_deg([0.001, 0.002, 0.003]),
            row(1.0)
                .with_id("p1")
                .with_target("B")
                .with_orientation([1.0, 0.0, 0.0, -0.0])
                .with_sigma_mm([0.01, 0.02, 0.03])
                .with_sigma_deg([0.001, 0.002, 0.003]),
        ];
        let set = MeasurementSet::new("s", 2, rows);
        let text = to_csv_string(&set, Some("two targets")).unwrap();
        assert_eq!(
            text,
            "# two targets\n\
             id,target,q1,q2,x,y,z,qw,qx,qy,qz,sx,sy,sz,srx,sry,srz\n\
             p1,A,1,2,1,2,3,0.7071067811865476,0,0,-0.7071067811865476,0.01,0.02,0.03,0.001,0.002,0.003\n\
             p1,B,1,2,1,2,3,1,0,0,-0,0.01,0.02,0.03,0.001,0.002,0.003\n"
        );
        let back = read_str(&text, "s", &ReadOptions::new(2)).unwrap();
        for (a, b) in set.rows.iter().zip(&back.rows) {
            assert_eq!(
                Measurement {
                    line: 0,
                    ..b.clone()
                },
                *a
            );
        }
        assert_eq!(back.poses(), vec![vec![0, 1]]);
    }

    /// Euler input is written as the quaternion it was converted to. The columns are the
    /// sequence's angles in order: with `ZYX`, `rz` is the third angle, about x.
    #[test]
    fn euler_input_is_written_as_quaternions() {
        let text = "q1,x,y,z,rx,ry,rz,srx,sry,srz\n1,2,3,4,0,0,90,1,1,1\n";
        let opts = ReadOptions::new(1).with_euler("ZYX".parse::<EulerConvention>().unwrap());
        let set = read_str(text, "e", &opts).unwrap();
        let out = to_csv_string(&set, None).unwrap();
        assert!(
            out.starts_with("q1,x,y,z,qw,qx,qy,qz,srx,sry,srz\n1,2,3,4,0.7071067811865476,0.7071067811865475,0,0,1,1,1\n"),
            "{out}"
        );
        let back = read_str(&out, "e", &ReadOptions::new(1)).unwrap();
        assert_eq!(back.rows[0].orientation, set.rows[0].orientation);
    }

    #[test]
    fn unwritable_new_fields() {
        let t = |q: f64, id: &str, target: &str| row(q).with_id(id).with_target(target);
        let cases: Vec<(Vec<Measurement>, &str)> = vec![
            (
                vec![row(1.0), row(1.0).with_target("A")],
                "some rows have a target",
            ),
            (
                vec![row(1.0), row(1.0).with_orientation([1.0, 0.0, 0.0, 0.0])],
                "some rows have an orientation",
            ),
            (
                vec![row(1.0).with_sigma_mm([1.0; 3]), row(1.0)],
                "some rows have sigma_mm",
            ),
            (
                vec![row(1.0), row(1.0).with_sigma_mm([1.0, 0.0, 1.0])],
                "some rows have sigma_mm",
            ),
            (
                vec![
                    row(1.0).with_sigma_mm([1.0; 3]),
                    row(1.0).with_sigma_mm([1.0, 0.0, 1.0]),
                ],
                "column \"sy\": standard deviation 0 is not positive",
            ),
            (
                vec![
                    row(1.0).with_orientation([1.0, 0.0, 0.0, 0.0]),
                    row(1.0).with_orientation([1.0, 0.0, 0.1, 0.0]),
                ],
                "norm",
            ),
            (
                vec![
                    row(1.0).with_orientation([1.0, 0.0, 0.0, 0.0]),
                    row(1.0).with_orientation([1.0, f64::NAN, 0.0, 0.0]),
                ],
                "column \"qx\" is NaN",
            ),
            (
                vec![t(1.0, "a", "A"), t(1.0, "b", "A b")],
                "not a simple name",
            ),
            (
                vec![t(1.0, "a", "A"), row(1.0).with_target("B")],
                "needs an id",
            ),
            (
                vec![t(1.0, "a", "A"), t(1.5, "a", "B")],
                "q1 is 1.5 here but 1 in row 1",
            ),
            (
                vec![t(1.0, "a", "A"), t(1.0, "a", "A")],
                "appears twice in pose \"a\"",
            ),
            (
                vec![t(1.0, "a", "A"), t(1.0, "b", "a")],
                "only in letter case",
            ),
        ];
        for (rows, why) in cases {
            let set = MeasurementSet::new("label", 2, rows);
            let err = to_csv_string(&set, None).unwrap_err();
            assert!(
                matches!(err, MeasurementError::Unwritable { row: 2, .. }),
                "{why}: {err:?}"
            );
            assert!(err.to_string().contains(why), "{err} lacks {why}");
        }
        // Standard deviations without their values.
        let set = MeasurementSet::new(
            "label",
            2,
            vec![Measurement::new(vec![1.0, 2.0], None).with_sigma_mm([1.0; 3])],
        );
        let err = to_csv_string(&set, None).unwrap_err();
        assert!(err.to_string().contains("without a point"), "{err}");
        let set = MeasurementSet::new("label", 2, vec![row(1.0).with_sigma_deg([1.0; 3])]);
        let err = to_csv_string(&set, None).unwrap_err();
        assert!(err.to_string().contains("without an orientation"), "{err}");
    }

    /// Any finite value, awkward ones often.
    fn value() -> impl Strategy<Value = f64> {
        prop_oneof![
            any::<f64>().prop_filter("finite", |v| v.is_finite()),
            -1e3..1e3f64,
            Just(-0.0),
            Just(0.1 + 0.2),
            Just(5e-324),
        ]
    }

    fn positive() -> impl Strategy<Value = f64> {
        prop_oneof![
            any::<f64>().prop_filter("positive finite", |v| v.is_finite() && *v > 0.0),
            1e-6..1.0f64,
            Just(f64::MIN_POSITIVE),
        ]
    }

    /// A unit quaternion from Euler angles, sometimes sign-flipped (both signs are kept).
    fn quaternion() -> impl Strategy<Value = [f64; 4]> {
        (
            -180.0..180.0f64,
            -180.0..180.0f64,
            -180.0..180.0f64,
            any::<bool>(),
        )
            .prop_map(|(a, b, c, flip)| {
                let q = "ZYZ"
                    .parse::<EulerConvention>()
                    .unwrap()
                    .to_quaternion([a, b, c]);
                if flip { q.map(|v| -v) } else { q }
            })
    }

    /// Which optional groups a set has: (id, target, points, orientation, sigma_mm, sigma_deg).
    fn set() -> impl Strategy<Value = MeasurementSet> {
        let flags = (
            any::<bool>(),
            any::<bool>(),
            any::<bool>(),
            any::<bool>(),
            any::<bool>(),
            any::<bool>(),
        );
        (flags, 1usize..4, 1usize..8).prop_flat_map(|((id, target, pts, ori, smm, sdeg), n, k)| {
            let pts = pts || smm;
            let ori = ori || sdeg;
            let id = id || target;
            let one = (
                prop::collection::vec(value(), n),
                prop::array::uniform3(value()),
                quaternion(),
                prop::array::uniform3(positive()),
                prop::array::uniform3(positive()),
                0usize..3,
                0usize..3,
            );
            prop::collection::vec(one, k).prop_map(move |rows| {
                let mut out: Vec<Measurement> = Vec::new();
                for (i, (q, p, o, s1, s2, pose, tgt)) in rows.into_iter().enumerate() {
                    let mut m = Measurement::new(q, pts.then_some(p));
                    if ori {
                        m = m.with_orientation(o);
                    }
                    if smm {
                        m = m.with_sigma_mm(s1);
                    }
                    if sdeg {
                        m = m.with_sigma_deg(s2);
                    }
                    if target {
                        // Pose `pose` takes the joints of its first row; a target at most
                        // once per pose.
                        let pid = format!("p{pose}");
                        let earlier: Vec<&Measurement> = out
                            .iter()
                            .filter(|r| r.id.as_deref() == Some(&pid))
                            .collect();
                        if let Some(first) = earlier.first() {
                            m.q_deg = first.q_deg.clone();
                        }
                        let name = (0..)
                            .map(|t| format!("T{}", (tgt + t) % 9))
                            .find(|name| earlier.iter().all(|r| r.target.as_deref() != Some(name)))
                            .unwrap();
                        m = m.with_id(pid).with_target(name);
                    } else if id && i % 2 == 0 {
                        m = m.with_id(format!("r{i}"));
                    }
                    out.push(m);
                }
                MeasurementSet::new("prop", n, out)
            })
        })
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(256))]

        /// Written, read back: the same rows to the bit, and writing again gives the same bytes.
        #[test]
        fn round_trip_is_exact(set in set()) {
            let text = to_csv_string(&set, Some("prop")).unwrap();
            let opts = if set.has_points() {
                ReadOptions::new(set.n_joints)
            } else {
                ReadOptions::new(set.n_joints).joints_only()
            };
            let back = read_str(&text, "prop", &opts).unwrap();
            prop_assert_eq!(back.rows.len(), set.rows.len());
            for (a, b) in set.rows.iter().zip(&back.rows) {
                let bits = |m: &Measurement| -> Vec<u64> {
                    m.q_deg
                        .iter()
                        .chain(m.point_mm.iter().flatten())
                        .chain(m.orientation.iter().flatten())
                        .chain(m.sigma_mm.iter().flatten())
                        .chain(m.sigma_deg.iter().flatten())
                        .map(|v| v.to_bits())
                        .collect()
                };
                prop_assert_eq!(bits(a), bits(b));
                prop_assert_eq!(&a.id, &b.id);
                prop_assert_eq!(&a.target, &b.target);
                prop_assert_eq!(a.point_mm.is_some(), b.point_mm.is_some());
                prop_assert_eq!(a.orientation.is_some(), b.orientation.is_some());
                prop_assert_eq!(a.sigma_mm.is_some(), b.sigma_mm.is_some());
                prop_assert_eq!(a.sigma_deg.is_some(), b.sigma_deg.is_some());
            }
            prop_assert_eq!(back.poses(), set.poses());
            prop_assert_eq!(to_csv_string(&back, Some("prop")).unwrap(), text);
        }
    }
}

/// A temporary left by a killed writer of the same file (`.NAME.PID.N.tmp`, its process
/// gone) is removed by the next write of that file; a live writer's temporary and another
/// file's temporary are kept (issue 39).
#[test]
fn a_dead_writers_temporary_is_removed_by_the_next_write() {
    let dir = scratch("dead-temporary");
    // No process has a pid above the kernel's limit (at most 2^22).
    let dead = ".predicted.csv.99999999.0.tmp";
    let live = format!(".predicted.csv.{}.999.tmp", std::process::id());
    let other = ".other.csv.99999999.0.tmp";
    let longer = ".predicted.csv.x.99999999.0.tmp";
    for f in [dead, live.as_str(), other, longer] {
        std::fs::write(dir.join(f), "partial").unwrap();
    }
    write_atomically(&dir.join("predicted.csv"), b"x,y,z\n").unwrap();
    let mut want = vec![
        live.clone(),
        longer.to_string(),
        other.to_string(),
        "predicted.csv".to_string(),
    ];
    want.sort();
    assert_eq!(entries(&dir), want);
}

/// A 240-character output name: the single-file write and the output directory's helper
/// files (lock, staged set) stay within the 255-byte file-name limit (issue 39: "File name
/// too long" from the hidden staging name); two long names sharing their first 200
/// characters do not share helper files.
#[test]
fn long_output_names_stay_within_the_file_name_limit() {
    let dir = scratch("long-names");
    let name = format!("{}.csv", "n".repeat(236));
    assert_eq!(name.len(), 240);
    write_atomically(&dir.join(&name), b"q1\n1\n").unwrap();
    assert_eq!(std::fs::read(dir.join(&name)).unwrap(), b"q1\n1\n");
    let a = dir.join(format!("{}a", "d".repeat(239)));
    let b = dir.join(format!("{}b", "d".repeat(239)));
    let held_a = measurements::OutputDir::lock(&a).unwrap();
    let held_b = measurements::OutputDir::lock(&b).unwrap();
    held_a.write_set(&[("summary.json", "{}\n")]).unwrap();
    held_b.write_set(&[("summary.json", "[]\n")]).unwrap();
    drop((held_a, held_b));
    assert_eq!(std::fs::read(a.join("summary.json")).unwrap(), b"{}\n");
    assert_eq!(std::fs::read(b.join("summary.json")).unwrap(), b"[]\n");
    for e in entries(&dir) {
        assert!(e.len() <= 255, "{e}");
    }
}
