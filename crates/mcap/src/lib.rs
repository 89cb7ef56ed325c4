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

use flexshape_record::TrackRecord;
use flexshape_rig::Rig;
use flexshape_track::Processed;
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

/// How the file's chunks are compressed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Compression {
    /// zstd (every MCAP reader reads it): raw images about 43 % smaller.
    #[default]
    Zstd,
    /// None: the largest file, the least work.
    None,
}

/// What goes into the file beyond the shapes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct McapOptions {
    /// Every camera's image and silhouette, and in which format.
    pub images: ImageFormat,
    /// How chunks are compressed.
    pub compression: Compression,
    /// Replace an existing file.
    pub overwrite: bool,
}

/// Messages queued for the writer thread before a frame's writing waits for it.
const QUEUE: usize = 256;

/// One message on its way to the file.
struct Queued {
    channel_id: u16,
    sequence: u32,
    stamp: u64,
    data: Vec<u8>,
}

/// An MCAP file being written, one frame at a time. Compressing and writing run on a thread
/// of their own, so a frame's caller only encodes its messages; the file is whole once
/// [`McapSink::finish`] returns (or, unasked, when the sink is dropped).
pub struct McapSink {
    path: PathBuf,
    topics: FrameTopics,
    /// Each topic's channel id.
    channels: Vec<(TopicId, u16)>,
    tf_written: bool,
    queue: Option<std::sync::mpsc::SyncSender<Queued>>,
    writer: Option<std::thread::JoinHandle<Result<(), McapError>>>,
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
        let compression = match options.compression {
            Compression::Zstd => Some(mcap::Compression::Zstd),
            Compression::None => None,
        };
        let mut writer = mcap::WriteOptions::new()
            .compression(compression)
            // The writer has its own thread; zstd's workers would take the tracking's cores.
            .compression_threads(0)
            // Level 1: a camera rate of raw images on one core; level 3 took twice as long
            // for 6 % less.
            .compression_level(1)
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
        let (queue, queued) = std::sync::mpsc::sync_channel::<Queued>(QUEUE);
        let file_path = path.to_path_buf();
        let thread = std::thread::Builder::new()
            .name("mcap-writer".into())
            .spawn(move || {
                let mcap = |source| McapError::Mcap {
                    path: file_path.clone(),
                    source,
                };
                for m in queued {
                    let header = MessageHeader {
                        channel_id: m.channel_id,
                        sequence: m.sequence,
                        log_time: m.stamp,
                        publish_time: m.stamp,
                    };
                    writer
                        .write_to_known_channel(&header, &m.data)
                        .map_err(mcap)?;
                }
                writer.finish().map_err(mcap)?;
                Ok(())
            })
            .map_err(io)?;
        Ok(McapSink {
            path: path.to_path_buf(),
            topics,
            channels,
            tf_written: false,
            queue: Some(queue),
            writer: Some(thread),
        })
    }

    /// Writes one tracked frame: its record, and what it holds of the shape and the images.
    /// An error is the writer's (the disk full, …), from this frame or an earlier one.
    pub fn write(&mut self, record: &TrackRecord, p: &Processed) -> Result<(), McapError> {
        let stamp = stamp_ns(record);
        let sequence = record.frame as u32;
        let mut messages = Vec::new();
        if !self.tf_written {
            messages.push((TopicId::Transforms, self.topics.transforms(stamp)));
            self.tf_written = true;
        }
        let _ = self.topics.messages(
            record,
            p,
            |_| true,
            |id, data| {
                messages.push((id, data.to_vec()));
                Ok::<(), std::convert::Infallible>(())
            },
        );
        for (id, data) in messages {
            // Every topic a frame speaks on was given a channel in `create`.
            let Some(&(_, channel_id)) = self.channels.iter().find(|(t, _)| *t == id) else {
                continue;
            };
            let queued = Queued {
                channel_id,
                sequence,
                stamp,
                data,
            };
            let sent = self.queue.as_ref().map(|q| q.send(queued));
            if !matches!(sent, Some(Ok(()))) {
                // The writer stopped: its error says why.
                return Err(self.join().err().unwrap_or_else(|| self.stopped()));
            }
        }
        Ok(())
    }

    /// Writes the file's summary and index and closes it.
    pub fn finish(mut self) -> Result<(), McapError> {
        self.join()
    }

    /// Closes the queue and waits for the writer to end the file.
    fn join(&mut self) -> Result<(), McapError> {
        self.queue = None;
        match self.writer.take() {
            Some(thread) => thread.join().unwrap_or_else(|_| Err(self.stopped())),
            None => Ok(()),
        }
    }

    /// The error of a writer that ended without saying why.
    fn stopped(&self) -> McapError {
        McapError::Io {
            path: self.path.clone(),
            source: std::io::Error::other("the MCAP writer stopped"),
        }
    }
}

impl Drop for McapSink {
    /// A sink dropped unfinished still ends its file whole.
    fn drop(&mut self) {
        let _ = self.join();
    }
}
