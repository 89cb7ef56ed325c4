//! A recording folder opened as a library user opens it, tracked, its records written as
//! `flexshape track` writes them and read back; what cannot be read is named.

use std::ops::ControlFlow;
use std::sync::atomic::AtomicBool;

use flexshape_record::{SummaryLine, TrackLine, parse_line, read_records};
use flexshape_sim::{SimConfig, Simulator};
use flexshape_track::{Recording, Tally, run};

#[test]
fn a_recording_is_tracked_and_its_records_read_back() {
    let dir = tempfile::tempdir().unwrap();
    let rec = dir.path().join("rec");
    let sim = Simulator::new(SimConfig::default()).unwrap();
    sim.write_recording(&rec, &sim.motion(4, 120.0), false, |_| {
        ControlFlow::Continue(())
    })
    .unwrap();
    let mut recording = Recording::open(&rec).unwrap();
    assert_eq!(recording.backgrounds.as_ref().map(Vec::len), Some(3));
    assert!(recording.skipped().is_empty());
    let pipeline = recording.pipeline().unwrap().following(true).unwrap();
    let mut lines = Vec::new();
    let mut tally = Tally::new();
    let end = run(
        &mut recording.source,
        &pipeline,
        2,
        &AtomicBool::new(false),
        |p| {
            let record = p.record();
            tally.add(&record);
            lines.push(serde_json::to_string(&record).unwrap());
            ControlFlow::Continue(())
        },
    );
    assert_eq!(end.frames, 4);
    let summary = SummaryLine {
        summary: tally.summary(&end),
    };
    lines.push(String::new());
    lines.push(serde_json::to_string(&summary).unwrap());
    let jsonl = dir.path().join("shapes.jsonl");
    std::fs::write(&jsonl, lines.join("\n")).unwrap();
    let records = read_records(&jsonl).unwrap();
    assert_eq!(records.len(), 4);
    assert!(records.iter().all(|(_, r)| r.status == "ok"), "{records:?}");
    assert_eq!(
        records
            .iter()
            .map(|(l, r)| (*l, r.frame))
            .collect::<Vec<_>>(),
        [(1, 0), (2, 1), (3, 2), (4, 3)]
    );
    match parse_line(lines.last().unwrap()).unwrap() {
        Some(TrackLine::Summary(s)) => assert_eq!((s.frames, s.ok), (4, 4)),
        other => panic!("{other:?}"),
    }
    assert_eq!(parse_line("  ").unwrap(), None);

    // A summary line, whatever it holds, is not a record; parse_line reads it strictly.
    std::fs::write(&jsonl, format!("{}\n{{\"summary\": {{}}}}\n", lines[0])).unwrap();
    assert_eq!(read_records(&jsonl).unwrap().len(), 1);
    assert!(
        parse_line("{\"summary\": {}}")
            .unwrap_err()
            .starts_with("not a summary")
    );
    // What is wrong is said with the file and the line.
    std::fs::write(&jsonl, format!("{}\n{{\"frame\": 1}}\n", lines[0])).unwrap();
    let e = read_records(&jsonl).unwrap_err().to_string();
    assert!(
        e.contains("shapes.jsonl line 2: not a tracking record"),
        "{e}"
    );
    std::fs::write(&jsonl, "{").unwrap();
    let e = read_records(&jsonl).unwrap_err().to_string();
    assert!(e.contains("line 1: not JSON"), "{e}");
    let e = read_records(&dir.path().join("none.jsonl")).unwrap_err();
    assert!(
        matches!(e, flexshape_record::RecordError::Records { line: None, .. }),
        "{e}"
    );
    // A recording without its backgrounds names the camera and the file.
    std::fs::remove_file(rec.join("background").join("cam1.png")).unwrap();
    let e = Recording::open(&rec).err().unwrap().to_string();
    assert!(
        e.starts_with("camera cam1: tracking needs its background image"),
        "{e}"
    );
    assert!(Recording::open(&dir.path().join("none")).is_err());
}
