//! What a tracked frame says on which topic, whatever carries it: an MCAP file
//! ([`crate::McapSink`]) or a live connection (`flexshape-foxglove`). One home, so that a live
//! viewer and a file show the same messages byte for byte.

use flexshape_camera::Camera;
use flexshape_record::TrackRecord;
use flexshape_rig::Rig;
use flexshape_track::Processed;
use image::{ExtendedColorType, ImageEncoder, RgbImage};
use nalgebra::UnitQuaternion;

use crate::msgs::{self, Marker, MessageType, Transform};

/// The world frame's id in every message.
pub const WORLD_FRAME: &str = "world";

/// rosbag2's QoS profile for `/tf_static` (the `offered_qos_profiles` channel metadata):
/// reliable and transient local, so `ros2 bag play` latches the cameras' poses for nodes that
/// start later, as a live `/tf_static` publisher does. Deadline, lifespan and lease 0: the
/// middleware's defaults.
pub const TF_STATIC_QOS: &str = "- history: 1\n  depth: 1\n  reliability: 1\n  durability: 1\n  deadline:\n    sec: 0\n    nsec: 0\n  lifespan:\n    sec: 0\n    nsec: 0\n  liveliness: 1\n  liveliness_lease_duration:\n    sec: 0\n    nsec: 0\n  avoid_ros_namespace_conventions: false\n";

/// Which of a frame's messages a topic carries.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum TopicId {
    /// `/flexshape/centerline`: `nav_msgs/msg/Path`.
    Centerline,
    /// `/flexshape/tube`: `visualization_msgs/msg/MarkerArray`.
    Tube,
    /// `/flexshape/hull`: `sensor_msgs/msg/PointCloud2`.
    Hull,
    /// `/flexshape/record`: the JSON Lines record.
    Record,
    /// `/tf_static`: `tf2_msgs/msg/TFMessage`, every camera's pose.
    Transforms,
    /// `/flexshape/CAM/camera_info` of the rig's camera with this index.
    CameraInfo(usize),
    /// `/flexshape/CAM/image` of the rig's camera with this index.
    Image(usize),
    /// `/flexshape/CAM/silhouette` of the rig's camera with this index.
    Silhouette(usize),
}

impl TopicId {
    /// Whether the topic carries a camera's view (its image or silhouette): what live carriers
    /// send at a capped rate.
    pub fn is_view(self) -> bool {
        matches!(self, TopicId::Image(_) | TopicId::Silhouette(_))
    }
}

/// How camera images and silhouettes are carried, if at all.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum ImageFormat {
    /// No images.
    #[default]
    None,
    /// `sensor_msgs/Image`, `rgb8` and `mono8` (about 0.9 MB per 640×480 image).
    Raw,
    /// `sensor_msgs/CompressedImage`: images as JPEG (quality 90), silhouettes as PNG (a
    /// mask's edges would blur in JPEG). About 45 kB per 640×480 image.
    Jpeg,
    /// `sensor_msgs/CompressedImage`, PNG: lossless, several times smaller than raw, slower
    /// to write than JPEG.
    Png,
}

impl ImageFormat {
    /// Whether images are carried at all.
    pub fn any(self) -> bool {
        self != ImageFormat::None
    }

    /// The message type of images in this format.
    fn message_type(self) -> &'static MessageType {
        match self {
            ImageFormat::Raw | ImageFormat::None => &msgs::IMAGE,
            ImageFormat::Jpeg | ImageFormat::Png => &msgs::COMPRESSED_IMAGE,
        }
    }
}

/// What a live carrier (Foxglove, ROS 2) sends of the cameras' views: a live viewer wants the
/// images, but not at the price of the shapes' pace.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LiveOptions {
    /// The cameras' images and silhouettes, in this format ([`ImageFormat::None`]: none).
    pub images: ImageFormat,
    /// At most this many frames' images a second (wall clock): a 640×480 JPEG is about
    /// 45 kB, raw 0.9 MB.
    pub image_hz: f64,
}

impl Default for LiveOptions {
    /// JPEG images (PNG silhouettes) at most 10 frames a second.
    fn default() -> Self {
        LiveOptions {
            images: ImageFormat::Jpeg,
            image_hz: 10.0,
        }
    }
}

/// When a live carrier sends the next frame's images: at most [`LiveOptions::image_hz`] a
/// second.
#[derive(Debug, Clone)]
pub struct ImageRate {
    every: std::time::Duration,
    last: Option<std::time::Instant>,
}

impl ImageRate {
    /// At most `hz` frames' images a second (every frame when `hz` is not a positive number).
    pub fn new(hz: f64) -> Self {
        let every = match hz > 0.0 && hz.is_finite() {
            true => std::time::Duration::from_secs_f64(1.0 / hz),
            false => std::time::Duration::ZERO,
        };
        ImageRate { every, last: None }
    }

    /// Whether this frame's images may go.
    pub fn due(&self) -> bool {
        self.last.is_none_or(|t| t.elapsed() >= self.every)
    }

    /// This frame's images went.
    pub fn sent(&mut self) {
        self.last = Some(std::time::Instant::now());
    }
}

/// One topic: its name, the schema its messages follow, how they are encoded.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Topic {
    /// What it carries.
    pub id: TopicId,
    /// Its name, e.g. `/flexshape/centerline`.
    pub name: String,
    /// The schema's name, e.g. `nav_msgs/msg/Path`.
    pub schema_name: &'static str,
    /// `ros2msg` or `jsonschema`.
    pub schema_encoding: &'static str,
    /// The schema's text.
    pub schema: String,
    /// `cdr` or `json`.
    pub message_encoding: &'static str,
    /// rosbag2's QoS profile where it is not the default ([`TF_STATIC_QOS`] on `/tf_static`).
    pub qos: Option<&'static str>,
}

impl Topic {
    fn ros2(id: TopicId, name: String, ty: &MessageType) -> Topic {
        Topic {
            id,
            name,
            schema_name: ty.name,
            schema_encoding: "ros2msg",
            schema: ty.schema(),
            message_encoding: "cdr",
            qos: None,
        }
    }
}

/// The topics of a rig's tracked frames, and each frame's messages on them (lengths in
/// metres, as ROS has them; stamps in ns since the Unix epoch).
#[derive(Debug, Clone)]
pub struct FrameTopics {
    cameras: Vec<(String, Camera)>,
    images: ImageFormat,
}

impl FrameTopics {
    /// The topics for `rig`'s cameras, with images in `images`.
    pub fn new(rig: &Rig, images: ImageFormat) -> Self {
        FrameTopics {
            cameras: rig
                .cameras
                .iter()
                .map(|c| (c.name.clone(), c.camera.clone()))
                .collect(),
            images,
        }
    }

    /// Every topic, in a fixed order: the shape's, the poses', then each camera's.
    pub fn topics(&self) -> Vec<Topic> {
        let mut topics = vec![
            Topic::ros2(
                TopicId::Centerline,
                "/flexshape/centerline".into(),
                &msgs::PATH,
            ),
            Topic::ros2(TopicId::Tube, "/flexshape/tube".into(), &msgs::MARKER_ARRAY),
            Topic::ros2(TopicId::Hull, "/flexshape/hull".into(), &msgs::POINT_CLOUD2),
            Topic {
                qos: Some(TF_STATIC_QOS),
                ..Topic::ros2(TopicId::Transforms, "/tf_static".into(), &msgs::TF_MESSAGE)
            },
        ];
        for (i, (name, _)) in self.cameras.iter().enumerate() {
            topics.push(Topic::ros2(
                TopicId::CameraInfo(i),
                format!("/flexshape/{name}/camera_info"),
                &msgs::CAMERA_INFO,
            ));
            if self.images.any() {
                let ty = self.images.message_type();
                topics.push(Topic::ros2(
                    TopicId::Image(i),
                    format!("/flexshape/{name}/image"),
                    ty,
                ));
                topics.push(Topic::ros2(
                    TopicId::Silhouette(i),
                    format!("/flexshape/{name}/silhouette"),
                    ty,
                ));
            }
        }
        topics.push(Topic {
            id: TopicId::Record,
            name: "/flexshape/record".into(),
            schema_name: "flexshape.TrackRecord",
            schema_encoding: "jsonschema",
            // The record's own JSON Schema (docs/record.schema.json's record), which Foxglove
            // reads to show and plot its fields.
            schema: serde_json::to_string(&flexshape_record::record_schema()).unwrap_or_default(),
            message_encoding: "json",
            qos: None,
        });
        topics
    }

    /// The `/tf_static` message: every camera's optical frame in the world frame, at its
    /// centre (m), turned by Rᵀ.
    pub fn transforms(&self, stamp_ns: u64) -> Vec<u8> {
        let transforms: Vec<Transform> = self
            .cameras
            .iter()
            .map(|(name, camera)| {
                // TF's transform is the pose's inverse (camera → world).
                let frame = camera.pose.inverse();
                let c = frame.translation;
                let q = UnitQuaternion::from_rotation_matrix(&frame.rotation);
                Transform {
                    parent: WORLD_FRAME,
                    child: name,
                    translation: [c.x / 1e3, c.y / 1e3, c.z / 1e3],
                    rotation: [q.i, q.j, q.k, q.w],
                }
            })
            .collect();
        msgs::tf_message(stamp_ns, &transforms)
    }

    /// One frame's messages, all but the cameras' poses, stamped with [`stamp_ns`]: each
    /// topic that `wanted` accepts gets its message passed to `emit`, in [`Self::topics`]'
    /// order. What a topic has nothing of this frame (a centerline when no shape was found,
    /// a hull when it was not carved) is left out; the tube's markers always go, to clear
    /// the last frame's. `wanted` spares encoding what nobody reads (a live viewer that did
    /// not subscribe to the images).
    pub fn messages<E>(
        &self,
        record: &TrackRecord,
        p: &Processed,
        wanted: impl Fn(TopicId) -> bool,
        mut emit: impl FnMut(TopicId, &[u8]) -> Result<(), E>,
    ) -> Result<(), E> {
        let stamp = stamp_ns(record);
        let metres: Vec<[f64; 3]> = record
            .centerline
            .iter()
            .map(|p| p.map(|v| v / 1e3))
            .collect();
        if !metres.is_empty() && wanted(TopicId::Centerline) {
            emit(
                TopicId::Centerline,
                &msgs::path(stamp, WORLD_FRAME, &metres),
            )?;
        }
        if wanted(TopicId::Tube) {
            emit(TopicId::Tube, &tube_markers(stamp, record, &metres))?;
        }
        if let Some(t) = p.result.as_ref().ok().filter(|t| !t.occupancy.is_empty())
            && wanted(TopicId::Hull)
        {
            let cloud: Vec<[f32; 3]> = t
                .occupancy
                .to_cloud()
                .points
                .iter()
                .map(|p| p.map(|v| v / 1e3))
                .collect();
            emit(
                TopicId::Hull,
                &msgs::point_cloud(stamp, WORLD_FRAME, &cloud),
            )?;
        }
        for (i, (name, camera)) in self.cameras.iter().enumerate() {
            if wanted(TopicId::CameraInfo(i)) {
                let k = &camera.intrinsics;
                let info = msgs::camera_info(
                    stamp,
                    name,
                    (k.width, k.height),
                    &k.distortion.to_opencv(),
                    [k.fx, 0.0, k.cx, 0.0, k.fy, k.cy, 0.0, 0.0, 1.0],
                );
                emit(TopicId::CameraInfo(i), &info)?;
            }
            if !self.images.any() {
                continue;
            }
            if let Some(img) = p.images.get(i).filter(|_| wanted(TopicId::Image(i)))
                && let Some(msg) = self.image(stamp, name, img)
            {
                emit(TopicId::Image(i), &msg)?;
            }
            let silhouette = p.result.as_ref().ok().and_then(|t| t.silhouettes.get(i));
            if let Some(s) = silhouette.filter(|_| wanted(TopicId::Silhouette(i)))
                && let Some(msg) = self.silhouette(stamp, name, &s.object.to_gray())
            {
                emit(TopicId::Silhouette(i), &msg)?;
            }
        }
        if wanted(TopicId::Record) {
            // A record always serialises (plain numbers and strings); an empty message
            // would say so rather than stop the run.
            let json = serde_json::to_vec(record).unwrap_or_default();
            emit(TopicId::Record, &json)?;
        }
        Ok(())
    }

    /// A camera image in the chosen format (`None` when an encoder refused it).
    fn image(&self, stamp: u64, name: &str, img: &RgbImage) -> Option<Vec<u8>> {
        let (w, h) = img.dimensions();
        let (format, file) = match self.images {
            ImageFormat::None => return None,
            ImageFormat::Raw => {
                return Some(msgs::image(
                    stamp,
                    name,
                    (w, h),
                    "rgb8",
                    3 * w,
                    img.as_raw(),
                ));
            }
            ImageFormat::Jpeg => ("jpeg", jpeg(img)?),
            ImageFormat::Png => ("png", png(img.as_raw(), (w, h), ExtendedColorType::Rgb8)?),
        };
        Some(msgs::compressed_image(stamp, name, format, &file))
    }

    /// A silhouette (object 255) in the chosen format: PNG whenever compressed.
    fn silhouette(&self, stamp: u64, name: &str, mask: &image::GrayImage) -> Option<Vec<u8>> {
        let (w, h) = mask.dimensions();
        match self.images {
            ImageFormat::None => None,
            ImageFormat::Raw => Some(msgs::image(stamp, name, (w, h), "mono8", w, mask.as_raw())),
            ImageFormat::Jpeg | ImageFormat::Png => {
                let file = png(mask.as_raw(), (w, h), ExtendedColorType::L8)?;
                Some(msgs::compressed_image(stamp, name, "png", &file))
            }
        }
    }
}

/// JPEG at quality 90: small, and sharp enough to see the tube's edges.
fn jpeg(img: &RgbImage) -> Option<Vec<u8>> {
    let mut out = Vec::new();
    image::codecs::jpeg::JpegEncoder::new_with_quality(&mut out, 90)
        .encode_image(img)
        .ok()?;
    Some(out)
}

/// PNG with fast compression and the Sub filter: written at camera rate, read once.
fn png(data: &[u8], (w, h): (u32, u32), color: ExtendedColorType) -> Option<Vec<u8>> {
    use image::codecs::png::{CompressionType, FilterType, PngEncoder};
    let mut out = Vec::new();
    PngEncoder::new_with_quality(&mut out, CompressionType::Fast, FilterType::Sub)
        .write_image(data, w, h, color)
        .ok()?;
    Some(out)
}

/// The frame's time, ns since the Unix epoch: captured, else processed, else the frame
/// number at 30 frames/s.
pub fn stamp_ns(record: &TrackRecord) -> u64 {
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
