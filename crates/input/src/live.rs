//! Live cameras through ffmpeg: V4L2 devices (`/dev/videoN`), network streams, or a video
//! file played at its own frame rate (to rehearse a live run).
//!
//! Pairing: each camera is read by its own thread, which keeps only that camera's newest
//! frame. When tracking is ready for a frame it waits until every camera has delivered a frame
//! newer than the last one taken, then takes the newest of each; the set's capture time is the
//! oldest of their arrival times. Cameras that are not hardware-synchronised can therefore be
//! up to one frame period apart. A frame overwritten by a newer one before it was taken is
//! dropped and counted.

use std::path::Path;
use std::sync::Arc;
use std::time::Instant;

use image::RgbImage;

use crate::ffmpeg::{Decoder, probe_size};
use crate::latest::{Latest, Taker};
use crate::{CaptureTime, FrameImage, FrameSet, FrameSource, InputError};

/// Frames from live cameras, newest first.
pub struct LiveSource {
    /// Each camera's newest frame and when it arrived.
    latest: Arc<Latest<(RgbImage, Instant)>>,
    taker: Taker,
    next: u64,
}

/// How long a camera may send no new frame before the source ends, naming it: far past any
/// frame interval or a camera's start.
const SILENCE: std::time::Duration = std::time::Duration::from_secs(10);

/// A live camera: its name, its input (a device path, a URL or a video file) and the
/// calibrated image size.
pub type LiveCamera = (String, String, (u32, u32));

impl LiveSource {
    /// Starts reading every camera (in the rig's order).
    pub fn open(cameras: &[LiveCamera]) -> Result<Self, InputError> {
        if cameras.is_empty() {
            return Err(InputError::Cameras(
                "no cameras given: give one input per camera".into(),
            ));
        }
        // Probe every input before starting any, so the streams start together.
        let args = cameras
            .iter()
            .map(|(camera, input, size)| input_args(camera, input, *size))
            .collect::<Result<Vec<_>, _>>()?;
        let decoders = cameras
            .iter()
            .zip(&args)
            .map(|((camera, input, size), args)| Decoder::spawn(camera, input, args, *size))
            .collect::<Result<Vec<_>, _>>()?;
        let latest = Arc::new(Latest::new(cameras.len()));
        for (i, decoder) in decoders.into_iter().enumerate() {
            let shared = latest.clone();
            std::thread::spawn(move || read_camera(i, decoder, &shared));
        }
        let names = cameras.iter().map(|(name, _, _)| name.clone()).collect();
        Ok(LiveSource {
            latest,
            taker: Taker::new(cameras.len()).patient(SILENCE, names),
            next: 0,
        })
    }
}

/// ffmpeg's input options for a camera: a V4L2 device at the calibrated size, a video file
/// played in real time, or a URL read with little buffering.
fn input_args(camera: &str, input: &str, size: (u32, u32)) -> Result<Vec<String>, InputError> {
    let mut args: Vec<String> = Vec::new();
    if input.starts_with("/dev/") {
        args.extend(["-f", "v4l2", "-video_size"].map(String::from));
        args.push(format!("{}x{}", size.0, size.1));
    } else {
        let found = probe_size(camera, input)?;
        if found != size {
            return Err(InputError::Size {
                what: input.into(),
                camera: camera.into(),
                width: found.0,
                height: found.1,
                expected_width: size.0,
                expected_height: size.1,
            });
        }
        if Path::new(input).is_file() {
            args.push("-re".into());
        } else {
            args.extend(["-fflags", "nobuffer", "-flags", "low_delay"].map(String::from));
        }
    }
    args.extend(["-i".to_string(), input.to_string()]);
    Ok(args)
}

/// A camera's reader thread: keeps the newest frame in its slot.
fn read_camera(index: usize, mut decoder: Decoder, latest: &Latest<(RgbImage, Instant)>) {
    while !latest.stopped() {
        match decoder.read() {
            Ok(Some(image)) => latest.put(index, (image, Instant::now())),
            Ok(None) => return latest.end(index, Ok(())),
            Err(e) => return latest.end(index, Err(e)),
        }
    }
}

impl FrameSource for LiveSource {
    fn next_frame(&mut self) -> Option<Result<FrameSet, InputError>> {
        let frames = match self.taker.take(&self.latest)? {
            Ok(frames) => frames,
            Err(e) => return Some(Err(e)),
        };
        let oldest = frames
            .iter()
            .map(|(_, at)| *at)
            .min()
            .unwrap_or_else(Instant::now);
        let images = frames
            .into_iter()
            .map(|(image, _)| FrameImage::Decoded(image))
            .collect();
        let mut set = FrameSet::new(self.next, images);
        set.captured = oldest;
        set.capture_time = CaptureTime::of_instant(oldest);
        self.next += 1;
        Some(Ok(set))
    }

    fn is_live(&self) -> bool {
        true
    }

    fn dropped(&self) -> u64 {
        self.taker.dropped()
    }
}

impl Drop for LiveSource {
    fn drop(&mut self) {
        // Reader threads stop after their next frame; dropping their decoders ends ffmpeg.
        self.latest.stop();
    }
}
