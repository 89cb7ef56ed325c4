//! `docs/record.schema.json`: the schema the record types derive, and every line a run writes
//! valid against it (and a wrong line not).

use std::path::Path;

use crate::common;

fn docs_schema() -> (std::path::PathBuf, serde_json::Value) {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../docs/record.schema.json");
    let text = std::fs::read_to_string(&path).unwrap_or_default();
    (
        path,
        serde_json::from_str(&text).unwrap_or(serde_json::Value::Null),
    )
}

#[test]
fn the_published_schema_is_the_one_the_records_derive() {
    let derived = serde_json::to_value(flexshape_record::json_lines_schema()).unwrap();
    let (path, published) = docs_schema();
    if std::env::var("FLEXSHAPE_BLESS").is_ok_and(|v| v == "1") {
        let text = serde_json::to_string_pretty(&derived).unwrap() + "\n";
        std::fs::write(&path, text).unwrap();
        return;
    }
    assert!(
        published == derived,
        "{} differs from the schema the record types derive: run this test with FLEXSHAPE_BLESS=1 to write it, and say the change in docs/formats.md",
        path.display()
    );
}

#[test]
fn every_line_of_a_run_is_valid_and_a_wrong_one_is_not() {
    let (_, schema) = docs_schema();
    let validator = jsonschema::validator_for(&schema).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let rec = dir.path().join("rec");
    let out = dir.path().join("shapes.jsonl");
    let rec_s = rec.to_str().unwrap();
    common::run(&[
        "simulate", "--out", rec_s, "--frames", "3", "--motion", "60",
    ]);
    common::run(&["track", rec_s, "--out", out.to_str().unwrap(), "--follow"]);
    let text = std::fs::read_to_string(&out).unwrap();
    let lines: Vec<serde_json::Value> = text
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    assert_eq!(lines.len(), 4, "three records and the summary");
    for (k, line) in lines.iter().enumerate() {
        let errors: Vec<String> = validator
            .iter_errors(line)
            .map(|e| format!("{} at {}", e, e.instance_path()))
            .collect();
        assert!(errors.is_empty(), "line {k}: {errors:?}");
    }
    // A status no version writes, a frame number as text, a point of two coordinates: refused.
    for (field, value) in [
        ("status", serde_json::json!("fine")),
        ("frame", serde_json::json!("7")),
        ("tip", serde_json::json!([1.0, 2.0])),
    ] {
        let mut wrong = lines[0].clone();
        wrong[field] = value;
        assert!(!validator.is_valid(&wrong), "{field} accepted");
    }
}
