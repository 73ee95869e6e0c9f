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
        matches!(err, MeasurementError::MissingColumn { .. }),
        "{err:?}"
    );
    assert_names(&err, "case.csv", 1, "x");
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
            value_deg,
            min_deg,
            max_deg,
            ..
        } => assert_eq!((*value_deg, *min_deg, *max_deg), (107.50001, -40.0, 107.5)),
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
        ReadOptions::new(0),
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
