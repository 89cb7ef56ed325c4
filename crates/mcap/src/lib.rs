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
//! | `/tf_static` | `tf2_msgs/msg/TFMessage` | every camera's pose in `world` (its optical frame, OpenCV's axes) |
//! | `/flexshape/CAM/camera_info` | `sensor_msgs/msg/CameraInfo` | every frame, beside its image |
//! | `/flexshape/CAM/image` | `sensor_msgs/msg/Image` (`rgb8`) | with [`McapOptions::images`] |
//! | `/flexshape/CAM/silhouette` | `sensor_msgs/msg/Image` (`mono8`, object 255) | with [`McapOptions::images`] |
//!
//! A message's log time is the frame's capture time where the input knows it, else when the
//! chain finished it; the frame number is its sequence number.
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

use std::collections::BTreeMap;
use std::fs::File;
use std::io::BufWriter;
use std::path::{Path, PathBuf};

use flexshape_camera::Camera;
use flexshape_rig::Rig;
use flexshape_track::{Processed, TrackRecord};
use mcap::records::MessageHeader;
use nalgebra::UnitQuaternion;
use thiserror::Error;

pub use cdr::Cdr;
use msgs::{Marker, MessageType, Transform};

/// The world frame's id in every message.
pub const WORLD_FRAME: &str = "world";

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
    /// Every camera's image (`rgb8`; about 0.9 MB per 640×480 image, uncompressed) and
    /// silhouette (`mono8`).
    pub images: bool,
    /// Replace an existing file.
    pub overwrite: bool,
}

/// Channel ids of the per-frame topics.
struct Channels {
    centerline: u16,
    tube: u16,
    hull: u16,
    record: u16,
    tf: u16,
    /// Per camera: camera info, and image and silhouette when asked for.
    cameras: Vec<(u16, Option<(u16, u16)>)>,
}

/// An MCAP file being written, one frame at a time.
pub struct McapSink {
    writer: mcap::Writer<BufWriter<File>>,
    path: PathBuf,
    channels: Channels,
    cameras: Vec<(String, Camera)>,
    tf_written: bool,
}

impl McapSink {
    /// Creates `path` for `rig`'s cameras.
    pub fn create(path: &Path, rig: &Rig, options: McapOptions) -> Result<Self, McapError> {
        let cameras: Vec<(String, Camera)> = rig
            .cameras
            .iter()
            .map(|c| (c.name.clone(), c.camera.clone()))
            .collect();
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
        let mut add = |ty: &MessageType, topic: &str| -> Result<u16, mcap::McapError> {
            let schema = writer.add_schema(ty.name, "ros2msg", ty.schema().as_bytes())?;
            writer.add_channel(schema, topic, "cdr", &BTreeMap::new())
        };
        let centerline = add(&msgs::PATH, "/flexshape/centerline").map_err(mcap)?;
        let tube = add(&msgs::MARKER_ARRAY, "/flexshape/tube").map_err(mcap)?;
        let hull = add(&msgs::POINT_CLOUD2, "/flexshape/hull").map_err(mcap)?;
        let tf = add(&msgs::TF_MESSAGE, "/tf_static").map_err(mcap)?;
        let mut per_camera = Vec::new();
        for (name, _) in &cameras {
            let info = add(
                &msgs::CAMERA_INFO,
                &format!("/flexshape/{name}/camera_info"),
            )
            .map_err(mcap)?;
            let image = match options.images {
                true => Some((
                    add(&msgs::IMAGE, &format!("/flexshape/{name}/image")).map_err(mcap)?,
                    add(&msgs::IMAGE, &format!("/flexshape/{name}/silhouette")).map_err(mcap)?,
                )),
                false => None,
            };
            per_camera.push((info, image));
        }
        let record_schema = writer
            .add_schema(
                "flexshape.TrackRecord",
                "jsonschema",
                br#"{"type":"object","description":"A flexshape JSON Lines record (docs/formats.md)"}"#,
            )
            .map_err(mcap)?;
        let record = writer
            .add_channel(record_schema, "/flexshape/record", "json", &BTreeMap::new())
            .map_err(mcap)?;
        Ok(McapSink {
            writer,
            path: path.to_path_buf(),
            channels: Channels {
                centerline,
                tube,
                hull,
                record,
                tf,
                cameras: per_camera,
            },
            cameras,
            tf_written: false,
        })
    }

    /// Writes one tracked frame: its record, and what it holds of the shape and the images.
    pub fn write(&mut self, record: &TrackRecord, p: &Processed) -> Result<(), McapError> {
        let stamp = stamp_ns(record);
        let sequence = record.frame as u32;
        if !self.tf_written {
            let tf = self.camera_transforms(stamp);
            self.put(self.channels.tf, sequence, stamp, &tf)?;
            self.tf_written = true;
        }
        let json = serde_json::to_vec(record).unwrap_or_default();
        self.put(self.channels.record, sequence, stamp, &json)?;
        let metres: Vec<[f64; 3]> = record
            .centerline
            .iter()
            .map(|p| p.map(|v| v / 1e3))
            .collect();
        if !metres.is_empty() {
            let path = msgs::path(stamp, WORLD_FRAME, &metres);
            self.put(self.channels.centerline, sequence, stamp, &path)?;
        }
        let tube = tube_markers(stamp, record, &metres);
        self.put(self.channels.tube, sequence, stamp, &tube)?;
        if let Some(t) = p.result.as_ref().ok().filter(|t| !t.occupancy.is_empty()) {
            let cloud: Vec<[f32; 3]> = t
                .occupancy
                .to_cloud()
                .points
                .iter()
                .map(|p| p.map(|v| v / 1e3))
                .collect();
            let msg = msgs::point_cloud(stamp, WORLD_FRAME, &cloud);
            self.put(self.channels.hull, sequence, stamp, &msg)?;
        }
        for i in 0..self.cameras.len() {
            let (name, camera) = &self.cameras[i];
            let name = name.clone();
            let k = &camera.intrinsics;
            let info = msgs::camera_info(
                stamp,
                &name,
                (k.width, k.height),
                &k.distortion.to_opencv(),
                [k.fx, 0.0, k.cx, 0.0, k.fy, k.cy, 0.0, 0.0, 1.0],
            );
            self.put(self.channels.cameras[i].0, sequence, stamp, &info)?;
            let Some((image, silhouette)) = self.channels.cameras[i].1 else {
                continue;
            };
            if let Some(img) = p.images.get(i) {
                let (w, h) = img.dimensions();
                let msg = msgs::image(stamp, &name, (w, h), "rgb8", 3 * w, img.as_raw());
                self.put(image, sequence, stamp, &msg)?;
            }
            if let Some(s) = p.result.as_ref().ok().and_then(|t| t.silhouettes.get(i)) {
                let mask = s.object.to_gray();
                let (w, h) = mask.dimensions();
                let msg = msgs::image(stamp, &name, (w, h), "mono8", w, mask.as_raw());
                self.put(silhouette, sequence, stamp, &msg)?;
            }
        }
        Ok(())
    }

    /// Writes the file's summary and index and closes it.
    pub fn finish(mut self) -> Result<(), McapError> {
        let path = self.path.clone();
        self.writer
            .finish()
            .map_err(|source| McapError::Mcap { path, source })?;
        Ok(())
    }

    fn put(
        &mut self,
        channel: u16,
        sequence: u32,
        stamp: u64,
        data: &[u8],
    ) -> Result<(), McapError> {
        let header = MessageHeader {
            channel_id: channel,
            sequence,
            log_time: stamp,
            publish_time: stamp,
        };
        self.writer
            .write_to_known_channel(&header, data)
            .map_err(|source| McapError::Mcap {
                path: self.path.clone(),
                source,
            })
    }

    /// Every camera's optical frame in the world frame: at its centre (m), turned by Rᵀ.
    fn camera_transforms(&self, stamp: u64) -> Vec<u8> {
        let transforms: Vec<Transform> = self
            .cameras
            .iter()
            .map(|(name, camera)| {
                let c = camera.centre();
                let q = UnitQuaternion::from_rotation_matrix(&camera.pose.rotation.inverse());
                Transform {
                    parent: WORLD_FRAME,
                    child: name,
                    translation: [c.x / 1e3, c.y / 1e3, c.z / 1e3],
                    rotation: [q.i, q.j, q.k, q.w],
                }
            })
            .collect();
        msgs::tf_message(stamp, &transforms)
    }
}

/// The frame's time, ns since the Unix epoch: captured, else processed, else the frame
/// number at 30 frames/s.
fn stamp_ns(record: &TrackRecord) -> u64 {
    let s = record
        .captured_s
        .or(record.processed_s)
        .unwrap_or(record.frame as f64 / 30.0);
    (s.max(0.0) * 1e9).round() as u64
}

/// The tube as a line strip as wide as it, its bands as spheres, its tip as a sphere, after
/// a marker that deletes every earlier one: a frame without a shape (or without bands) leaves
/// none of the last frame's standing (an empty array clears nothing in RViz or Foxglove).
fn tube_markers(stamp: u64, record: &TrackRecord, metres: &[[f64; 3]]) -> Vec<u8> {
    let diameter = 2.0 * record.radius.unwrap_or(1.0) / 1e3;
    let bands: Vec<[f64; 3]> = record
        .bands
        .iter()
        .map(|b| b.position.map(|v| v / 1e3))
        .collect();
    let tip: Vec<[f64; 3]> = record.tip.iter().map(|t| t.map(|v| v / 1e3)).collect();
    let mut markers = vec![Marker {
        ns: "",
        id: 0,
        kind: 0,
        position: [0.0; 3],
        scale: [0.0; 3],
        color: [0.0; 4],
        points: &[],
        action: msgs::DELETE_ALL,
    }];
    if !metres.is_empty() {
        markers.push(Marker {
            ns: "tube",
            id: 0,
            kind: 4,
            position: [0.0; 3],
            scale: [diameter, 0.0, 0.0],
            color: [0.2, 0.6, 1.0, 0.8],
            points: metres,
            action: 0,
        });
    }
    if !bands.is_empty() {
        markers.push(Marker {
            ns: "bands",
            id: 0,
            kind: 7,
            position: [0.0; 3],
            scale: [diameter * 1.2; 3],
            color: [0.9, 0.1, 0.1, 1.0],
            points: &bands,
            action: 0,
        });
    }
    if let Some(t) = tip.first() {
        markers.push(Marker {
            ns: "tip",
            id: 0,
            kind: 2,
            position: *t,
            scale: [diameter * 1.3; 3],
            color: [1.0, 0.8, 0.0, 1.0],
            points: &[],
            action: 0,
        });
    }
    msgs::marker_array(stamp, WORLD_FRAME, &markers)
}
