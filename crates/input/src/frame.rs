//! One frame set: an image per camera plus what the input knows about the frame.

use std::path::PathBuf;
use std::time::Instant;

use flexshape_recording::{Command, Truth};
use image::RgbImage;

use crate::InputError;

/// One camera's image of a frame: decoded already (videos, cameras) or a file that the
/// tracking worker decodes (so decoding runs in parallel with everything else).
#[derive(Debug, Clone)]
pub enum FrameImage {
    /// 8-bit RGB pixels.
    Decoded(RgbImage),
    /// An image file (PNG, JPEG).
    File(PathBuf),
}

impl FrameImage {
    /// The pixels, checking the size against camera `camera`'s calibrated `size`.
    pub fn load(self, camera: &str, size: (u32, u32)) -> Result<RgbImage, InputError> {
        self.load_with_kind(camera, size).map(|(image, _)| image)
    }

    /// As [`FrameImage::load`], and whether the file held a greyscale image (converted to RGB
    /// with equal channels: colour cues such as red marker bands are gone).
    pub fn load_with_kind(
        self,
        camera: &str,
        size: (u32, u32),
    ) -> Result<(RgbImage, bool), InputError> {
        let mut grey = false;
        let (image, what) = match self {
            FrameImage::Decoded(image) => (image, format!("frame of camera `{camera}`")),
            FrameImage::File(path) => {
                // The size is checked from the header, before any pixel is decoded.
                let image = match flexshape_rig::files::read_image(&path, Some(size)) {
                    Ok(image) => {
                        grey = !image.color().has_color();
                        image.to_rgb8()
                    }
                    Err(flexshape_rig::files::FileError::Size { width, height, .. }) => {
                        return Err(InputError::Size {
                            what: path.display().to_string(),
                            camera: camera.into(),
                            width,
                            height,
                            expected_width: size.0,
                            expected_height: size.1,
                        });
                    }
                    Err(e) => {
                        return Err(InputError::Decode {
                            path: path.clone(),
                            message: e.reason(),
                        });
                    }
                };
                (image, path.display().to_string())
            }
        };
        if image.dimensions() != size {
            return Err(InputError::Size {
                what,
                camera: camera.into(),
                width: image.width(),
                height: image.height(),
                expected_width: size.0,
                expected_height: size.1,
            });
        }
        Ok((image, grey))
    }
}

/// Where a frame's capture time comes from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CaptureSource {
    /// The wall clock when the frame arrived from a live camera (or the simulator).
    Clock,
    /// The recording's `timestamps.csv`.
    Timestamps,
    /// The image file's modification time (the first camera's).
    FileTime,
    /// The cameras' streams: live devices' driver timestamps, or videos' own timelines (read
    /// as files or played live) — the earliest of the set's cameras' times.
    Stream,
}

impl CaptureSource {
    /// Its name in records: `clock`, `timestamps`, `file_time` or `stream`.
    pub fn name(self) -> &'static str {
        match self {
            CaptureSource::Clock => "clock",
            CaptureSource::Timestamps => "timestamps",
            CaptureSource::FileTime => "file_time",
            CaptureSource::Stream => "stream",
        }
    }
}

/// When a frame was captured.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CaptureTime {
    /// Seconds since the Unix epoch (UTC) — or, from a timestamps file, in that file's own
    /// time base.
    pub seconds: f64,
    /// Where it comes from.
    pub source: CaptureSource,
}

impl CaptureTime {
    /// The wall clock at `instant` (a moment of this process, not long ago).
    pub fn of_instant(instant: Instant) -> Option<Self> {
        let at = std::time::SystemTime::now().checked_sub(instant.elapsed())?;
        Some(CaptureTime {
            seconds: unix_seconds(at)?,
            source: CaptureSource::Clock,
        })
    }

    /// The modification time of `path`, if the file system gives one.
    pub fn of_file(path: &std::path::Path) -> Option<Self> {
        let at = std::fs::metadata(path).ok()?.modified().ok()?;
        Some(CaptureTime {
            seconds: unix_seconds(at)?,
            source: CaptureSource::FileTime,
        })
    }
}

/// Seconds since the Unix epoch.
pub fn unix_seconds(at: std::time::SystemTime) -> Option<f64> {
    Some(at.duration_since(std::time::UNIX_EPOCH).ok()?.as_secs_f64())
}

/// The images of one instant, one per camera in the rig's order.
#[derive(Debug, Clone)]
pub struct FrameSet {
    /// Frame number: the recording's, the position in a folder or video, or a running count
    /// for live input.
    pub frame: u64,
    /// The input's own name of the frame, when it has one (a plain folder's file name).
    pub name: Option<String>,
    /// One image per camera.
    pub images: Vec<FrameImage>,
    /// When the frame was captured (live input: the oldest of the cameras' frames) or read.
    pub captured: Instant,
    /// When the frame was captured, in wall-clock terms, where the input knows it.
    pub capture_time: Option<CaptureTime>,
    /// Each camera's own capture time, rig order, seconds in `capture_time`'s time base, where
    /// the input knows them: cameras that are not triggered together (a recording's
    /// `timestamps/<cam>.csv`, live cameras' stream times). Live cameras known only by their
    /// frames' arrival leave it out: an arrival is a capture plus a transfer time that differs
    /// between cameras, which would carry the tube of cameras triggered together apart.
    pub camera_times: Option<Vec<f64>>,
    /// The commanded tendon displacements (recordings of model experiments).
    pub command: Option<Command>,
    /// Ground truth (simulated recordings).
    pub truth: Option<Truth>,
    /// Problems that did not stop the frame (e.g. an unreadable command file).
    pub warnings: Vec<String>,
}

impl FrameSet {
    /// A frame set with only images.
    pub fn new(frame: u64, images: Vec<FrameImage>) -> Self {
        FrameSet {
            frame,
            name: None,
            images,
            captured: Instant::now(),
            capture_time: None,
            camera_times: None,
            command: None,
            truth: None,
            warnings: Vec::new(),
        }
    }

    /// Its cameras' capture times (rig order) from their streams' shared clock (videos'
    /// timelines, devices' driver timestamps): each camera's own, and the set's the earliest.
    pub(crate) fn stream_times(&mut self, times: Vec<f64>) {
        self.capture_time = Some(CaptureTime {
            seconds: times.iter().copied().fold(f64::INFINITY, f64::min),
            source: CaptureSource::Stream,
        });
        self.camera_times = Some(times);
    }
}
