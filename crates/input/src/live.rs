//! Live cameras through ffmpeg: V4L2 devices (`/dev/videoN`), network streams, or a video
//! file played at its own frame rate (to rehearse a live run).
//!
//! Pairing by time: each camera is read by its own thread, which keeps that camera's newest
//! few frames, each with its capture time. When tracking is ready for a frame it waits until
//! every camera has delivered a frame it has not taken, then takes each camera's frame nearest
//! the newest instant all have reached; a set whose frames lie farther apart than the pairing
//! tolerance (by default 0.6 of the slowest camera's frame period) is not taken but counted
//! as unpaired. Frames passed over are dropped and counted.
//!
//! Capture times: devices of one machine (their driver's timestamps) and videos (their own
//! timelines) share a clock, so their streams' presentation times pair the frames captured
//! together and say when each camera captured (`FrameSet::camera_times`, for the fit across
//! time). Network streams each have their own clock: they are paired by arrival, and their
//! captures are not told apart (an arrival is a capture plus a transfer time that differs
//! between cameras).

use std::path::Path;
use std::sync::Arc;
use std::time::Instant;

use image::RgbImage;

use crate::ffmpeg::{Decoder, probe_size};
use crate::latest::{Latest, Taker};
use crate::{CaptureTime, FrameImage, FrameSet, FrameSource, InputError};

/// Frames from live cameras, paired by capture time.
pub struct LiveSource {
    latest: Arc<Latest<LiveFrame>>,
    taker: Taker,
    next: u64,
    /// Whether the cameras' times are their streams' (one clock), not their arrivals.
    streamed: bool,
    /// The pairing tolerance asked for, seconds (`None`: from the frame intervals).
    within_s: Option<f64>,
}

/// One camera's frame as its reader thread keeps it.
struct LiveFrame {
    image: RgbImage,
    arrived: Instant,
    /// When it was captured, seconds: the stream's presentation time, or its arrival since
    /// the source opened (see [`LiveSource`]).
    time_s: f64,
    /// The camera's frame period, seconds: the median of its recent frame intervals.
    interval_s: Option<f64>,
}

/// How long a camera may send no new frame before the source ends, naming it: far past any
/// frame interval or a camera's start.
const SILENCE: std::time::Duration = std::time::Duration::from_secs(10);

/// Frames each camera keeps for pairing: a few frame intervals of the cameras' different
/// delivery delays.
const KEPT: usize = 6;

/// The default pairing tolerance, a share of the slowest camera's frame period: cameras
/// of one rate are always within half an interval of each other, so a set farther apart
/// misses a frame.
const WITHIN_INTERVAL: f64 = 0.6;

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
        // Streams share a clock when every camera is a device of this machine, or every one a
        // video file.
        let device = |input: &str| input.starts_with("/dev/");
        let file = |input: &str| !device(input) && Path::new(input).is_file();
        let streamed =
            cameras.iter().all(|(_, i, _)| device(i)) || cameras.iter().all(|(_, i, _)| file(i));
        // Probe every input before starting any, so the streams start together.
        let args = cameras
            .iter()
            .map(|(camera, input, size)| input_args(camera, input, *size))
            .collect::<Result<Vec<_>, _>>()?;
        let decoders = cameras
            .iter()
            .zip(&args)
            .map(|((camera, input, size), args)| {
                if streamed {
                    Decoder::spawn_timed(camera, input, args, *size)
                } else {
                    Decoder::spawn(camera, input, args, *size)
                }
            })
            .collect::<Result<Vec<_>, _>>()?;
        let latest = Arc::new(Latest::new(cameras.len(), KEPT));
        let opened = Instant::now();
        for (i, decoder) in decoders.into_iter().enumerate() {
            let shared = latest.clone();
            std::thread::spawn(move || read_camera(i, decoder, &shared, opened));
        }
        let names = cameras.iter().map(|(name, _, _)| name.clone()).collect();
        Ok(LiveSource {
            latest,
            taker: Taker::new(cameras.len()).patient(SILENCE, names),
            next: 0,
            streamed,
            within_s: None,
        })
    }

    /// Pairs frames only within `within_s` seconds of one instant (`None`: 0.6 of the
    /// slowest camera's frame period, the median of its recent frame intervals).
    pub fn pair_within(mut self, within_s: Option<f64>) -> Self {
        self.within_s = within_s;
        self
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

/// A camera's reader thread: keeps its newest frames in its slot, each with its capture
/// time (the stream's where the decoder reads it; a frame without one is placed by its arrival
/// at the stream's last offset from the arrival clock).
fn read_camera(index: usize, mut decoder: Decoder, latest: &Latest<LiveFrame>, opened: Instant) {
    let mut last: Option<f64> = None;
    let mut offset = 0.0;
    let mut intervals = Intervals::default();
    while !latest.stopped() {
        match decoder.read_timed() {
            Ok(Some((image, stream))) => {
                let arrived = Instant::now();
                let arrival = arrived.duration_since(opened).as_secs_f64();
                if let Some(t) = stream {
                    offset = t - arrival;
                }
                let time_s = stream.unwrap_or(arrival + offset);
                if let Some(d) = last.map(|l| time_s - l).filter(|d| *d > 0.0) {
                    intervals.add(d);
                }
                let interval_s = intervals.median();
                last = Some(time_s);
                latest.put(
                    index,
                    LiveFrame {
                        image,
                        arrived,
                        time_s,
                        interval_s,
                    },
                );
            }
            Ok(None) => return latest.end(index, Ok(())),
            Err(e) => return latest.end(index, Err(e)),
        }
    }
}

/// A camera's recent frame intervals: their median is its frame period even when frames
/// arrive in bursts (a network stream's two frames a millisecond apart would otherwise make
/// the pairing tolerance a millisecond).
#[derive(Default)]
struct Intervals {
    recent: std::collections::VecDeque<f64>,
}

impl Intervals {
    /// Intervals kept: a second or so at most frame rates.
    const KEPT: usize = 31;

    fn add(&mut self, d: f64) {
        self.recent.push_back(d);
        if self.recent.len() > Self::KEPT {
            self.recent.pop_front();
        }
    }

    /// The median, seconds (`None` before the first interval).
    fn median(&self) -> Option<f64> {
        let mut sorted: Vec<f64> = self.recent.iter().copied().collect();
        sorted.sort_by(f64::total_cmp);
        sorted.get(sorted.len() / 2).copied()
    }
}

impl FrameSource for LiveSource {
    fn next_frame(&mut self) -> Option<Result<FrameSet, InputError>> {
        let within = self.within_s;
        let frames = match self.taker.take_paired(
            &self.latest,
            |f| f.time_s,
            |set| {
                within.unwrap_or_else(|| {
                    let slowest = set.iter().filter_map(|f| f.interval_s).reduce(f64::max);
                    slowest.map_or(f64::INFINITY, |d| WITHIN_INTERVAL * d)
                })
            },
        )? {
            Ok(frames) => frames,
            Err(e) => return Some(Err(e)),
        };
        let oldest = frames
            .iter()
            .map(|f| f.arrived)
            .min()
            .unwrap_or_else(Instant::now);
        let times: Vec<f64> = frames.iter().map(|f| f.time_s).collect();
        let images = frames
            .into_iter()
            .map(|f| FrameImage::Decoded(f.image))
            .collect();
        let mut set = FrameSet::new(self.next, images);
        set.captured = oldest;
        if self.streamed {
            set.stream_times(times);
        } else {
            set.capture_time = CaptureTime::of_instant(oldest);
        }
        self.next += 1;
        Some(Ok(set))
    }

    fn is_live(&self) -> bool {
        true
    }

    fn dropped(&self) -> u64 {
        self.taker.dropped()
    }

    fn unpaired(&self) -> u64 {
        self.taker.unpaired()
    }
}

impl Drop for LiveSource {
    fn drop(&mut self) {
        // Reader threads stop after their next frame; dropping their decoders ends ffmpeg.
        self.latest.stop();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_burst_of_frames_leaves_the_frame_period_as_it_was() {
        let mut intervals = Intervals::default();
        assert_eq!(intervals.median(), None);
        // 30 frames/s, with pairs of frames arriving 1 ms apart now and then.
        for k in 0..40 {
            intervals.add(if k % 5 == 0 { 0.001 } else { 1.0 / 30.0 });
        }
        let period = intervals.median().unwrap();
        assert!((period - 1.0 / 30.0).abs() < 1e-12, "{period}");
        assert!(intervals.recent.len() <= Intervals::KEPT);
    }
}
