//! The live viewer as the commands use it: started from `--viewer` (`flexshape_viewer::Live`).

use std::time::Duration;

use anyhow::Context;
use flexshape_track::Pipeline;
pub use flexshape_viewer::Live;

use crate::cli::ViewerArgs;
use crate::interrupt::Interrupt;

/// Starts the viewer if `--viewer` was given, and prints its address.
pub fn start(args: &ViewerArgs, pipeline: &Pipeline) -> anyhow::Result<Option<Live>> {
    let Some(addr) = &args.viewer else {
        return Ok(None);
    };
    start_at(addr, args.allow_remote, pipeline).map(Some)
}

/// Starts the viewer at `addr` and prints its address.
pub fn start_at(addr: &str, allow_remote: bool, pipeline: &Pipeline) -> anyhow::Result<Live> {
    let viewer = Live::start(addr, allow_remote, pipeline).context("cannot start the viewer")?;
    eprintln!("viewer: {}", viewer.url());
    Ok(viewer)
}

/// After the input ended: the viewer keeps showing the last frame until Ctrl-C, unless
/// `--viewer-exit` or the run was already interrupted.
pub fn linger(live: Option<&Live>, args: &ViewerArgs, stop: &Interrupt) {
    let Some(live) = live.filter(|_| !args.viewer_exit && !stop.requested()) else {
        return;
    };
    eprintln!(
        "viewer: the last frame stays at {} until Ctrl-C (--viewer-exit ends with the input)",
        live.url()
    );
    while !stop.requested() {
        std::thread::sleep(Duration::from_millis(100));
    }
}
