//! Tracks a recording folder (as `flexshape simulate` or `flexshape capture` writes it) and
//! writes one JSON Lines record per frame to standard output, as `flexshape track REC` does.
//!
//! ```text
//! flexshape simulate --out /tmp/rec --frames 10
//! cargo run --release -p flexshape-track --example track_recording -- /tmp/rec
//! ```

use std::ops::ControlFlow;
use std::sync::atomic::AtomicBool;

use flexshape_track::{Recording, run};

fn main() {
    if let Err(e) = track() {
        eprintln!("error: {e}");
        std::process::exit(1);
    }
}

fn track() -> Result<(), Box<dyn std::error::Error>> {
    let dir = std::env::args()
        .nth(1)
        .ok_or("usage: track_recording RECORDING_DIR")?;
    let mut recording = Recording::open(dir.as_ref())?;
    let pipeline = recording.pipeline()?;
    let stop = AtomicBool::new(false); // set it (e.g. from a Ctrl-C handler) to stop early
    let end = run(&mut recording.source, &pipeline, 2, &stop, |processed| {
        let record = processed.record();
        println!("{}", serde_json::to_string(&record).unwrap_or_default());
        ControlFlow::Continue(())
    });
    eprintln!("{} frames", end.frames);
    Ok(())
}
