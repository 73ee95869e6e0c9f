//! Helpers shared by the campaign crate's integration tests.

#![allow(dead_code)]

use std::path::{Path, PathBuf};

use campaign::{LoadedScenario, Scenario};

/// The committed scenario `scenarios/<name>.json`.
pub fn scenario_path(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join(format!("../../scenarios/{name}.json"))
}

/// Loads a committed scenario.
pub fn load(name: &str) -> LoadedScenario {
    Scenario::from_file(&scenario_path(name)).unwrap()
}

/// Loads a committed scenario as JSON, lets the test edit it, and loads the result.
pub fn load_edited(name: &str, edit: impl FnOnce(&mut serde_json::Value)) -> LoadedScenario {
    let path = scenario_path(name);
    let mut v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap();
    edit(&mut v);
    Scenario::from_value(v, "edited")
        .unwrap()
        .load(path.parent().unwrap(), "edited")
        .unwrap()
}
