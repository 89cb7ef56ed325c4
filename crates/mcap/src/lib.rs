//! Tracked shapes as an MCAP file (`flexshape track --mcap`) in the standard ROS 2 message
//! layouts (CDR, `ros2msg` schemas), so Foxglove, the `mcap` readers and ROS 2 tools
//! (`ros2 bag` reads MCAP) show them with no glue. Lengths in metres, as ROS has them.
//!
//! | topic | type | what |
//! |---|---|---|
//! | `/flexshape/centerline` | `nav_msgs/msg/Path` | the centerline, proximal to distal, each pose's x axis along it |
//! | `/flexshape/tube` | `visualization_msgs/msg/MarkerArray` | a DELETEALL marker, then the tube (a line strip as wide as the tube), bands, tip |
//! | `/flexshape/hull` | `sensor_msgs/msg/PointCloud2` | the carved voxel centres (frames that were carved) |
//! | `/flexshape/record` | JSON (`jsonschema`) | the frame's JSON Lines record, whole |
//! | `/tf_static` | `tf2_msgs/msg/TFMessage` | every camera's pose in `world` (its optical frame, OpenCV's axes); QoS transient local for `ros2 bag play` |
//! | `/flexshape/CAM/camera_info` | `sensor_msgs/msg/CameraInfo` | every frame, beside its image |
//! | `/flexshape/CAM/image` | `sensor_msgs/msg/Image` (`rgb8`) or `CompressedImage` (JPEG, PNG) | with [`McapOptions::images`] |
//! | `/flexshape/CAM/silhouette` | `sensor_msgs/msg/Image` (`mono8`, object 255) or `CompressedImage` (PNG) | with [`McapOptions::images`] |
//!
//! A message's log time is the frame's capture time where the input knows it, else when the
//! chain finished it; the frame number is its sequence number. What each frame says on which
//! topic has one home, [`topics`], which live connections share.
//!
//! ```no_run
//! use flexshape_mcap::{McapOptions, McapSink};
//! # fn main() -> Result<(), Box<dyn std::error::Error>> {
//! let rig = flexshape_rig::Rig::load(std::path::Path::new("rig.toml"))?;
//! let mut sink = McapSink::create("shapes.mcap".as_ref(), &rig, McapOptions::default())?;
//! // For every tracked frame: sink.write(&record, &processed)?;
//! sink.finish()?;
//! # Ok(())
//! # }
//! ```

mod cdr;
pub mod msgs;
pub mod topics;

use std::collections::BTreeMap;
use std::fs::File;
use std::io::BufWriter;
use std::path::{Path, PathBuf};

use flexshape_rig::Rig;
use flexshape_track::{Processed, TrackRecord};
use mcap::records::MessageHeader;
use thiserror::Error;

pub use cdr::Cdr;
pub use topics::{
    FrameTopics, ImageFormat, ImageRate, LiveOptions, Topic, TopicId, WORLD_FRAME, stamp_ns,
};

/// Why the MCAP file cannot be written.
#[derive(Debug, Error)]
pub enum McapError {
    /// The file could not be created or written.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// What went wrong.
        source: std::io::Error,
    },
    /// The MCAP writer refused.
    #[error("{}: {source}", path.display())]
    Mcap {
        /// The file.
        path: PathBuf,
        /// What went wrong.
        source: mcap::McapError,
    },
    /// The file exists and replacing it was not asked for.
    #[error("{} already exists: give --overwrite to replace it, or another file", .0.display())]
    Exists(PathBuf),
}

/// What goes into the file beyond the shapes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct McapOptions {
    /// Every camera's image and silhouette, and in which format.
    pub images: ImageFormat,
    /// Replace an existing file.
    pub overwrite: bool,
}

/// An MCAP file being written, one frame at a time.
pub struct McapSink {
    writer: mcap::Writer<BufWriter<File>>,
    path: PathBuf,
    topics: FrameTopics,
    /// Each topic's channel id.
    channels: Vec<(TopicId, u16)>,
    tf_written: bool,
}

impl McapSink {
    /// Creates `path` for `rig`'s cameras.
    pub fn create(path: &Path, rig: &Rig, options: McapOptions) -> Result<Self, McapError> {
        if path.exists() && !options.overwrite {
            return Err(McapError::Exists(path.to_path_buf()));
        }
        let io = |source| McapError::Io {
            path: path.to_path_buf(),
            source,
        };
        let file = File::create(path).map_err(io)?;
        let mcap = |source| McapError::Mcap {
            path: path.to_path_buf(),
            source,
        };
        let mut writer = mcap::WriteOptions::new()
            .compression(None)
            .profile("ros2")
            .create(BufWriter::new(file))
            .map_err(mcap)?;
        let topics = FrameTopics::new(rig, options.images);
        let mut channels = Vec::new();
        for t in topics.topics() {
            let schema = writer
                .add_schema(t.schema_name, t.schema_encoding, t.schema.as_bytes())
                .map_err(mcap)?;
            let metadata: BTreeMap<String, String> = t
                .qos
                .map(|q| ("offered_qos_profiles".to_string(), q.to_string()))
                .into_iter()
                .collect();
            let channel = writer
                .add_channel(schema, &t.name, t.message_encoding, &metadata)
                .map_err(mcap)?;
            channels.push((t.id, channel));
        }
        Ok(McapSink {
            writer,
            path: path.to_path_buf(),
            topics,
            channels,
            tf_written: false,
        })
    }

    /// Writes one tracked frame: its record, and what it holds of the shape and the images.
    pub fn write(&mut self, record: &TrackRecord, p: &Processed) -> Result<(), McapError> {
        let stamp = stamp_ns(record);
        let sequence = record.frame as u32;
        let McapSink {
            writer,
            path,
            topics,
            channels,
            tf_written,
        } = self;
        let mut put = |topic: TopicId, data: &[u8]| {
            // Every topic a frame speaks on was given a channel in `create`.
            let Some(&(_, channel_id)) = channels.iter().find(|(id, _)| *id == topic) else {
                return Ok(());
            };
            let header = MessageHeader {
                channel_id,
                sequence,
                log_time: stamp,
                publish_time: stamp,
            };
            writer
                .write_to_known_channel(&header, data)
                .map_err(|source| McapError::Mcap {
                    path: path.clone(),
                    source,
                })
        };
        if !*tf_written {
            put(TopicId::Transforms, &topics.transforms(stamp))?;
            *tf_written = true;
        }
        topics.messages(record, p, |_| true, put)
    }

    /// Writes the file's summary and index and closes it.
    pub fn finish(mut self) -> Result<(), McapError> {
        let path = self.path.clone();
        self.writer
            .finish()
            .map_err(|source| McapError::Mcap { path, source })?;
        Ok(())
    }
}
