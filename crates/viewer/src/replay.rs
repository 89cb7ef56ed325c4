//! Playing back in the viewer (`flexshape view`): a record stream, or a recording whose frames
//! are tracked as they are shown (with their images and overlays), at the recorded pace (capture
//! or processing times) times a speed, with pause, step and seek from the page.

use std::collections::BTreeMap;
use std::path::Path;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{Receiver, RecvTimeoutError};
use std::time::{Duration, Instant};

use flexshape_camera::Camera;
use flexshape_input::FrameSource;
use flexshape_record::TrackRecord;
use flexshape_track::{Pipeline, Processed, Recording, TrackError};
use serde::{Deserialize, Serialize};

use crate::{Scene, Stats, Update, Viewer};

/// What a replay plays, frame by frame.
pub trait Replayed {
    /// Frames in it.
    fn frames(&self) -> usize;
    /// Recorded time from frame `index` to the next, s (the default pace when not known).
    fn gap_s(&self, index: usize) -> f64;
    /// The viewer's frame `index` (from 0), shown at `state`.
    fn frame(&mut self, index: usize, state: ReplayState) -> Update;
    /// What the page shows around the frames.
    fn scene(&self) -> Scene;
}

/// A record stream (a `flexshape track` JSON Lines file): shapes and figures, no images.
pub struct RecordStream(pub Vec<TrackRecord>);

impl Replayed for RecordStream {
    fn frames(&self) -> usize {
        self.0.len()
    }

    fn gap_s(&self, index: usize) -> f64 {
        match (self.0.get(index), self.0.get(index + 1)) {
            (Some(a), Some(b)) => {
                let times = [(a.captured_s, b.captured_s), (a.processed_s, b.processed_s)];
                paced(times.iter().find_map(|&(x, y)| Some(y? - x?)))
            }
            _ => DEFAULT_GAP_S,
        }
    }

    fn frame(&mut self, index: usize, state: ReplayState) -> Update {
        let record = &self.0[index];
        Update::of_record(
            record.clone(),
            stats(state, record.latency_ms.unwrap_or(0.0)),
        )
        .with_replay(state)
    }

    fn scene(&self) -> Scene {
        scene_of(&self.0)
    }
}

/// A recording folder, each frame tracked when it is shown (from its own hull: a seek may land
/// anywhere), with its images, silhouettes and overlays.
pub struct RecordingReplay {
    recording: Recording,
    pipeline: Pipeline,
    cameras: Arc<[Camera]>,
    /// Capture times by frame number (`timestamps.csv`), s.
    times: BTreeMap<u64, f64>,
    /// The working volume's bounds (as [`Scene::volume`]), which the truth is kept within.
    volume: [f64; 6],
}

impl RecordingReplay {
    /// Opens the recording at `dir` as `flexshape track` would track it.
    pub fn open(dir: &Path) -> Result<Self, TrackError> {
        let recording = Recording::open(dir)?;
        let pipeline = recording.pipeline()?;
        let times = recording
            .source
            .reader()
            .read_timestamps()
            .unwrap_or_default();
        Ok(RecordingReplay {
            cameras: pipeline.cameras().into(),
            volume: Scene::of(&pipeline).volume,
            recording,
            pipeline,
            times,
        })
    }
}

impl Replayed for RecordingReplay {
    fn frames(&self) -> usize {
        self.recording.source.reader().frames().len()
    }

    fn gap_s(&self, index: usize) -> f64 {
        let frames = self.recording.source.reader().frames();
        match (frames.get(index), frames.get(index + 1)) {
            (Some(a), Some(b)) => {
                paced(self.times.get(b).zip(self.times.get(a)).map(|(y, x)| y - x))
            }
            _ => DEFAULT_GAP_S,
        }
    }

    fn frame(&mut self, index: usize, state: ReplayState) -> Update {
        self.recording.source.seek(index);
        let processed = match self.recording.source.next_frame() {
            Some(Ok(set)) => Processed::of(&self.pipeline, set, None),
            Some(Err(e)) => Processed::unreadable(index as u64, e.to_string(), 0),
            None => Processed::unreadable(index as u64, "no such frame".into(), 0),
        };
        let record = processed.record();
        let stats = stats(state, processed.latency_ms);
        Update::new(processed, record, stats)
            .with_cameras(self.cameras.clone())
            .with_truth_within(self.volume)
            .with_replay(state)
    }

    fn scene(&self) -> Scene {
        Scene {
            replay: Some(self.frames()),
            ..Scene::of(&self.pipeline)
        }
    }
}

/// What the page asks of a replay (a WebSocket text message such as `{"control": "pause"}`,
/// `{"control": "step", "by": -1}` or `{"control": "seek", "index": 12}`).
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(tag = "control", rename_all = "snake_case")]
pub enum Control {
    /// Go on at the recorded pace.
    Play,
    /// Stop at the current record.
    Pause,
    /// Pause and move by `by` records.
    Step {
        /// Records to move (negative: back).
        by: i64,
    },
    /// Pause at record `index` (from 0).
    Seek {
        /// The record's place in the stream.
        index: usize,
    },
}

/// Where a replay is, sent with each frame it shows.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct ReplayState {
    /// The record shown, from 0.
    pub index: usize,
    /// Records in the stream.
    pub frames: usize,
    /// Whether it plays on (else paused).
    pub playing: bool,
}

/// Longest wait between two records, s (a gap in the stream is not waited out).
const MAX_GAP_S: f64 = 1.0;
/// Pace of records without times, s.
const DEFAULT_GAP_S: f64 = 1.0 / 30.0;

/// The scene of a record stream without its rig: camera names from the first record that
/// names them, the volume the centerlines span (with a 20 mm margin; the default 256 mm cube
/// when none has one), and the replay's length.
pub fn scene_of(records: &[TrackRecord]) -> Scene {
    let cameras = records
        .iter()
        .find(|r| !r.cameras.is_empty())
        .map(|r| r.cameras.iter().map(|c| c.camera.clone()).collect())
        .unwrap_or_default();
    let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
    for p in records.iter().flat_map(|r| &r.centerline) {
        for i in 0..3 {
            lo[i] = lo[i].min(p[i]);
            hi[i] = hi[i].max(p[i]);
        }
    }
    let volume = if lo[0].is_finite() {
        [
            lo[0] - 20.0,
            lo[1] - 20.0,
            lo[2] - 20.0,
            hi[0] + 20.0,
            hi[1] + 20.0,
            hi[2] + 20.0,
        ]
    } else {
        [-128.0, -128.0, -128.0, 128.0, 128.0, 128.0]
    };
    Scene {
        cameras,
        image_sizes: Vec::new(),
        frusta: Vec::new(),
        volume,
        voxel: 1.0,
        replay: Some(records.len()),
    }
}

/// Plays `played` in `viewer` at `speed` times its recorded pace, obeying `controls`, until
/// `stop` is set; at the end it pauses on the last frame (the page can go back).
pub fn replay(
    viewer: &Viewer,
    played: &mut dyn Replayed,
    speed: f64,
    controls: &Receiver<Control>,
    stop: &AtomicBool,
) {
    let frames = played.frames();
    if frames == 0 {
        return;
    }
    let last = frames - 1;
    let (mut index, mut playing) = (0usize, true);
    let mut shown: Option<usize> = None;
    let mut next_at = Instant::now();
    while !stop.load(Ordering::SeqCst) {
        if shown != Some(index) || playing && Instant::now() >= next_at {
            if shown == Some(index) {
                if index == last {
                    playing = false;
                } else {
                    index += 1;
                }
            }
            let state = ReplayState {
                index,
                frames,
                playing,
            };
            let started = Instant::now();
            viewer.publish(played.frame(index, state));
            shown = Some(index);
            // The recorded gap counts from when the frame was asked for: tracking it takes part.
            next_at = started + Duration::from_secs_f64(played.gap_s(index) / speed);
        }
        let wait = if playing {
            next_at.saturating_duration_since(Instant::now())
        } else {
            Duration::from_millis(50)
        };
        match controls.recv_timeout(wait.min(Duration::from_millis(50))) {
            Ok(Control::Play) => {
                playing = true;
                if index == last {
                    index = 0;
                }
                shown = None;
            }
            Ok(Control::Pause) => {
                playing = false;
                shown = None;
            }
            Ok(Control::Step { by }) => {
                playing = false;
                index = index.saturating_add_signed(by as isize).min(last);
                shown = None;
            }
            Ok(Control::Seek { index: i }) => {
                playing = false;
                index = i.min(last);
                shown = None;
            }
            Err(RecvTimeoutError::Timeout) | Err(RecvTimeoutError::Disconnected) => {}
        }
    }
}

/// A recorded gap, s, at most `MAX_GAP_S`; the default pace when unknown or negative.
fn paced(gap: Option<f64>) -> f64 {
    gap.filter(|d| d.is_finite() && *d >= 0.0)
        .unwrap_or(DEFAULT_GAP_S)
        .min(MAX_GAP_S)
}

/// The figures shown beside a replayed frame.
fn stats(state: ReplayState, latency_ms: f64) -> Stats {
    Stats {
        frames: state.index + 1,
        fps: 0.0,
        latency_ms,
        dropped: 0,
        truth_rms_mm: None,
        truth_tip_mm: None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn controls_read_as_the_page_sends_them() {
        let read = |t: &str| serde_json::from_str::<Control>(t).unwrap();
        assert_eq!(read(r#"{"control":"play"}"#), Control::Play);
        assert_eq!(read(r#"{"control":"pause"}"#), Control::Pause);
        assert_eq!(
            read(r#"{"control":"step","by":-1}"#),
            Control::Step { by: -1 }
        );
        assert_eq!(
            read(r#"{"control":"seek","index":7}"#),
            Control::Seek { index: 7 }
        );
        assert!(serde_json::from_str::<Control>(r#"{"control":"rewind"}"#).is_err());
    }
}
