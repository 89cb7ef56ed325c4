//! The visual hull of every frame: each carved frame's files and every frame's line, flushed
//! as written; a run stopped early says so and keeps what it wrote.

use std::sync::atomic::AtomicBool;

use flexshape_carve::PlyEncoding;
use flexshape_lab::carve::carve_all;
use flexshape_record::{HullRecord, RecordStatus};
use flexshape_sim::{SimConfig, Simulator};
use flexshape_track::Recording;

#[test]
fn every_frame_gets_its_line_and_each_carved_one_its_files() {
    let dir = tempfile::tempdir().unwrap();
    let rec = dir.path().join("rec");
    let sim = Simulator::new(SimConfig::default()).unwrap();
    sim.write_recording(&rec, &sim.sweep(3), false, |_| {
        std::ops::ControlFlow::Continue(())
    })
    .unwrap();
    let out = dir.path().join("hull");
    std::fs::create_dir_all(&out).unwrap();
    let mut recording = Recording::open(&rec).unwrap();
    let pipeline = recording.pipeline().unwrap();
    let mut shown = Vec::new();
    let done = carve_all(
        &mut recording.source,
        &pipeline,
        &out,
        PlyEncoding::Binary,
        &AtomicBool::new(false),
        |r| shown.push(r.frame),
    )
    .unwrap();
    assert_eq!((done.frames, done.carved, done.failed), (3, 3, 0));
    assert!(!done.stopped);
    assert_eq!(shown, [0, 1, 2]);
    let text = std::fs::read_to_string(out.join("hull.jsonl")).unwrap();
    let lines: Vec<HullRecord> = text
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    assert_eq!(lines.len(), 3);
    for r in &lines {
        assert_eq!(r.status, RecordStatus::Ok, "{r:?}");
        assert!(r.voxels > 0 && r.surface_mm2 > 0.0, "{r:?}");
        assert!(out.join(format!("{:06}.ply", r.frame)).is_file());
        assert!(out.join(format!("{:06}.surface.ply", r.frame)).is_file());
    }
    // Stopped before the first frame: nothing carved, the file there and empty.
    let stopped = dir.path().join("stopped");
    std::fs::create_dir_all(&stopped).unwrap();
    let mut again = Recording::open(&rec).unwrap();
    let done = carve_all(
        &mut again.source,
        &pipeline,
        &stopped,
        PlyEncoding::Ascii,
        &AtomicBool::new(true),
        |_| {},
    )
    .unwrap();
    assert!(done.stopped && done.frames == 0);
    assert_eq!(
        std::fs::read_to_string(stopped.join("hull.jsonl")).unwrap(),
        ""
    );
}
