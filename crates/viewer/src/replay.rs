//! Playing a record stream back in the viewer (`flexshape view FILE.jsonl`): at its recorded
//! pace (the records' capture or processing times) times a speed, with pause, step and seek
//! from the page.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{Receiver, RecvTimeoutError};
use std::time::{Duration, Instant};

use flexshape_track::TrackRecord;
use serde::{Deserialize, Serialize};

use crate::{Scene, Stats, Update, Viewer};

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

/// Plays `records` in `viewer` at `speed` times their recorded pace, obeying `controls`, until
/// `stop` is set; at the end it pauses on the last record (the page can go back).
pub fn replay(
    viewer: &Viewer,
    records: &[TrackRecord],
    speed: f64,
    controls: &Receiver<Control>,
    stop: &AtomicBool,
) {
    if records.is_empty() {
        return;
    }
    let last = records.len() - 1;
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
                frames: records.len(),
                playing,
            };
            viewer.publish(update(&records[index], state));
            shown = Some(index);
            let gap = if index < last {
                gap_s(&records[index], &records[index + 1])
            } else {
                DEFAULT_GAP_S
            };
            next_at = Instant::now() + Duration::from_secs_f64(gap / speed);
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

/// The recorded time between two records, s: their capture times, else their processing
/// times, else the default pace; at most `MAX_GAP_S`.
fn gap_s(a: &TrackRecord, b: &TrackRecord) -> f64 {
    let times = [(a.captured_s, b.captured_s), (a.processed_s, b.processed_s)];
    times
        .iter()
        .find_map(|&(x, y)| Some(y? - x?))
        .filter(|d| d.is_finite() && *d >= 0.0)
        .unwrap_or(DEFAULT_GAP_S)
        .min(MAX_GAP_S)
}

/// The viewer's frame of `record` at `state`.
fn update(record: &TrackRecord, state: ReplayState) -> Update {
    let stats = Stats {
        frames: state.index + 1,
        fps: 0.0,
        latency_ms: record.latency_ms.unwrap_or(0.0),
        dropped: 0,
        truth_rms_mm: None,
        truth_tip_mm: None,
    };
    Update::of_record(record.clone(), stats).with_replay(state)
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
