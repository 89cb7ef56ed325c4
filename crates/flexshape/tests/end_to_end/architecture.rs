//! The workspace's layering as `ARCHITECTURE.md` states it: the code map lists every crate in
//! data-flow order, and each crate's `[dependencies]` on our crates are listed above it — a
//! lower stage never depends on a higher one, no library on the application.

use std::path::{Path, PathBuf};

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// The code map's crates, in its order.
fn code_map() -> Vec<String> {
    let text = std::fs::read_to_string(root().join("ARCHITECTURE.md")).unwrap();
    text.lines()
        .filter_map(|l| l.strip_prefix("| `")?.split_once("` |").map(|(n, _)| n))
        .map(str::to_string)
        .collect()
}

/// Our crates a crate's `[dependencies]` name (its folder names), dev-dependencies aside.
fn dependencies(manifest: &Path) -> Vec<String> {
    let text = std::fs::read_to_string(manifest).unwrap();
    let table: toml::Table = text.parse().unwrap();
    table
        .get("dependencies")
        .and_then(|d| d.as_table())
        .map(|deps| {
            deps.keys()
                .filter_map(|k| k.strip_prefix("flexshape-"))
                .filter(|k| *k != "workspace-hack")
                .map(str::to_string)
                .collect()
        })
        .unwrap_or_default()
}

#[test]
fn every_crate_depends_only_on_crates_the_code_map_lists_above_it() {
    let order = code_map();
    let mut crates: Vec<String> = std::fs::read_dir(root().join("crates"))
        .unwrap()
        .filter_map(|e| e.ok())
        .filter(|e| e.path().join("Cargo.toml").is_file())
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .collect();
    crates.sort();
    let mut listed = order.clone();
    listed.sort();
    assert_eq!(
        crates, listed,
        "ARCHITECTURE.md's code map lists every crate once"
    );
    let place = |name: &str| order.iter().position(|c| c == name);
    let mut wrong = Vec::new();
    for name in &crates {
        let manifest = root().join("crates").join(name).join("Cargo.toml");
        for dep in dependencies(&manifest) {
            if place(&dep) >= place(name) {
                wrong.push(format!("{name} → {dep}"));
            }
        }
    }
    assert!(
        wrong.is_empty(),
        "dependencies on crates the code map lists below: {wrong:?}"
    );
    // The record is read apart from the engine: it never depends on `track`.
    let record = dependencies(&root().join("crates/record/Cargo.toml"));
    assert!(
        !record.iter().any(|d| d == "track" || d == "input"),
        "{record:?}"
    );
}
