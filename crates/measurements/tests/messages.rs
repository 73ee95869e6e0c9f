//! Messages of files that are almost measurement files (issue 38): each names the file, the
//! line and the character column, and says what was found — the separator, the decimal
//! comma, the letter case of a header — and prints huge numbers in exponent form.

use measurements::{MeasurementError, ReadOptions, number, read_str, short};

const ROW: &str =
    "-179.999848,-90.000210,0.5,-90.000210,0.25,0.125,383.762940,-3240.873400,201.931570";

fn read(text: &str) -> MeasurementError {
    read_str(text, "f.csv", &ReadOptions::new(6)).unwrap_err()
}

#[test]
fn a_header_separated_by_semicolons_tabs_or_spaces_names_the_separator() {
    for (sep, said) in [(';', "';' (semicolons)"), ('\t', "tabs"), (' ', "spaces")] {
        let header = "q1,q2,q3,q4,q5,q6,x,y,z".replace(',', &sep.to_string());
        let row = ROW.replace(',', &sep.to_string());
        let e = read(&format!("# comment\n{header}\n{row}\n"));
        let msg = e.to_string();
        assert!(matches!(e, MeasurementError::Separator { .. }), "{e:?}");
        assert!(
            msg.starts_with("f.csv:2:3: the header is separated by "),
            "{msg}"
        );
        assert!(msg.contains(said), "{msg}");
        assert!(msg.contains("comma-separated"), "{msg}");
        assert!(!msg.contains("decimal comma"), "{msg}");
        assert!(!msg.contains("missing required column"), "{msg}");
    }
}

#[test]
fn semicolons_with_decimal_commas_say_both() {
    let header = "q1;q2;q3;q4;q5;q6;x;y;z";
    let row = ROW.replace(',', ";").replace('.', ",");
    let msg = read(&format!("{header}\n{row}\n")).to_string();
    assert!(
        msg.starts_with("f.csv:1:3: the header is separated by ';'"),
        "{msg}"
    );
    assert!(
        msg.contains("line 2 also writes numbers with a decimal comma (\"-179,999848\")"),
        "{msg}"
    );
}

#[test]
fn decimal_commas_in_a_comma_separated_file_are_named_with_line_and_column() {
    let row = ROW.replace('.', ",");
    let e = read(&format!("q1,q2,q3,q4,q5,q6,x,y,z\n{row}\n"));
    let msg = e.to_string();
    assert!(matches!(e, MeasurementError::DecimalComma { .. }), "{e:?}");
    assert!(
        msg.starts_with("f.csv:2:5: \"-179,999848\" is a number with a decimal comma"),
        "{msg}"
    );
    assert!(msg.contains("18 fields where the header has 9"), "{msg}");
    // A ragged row with decimal points is still a ragged row.
    let e = read(&format!("q1,q2,q3,q4,q5,q6,x,y,z\n{ROW},1.5\n"));
    assert!(matches!(e, MeasurementError::RaggedRow { .. }), "{e:?}");
}

#[test]
fn an_upper_case_header_names_the_case() {
    let e = read(&format!("Q1,Q2,Q3,Q4,Q5,Q6,X,Y,Z\n{ROW}\n"));
    let msg = e.to_string();
    assert!(matches!(e, MeasurementError::HeaderCase { .. }), "{e:?}");
    assert!(
        msg.starts_with("f.csv:1:1: column \"Q1\": column names are lower-case"),
        "{msg}"
    );
    assert!(msg.contains("write \"q1\""), "{msg}");
    assert_eq!(e.column(), Some("Q1"));
    // Only the points upper-case: the first of them, at its column.
    let msg = read(&format!("q1,q2,q3,q4,q5,q6, X,Y,Z\n{ROW}\n")).to_string();
    assert!(msg.starts_with("f.csv:1:20: column \"X\""), "{msg}");
}

#[test]
fn a_joint_value_of_1e300_prints_in_exponent_form() {
    let row = ROW.replacen("-179.999848", "1e300", 1);
    let opts = ReadOptions::new(6).with_limits_deg(vec![[-360.0, 360.0]; 6]);
    let e = read_str(&format!("q1,q2,q3,q4,q5,q6,x,y,z\n{row}\n"), "f.csv", &opts).unwrap_err();
    let msg = e.to_string();
    assert!(msg.contains("joint value 1e300 deg"), "{msg}");
    assert!(msg.len() < 200, "{msg}");
}

#[test]
fn numbers_for_messages_switch_to_exponent_form_at_a_million() {
    assert_eq!(short(1e300), "1e300");
    assert_eq!(short(2f64.powi(64)), "1.8446744073709552e19");
    assert_eq!(short(999_999.5), "999999.5");
    assert_eq!(short(-1e6), "-1e6");
    assert_eq!(short(0.0), "0");
    assert_eq!(number(99469.04591, 4), "99469.0459");
    assert_eq!(number(1e300, 4), "1e300");
    assert_eq!(number(1_234_567.0, 1), "1.235e6");
    assert_eq!(number(-2.5e7, 3), "-2.5e7");
    assert_eq!(number(f64::INFINITY, 4), "inf");
}
