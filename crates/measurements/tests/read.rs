//! Reader tests: one per malformed case, plus the accepted variations of the format.

use std::path::PathBuf;

use measurements::{MeasurementError, ReadOptions, read_file, read_str};

const HEADER6: &str = "q1,q2,q3,q4,q5,q6,x,y,z";
const ROW6: &str = "1,2,3,4,5,6,100,200,300";

fn opts6() -> ReadOptions {
    ReadOptions::new(6)
}

/// A fresh, empty scratch directory for one test.
fn scratch(name: &str) -> PathBuf {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join(format!("measurements-read-{name}"));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// The message names the file, the line (`file:line:`) and the column (`column "c"`).
#[track_caller]
fn assert_names(err: &MeasurementError, file: &str, line: usize, column: &str) {
    let msg = err.to_string();
    assert!(
        msg.starts_with(&format!("{file}:{line}: ")),
        "message does not start with {file}:{line}: -- {msg}"
    );
    assert!(
        msg.contains(&format!("column \"{column}\"")),
        "message does not name column {column}: {msg}"
    );
    assert_eq!(err.file(), file);
    assert_eq!(err.line(), Some(line));
    assert_eq!(err.column(), Some(column));
}

#[test]
fn io_error_names_the_file() {
    let dir = scratch("io");
    let path = dir.join("does-not-exist.csv");
    let err = read_file(&path, &opts6()).unwrap_err();
    assert!(matches!(err, MeasurementError::Io { .. }), "{err:?}");
    assert!(
        err.to_string()
            .starts_with(&format!("{}: ", path.display())),
        "{err}"
    );
}

#[test]
fn empty_file_and_comment_only_file_have_no_header() {
    for text in ["", "\n\n", "\u{feff}", "# only\n   # comments\n\r\n  \n"] {
        let err = read_str(text, "empty.csv", &opts6()).unwrap_err();
        assert!(matches!(err, MeasurementError::NoHeader { .. }), "{err:?}");
        assert!(err.to_string().starts_with("empty.csv: "), "{err}");
        assert!(err.to_string().contains("no header"), "{err}");
    }
}

#[test]
fn missing_point_column_is_named_on_the_header_line() {
    let text = "# comment\n\nq1,q2,q3,q4,q5,q6,x,y\n1,2,3,4,5,6,7,8\n";
    let err = read_str(text, "m.csv", &opts6()).unwrap_err();
    assert!(
        matches!(err, MeasurementError::MissingColumn { .. }),
        "{err:?}"
    );
    assert_names(&err, "m.csv", 3, "z");
    assert_eq!(err.to_string(), "m.csv:3: missing required column \"z\"");
}

#[test]
fn missing_joint_in_the_middle_is_a_missing_column() {
    let text = "q1,q2,q4,q5,q6,x,y,z\n";
    let err = read_str(text, "m.csv", &opts6()).unwrap_err();
    assert!(
        matches!(err, MeasurementError::MissingColumn { .. }),
        "{err:?}"
    );
    assert_names(&err, "m.csv", 1, "q3");
}

#[test]
fn header_names_are_case_sensitive() {
    let text = "q1,q2,q3,q4,q5,q6,X,y,z\n";
    let err = read_str(text, "case.csv", &opts6()).unwrap_err();
    assert!(
        matches!(err, MeasurementError::HeaderCase { .. }),
        "{err:?}"
    );
    // The name as written, at its column, and the name expected.
    assert!(
        err.to_string()
            .starts_with("case.csv:1:19: column \"X\": column names are lower-case"),
        "{err}"
    );
    assert!(err.to_string().contains("write \"x\""), "{err}");
    // In the joints-only form the upper-case column is merely ignored, with a hint.
    let text = "Q1,q1,q2,q3,q4,q5,q6\n1,2,3,4,5,6,7\n";
    let set = read_str(text, "case.csv", &opts6().joints_only()).unwrap();
    assert_eq!(set.rows[0].q_deg, vec![2.0, 3.0, 4.0, 5.0, 6.0, 7.0]);
    assert_eq!(
        set.notices,
        vec![
            "case.csv:1: ignored unknown column \"Q1\" (column names are case-sensitive, lower-case)"
        ]
    );
}

#[test]
fn duplicate_column() {
    let text = "# c\nq1,q2,q3,x,q4,q5,q6, x ,y,z\n";
    let err = read_str(text, "d.csv", &opts6()).unwrap_err();
    match &err {
        MeasurementError::DuplicateColumn {
            first_field,
            second_field,
            ..
        } => assert_eq!((*first_field, *second_field), (4, 8)),
        other => panic!("{other:?}"),
    }
    assert_names(&err, "d.csv", 2, "x");
}

#[test]
fn non_number_names_file_line_and_column() {
    // Header on line 3; comments and blank lines in between still count: the bad row is line 17.
    let mut text = String::from("# a\n\nq1,q2,q3,q4,q5,q6,x,y,z\n");
    for line in 4..=16 {
        if line % 4 == 0 {
            text.push_str("  # interleaved comment\n");
        } else if line % 5 == 0 {
            text.push('\n');
        } else {
            text.push_str(ROW6);
            text.push('\n');
        }
    }
    text.push_str("1,2,abc,4,5,6,7,8,9\n");
    text.push_str(ROW6);
    let err = read_str(&text, "data.csv", &opts6()).unwrap_err();
    assert!(
        matches!(err, MeasurementError::NotANumber { .. }),
        "{err:?}"
    );
    assert_names(&err, "data.csv", 17, "q3");
    assert_eq!(
        err.to_string(),
        "data.csv:17: column \"q3\": \"abc\" is not a number"
    );
}

#[test]
fn empty_field_is_not_a_number() {
    let text = format!("{HEADER6}\n1,2,3,4,5,6,7, ,9\n");
    let err = read_str(&text, "e.csv", &opts6()).unwrap_err();
    assert!(
        matches!(err, MeasurementError::NotANumber { .. }),
        "{err:?}"
    );
    assert_names(&err, "e.csv", 2, "y");
}

#[test]
fn nan_and_infinity_are_rejected() {
    for bad in [
        "NaN",
        "nan",
        "inf",
        "-inf",
        "+inf",
        "infinity",
        "-Infinity",
        "1e999",
    ] {
        let text = format!("{HEADER6}\n{ROW6}\n1,2,3,4,5,{bad},7,8,9\n");
        let err = read_str(&text, "nan.csv", &opts6()).unwrap_err();
        assert!(
            matches!(err, MeasurementError::NonFinite { .. }),
            "{bad}: {err:?}"
        );
        assert_names(&err, "nan.csv", 3, "q6");
        assert!(err.to_string().contains(&format!("\"{bad}\"")), "{err}");
    }
}

#[test]
fn ragged_rows_say_expected_and_found() {
    let short = format!("{HEADER6}\n{ROW6}\n1,2,3,4,5,6,7,8\n");
    let err = read_str(&short, "r.csv", &opts6()).unwrap_err();
    match &err {
        MeasurementError::RaggedRow {
            expected, found, ..
        } => assert_eq!((*expected, *found), (9, 8)),
        other => panic!("{other:?}"),
    }
    assert_names(&err, "r.csv", 3, "z");
    assert!(
        err.to_string()
            .contains("row has 8 field(s) but the header has 9"),
        "{err}"
    );

    let long = format!("{HEADER6}\n{ROW6},\n");
    let err = read_str(&long, "r.csv", &opts6()).unwrap_err();
    match &err {
        MeasurementError::RaggedRow {
            expected, found, ..
        } => assert_eq!((*expected, *found), (9, 10)),
        other => panic!("{other:?}"),
    }
    assert!(err.to_string().starts_with("r.csv:2: "), "{err}");
    assert_eq!(err.line(), Some(2));
}

#[test]
fn joint_outside_limits_gives_value_and_limits() {
    let limits = vec![
        [-150.0, 150.0],
        [-40.0, 107.5],
        [-200.0, 55.0],
        [-350.0, 350.0],
        [-118.0, 118.0],
        [-350.0, 350.0],
    ];
    let opts = opts6().with_limits_deg(limits);
    // Limits are inclusive.
    let ok = format!("{HEADER6}\n150,107.5,-200,4,5,6,7,8,9\n");
    read_str(&ok, "l.csv", &opts).unwrap();
    let text = format!("{HEADER6}\n{ROW6}\n1,107.50001,3,4,5,6,7,8,9\n");
    let err = read_str(&text, "l.csv", &opts).unwrap_err();
    match &err {
        MeasurementError::JointOutOfLimits {
            value,
            min,
            max,
            unit,
            ..
        } => assert_eq!(
            (*value, *min, *max, *unit),
            (107.50001, -40.0, 107.5, "deg")
        ),
        other => panic!("{other:?}"),
    }
    assert_names(&err, "l.csv", 3, "q2");
    assert!(err.to_string().contains("107.50001"), "{err}");
    assert!(err.to_string().contains("[-40, 107.5]"), "{err}");
}

#[test]
fn too_few_rows_says_found_needed_and_why() {
    let text = format!("{HEADER6}\n{ROW6}\n{ROW6}\n");
    let opts = opts6().with_min_rows(3);
    let err = read_str(&text, "few.csv", &opts).unwrap_err();
    match &err {
        MeasurementError::TooFewRows { found, needed, .. } => assert_eq!((*found, *needed), (2, 3)),
        other => panic!("{other:?}"),
    }
    assert_eq!(
        err.to_string(),
        "few.csv: 2 data row(s), but at least 3 are needed (fewer rows than the free parameters need)"
    );
    let text = format!("{text}{ROW6}\n");
    assert_eq!(read_str(&text, "few.csv", &opts).unwrap().rows.len(), 3);
}

#[test]
fn extra_joint_column_is_a_joint_count_mismatch() {
    let text = "# seven joints\nq1,q2,q3,q4,q5,q6,q7,x,y,z,temp\n";
    let err = read_str(text, "j.csv", &opts6()).unwrap_err();
    match &err {
        MeasurementError::JointCountMismatch {
            expected, found, ..
        } => {
            assert_eq!(*expected, 6);
            assert_eq!(found.len(), 7);
        }
        other => panic!("{other:?}"),
    }
    assert_names(&err, "j.csv", 2, "q7");
    assert_eq!(
        err.to_string(),
        "j.csv:2: column \"q7\": the header has 7 joint column(s) (q1..q7) but 6 joints are expected (q1..q6)"
    );
}

#[test]
fn too_few_joint_columns_is_a_joint_count_mismatch() {
    let text = "q1,q2,q3,q4,q5,x,y,z\n1,2,3,4,5,6,7,8\n";
    let err = read_str(text, "j.csv", &opts6()).unwrap_err();
    assert!(
        matches!(
            err,
            MeasurementError::JointCountMismatch { expected: 6, .. }
        ),
        "{err:?}"
    );
    assert_names(&err, "j.csv", 1, "q6");
    assert!(
        err.to_string().contains("5 joint column(s) (q1..q5)"),
        "{err}"
    );
}

#[test]
fn zero_based_or_padded_joint_names_are_a_joint_count_mismatch() {
    for (header, bad) in [
        ("q0,q1,q2,q3,q4,q5,x,y,z", "q0"),
        ("q01,q2,q3,q4,q5,q6,x,y,z", "q01"),
    ] {
        let err = read_str(header, "j.csv", &opts6()).unwrap_err();
        assert!(
            matches!(err, MeasurementError::JointCountMismatch { .. }),
            "{err:?}"
        );
        assert_names(&err, "j.csv", 1, bad);
    }
}

#[test]
fn invalid_utf8_names_the_line() {
    let dir = scratch("utf8");
    let path = dir.join("latin1.csv");
    let mut bytes = format!("{HEADER6}\n{ROW6}\n").into_bytes();
    bytes.extend_from_slice(b"# caf\xe9\n");
    std::fs::write(&path, bytes).unwrap();
    let err = read_file(&path, &opts6()).unwrap_err();
    assert!(matches!(err, MeasurementError::NotUtf8 { .. }), "{err:?}");
    assert!(
        err.to_string()
            .starts_with(&format!("{}:3: ", path.display())),
        "{err}"
    );
}

#[test]
fn invalid_options_are_reported() {
    let text = format!("{HEADER6}\n{ROW6}\n");
    for opts in [
        // No joints and no points required: a file of nothing (no joints with points
        // required is a file of poses, Cartesian targets).
        ReadOptions::new(0).joints_only(),
        opts6().with_limits_deg(vec![[-1.0, 1.0]; 5]),
        opts6().with_limits_deg(vec![[1.0, -1.0]; 6]),
    ] {
        let err = read_str(&text, "o.csv", &opts).unwrap_err();
        assert!(
            matches!(err, MeasurementError::InvalidOptions { .. }),
            "{err:?}"
        );
        assert!(err.to_string().starts_with("o.csv: "), "{err}");
    }
}

#[test]
fn crlf_bom_extra_columns_comments_any_order_and_whitespace() {
    let text = "\u{feff}# exported by SpatialAnalyzer\r\n\
                \r\n\
                \u{20}  # indented comment\r\n\
                 z , temp_C,q6,q5,q4,q3,q2,q1, id ,x,y,\r\n\
                3.5,21.9,6,5,4,3,2,1,pose-1,1.5,2.5,\r\n\
                # comment between rows\r\n\
                \r\n\
                -0.25 ,22.0, -6,-5,-4,-3,-2, -1 ,  ,1e-3,+2,\r\n";
    let set = read_str(text, "crlf.csv", &opts6()).unwrap();
    assert_eq!(set.source, "crlf.csv");
    assert_eq!(set.n_joints, 6);
    assert_eq!(set.rows.len(), 2);
    let a = &set.rows[0];
    assert_eq!(a.line, 5);
    assert_eq!(a.id.as_deref(), Some("pose-1"));
    assert_eq!(a.q_deg, vec![1.0, 2.0, 3.0, 4.0, 5.0, 6.0]);
    assert_eq!(a.point_mm, Some([1.5, 2.5, 3.5]));
    let b = &set.rows[1];
    assert_eq!(b.line, 8);
    assert_eq!(b.id, None);
    assert_eq!(b.q_deg, vec![-1.0, -2.0, -3.0, -4.0, -5.0, -6.0]);
    assert_eq!(b.point_mm, Some([0.001, 2.0, -0.25]));
    assert_eq!(
        set.notices,
        vec![
            "crlf.csv:4: ignored unknown column \"temp_C\"".to_owned(),
            "crlf.csv:4: ignored unnamed column (header field 12)".to_owned(),
        ]
    );
}

#[test]
fn bom_and_crlf_line_numbers_in_errors_from_a_file() {
    let dir = scratch("bom-file");
    let path = dir.join("bom.csv");
    let text = format!("\u{feff}# c\r\n{HEADER6}\r\n{ROW6}\r\n\r\n1,2,3,4,5,6,7,8,NaN\r\n");
    std::fs::write(&path, text).unwrap();
    let err = read_file(&path, &opts6()).unwrap_err();
    assert!(matches!(err, MeasurementError::NonFinite { .. }), "{err:?}");
    assert_names(&err, &path.display().to_string(), 5, "z");
}

#[test]
fn joints_only_form() {
    let text = "id,q1,q2,q3\na,1,2,3\n,4,5,6\n";
    let opts = ReadOptions::new(3).joints_only();
    let set = read_str(text, "j.csv", &opts).unwrap();
    assert_eq!(set.rows.len(), 2);
    assert!(set.rows.iter().all(|r| r.point_mm.is_none()));
    assert!(!set.has_points());
    assert_eq!(set.rows[1].q_deg, vec![4.0, 5.0, 6.0]);
    // Points are still read when present ...
    let text = "q1,q2,q3,x,y,z\n1,2,3,4,5,6\n";
    let set = read_str(text, "j.csv", &opts).unwrap();
    assert_eq!(set.rows[0].point_mm, Some([4.0, 5.0, 6.0]));
    // ... but must then be complete.
    let err = read_str("q1,q2,q3,x,z\n", "j.csv", &opts).unwrap_err();
    assert!(
        matches!(err, MeasurementError::MissingColumn { .. }),
        "{err:?}"
    );
    assert_names(&err, "j.csv", 1, "y");
    // And the same joints-only file is an error when points are required.
    let err = read_str("q1,q2,q3\n1,2,3\n", "j.csv", &ReadOptions::new(3)).unwrap_err();
    assert_names(&err, "j.csv", 1, "x");
}

#[test]
fn header_only_file_is_an_empty_set() {
    let set = read_str(HEADER6, "h.csv", &opts6()).unwrap();
    assert!(set.rows.is_empty());
}

#[test]
fn real_ur10_series_b_file() {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../data/ur10-ipa/series-b-joint-configurations.csv"
    );
    let opts = ReadOptions::new(6)
        .with_limits_deg(vec![[-360.0, 360.0]; 6])
        .with_min_rows(100);
    let set = read_file(path.as_ref(), &opts).unwrap();
    assert_eq!(set.rows.len(), 1495);
    assert_eq!(set.n_joints, 6);
    assert!(set.notices.is_empty(), "{:?}", set.notices);
    assert!(set.has_points());
    let first = &set.rows[0];
    assert_eq!(first.line, 2);
    assert_eq!(
        first.q_deg,
        vec![-179.999848, -90.000210, 0.0, -90.000210, 0.0, 0.0]
    );
    assert_eq!(first.point_mm, Some([383.762940, -3240.873400, 201.931570]));
    assert_eq!(set.rows.last().unwrap().line, 1496);
}

/// The optional columns of issue 31: orientation, standard deviations, several targets.
mod six_dof_and_targets {
    use measurements::{EulerConvention, MeasurementError, ReadOptions, read_str};

    fn opts2() -> ReadOptions {
        ReadOptions::new(2)
    }

    fn euler(text: &str) -> EulerConvention {
        text.parse().unwrap()
    }

    #[track_caller]
    fn err(text: &str, opts: &ReadOptions) -> MeasurementError {
        read_str(text, "m.csv", opts).unwrap_err()
    }

    #[track_caller]
    fn assert_at(e: &MeasurementError, line: usize, column: &str, words: &str) {
        let msg = e.to_string();
        assert!(
            msg.starts_with(&format!("m.csv:{line}: column \"{column}\": ")),
            "{msg}"
        );
        assert!(msg.contains(words), "{msg} lacks {words}");
        assert_eq!(e.file(), "m.csv");
        assert_eq!(e.line(), Some(line));
        assert_eq!(e.column(), Some(column));
    }

    #[test]
    fn quaternion_columns_are_read_as_given() {
        let h = (0.5f64).sqrt();
        let text =
            format!("q1,q2,x,y,z,qz,qw,qx,qy\n1,2,3,4,5,{h},{h},0,0\n1,2,3,4,5,0.0000005,1,0,0\n");
        let set = read_str(&text, "m.csv", &opts2()).unwrap();
        assert_eq!(set.rows[0].orientation, Some([h, 0.0, 0.0, h]));
        // Within the tolerance: kept as given, not renormalised.
        assert_eq!(set.rows[1].orientation, Some([1.0, 0.0, 0.0, 0.0000005]));
        assert!(set.has_orientation());
        assert!(set.notices.is_empty(), "{:?}", set.notices);
        assert_eq!(set.rows[0].sigma_mm, None);
        assert_eq!(set.rows[0].target, None);
    }

    #[test]
    fn a_non_unit_quaternion_is_refused() {
        for q in [
            "1,0,0,0.002",
            "0.5,0.5,0.5,0.4",
            "0,0,0,0",
            "1.000002,0,0,0",
        ] {
            let text = format!("q1,q2,x,y,z,qw,qx,qy,qz\n1,2,3,4,5,1,0,0,0\n\n1,2,3,4,5,{q}\n");
            let e = err(&text, &opts2());
            assert!(
                matches!(e, MeasurementError::NotUnitQuaternion { .. }),
                "{e:?}"
            );
            assert_at(&e, 4, "qw", "not 1 (|norm - 1| must be at most 0.000001)");
        }
    }

    #[test]
    fn orientation_groups_are_all_or_nothing() {
        let e = err("q1,q2,x,y,z,qw,qx,qy\n1,2,3,4,5,1,0,0\n", &opts2());
        assert!(matches!(e, MeasurementError::MissingColumn { .. }), "{e:?}");
        assert_eq!(e.to_string(), "m.csv:1: missing required column \"qz\"");
        let e = err(
            "q1,q2,x,y,z,rz\n1,2,3,4,5,1\n",
            &opts2().with_euler(euler("XYZ")),
        );
        assert_eq!(e.to_string(), "m.csv:1: missing required column \"rx\"");
        let e = err("q1,q2,x,y,z,sx,sz\n1,2,3,4,5,1,1\n", &opts2());
        assert_eq!(e.to_string(), "m.csv:1: missing required column \"sy\"");
    }

    #[test]
    fn euler_columns_need_a_convention() {
        let text = "q1,q2,x,y,z,rx,ry,rz\n1,2,3,4,5,10,20,30\n";
        let e = err(text, &opts2());
        assert!(
            matches!(e, MeasurementError::EulerConventionMissing { .. }),
            "{e:?}"
        );
        assert_at(&e, 1, "rx", "ReadOptions::euler");
        assert!(e.to_string().contains("\"XYZ\""), "{e}");
        assert!(e.to_string().contains("qw,qx,qy,qz"), "{e}");
    }

    #[test]
    fn euler_columns_are_converted_with_the_convention() {
        let text = "q1,q2,x,y,z,rx,ry,rz\n1,2,3,4,5,30,-45,60\n";
        for conv in ["XYZ", "xyz", "ZYX", "zyx", "ZYZ", "zyz"] {
            let c = euler(conv);
            let set = read_str(text, "m.csv", &opts2().with_euler(c)).unwrap();
            assert_eq!(
                set.rows[0].orientation,
                Some(c.to_quaternion([30.0, -45.0, 60.0])),
                "{conv}"
            );
        }
        // Intrinsic XYZ, SciPy's value (see rotation.rs).
        let set = read_str(text, "m.csv", &opts2().with_euler(euler("XYZ"))).unwrap();
        let want = [
            0.8223631719059994,
            0.022260026714733816,
            -0.43967973954090955,
            0.3604234056503559,
        ];
        let q = set.rows[0].orientation.unwrap();
        assert!((0..4).all(|k| (q[k] - want[k]).abs() < 1e-15), "{q:?}");
        // The columns are the sequence's angles in order, whatever their names: with ZYX,
        // rx is about z.
        let set = read_str(
            "q1,q2,x,y,z,rx,ry,rz\n1,2,3,4,5,90,0,0\n",
            "m.csv",
            &opts2().with_euler(euler("ZYX")),
        )
        .unwrap();
        let q = set.rows[0].orientation.unwrap();
        assert!(
            (q[0] - q[3]).abs() < 1e-15 && q[1] == 0.0 && q[2] == 0.0,
            "{q:?}"
        );
        // A convention for a file without Euler columns is unused.
        let set = read_str(
            "q1,q2,x,y,z\n1,2,3,4,5\n",
            "m.csv",
            &opts2().with_euler(euler("zyz")),
        )
        .unwrap();
        assert_eq!(set.rows[0].orientation, None);
    }

    #[test]
    fn quaternion_and_euler_together_are_refused() {
        let text = "q1,q2,x,y,z,qw,qx,qy,qz,rx,ry,rz\n1,2,3,4,5,1,0,0,0,0,0,0\n";
        let e = err(text, &opts2().with_euler(euler("XYZ")));
        assert!(
            matches!(e, MeasurementError::ColumnConflict { .. }),
            "{e:?}"
        );
        assert_at(&e, 1, "rx", "give one of the two");
    }

    #[test]
    fn standard_deviations() {
        let text = "q1,q2,x,y,z,sx,sy,sz,qw,qx,qy,qz,srx,sry,srz\n\
                    1,2,3,4,5,0.01,0.02,0.03,1,0,0,0,0.001,0.002,0.003\n";
        let set = read_str(text, "m.csv", &opts2()).unwrap();
        assert_eq!(set.rows[0].sigma_mm, Some([0.01, 0.02, 0.03]));
        assert_eq!(set.rows[0].sigma_deg, Some([0.001, 0.002, 0.003]));

        for (bad, col) in [
            ("0,0.02,0.03", "sx"),
            ("0.01,-1,0.03", "sy"),
            ("0.01,0.02,-0", "sz"),
        ] {
            let t = format!("q1,q2,x,y,z,sx,sy,sz\n1,2,3,4,5,{bad}\n");
            let e = err(&t, &opts2());
            assert!(matches!(e, MeasurementError::InvalidField { .. }), "{e:?}");
            assert_at(&e, 2, col, "is not positive");
        }
        let e = err("q1,q2,x,y,z,sx,sy,sz\n1,2,3,4,5,1,nan,1\n", &opts2());
        assert!(matches!(e, MeasurementError::NonFinite { .. }), "{e:?}");

        // Standard deviations without the values they belong to.
        let e = err("q1,q2,sx,sy,sz\n1,2,1,1,1\n", &opts2().joints_only());
        assert_at(&e, 1, "sx", "without the point columns");
        let e = err("q1,q2,x,y,z,srx,sry,srz\n1,2,3,4,5,1,1,1\n", &opts2());
        assert_at(&e, 1, "srx", "without orientation columns");
    }

    const TARGETS: &str = "# two poses, three reflectors\n\
        id,target,q1,q2,x,y,z\n\
        p1,A,10,20,1,2,3\n\
        p1,B,10,20,4,5,6\n\
        p2,A,11,21,7,8,9\n\
        p1,C,10,20,0,0,0\n\
        p2,B_2,11,21,1,1,1\n";

    #[test]
    fn rows_with_the_same_id_form_one_pose() {
        let set = read_str(TARGETS, "m.csv", &opts2()).unwrap();
        assert!(set.has_targets());
        assert_eq!(set.targets(), vec!["A", "B", "C", "B_2"]);
        assert_eq!(set.poses(), vec![vec![0, 1, 3], vec![2, 4]]);
        assert_eq!(set.rows[1].target.as_deref(), Some("B"));
        assert_eq!(set.rows[1].id.as_deref(), Some("p1"));
        assert_eq!(set.rows[1].line, 4);
        // Without a target column every row is a pose, whatever its id.
        let plain = read_str(
            "id,q1,q2,x,y,z\na,1,2,3,4,5\na,1,2,3,4,5\n",
            "m.csv",
            &opts2(),
        )
        .unwrap();
        assert_eq!(plain.poses(), vec![vec![0], vec![1]]);
        assert!(!plain.has_targets());
    }

    #[test]
    fn target_errors_name_file_lines_and_column() {
        let base = "id,target,q1,q2,x,y,z\np1,A,10,20,1,2,3\n";
        // Joints that disagree within a pose.
        let e = err(
            &format!("{base}p2,A,0,0,0,0,0\np1,B,10,20.5,1,2,3\n"),
            &opts2(),
        );
        assert!(
            matches!(
                e,
                MeasurementError::PoseJointsDisagree { first_line: 2, .. }
            ),
            "{e:?}"
        );
        assert_at(&e, 4, "q2", "pose \"p1\" has 20.5 here but 20 on line 2");
        // A target twice in one pose.
        let e = err(
            &format!("{base}p2,A,0,0,0,0,0\np1,A,10,20,1,2,3\n"),
            &opts2(),
        );
        assert!(
            matches!(e, MeasurementError::DuplicateTarget { .. }),
            "{e:?}"
        );
        assert_at(
            &e,
            4,
            "target",
            "target \"A\" appears twice in pose \"p1\" (lines 2 and 4)",
        );
        // One reflector named two ways.
        let e = err(&format!("{base}p2,a,0,0,0,0,0\n"), &opts2());
        assert!(
            matches!(e, MeasurementError::InconsistentTarget { .. }),
            "{e:?}"
        );
        assert_at(
            &e,
            3,
            "target",
            "differs from target \"A\" (line 2) only in letter case",
        );
        // Bad names.
        for (name, words) in [
            ("", "is empty"),
            ("a b", "not a simple name"),
            ("tä", "not a simple name"),
            ("-a", "does not start with"),
            (".a", "does not start with"),
        ] {
            let e = err(&format!("{base}p2,{name},0,0,0,0,0\n"), &opts2());
            assert!(matches!(e, MeasurementError::InvalidField { .. }), "{e:?}");
            assert_at(&e, 3, "target", words);
        }
        // An empty id.
        let e = err(&format!("{base},B,0,0,0,0,0\n"), &opts2());
        assert_at(&e, 3, "id", "every row needs one");
        // No id column.
        let e = err("target,q1,q2,x,y,z\nA,1,2,3,4,5\n", &opts2());
        assert!(
            matches!(e, MeasurementError::ColumnConflict { .. }),
            "{e:?}"
        );
        assert_at(&e, 1, "target", "needs an id column");
        // Joints equal as numbers agree, whatever their spelling.
        let ok = read_str(&format!("{base}p1,B,1e1,20.000,1,2,3\n"), "m.csv", &opts2()).unwrap();
        assert_eq!(ok.poses(), vec![vec![0, 1]]);
    }

    #[test]
    fn wrongly_cased_new_columns_get_the_hint() {
        let set = read_str(
            "q1,q2,x,y,z,QW,Target,SX\n1,2,3,4,5,1,A,1\n",
            "m.csv",
            &opts2(),
        )
        .unwrap();
        assert_eq!(set.notices.len(), 3);
        for n in &set.notices {
            assert!(n.contains("case-sensitive"), "{n}");
        }
        assert_eq!(set.rows[0].orientation, None);
    }
}

/// The vendored IPA series B with orientation (`data/ur10-ipa/`), checked against the raw
/// published file and against the position-only conversion.
mod ipa_series_b {
    use measurements::{EulerConvention, ReadOptions, read_file, read_str, to_csv_string};
    use std::path::{Path, PathBuf};

    fn data(name: &str) -> PathBuf {
        Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../../data/ur10-ipa")
            .join(name)
    }

    fn opts() -> ReadOptions {
        ReadOptions::new(6).with_limits_deg(vec![[-360.0, 360.0]; 6])
    }

    /// The raw file's rows: field name -> value (`;`-separated, `,` decimals, CRLF).
    fn raw_rows() -> Vec<Vec<(String, f64)>> {
        let text =
            std::fs::read_to_string(data("raw/measurements_joint_configurations.csv")).unwrap();
        let mut lines = text.lines();
        let header: Vec<String> = lines
            .next()
            .unwrap()
            .split(';')
            .map(str::to_owned)
            .collect();
        lines
            .map(|l| {
                header
                    .iter()
                    .cloned()
                    .zip(
                        l.split(';')
                            .map(|f| f.replace(',', ".").parse::<f64>().unwrap()),
                    )
                    .collect()
            })
            .collect()
    }

    fn get(row: &[(String, f64)], name: &str) -> f64 {
        row.iter().find(|(n, _)| n == name).unwrap().1
    }

    #[test]
    fn six_dof_file_reads_and_is_canonical() {
        let path = data("series-b-6dof.csv");
        let set = read_file(&path, &opts()).unwrap();
        assert_eq!(set.rows.len(), 1495);
        assert!(set.notices.is_empty(), "{:?}", set.notices);
        assert!(set.has_points() && set.has_orientation() && !set.has_targets());
        assert!(
            set.rows
                .iter()
                .all(|r| r.sigma_mm.is_some() && r.sigma_deg.is_some())
        );
        assert_eq!(set.rows[0].id.as_deref(), Some("b0001"));
        assert_eq!(set.rows[1494].id.as_deref(), Some("b1495"));
        // The writer gives back the file's bytes after its comment lines.
        let text = std::fs::read_to_string(&path).unwrap();
        let body: String = text
            .split_inclusive('\n')
            .filter(|l| !l.starts_with('#'))
            .collect();
        assert_eq!(to_csv_string(&set, None).unwrap(), body);
    }

    /// Same poses, same order as the position-only file, which rounded degrees and
    /// millimetres to 6 decimals (`%.6f`): joints and points agree within 5e-7.
    #[test]
    fn agrees_with_the_position_only_file() {
        let six = read_file(&data("series-b-6dof.csv"), &opts()).unwrap();
        let three = read_file(&data("series-b-joint-configurations.csv"), &opts()).unwrap();
        assert_eq!(six.rows.len(), three.rows.len());
        let (mut dq, mut dp) = (0.0f64, 0.0f64);
        for (a, b) in six.rows.iter().zip(&three.rows) {
            for (x, y) in a.q_deg.iter().zip(&b.q_deg) {
                dq = dq.max((x - y).abs());
            }
            for (x, y) in a.point_mm.unwrap().iter().zip(&b.point_mm.unwrap()) {
                dp = dp.max((x - y).abs());
            }
            // Rounded to 6 decimals, exactly.
            for (x, y) in a.q_deg.iter().zip(&b.q_deg) {
                assert_eq!(format!("{x:.6}"), format!("{y:.6}"), "line {}", a.line);
            }
        }
        assert!(dq <= 5.0e-7 + 1e-12, "max joint difference {dq} deg");
        assert!(dp <= 5.0e-7 + 1e-12, "max point difference {dp} mm");
        assert!(
            dq > 1e-7 && dp > 1e-7,
            "the roundings are visible: {dq} {dp}"
        );
    }

    /// The committed values against the raw file, converted again here (the Rust Euler
    /// conversion against the script's own): joints, points, sigmas, the quaternion of
    /// intrinsic XYZ and the propagated orientation sigmas.
    #[test]
    fn agrees_with_the_raw_file() {
        let six = read_file(&data("series-b-6dof.csv"), &opts()).unwrap();
        let raw = raw_rows();
        assert_eq!(raw.len(), six.rows.len());
        let xyz = EulerConvention::parse("XYZ").unwrap();
        let joints = [
            "shoulder_pan_joint",
            "shoulder_lift_joint",
            "elbow_joint",
            "wrist_1_joint",
            "wrist_2_joint",
            "wrist_3_joint",
        ];
        for (r, m) in raw.iter().zip(&six.rows) {
            for (j, name) in joints.iter().enumerate() {
                assert!((get(r, name).to_degrees() - m.q_deg[j]).abs() < 1e-12);
            }
            let p = ["x", "y", "z"].map(|c| get(r, &format!("measurement_{c}")));
            assert_eq!(m.point_mm, Some(p));
            let s = ["x", "y", "z"].map(|c| get(r, &format!("measurement_std_{c}")));
            assert_eq!(m.sigma_mm, Some(s));
            let e = ["x", "y", "z"].map(|c| get(r, &format!("measurement_r{c}")));
            let q = xyz.to_quaternion(e);
            let got = m.orientation.unwrap();
            assert!(
                (0..4).all(|k| (q[k] - got[k]).abs() < 1e-15),
                "line {}: {q:?} vs {got:?}",
                m.line
            );
            // σ about the tracker axes: columns e_x, Rx(a)·e_y, Rx(a)·Ry(b)·e_z.
            let se = ["x", "y", "z"].map(|c| get(r, &format!("measurement_std_r{c}")));
            let (sa, ca) = e[0].to_radians().sin_cos();
            let (sb, cb) = e[1].to_radians().sin_cos();
            let cols = [[1.0, 0.0, 0.0], [0.0, ca, sa], [sb, -sa * cb, ca * cb]];
            let sd = m.sigma_deg.unwrap();
            for k in 0..3 {
                let want = (0..3)
                    .map(|j| (cols[j][k] * se[j]).powi(2))
                    .sum::<f64>()
                    .sqrt();
                assert!((want - sd[k]).abs() < 1e-15, "line {}", m.line);
            }
        }
    }

    /// The same file with Euler columns reads to the same quaternions (the raw angles, given
    /// to the reader as `rx,ry,rz` with `XYZ`).
    #[test]
    fn euler_form_reads_to_the_same_quaternions() {
        let raw = raw_rows();
        let mut text = String::from("q1,q2,q3,q4,q5,q6,x,y,z,rx,ry,rz\n");
        for r in raw.iter().take(50) {
            let e = ["x", "y", "z"].map(|c| get(r, &format!("measurement_r{c}")));
            text.push_str(&format!("0,0,0,0,0,0,1,2,3,{},{},{}\n", e[0], e[1], e[2]));
        }
        let set = read_str(&text, "e.csv", &opts().with_euler("XYZ".parse().unwrap())).unwrap();
        let six = read_file(&data("series-b-6dof.csv"), &opts()).unwrap();
        for (a, b) in set.rows.iter().zip(&six.rows) {
            assert_eq!(a.orientation, b.orientation);
        }
    }
}

/// The example files of `docs/model.md` §5 read as the text says.
mod docs_examples {
    use measurements::{ReadOptions, read_str};

    #[test]
    fn model_md_section_5_examples_read() {
        let md =
            std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/../../docs/model.md"))
                .unwrap();
        let start = md
            .find("# two poses of a 6-DoF probe")
            .expect("the §5 example block");
        let block = &md[start..start + md[start..].find("```").unwrap()];
        let files: Vec<&str> = block.split("\n\n").collect();
        assert_eq!(files.len(), 3);
        let opts = ReadOptions::new(6).with_limits_deg(vec![[-360.0, 360.0]; 6]);

        let quat = read_str(files[0], "quat.csv", &opts).unwrap();
        assert!(quat.has_orientation() && quat.notices.is_empty());
        assert!(quat.rows.iter().all(|r| r.sigma_deg.is_some()));

        let euler = read_str(
            files[1],
            "euler.csv",
            &opts.clone().with_euler("XYZ".parse().unwrap()),
        )
        .unwrap();
        let (a, b) = (
            euler.rows[0].orientation.unwrap(),
            quat.rows[0].orientation.unwrap(),
        );
        assert!((0..4).all(|k| (a[k] - b[k]).abs() < 1e-8), "{a:?} {b:?}");
        assert!(read_str(files[1], "euler.csv", &opts).is_err());

        let targets = read_str(files[2], "targets.csv", &opts).unwrap();
        assert_eq!(targets.poses(), vec![vec![0, 1, 2], vec![3, 4]]);
        assert_eq!(targets.targets(), vec!["A", "B", "C"]);
    }
}

/// Mutation fuzzing (as `fuzz.rs`) of files with the new columns: no panic, every rejection
/// names the file and its line, and whatever is accepted writes back and reads identically.
mod fuzz_new_columns {
    use std::cell::RefCell;

    use measurements::{ReadOptions, read_str, to_csv_string};
    use proptest::test_runner::TestRunner;

    use crate::mutate::{Tally, apply, mutations};

    const QUAT: &str = "# targets and a probe\n\
        id,target,q1,q2,q3,x,y,z,qw,qx,qy,qz,sx,sy,sz,srx,sry,srz\n\
        p1,A,10,20,30,1.5,2.5,3.5,0.5,0.5,0.5,0.5,0.01,0.02,0.03,0.001,0.002,0.003\n\
        p1,B,10,20,30,4,5,6,0.5,0.5,0.5,0.5,0.01,0.02,0.03,0.001,0.002,0.003\n\
        p2,A,-1,-2.25,3e1,7,8,9,1,0,0,0,0.5,0.5,0.5,0.1,0.1,0.1\n\
        p2,C_1,-1,-2.25,3e1,7,8,9,0.7071067811865476,0,0,0.7071067811865476,0.5,0.5,0.5,0.1,0.1,0.1\n";
    const EULER: &str = "id,target,q1,q2,q3,x,y,z,rx,ry,rz,srx,sry,srz\n\
        p1,A,10,20,30,1.5,2.5,3.5,10,20,30,0.001,0.002,0.003\n\
        p1,B,10,20,30,4,5,6,-170,80,15.5,0.001,0.002,0.003\n\
        p2,A,-1,-2,3,7,8,9,0,0,0,0.1,0.1,0.1\n";

    fn read(bytes: &[u8], opts: &ReadOptions) -> Result<(), String> {
        let Ok(text) = std::str::from_utf8(bytes) else {
            return Err("not UTF-8".to_owned());
        };
        match read_str(text, "f.csv", opts) {
            // An empty set writes as a bare joint header (the writer cannot know the rest).
            Ok(set) if set.rows.is_empty() => Ok(()),
            Ok(set) => {
                // The reader takes ids the writer refuses (quotes; as before the new columns).
                let out = match to_csv_string(&set, None) {
                    Ok(out) => out,
                    Err(e) if e.to_string().contains(": id \"") => return Ok(()),
                    Err(e) => return Err(format!("BAD unwritable: {e}")),
                };
                let back = read_str(&out, "f.csv", opts)
                    .map_err(|e| format!("BAD written file does not read: {e}"))?;
                if back.rows.iter().zip(&set.rows).any(|(a, b)| {
                    (
                        a.id.as_ref(),
                        &a.target,
                        &a.q_deg,
                        a.point_mm,
                        a.orientation,
                        a.sigma_mm,
                        a.sigma_deg,
                    ) != (
                        b.id.as_ref(),
                        &b.target,
                        &b.q_deg,
                        b.point_mm,
                        b.orientation,
                        b.sigma_mm,
                        b.sigma_deg,
                    )
                }) || back.poses() != set.poses()
                {
                    return Err("BAD round trip differs".to_owned());
                }
                Ok(())
            }
            Err(e) => {
                let msg = e.to_string();
                if e.file() != "f.csv" || !msg.starts_with("f.csv") {
                    return Err(format!("BAD does not name the file: {msg}"));
                }
                if let Some(l) = e.line()
                    && !msg.starts_with(&format!("f.csv:{l}:"))
                {
                    return Err(format!("BAD line {l} not in the message: {msg}"));
                }
                if msg.contains("00000000000000000000000000000000") {
                    return Err(format!("BAD a number written out in full: {msg}"));
                }
                Err(msg)
            }
        }
    }

    #[test]
    fn mutated_files_with_new_columns_are_read_or_refused_clearly() {
        let opts = ReadOptions::new(3).with_euler("XYZ".parse().unwrap());
        for seed in [QUAT, EULER] {
            read(seed.as_bytes(), &opts).expect("the seed is valid");
            let tally = RefCell::new(Tally::default());
            let mut runner = TestRunner::new(crate::mutate::config(1500));
            runner
                .run(&mutations(), |muts| {
                    let input = apply(seed.as_bytes(), &muts);
                    let i = input.clone();
                    let o = opts.clone();
                    tally.borrow_mut().case(
                        &input,
                        move || read(&i, &o),
                        |msg| msg.starts_with("BAD").then(|| msg.to_string()),
                    )
                })
                .unwrap();
            let t = tally.into_inner();
            eprintln!("new columns fuzz: {t:?}");
            assert!(t.rejected > t.cases / 4 && t.accepted > 0, "{t:?}");
        }
    }
}
