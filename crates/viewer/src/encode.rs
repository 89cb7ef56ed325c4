//! Frames for the browser: a JSON message with the figures, the shape and a subsampled cloud,
//! and binary messages with each camera's frame (JPEG) and silhouette (PNG) at half size.

use std::io::Cursor;
use std::sync::Arc;

use flexshape_camera::Camera;

use flexshape_record::TrackRecord;
use flexshape_silhouette::Silhouette;
use flexshape_track::{Processed, Tracked};
use image::codecs::jpeg::JpegEncoder;
use image::{ImageFormat, RgbImage};
use serde::Serialize;

use crate::overlay::{CameraOverlay, overlays};

/// Live figures shown beside the frame.
#[derive(Debug, Clone, Default, Serialize)]
pub struct Stats {
    /// Frames handed to the viewer so far.
    pub frames: usize,
    /// Frames per second over the last second or so.
    pub fps: f64,
    /// Capture (or reading) to shape, ms.
    pub latency_ms: f64,
    /// Frame sets a live input dropped so far.
    pub dropped: u64,
    /// Centerline RMS against truth, mm (simulated input).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub truth_rms_mm: Option<f64>,
    /// Tip error against truth, mm (simulated input).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub truth_tip_mm: Option<f64>,
}

/// The closed loop at a frame (`flexshape model steer`), for the steering panel.
#[derive(Debug, Clone, Default, Serialize)]
pub struct Steering {
    /// The target, world mm.
    pub target: [f64; 3],
    /// Which target (from 0), of `targets`.
    pub target_index: usize,
    /// Targets in the run.
    pub targets: usize,
    /// `[Kx, Kz]` the controller used for this frame's command (the model file's units).
    pub stiffness: [f64; 2],
    /// The true `[Kx, Kz]`, when the catheter is simulated.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub true_stiffness: Option<[f64; 2]>,
    /// The frames so far, oldest first (the most recent [`Steering::HISTORY`]).
    pub history: Vec<SteeringSample>,
}

impl Steering {
    /// Frames of history a message carries: a browser that connects late or misses frames
    /// still draws the whole recent run.
    pub const HISTORY: usize = 400;
}

/// One frame of the closed loop's history.
#[derive(Debug, Clone, Default, Serialize)]
pub struct SteeringSample {
    /// Frame number.
    pub frame: u64,
    /// Which target.
    pub target_index: usize,
    /// The sensed tip's distance from the target, mm (when the frame gave a shape).
    pub sensed_error_mm: Option<f64>,
    /// The true tip's, mm (simulation).
    pub true_error_mm: Option<f64>,
    /// `[κx, κz]` the controller's model expected of the command, 1/mm.
    pub commanded_kappa: [f64; 2],
    /// `[κx, κz]` sensed, 1/mm.
    pub sensed_kappa: Option<[f64; 2]>,
}

/// One tracked frame as tracking hands it over.
pub struct Update {
    record: TrackRecord,
    images: Vec<RgbImage>,
    tracked: Option<Tracked>,
    stats: Stats,
    steering: Option<Steering>,
    cameras: Option<Arc<[Camera]>>,
    replay: Option<crate::ReplayState>,
    /// The true centerline (simulated input), thinned to about every 1.5 mm.
    truth: Option<Vec<[f64; 3]>>,
}

/// Spacing of the true centerline's points sent to the page, mm.
const TRUTH_STEP_MM: f64 = 1.5;

/// The true centerline thinned for the page (a point every `TRUTH_STEP_MM` or more), its
/// tip kept.
fn thinned(centerline: &[[f64; 3]]) -> Vec<[f64; 3]> {
    let mut out: Vec<[f64; 3]> = Vec::new();
    for &p in centerline {
        let far = out.last().is_none_or(|q: &[f64; 3]| {
            (0..3).map(|i| (p[i] - q[i]).powi(2)).sum::<f64>() >= TRUTH_STEP_MM.powi(2)
        });
        if far {
            out.push(p);
        }
    }
    if let (Some(&tip), Some(kept)) = (centerline.last(), out.last())
        && tip != *kept
    {
        out.push(tip);
    }
    out
}

impl Update {
    /// A frame from the runner with its record and the figures so far (takes the images and
    /// results without copying them).
    pub fn new(processed: Processed, record: TrackRecord, stats: Stats) -> Self {
        Update {
            record,
            images: processed.images,
            tracked: processed.result.ok(),
            stats,
            steering: None,
            cameras: None,
            replay: None,
            truth: processed.truth.map(|t| thinned(&t.centerline)),
        }
    }

    /// A frame known only by its record (a replayed record stream): no images, no cloud.
    pub fn of_record(record: TrackRecord, stats: Stats) -> Self {
        Update {
            record,
            images: Vec::new(),
            tracked: None,
            stats,
            steering: None,
            cameras: None,
            replay: None,
            truth: None,
        }
    }

    /// The same frame with its true centerline kept only within 10 mm of the box `volume`
    /// (`[xmin, ymin, zmin, xmax, ymax, zmax]`, world mm): a simulated catheter runs on far
    /// outside what the cameras watch.
    pub fn with_truth_within(mut self, volume: [f64; 6]) -> Self {
        if let Some(t) = &mut self.truth {
            t.retain(|p| (0..3).all(|i| p[i] >= volume[i] - 10.0 && p[i] <= volume[i + 3] + 10.0));
        }
        self
    }

    /// The same frame as a replay shows it.
    pub fn with_replay(mut self, state: crate::ReplayState) -> Self {
        self.replay = Some(state);
        self
    }

    /// The same frame with the rig's cameras, so the page draws the shape over each camera's
    /// image (the cameras in the order of the images).
    pub fn with_cameras(mut self, cameras: Arc<[Camera]>) -> Self {
        self.cameras = Some(cameras);
        self
    }

    /// The same frame with the closed loop's state.
    pub fn with_steering(mut self, steering: Steering) -> Self {
        self.steering = Some(steering);
        self
    }
}

/// Most points sent per frame (the cloud is thinned evenly beyond this).
const MAX_POINTS: usize = 12_000;

#[derive(Serialize)]
struct FrameMessage<'a> {
    #[serde(rename = "type")]
    kind: &'static str,
    record: &'a TrackRecord,
    stats: &'a Stats,
    #[serde(skip_serializing_if = "Option::is_none")]
    steering: Option<&'a Steering>,
    /// Where a replay is.
    #[serde(skip_serializing_if = "Option::is_none")]
    replay: Option<crate::ReplayState>,
    /// The true centerline (simulated input), world mm.
    #[serde(skip_serializing_if = "Option::is_none")]
    truth_centerline: Option<&'a [[f64; 3]]>,
    /// Flat x, y, z, … of voxel centres, 0.1 mm resolution.
    cloud: Vec<f32>,
    /// Per cloud point: 0 outside bands, else the band's number.
    cloud_band: Vec<u16>,
}

#[derive(Serialize)]
struct OverlaysMessage<'a> {
    #[serde(rename = "type")]
    kind: &'static str,
    /// The frame the images just sent show.
    frame: u64,
    /// Per camera: the shape in its image, pixels.
    overlays: Vec<CameraOverlay>,
    /// Per camera: how well the fitted tube explains it (the record's `cameras`).
    cameras: &'a [flexshape_fit::CameraCheck],
}

/// The JSON of the shape over each camera's image of `update` (when its cameras are known):
/// sent after that frame's images.
pub(crate) fn overlays_json(update: &Update) -> Option<String> {
    let cameras = update.cameras.as_deref()?;
    let tube = update
        .tracked
        .as_ref()
        .and_then(|t| t.fit.as_ref())
        .map(|f| &f.tube);
    let message = OverlaysMessage {
        kind: "overlays",
        frame: update.record.frame,
        overlays: overlays(cameras, tube, &update.record, update.truth.as_deref()),
        cameras: &update.record.cameras,
    };
    serde_json::to_string(&message).ok()
}

/// The JSON of a frame.
pub(crate) fn frame_json(update: &Update) -> String {
    let (mut cloud, mut cloud_band) = (Vec::new(), Vec::new());
    if let Some(t) = &update.tracked {
        let c = t.occupancy.to_cloud_with_bands(&t.bands);
        let step = c.points.len().div_ceil(MAX_POINTS).max(1);
        for (p, &b) in c.points.iter().zip(&c.band).step_by(step) {
            cloud.extend(p.map(|v| (v * 10.0).round() / 10.0));
            cloud_band.push(b);
        }
    }
    let message = FrameMessage {
        kind: "frame",
        record: &update.record,
        stats: &update.stats,
        steering: update.steering.as_ref(),
        replay: update.replay,
        truth_centerline: update.truth.as_deref(),
        cloud,
        cloud_band,
    };
    serde_json::to_string(&message).unwrap_or_else(|e| {
        format!("{{\"type\":\"error\",\"message\":\"cannot encode frame: {e}\"}}")
    })
}

/// Binary messages: `[kind, camera, payload…]`, kind 0 = frame JPEG, 1 = silhouette PNG.
pub(crate) fn image_messages(update: &Update) -> Vec<Vec<u8>> {
    let mut out = Vec::new();
    for (cam, image) in update.images.iter().enumerate() {
        let mut bytes = vec![0u8, cam as u8];
        let small = half_size(image);
        let mut jpeg = JpegEncoder::new_with_quality(&mut bytes, 80);
        if jpeg.encode_image(&small).is_ok() {
            out.push(bytes);
        }
    }
    if let Some(t) = &update.tracked {
        for (cam, s) in t.silhouettes.iter().enumerate() {
            let mut bytes = Cursor::new(vec![1u8, cam as u8]);
            bytes.set_position(2);
            if silhouette_image(s)
                .write_to(&mut bytes, ImageFormat::Png)
                .is_ok()
            {
                out.push(bytes.into_inner());
            }
        }
    }
    out
}

/// A 2×2 box average: half the width and height.
fn half_size(image: &RgbImage) -> RgbImage {
    let (w, h) = (image.width() / 2, image.height() / 2);
    RgbImage::from_fn(w.max(1), h.max(1), |x, y| {
        let mut sum = [0u32; 3];
        for (dx, dy) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
            let p = image.get_pixel(
                (2 * x + dx).min(image.width() - 1),
                (2 * y + dy).min(image.height() - 1),
            );
            for (s, v) in sum.iter_mut().zip(p.0) {
                *s += v as u32;
            }
        }
        image::Rgb(sum.map(|s| (s / 4) as u8))
    })
}

/// The silhouette at half size: object light grey, marker bands red, background dark.
fn silhouette_image(s: &Silhouette) -> RgbImage {
    let (w, h) = (s.object.width() as u32 / 2, s.object.height() as u32 / 2);
    RgbImage::from_fn(w.max(1), h.max(1), |x, y| {
        let (px, py) = (2 * x as usize, 2 * y as usize);
        let any = |m: &flexshape_silhouette::BitMask| {
            [(0, 0), (1, 0), (0, 1), (1, 1)].iter().any(|&(dx, dy)| {
                let (qx, qy) = (px + dx, py + dy);
                qx < m.width() && qy < m.height() && m.get(qx, qy)
            })
        };
        if any(&s.markers) {
            image::Rgb([235, 40, 40])
        } else if any(&s.object) {
            image::Rgb([225, 225, 225])
        } else {
            image::Rgb([24, 26, 32])
        }
    })
}
