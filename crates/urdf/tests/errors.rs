//! Bad input: clear errors naming the element.

use urdf::{ImportOptions, UrdfError, import_str};

/// A three-link chain base → l1 → l2 → tip with the given middle joint and limit text.
fn chain(middle_type: &str, limit: &str, extra: &str) -> String {
    format!(
        r#"<?xml version="1.0"?>
<robot name="t">
  <link name="base"/><link name="l1"/><link name="l2"/><link name="tip"/><link name="side"/>
  <joint name="j1" type="revolute"><parent link="base"/><child link="l1"/>
    <origin xyz="0 0 0.5" rpy="0 0 0"/><axis xyz="0 0 1"/>
    <limit lower="-3" upper="3" effort="1" velocity="1"/></joint>
  <joint name="j2" type="{middle_type}"><parent link="l1"/><child link="l2"/>
    <origin xyz="0.3 0 0" rpy="0 0 0"/><axis xyz="0 1 0"/>{limit}</joint>
  <joint name="j3" type="fixed"><parent link="l2"/><child link="tip"/>
    <origin xyz="0.2 0 0" rpy="0 0 0"/></joint>
  {extra}
</robot>"#
    )
}

const LIMIT: &str = r#"<limit lower="-2" upper="2" effort="1" velocity="1"/>"#;

fn import(text: &str, base: &str, tip: &str) -> Result<urdf::Imported, UrdfError> {
    import_str(text, "t.urdf", base, tip, &ImportOptions::default())
}

#[test]
fn a_good_chain_imports() {
    let r = import(&chain("revolute", LIMIT, ""), "base", "tip").unwrap();
    assert_eq!(r.joint_names, ["j1", "j2"]);
    assert_eq!(r.fixed_joints, ["j3"]);
    assert_eq!(
        r.spec.joints[1].limits_deg,
        [-2f64.to_degrees(), 2f64.to_degrees()]
    );
}

#[test]
fn planar_or_continuous_on_the_chain_is_refused_off_it_ignored() {
    let e = import(&chain("planar", LIMIT, ""), "base", "tip")
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("t.urdf") && e.contains("<joint name=\"j2\" type=\"planar\">"),
        "{e}"
    );
    // A prismatic joint imports, its limits metres → millimetres.
    let r = import(&chain("prismatic", LIMIT, ""), "base", "tip").unwrap();
    assert_eq!(
        r.spec.joints[1].joint_type,
        kinematics::JointType::Prismatic
    );
    assert_eq!(r.spec.joints[1].limits_deg, [-2000.0, 2000.0]);
    let e = import(&chain("continuous", "", ""), "base", "tip")
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("<joint name=\"j2\" type=\"continuous\">") && e.contains("no limits"),
        "{e}"
    );
    // The same joints off the chain do not matter.
    let side = r#"<joint name="s" type="prismatic"><parent link="l1"/><child link="side"/>
        <axis xyz="1 0 0"/><limit lower="0" upper="1" effort="1" velocity="1"/></joint>"#;
    let r = import(&chain("revolute", LIMIT, side), "base", "tip").unwrap();
    assert_eq!(r.joint_names.len(), 2);
    // A chain ending before the planar joint is fine.
    assert!(import(&chain("planar", LIMIT, ""), "base", "l1").is_ok());
}

#[test]
fn missing_limits_name_the_joint() {
    let e = import(&chain("revolute", "", ""), "base", "tip").unwrap_err();
    assert!(
        matches!(e, UrdfError::MissingLimits { ref joint, .. } if joint == "j2"),
        "{e}"
    );
    let reversed = r#"<limit lower="1" upper="-1" effort="1" velocity="1"/>"#;
    let e = import(&chain("revolute", reversed, ""), "base", "tip")
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("<joint name=\"j2\" type=\"revolute\">: <limit>"),
        "{e}"
    );
}

#[test]
fn tip_not_below_base() {
    let e = import(&chain("revolute", LIMIT, ""), "tip", "base")
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("<link name=\"base\"> is not below <link name=\"tip\">"),
        "{e}"
    );
    let side = r#"<joint name="s" type="fixed"><parent link="base"/><child link="side"/></joint>"#;
    let e = import(&chain("revolute", LIMIT, side), "l1", "side")
        .unwrap_err()
        .to_string();
    assert!(e.contains("side ← base"), "{e}");
}

#[test]
fn unknown_links_are_named_with_the_known_ones() {
    let e = import(&chain("revolute", LIMIT, ""), "base", "tool0")
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("no <link name=\"tool0\"> (the tip link)") && e.contains("base, l1"),
        "{e}"
    );
}

#[test]
fn a_link_with_two_parents_is_refused() {
    let second =
        r#"<joint name="loop" type="fixed"><parent link="base"/><child link="l2"/></joint>"#;
    let e = import(&chain("revolute", LIMIT, second), "base", "tip")
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("<link name=\"l2\"> is the child of two joints")
            && e.contains("\"j2\"")
            && e.contains("\"loop\""),
        "{e}"
    );
}

#[test]
fn malformed_xml_and_no_revolute_joint() {
    let text = chain("revolute", LIMIT, "").replace("</robot>", "");
    let e = import(&text, "base", "tip").unwrap_err();
    assert!(matches!(e, UrdfError::Xml { .. }), "{e}");
    assert!(
        e.to_string().starts_with("t.urdf: not a readable URDF"),
        "{e}"
    );
    let e = import(&chain("revolute", LIMIT, ""), "l2", "tip")
        .unwrap_err()
        .to_string();
    assert!(e.contains("has 0 revolute joints"), "{e}");
    let zero_axis =
        chain("revolute", LIMIT, "").replace("<axis xyz=\"0 1 0\"/>", "<axis xyz=\"0 0 0\"/>");
    let e = import(&zero_axis, "base", "tip").unwrap_err().to_string();
    assert!(
        e.contains("<joint name=\"j2\">: <axis xyz=\"0 0 0\"> is not a direction"),
        "{e}"
    );
}

/// A fixed joint from the tip back to the base closes the chain into a loop: refused, naming
/// the joint and the loop, although every link has one parent and the tip is below the base.
#[test]
fn a_fixed_joint_from_the_tip_back_to_the_base_is_refused() {
    let back =
        r#"<joint name="loop" type="fixed"><parent link="tip"/><child link="base"/></joint>"#;
    let e = import(&chain("revolute", LIMIT, back), "base", "tip").unwrap_err();
    assert!(
        matches!(e, UrdfError::ClosedLoop { ref joint, .. } if joint == "loop"),
        "{e:?}"
    );
    let e = e.to_string();
    assert!(
        e.starts_with("t.urdf: <joint name=\"loop\"> closes a loop (")
            && e.contains("base ← tip ← l2 ← l1 ← base")
            && e.contains("a closed structure"),
        "{e}"
    );
    // The same loop from a fixture file: the error names the file.
    let path =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/closed-loop.urdf");
    let e = urdf::import_file(&path, "base", "tip", &ImportOptions::default())
        .unwrap_err()
        .to_string();
    assert!(
        e.starts_with(&format!(
            "{}: <joint name=\"tip_to_base\"> closes a loop",
            path.display()
        )),
        "{e}"
    );
    // A loop off the chain is refused too: the description is not a tree.
    let off = r#"<link name="a"/><link name="b"/>
        <joint name="ab" type="fixed"><parent link="a"/><child link="b"/></joint>
        <joint name="ba" type="fixed"><parent link="b"/><child link="a"/></joint>"#;
    let e = import(&chain("revolute", LIMIT, off), "base", "tip").unwrap_err();
    assert!(
        matches!(e, UrdfError::ClosedLoop { ref joint, ref cycle, .. } if joint == "ba" && cycle == "a ← b ← a"),
        "{e:?}"
    );
}

/// A joint whose parent and child are the same link: refused, naming the joint and the link.
#[test]
fn a_joint_from_a_link_to_itself_is_refused() {
    for link in ["base", "l2", "tip", "side"] {
        let own = format!(
            r#"<joint name="own" type="fixed"><parent link="{link}"/><child link="{link}"/></joint>"#
        );
        let e = import(&chain("revolute", LIMIT, &own), "base", "tip").unwrap_err();
        let msg = e.to_string();
        assert!(
            matches!(e, UrdfError::ClosedLoop { ref joint, .. } if joint == "own"),
            "{msg}"
        );
        assert!(
            msg.contains(&format!(
                "<joint name=\"own\"> closes a loop ({link} ← {link})"
            )),
            "{msg}"
        );
    }
}
