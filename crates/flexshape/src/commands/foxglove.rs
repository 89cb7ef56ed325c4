//! `--foxglove`: the run served live to Foxglove while it goes on.

use anyhow::Context;
use flexshape_foxglove::{FoxgloveServer, LiveOptions};
use flexshape_rig::Rig;

/// The Foxglove server `--foxglove ADDR` asks for, its address printed.
pub fn start(
    addr: Option<&str>,
    allow_remote: bool,
    rig: &Rig,
) -> anyhow::Result<Option<FoxgloveServer>> {
    let Some(addr) = addr else {
        return Ok(None);
    };
    let server = FoxgloveServer::start(addr, allow_remote, rig, LiveOptions::default())
        .context("cannot serve the run to Foxglove")?;
    eprintln!(
        "foxglove: {} (in Foxglove: Open connection → Foxglove WebSocket)",
        server.url()
    );
    Ok(Some(server))
}
