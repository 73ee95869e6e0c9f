//! Tidy tests: invariants of the repository itself, checked as ordinary `#[test]`s (the idea
//! of rust-analyzer's tidy tests). They run with `cargo test --workspace`.
//!
//! * ARCHITECTURE.md's crate table names, for every crate, exactly the normal dependencies
//!   of its Cargo.toml (internal and external), so the document cannot drift from the build.

#[cfg(test)]
mod tests {
    use std::collections::{BTreeMap, BTreeSet};
    use std::path::{Path, PathBuf};
    use std::process::Command;

    fn root() -> PathBuf {
        Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
    }

    /// Package directory (relative to the root, e.g. `crates/kinematics`) → its normal
    /// dependencies, from `cargo metadata`.
    fn cargo_dependencies() -> BTreeMap<String, BTreeSet<String>> {
        let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
        let out = Command::new(cargo)
            .args([
                "metadata",
                "--format-version",
                "1",
                "--no-deps",
                "--offline",
            ])
            .current_dir(root())
            .output()
            .expect("running cargo metadata");
        assert!(
            out.status.success(),
            "cargo metadata failed: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        let meta: serde_json::Value = serde_json::from_slice(&out.stdout).expect("metadata JSON");
        let root = root().canonicalize().expect("root");
        let mut map = BTreeMap::new();
        for p in meta["packages"].as_array().expect("packages") {
            let manifest = PathBuf::from(p["manifest_path"].as_str().expect("manifest path"));
            let dir = manifest
                .parent()
                .expect("manifest dir")
                .strip_prefix(&root)
                .expect("package inside the workspace")
                .to_string_lossy()
                .into_owned();
            let deps: BTreeSet<String> = p["dependencies"]
                .as_array()
                .expect("dependencies")
                .iter()
                .filter(|d| d["kind"].is_null())
                .map(|d| d["name"].as_str().expect("name").to_string())
                .collect();
            map.insert(dir, deps);
        }
        map
    }

    /// The `## Crates` table of ARCHITECTURE.md: crate directory → the names in its
    /// "depends on" column (comma-separated, backticks optional).
    fn documented_dependencies(text: &str) -> BTreeMap<String, BTreeSet<String>> {
        let section = text
            .split("\n## Crates")
            .nth(1)
            .expect("ARCHITECTURE.md has a `## Crates` section");
        let section = section.split("\n## ").next().unwrap_or(section);
        let mut map = BTreeMap::new();
        for line in section.lines().filter(|l| l.starts_with("| `")) {
            let cells: Vec<&str> = line.trim_matches('|').split(" | ").collect();
            let dir = cells[0].trim().trim_matches('`').to_string();
            let deps = cells
                .last()
                .expect("a depends-on column")
                .split(',')
                .map(|d| d.trim().trim_matches('`').to_string())
                .filter(|d| !d.is_empty() && d != "–")
                .collect();
            map.insert(dir, deps);
        }
        map
    }

    #[test]
    fn architecture_crate_table_matches_the_cargo_manifests() {
        let text = std::fs::read_to_string(root().join("ARCHITECTURE.md")).expect("reading");
        let documented = documented_dependencies(&text);
        let actual = cargo_dependencies();
        let mut problems = Vec::new();
        for (dir, deps) in &actual {
            match documented.get(dir) {
                None => problems.push(format!("`{dir}` has no row in ARCHITECTURE.md's table")),
                Some(doc) if doc != deps => problems.push(format!(
                    "`{dir}`: ARCHITECTURE.md says {}, Cargo.toml has {}",
                    doc.iter().cloned().collect::<Vec<_>>().join(", "),
                    deps.iter().cloned().collect::<Vec<_>>().join(", ")
                )),
                Some(_) => {}
            }
        }
        for dir in documented.keys().filter(|d| !actual.contains_key(*d)) {
            problems.push(format!(
                "ARCHITECTURE.md names `{dir}`, which is not a package"
            ));
        }
        assert!(problems.is_empty(), "{}", problems.join("\n"));
    }

    #[test]
    fn the_table_parser_reads_names_and_ignores_backticks() {
        let text = "# A\n\n## Crates\n\n| crate | job | depends on |\n|---|---|---|\n\
                    | `crates/a` | x | `b`, serde |\n| `xtask` | y | – |\n\n## Next\n| `z` | q | r |\n";
        let d = documented_dependencies(text);
        assert_eq!(d.len(), 2);
        assert_eq!(
            d["crates/a"],
            BTreeSet::from(["b".to_string(), "serde".to_string()])
        );
        assert!(d["xtask"].is_empty());
    }
}
