//! One video file per camera, decoded by ffmpeg; the n-th frames of all videos make frame n.
//! Each frame's presentation time is read with it: videos of one recording share a timeline,
//! so cameras that were not triggered together (a video whose frames are offset by its
//! camera's phase) are each fitted at their own capture (`FrameSet::camera_times`).

use std::path::PathBuf;

use crate::ffmpeg::{Decoder, probe_size};
use crate::{FrameImage, FrameSet, FrameSource, InputError};

/// Frames from one video per camera.
pub struct VideoSource {
    decoders: Vec<Decoder>,
    next: u64,
    ended: bool,
}

/// A camera's video: its name, the file and the calibrated image size.
pub type CameraVideo = (String, PathBuf, (u32, u32));

impl VideoSource {
    /// Opens every camera's video (in the rig's order), checking each is the calibrated size.
    pub fn open(videos: &[CameraVideo]) -> Result<Self, InputError> {
        if videos.is_empty() {
            return Err(InputError::Cameras(
                "no videos given: give one per camera".into(),
            ));
        }
        let mut decoders = Vec::new();
        for (camera, path, size) in videos {
            let input = path.display().to_string();
            if !path.is_file() {
                return Err(InputError::io(
                    path,
                    std::io::Error::new(std::io::ErrorKind::NotFound, "no such video file"),
                ));
            }
            let found = probe_size(camera, &input)?;
            if found != *size {
                return Err(InputError::Size {
                    what: input,
                    camera: camera.clone(),
                    width: found.0,
                    height: found.1,
                    expected_width: size.0,
                    expected_height: size.1,
                });
            }
            let args = vec!["-i".to_string(), input.clone()];
            decoders.push(Decoder::spawn_timed(camera, &input, &args, *size)?);
        }
        Ok(VideoSource {
            decoders,
            next: 0,
            ended: false,
        })
    }
}

impl FrameSource for VideoSource {
    fn next_frame(&mut self) -> Option<Result<FrameSet, InputError>> {
        if self.ended {
            return None;
        }
        let mut images = Vec::with_capacity(self.decoders.len());
        let mut times = Vec::with_capacity(self.decoders.len());
        let mut finished = Vec::new();
        for (i, d) in self.decoders.iter_mut().enumerate() {
            match d.read_timed() {
                Ok(Some((image, time))) => {
                    images.push(FrameImage::Decoded(image));
                    times.push(time);
                }
                Ok(None) => finished.push(i),
                Err(e) => {
                    self.ended = true;
                    return Some(Err(e));
                }
            }
        }
        if !finished.is_empty() {
            self.ended = true;
            // All ended together: the natural end. Otherwise one video is shorter.
            if finished.len() == self.decoders.len() {
                return None;
            }
            let d = &self.decoders[finished[0]];
            return Some(Err(InputError::Ended {
                camera: d.camera().into(),
                frames: d.frames,
            }));
        }
        let mut set = FrameSet::new(self.next, images);
        // Every camera's time, or none: a missing one would leave the others' offsets
        // counted from an instant the set does not have.
        if let Some(times) = times.into_iter().collect::<Option<Vec<f64>>>() {
            set.stream_times(times);
        }
        self.next += 1;
        Some(Ok(set))
    }
}
