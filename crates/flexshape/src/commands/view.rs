//! `flexshape view`: a tracking output, or a recording tracked on the spot, played back in the
//! viewer (`flexshape_viewer::replay`).

use anyhow::{Context, ensure};
use flexshape_lab::identify::records_of;
use flexshape_viewer::{Viewer, replay, scene_of};

use crate::cli::ViewArgs;
use crate::interrupt::Interrupt;

pub fn run(args: &ViewArgs) -> anyhow::Result<()> {
    ensure!(
        args.speed.is_finite() && args.speed > 0.0,
        "--speed {}: give a positive factor (1 is the recorded pace)",
        args.speed
    );
    let stop = Interrupt::install();
    if args.records.is_dir() {
        eprintln!("tracking {} …", args.records.display());
    }
    // A JSON Lines file is read; a recording folder is tracked here first.
    let records: Vec<_> = records_of(&args.records, super::cores(), stop.flag())
        .with_context(|| args.records.display().to_string())?
        .into_iter()
        .map(|(_, r)| r)
        .collect();
    ensure!(
        !records.is_empty(),
        "{} holds no records: give a `flexshape track` JSON Lines file or a recording",
        args.records.display()
    );
    let mut viewer = Viewer::start(&args.viewer, args.allow_remote, scene_of(&records))
        .context("cannot start the viewer")?;
    eprintln!("viewer: {}", viewer.url());
    eprintln!(
        "playing {} records at {}× their pace; pause, step and seek on the page; Ctrl-C ends",
        records.len(),
        args.speed
    );
    let controls = viewer
        .take_controls()
        .context("the viewer of a replay takes controls")?;
    replay(&viewer, &records, args.speed, &controls, stop.flag());
    Ok(())
}
