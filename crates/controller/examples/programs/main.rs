//! Writes the example programs of `docs/controller.md` into `docs/controller/`:
//! `cargo run -p controller --example programs` (the golden test checks the committed files
//! are what this writes).

mod demo;

fn main() {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    std::fs::create_dir_all(root.join("docs/controller")).expect("docs/controller");
    for (path, text) in demo::files(&root) {
        std::fs::write(root.join(&path), text).unwrap_or_else(|e| panic!("{path}: {e}"));
        println!("wrote {path}");
    }
}
