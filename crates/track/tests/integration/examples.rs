//! The crate's examples run as an integrator would run them: a recording tracked to JSON
//! Lines, that stream read back, and frames fed from one's own camera driver.

use std::io::Write;
use std::path::PathBuf;
use std::process::{Command, Stdio};

use flexshape_record::{TrackLine, parse_line};
use flexshape_sim::{SimConfig, Simulator};

/// An example's executable: `cargo test` builds the examples beside the test binaries
/// (`target/PROFILE/examples/`).
fn example(name: &str) -> PathBuf {
    let exe = std::env::current_exe().expect("the test's own path");
    let profile = exe
        .parent()
        .and_then(|deps| deps.parent())
        .expect("target/PROFILE/deps/");
    let path = profile.join("examples").join(name);
    assert!(path.is_file(), "{} is not built", path.display());
    path
}

#[test]
fn a_recording_is_tracked_and_its_stream_read_back() {
    let dir = tempfile::tempdir().unwrap();
    let rec = dir.path().join("rec");
    let sim = Simulator::new(SimConfig::default()).unwrap();
    sim.write_recording(&rec, &sim.sweep(3), false, |_| {
        std::ops::ControlFlow::Continue(())
    })
    .unwrap();
    let tracked = Command::new(example("track_recording"))
        .arg(&rec)
        .output()
        .unwrap();
    assert!(
        tracked.status.success(),
        "{}",
        String::from_utf8_lossy(&tracked.stderr)
    );
    let stream = String::from_utf8(tracked.stdout).unwrap();
    let mut records = 0;
    for line in stream.lines() {
        if let Some(TrackLine::Record(r)) = parse_line(line).unwrap() {
            assert!(r.status.is_ok(), "{line}");
            records += 1;
        }
    }
    assert_eq!(records, 3, "{stream}");
    // The stream piped into the reader.
    let mut reader = Command::new(example("read_stream"))
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .spawn()
        .unwrap();
    reader
        .stdin
        .take()
        .unwrap()
        .write_all(stream.as_bytes())
        .unwrap();
    let read = reader.wait_with_output().unwrap();
    assert!(read.status.success());
    let text = String::from_utf8(read.stdout).unwrap();
    assert_eq!(
        text.lines().filter(|l| l.contains(": ok tip")).count(),
        3,
        "{text}"
    );
}

#[test]
fn frames_from_ones_own_driver_are_followed() {
    let run = Command::new(example("own_camera")).output().unwrap();
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    let text = String::from_utf8(run.stdout).unwrap();
    let frames: Vec<&str> = text.lines().filter(|l| l.starts_with("frame ")).collect();
    assert_eq!(frames.len(), 20, "{text}");
    // After the first, every frame starts from the one before and is right.
    assert!(
        frames[1..]
            .iter()
            .all(|l| l.contains(": ok (from previous)")),
        "{text}"
    );
}
