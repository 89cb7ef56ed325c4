//! The validation tools end to end: the simulated experiments, their figures (kept in
//! `target/tmp/validation/` as artifacts), and `validate points` / `validate shape` / `report`
//! on the data the simulation writes.

use crate::common;

use common::{flexshape, ink};

use std::path::PathBuf;

fn json(args: &[&str]) -> serde_json::Value {
    let o = flexshape(args);
    assert!(
        o.status.success(),
        "flexshape {args:?}: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    serde_json::from_slice(&o.stdout).unwrap()
}

fn f(v: &serde_json::Value) -> f64 {
    v.as_f64().unwrap()
}

#[test]
fn simulated_validation_meets_its_targets_and_the_tools_reproduce_it() {
    let out = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("validation");
    let _ = std::fs::remove_dir_all(&out);
    let dir = out.to_str().unwrap();
    // Fewer poses than the defaults (25 and 8, which the validate crate's own tests run): the
    // command, its files and the tools reading them back are what is tested here.
    let v = json(&[
        "validate",
        "--simulate",
        "--probe-poses",
        "10",
        "--object-poses",
        "3",
        "--out",
        dir,
        "--json",
    ]);
    assert_eq!(v["accuracy"]["points"], 10, "{}", v["accuracy"]);
    assert_eq!(v["precision"]["poses"], 3, "{}", v["precision"]);
    assert_eq!(v["judged"]["said_right_but_off"], 0, "{}", v["judged"]);
    // Targets: ≤ 0.5 mm per axis for points, ≤ 0.3 mm per axis for the shape.
    let acc = &v["accuracy"];
    for axis in ["rms_x", "rms_y", "rms_z"] {
        assert!(f(&acc[axis]) <= 0.5, "accuracy {axis}: {acc}");
    }
    let pre = &v["precision"];
    for a in 0..3 {
        assert!(f(&pre["rms_along"][a]) <= 0.3, "{pre}");
        assert!(f(&pre["rms_marks"][a]) <= 0.3, "{pre}");
    }
    assert_eq!(v["paper"]["accuracy"][0], 0.72);
    // Every figure is written and not blank.
    for name in [
        "accuracy",
        "accuracy_errors",
        "precision_cloud",
        "precision_shapes",
        "precision_errors",
    ] {
        let png = out.join(format!("{name}.png"));
        let (inked, colours) = ink(&png);
        assert!(inked > 0.02 && colours > 10, "{name}: {inked} {colours}");
        assert!(out.join(format!("{name}.svg")).is_file());
    }
    // The tools on the data it wrote give the same figures.
    let p = |name: &str| out.join(name).to_str().unwrap().to_string();
    let points = json(&[
        "validate",
        "points",
        "--sensed-from",
        &p("stylus_tracks.jsonl"),
        "--extract",
        "tip",
        "--reference",
        &p("stylus_reference.csv"),
        "--json",
    ]);
    // The same within the files' rounding of each coordinate (ten poses register less
    // stiffly than 25: 1.2e-5 mm apart).
    assert!(
        (f(&points["rms"]) - f(&acc["rms"])).abs() < 1e-4,
        "{points}"
    );
    let shape = json(&[
        "validate",
        "shape",
        "--records",
        &p("object_tracks.jsonl"),
        "--known",
        &p("object_known.csv"),
        "--marks",
        &p("object_marks.csv"),
        "--json",
    ]);
    // The same within the records' rounding (positions to 0.1 µm, each point moved by up to
    // 0.09 µm; seen 1.3e-6 mm apart).
    assert!(
        (f(&shape["precision"]["rms_along_3d"]) - f(&pre["rms_along_3d"])).abs() < 1e-4,
        "{shape}"
    );
    // The report of a tracking output.
    let report = out.join("report");
    let o = flexshape(&[
        "report",
        "--data",
        &p("object_tracks.jsonl"),
        "--out",
        report.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    for name in ["shapes", "timings"] {
        let (inked, _) = ink(&report.join(format!("{name}.png")));
        assert!(inked > 0.02, "{name}: {inked}");
    }
}

#[test]
fn validation_input_errors_name_the_problem() {
    let dir = tempfile::tempdir().unwrap();
    let o = flexshape(&["validate"]);
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("--simulate"));
    // A known shape with one point is not a centerline.
    let known = dir.path().join("known.csv");
    std::fs::write(&known, "0,0,0\n").unwrap();
    let records = dir.path().join("r.jsonl");
    std::fs::write(&records, "").unwrap();
    let o = flexshape(&[
        "validate",
        "shape",
        "--records",
        records.to_str().unwrap(),
        "--known",
        known.to_str().unwrap(),
    ]);
    assert!(!o.status.success());
    assert!(
        String::from_utf8_lossy(&o.stderr).contains("known.csv: not a centerline"),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
    // An unknown extraction is explained.
    let o = flexshape(&[
        "validate",
        "points",
        "--sensed-from",
        records.to_str().unwrap(),
        "--extract",
        "middle",
        "--reference",
        known.to_str().unwrap(),
    ]);
    assert!(!o.status.success());
    assert!(
        String::from_utf8_lossy(&o.stderr).contains("band:K"),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
}
