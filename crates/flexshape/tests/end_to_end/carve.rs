//! `flexshape carve`: the hull alone, for any object.

use crate::common;

use serde_json::Value;

#[test]
fn carve_writes_the_hull_cloud_surface_and_figures_of_every_frame() {
    let dir = tempfile::tempdir().unwrap();
    let rec = dir.path().join("rec");
    let r = rec.to_str().unwrap();
    common::run(&["simulate", "--out", r, "--frames", "2"]);
    let out = dir.path().join("hull");
    let o = out.to_str().unwrap();
    common::run(&["carve", r, "-o", o, "--ascii-ply"]);
    let records: Vec<Value> = std::fs::read_to_string(out.join("hull.jsonl"))
        .unwrap()
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    assert_eq!(records.len(), 2);
    // The same hull as tracking carves.
    let tracked = dir.path().join("track.jsonl");
    common::run(&["track", r, "-o", tracked.to_str().unwrap()]);
    let track = common::frame_records(&tracked);
    for (h, t) in records.iter().zip(&track) {
        assert_eq!(h["status"], "ok", "{h}");
        assert_eq!(h["voxels"], t["voxels"]);
        // The capture time, as tracking reads it.
        assert_eq!(h["captured_s"], t["captured_s"]);
        assert_eq!(h["captured_from"], t["captured_from"]);
        assert!(h["captured_s"].is_number(), "{h}");
        let voxels = h["voxels"].as_u64().unwrap();
        assert!(
            (h["volume_mm3"].as_f64().unwrap() - voxels as f64).abs() < 1e-6,
            "1-mm voxels"
        );
        // A tube of radius 3 mm: a surface of the order of 2πr per mm of length, and a
        // volume of πr² per mm; their ratio is about 2/r.
        let ratio = h["surface_mm2"].as_f64().unwrap() / h["volume_mm3"].as_f64().unwrap();
        assert!((0.5..2.0).contains(&ratio), "{ratio}");
        let frame = h["frame"].as_u64().unwrap();
        let mesh = std::fs::read_to_string(out.join(format!("{frame:06}.surface.ply"))).unwrap();
        assert!(mesh.contains("element face") && mesh.contains("\n4 "));
        let cloud = std::fs::read_to_string(out.join(format!("{frame:06}.ply"))).unwrap();
        assert!(cloud.contains(&format!("element vertex {voxels}\n")));
    }
    // Run again: refused without --overwrite.
    let e = common::fails(&["carve", r, "-o", o]);
    assert!(
        e.contains("already exists") && e.contains("--overwrite"),
        "{e}"
    );
    // Binary PLY by default: 12 bytes a vertex, 17 a quad (a count and four indices).
    common::run(&["carve", r, "-o", o, "--overwrite"]);
    let text = std::fs::read_to_string(out.join("000000.surface.ply")).unwrap_err();
    assert_eq!(text.kind(), std::io::ErrorKind::InvalidData, "not text");
    let bytes = std::fs::read(out.join("000000.surface.ply")).unwrap();
    let end = bytes
        .windows(11)
        .position(|w| w == b"end_header\n")
        .unwrap()
        + 11;
    let header = std::str::from_utf8(&bytes[..end]).unwrap();
    let count = |what: &str| -> usize {
        let line = header.lines().find(|l| l.starts_with(what)).unwrap();
        line.rsplit(' ').next().unwrap().parse().unwrap()
    };
    assert!(header.contains("format binary_little_endian 1.0"));
    assert_eq!(
        bytes.len() - end,
        12 * count("element vertex") + 17 * count("element face")
    );
    // A volume away from the object leaves nothing: said per frame.
    let far = dir.path().join("far");
    common::run(&[
        "carve",
        r,
        "-o",
        far.to_str().unwrap(),
        "--volume",
        "200,200,200,260,260,260",
    ]);
    let first = std::fs::read_to_string(far.join("hull.jsonl")).unwrap();
    let v: Value = serde_json::from_str(first.lines().next().unwrap()).unwrap();
    assert_eq!(v["status"], "no_object", "{v}");
}

/// A run in which every frame failed did not do what was asked: `carve` exits with an error,
/// as `track` does, its records kept.
#[test]
fn carve_fails_when_every_frame_failed() {
    let dir = tempfile::tempdir().unwrap();
    let rec = dir.path().join("rec");
    let r = rec.to_str().unwrap();
    common::run(&["simulate", "--out", r, "--frames", "2"]);
    for n in 0..2 {
        std::fs::write(rec.join(format!("frames/cam1/{n:06}.png")), b"not a png").unwrap();
    }
    let out = dir.path().join("hull");
    let e = common::fails(&["carve", r, "-o", out.to_str().unwrap()]);
    assert!(e.contains("every one of the 2 frames failed"), "{e}");
    let records = std::fs::read_to_string(out.join("hull.jsonl")).unwrap();
    assert_eq!(records.lines().count(), 2, "{records}");
    assert!(
        records.lines().all(|l| l.contains("\"error\"")),
        "{records}"
    );
}
