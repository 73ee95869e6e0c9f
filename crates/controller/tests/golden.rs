//! The committed example programs (`docs/controller/`, shown in `docs/controller.md`) are
//! the bytes `cargo run -p controller --example programs` writes.

#[path = "../examples/programs/demo.rs"]
mod demo;

use std::path::Path;

#[test]
fn committed_programs_are_what_the_generator_writes() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let files = demo::files(&root);
    assert_eq!(files.len(), 8);
    for (path, text) in files {
        let committed = std::fs::read_to_string(root.join(&path))
            .unwrap_or_else(|e| panic!("{path}: {e} (cargo run -p controller --example programs)"));
        assert!(
            committed == text,
            "{path} differs from what the generator writes: cargo run -p controller --example programs"
        );
    }
}

/// The KR1000's ten targets reach every Status its limits allow: forward and overhead,
/// elbow up and beyond stretched, A5 of either sign.
#[test]
fn kr1000_examples_cover_the_status_bits() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let (_, file, _, sets) = demo::ROBOTS[0];
    let robot = kinematics::Robot::from_file(&root.join(file)).unwrap();
    let decl = controller::declare(&robot, &demo::targets(&robot, &sets)).unwrap();
    let status: Vec<u8> = decl
        .iter()
        .map(|d| controller::kuka_status(&d.config, &d.axes_deg))
        .collect();
    println!("KR1000 example Status: {status:?}");
    for bit in 0..3 {
        assert!(
            status.iter().any(|s| s >> bit & 1 == 1),
            "bit {bit}: {status:?}"
        );
        assert!(
            status.iter().any(|s| s >> bit & 1 == 0),
            "bit {bit}: {status:?}"
        );
    }
}

/// The excerpts of `docs/controller.md` (a ```text block after a line naming
/// `docs/controller/FILE`) are lines of that file, in order (`…` stands for any lines).
#[test]
fn doc_excerpts_are_the_files_lines() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let doc = std::fs::read_to_string(root.join("docs/controller.md")).unwrap();
    let lines: Vec<&str> = doc.lines().collect();
    let mut checked = 0;
    for (i, l) in lines.iter().enumerate() {
        if l.trim() != "```text" {
            continue;
        }
        let named = lines[..i]
            .iter()
            .rev()
            .find_map(|p| p.split('`').find(|w| w.starts_with("docs/controller/")))
            .expect("an excerpt names its file");
        let file = std::fs::read_to_string(root.join(named)).unwrap();
        let mut rest = file.lines();
        for want in lines[i + 1..].iter().take_while(|w| w.trim() != "```") {
            if want.trim() == "…" {
                continue;
            }
            assert!(
                rest.any(|got| got == *want),
                "docs/controller.md: {want:?} is not a later line of {named}"
            );
        }
        checked += 1;
    }
    assert_eq!(checked, 4);
}
