//! The live viewer as the commands use it: started from `--viewer` (`flexshape_viewer::Live`).

use anyhow::Context;
use flexshape_track::Pipeline;
pub use flexshape_viewer::Live;

use crate::cli::ViewerArgs;

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
