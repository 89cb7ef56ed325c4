//! `flexshape view`: a tracking output, or a recording tracked frame by frame as it is shown,
//! played back in the viewer (`flexshape_viewer::replay`).

use anyhow::{Context, ensure};
use flexshape_viewer::{RecordStream, RecordingReplay, Replayed, Viewer, replay};

use crate::cli::ViewArgs;
use crate::interrupt::Interrupt;

pub fn run(args: &ViewArgs) -> anyhow::Result<()> {
    ensure!(
        args.speed.is_finite() && args.speed > 0.0,
        "--speed {}: give a positive factor (1 is the recorded pace)",
        args.speed
    );
    let stop = Interrupt::install();
    // A recording is tracked frame by frame as it is shown; a JSON Lines file is read.
    let mut played: Box<dyn Replayed> = if args.records.is_dir() {
        Box::new(
            RecordingReplay::open(&args.records)
                .with_context(|| format!("cannot replay {}", args.records.display()))?,
        )
    } else {
        let records: Vec<_> = flexshape_record::read_records(&args.records)?
            .into_iter()
            .map(|(_, r)| r)
            .collect();
        Box::new(RecordStream(records))
    };
    ensure!(
        played.frames() > 0,
        "{} holds no records: give a `flexshape track` JSON Lines file or a recording",
        args.records.display()
    );
    let mut viewer = Viewer::start(&args.viewer, args.allow_remote, played.scene())
        .context("cannot start the viewer")?;
    eprintln!("viewer: {}", viewer.url());
    eprintln!(
        "playing {} frames at {}× their pace; pause, step and seek on the page; Ctrl-C ends",
        played.frames(),
        args.speed
    );
    let controls = viewer
        .take_controls()
        .context("the viewer of a replay takes controls")?;
    replay(&viewer, played.as_mut(), args.speed, &controls, stop.flag());
    Ok(())
}
