//! `--foxglove` and `--ros2`: the run served live to the tools labs run, while it goes on.

use anyhow::Context;
use flexshape_foxglove::{FoxgloveServer, LiveOptions};
use flexshape_record::TrackRecord;
use flexshape_rig::Rig;
use flexshape_track::Processed;

use super::ros2;
use crate::cli::LiveArgs;

/// The live outputs a run was asked for.
pub struct LiveOutputs {
    foxglove: Option<FoxgloveServer>,
    ros2: Option<ros2::Publisher>,
}

impl LiveOutputs {
    /// Starts what `args` asks for on `rig`'s topics, each address or domain printed
    /// (`allow_remote`: a Foxglove server may listen beyond this machine).
    pub fn start(args: &LiveArgs, allow_remote: bool, rig: &Rig) -> anyhow::Result<Self> {
        let foxglove = match &args.foxglove {
            Some(addr) => {
                let server = FoxgloveServer::start(addr, allow_remote, rig, LiveOptions::default())
                    .context("cannot serve the run to Foxglove")?;
                eprintln!(
                    "foxglove: {} (in Foxglove: Open connection → Foxglove WebSocket)",
                    server.url()
                );
                Some(server)
            }
            None => None,
        };
        Ok(LiveOutputs {
            foxglove,
            ros2: ros2::start(args.ros2, rig)?,
        })
    }

    /// Sends one frame to every live output.
    pub fn publish(&mut self, record: &TrackRecord, p: &Processed) {
        if let Some(f) = &mut self.foxglove {
            f.publish(record, p);
        }
        if let Some(r) = &mut self.ros2 {
            r.publish(record, p);
        }
    }

    /// Says what was lost, if anything, when the run ends.
    pub fn finish(&self) {
        if let Some(lost) = self
            .ros2
            .as_ref()
            .map(ros2::Publisher::failed_writes)
            .filter(|&n| n > 0)
        {
            eprintln!("ros2: {lost} messages could not be sent (the middleware refused them)");
        }
    }
}
