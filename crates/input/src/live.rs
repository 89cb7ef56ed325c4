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
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Condvar, Mutex};
use std::time::Instant;

use image::RgbImage;

use crate::ffmpeg::{Decoder, probe_size};
use crate::{CaptureTime, FrameImage, FrameSet, FrameSource, InputError};

/// One camera's newest frame.
#[derive(Default)]
struct Slot {
    image: Option<(RgbImage, Instant)>,
    /// Frames received so far.
    received: u64,
    /// Set when the camera's stream ended: `Ok` cleanly (a file played to its end).
    ended: Option<Result<(), InputError>>,
}

struct Shared {
    slots: Mutex<Vec<Slot>>,
    arrived: Condvar,
    stop: AtomicBool,
}

/// Frames from live cameras, newest first.
pub struct LiveSource {
    shared: Arc<Shared>,
    /// Per camera, the `received` count of the last frame taken.
    taken: Vec<u64>,
    dropped: Vec<u64>,
    next: u64,
    finished: bool,
}

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
        let shared = Arc::new(Shared {
            slots: Mutex::new((0..cameras.len()).map(|_| Slot::default()).collect()),
            arrived: Condvar::new(),
            stop: AtomicBool::new(false),
        });
        for (i, decoder) in decoders.into_iter().enumerate() {
            let shared = shared.clone();
            std::thread::spawn(move || read_camera(i, decoder, &shared));
        }
        Ok(LiveSource {
            shared,
            taken: vec![0; cameras.len()],
            dropped: vec![0; cameras.len()],
            next: 0,
            finished: false,
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
fn read_camera(index: usize, mut decoder: Decoder, shared: &Shared) {
    loop {
        if shared.stop.load(Ordering::Relaxed) {
            return;
        }
        let result = decoder.read();
        let Ok(mut slots) = shared.slots.lock() else {
            return;
        };
        let slot = &mut slots[index];
        match result {
            Ok(Some(image)) => {
                slot.image = Some((image, Instant::now()));
                slot.received += 1;
            }
            Ok(None) => slot.ended = Some(Ok(())),
            Err(e) => slot.ended = Some(Err(e)),
        }
        let ended = slot.ended.is_some();
        drop(slots);
        shared.arrived.notify_all();
        if ended {
            return;
        }
    }
}

impl FrameSource for LiveSource {
    fn next_frame(&mut self) -> Option<Result<FrameSet, InputError>> {
        if self.finished {
            return None;
        }
        let Ok(mut slots) = self.shared.slots.lock() else {
            self.finished = true;
            return None;
        };
        loop {
            let fresh = slots
                .iter()
                .zip(&self.taken)
                .all(|(s, &t)| s.received > t && s.image.is_some());
            if fresh {
                break;
            }
            // A camera that ended with no new frame ends the input.
            if let Some(i) = (0..slots.len())
                .find(|&i| slots[i].ended.is_some() && slots[i].received == self.taken[i])
            {
                self.finished = true;
                return match slots[i].ended.take() {
                    Some(Err(e)) => Some(Err(e)),
                    _ => None,
                };
            }
            slots = match self.shared.arrived.wait(slots) {
                Ok(s) => s,
                Err(_) => {
                    self.finished = true;
                    return None;
                }
            };
        }
        let mut images = Vec::with_capacity(slots.len());
        let mut oldest = Instant::now();
        for (i, slot) in slots.iter_mut().enumerate() {
            let Some((image, at)) = slot.image.take() else {
                continue;
            };
            self.dropped[i] += slot.received - self.taken[i] - 1;
            self.taken[i] = slot.received;
            oldest = oldest.min(at);
            images.push(FrameImage::Decoded(image));
        }
        drop(slots);
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
        self.dropped.iter().copied().max().unwrap_or(0)
    }
}

impl Drop for LiveSource {
    fn drop(&mut self) {
        // Reader threads stop after their next frame; dropping their decoders ends ffmpeg.
        self.shared.stop.store(true, Ordering::Relaxed);
    }
}
