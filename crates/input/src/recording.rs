//! A recording folder in the project's layout (`docs/formats.md`).

use std::collections::BTreeMap;

use flexshape_recording::RecordingReader;

use crate::{CaptureSource, CaptureTime, FrameImage, FrameSet, FrameSource, InputError};

/// Every frame of a recording, in order, with its command and truth when present.
pub struct RecordingSource {
    reader: RecordingReader,
    next: usize,
    /// Capture times from `timestamps.csv`, or why they could not be read.
    timestamps: Result<BTreeMap<u64, f64>, String>,
    /// Each camera's own capture times from `timestamps/<cam>.csv` (none: triggered
    /// together), or why they could not be read.
    camera_times: Result<Option<Vec<BTreeMap<u64, f64>>>, String>,
}

impl RecordingSource {
    /// Reads the frames of `reader`'s recording. Capture times come from its
    /// `timestamps.csv`, else from the first camera's file times.
    pub fn new(reader: RecordingReader) -> Self {
        let timestamps = reader.read_timestamps().map_err(|e| e.to_string());
        let camera_times = reader.read_camera_timestamps().map_err(|e| e.to_string());
        RecordingSource {
            reader,
            next: 0,
            timestamps,
            camera_times,
        }
    }

    /// The recording.
    pub fn reader(&self) -> &RecordingReader {
        &self.reader
    }

    /// Makes the frame at `index` (its place in the recording, from 0; clamped to the last)
    /// the next one read: random access for a replay.
    pub fn seek(&mut self, index: usize) {
        self.next = index.min(self.reader.frames().len().saturating_sub(1));
    }
}

impl FrameSource for RecordingSource {
    fn next_frame(&mut self) -> Option<Result<FrameSet, InputError>> {
        let &frame = self.reader.frames().get(self.next)?;
        self.next += 1;
        let images = self
            .reader
            .rig()
            .cameras
            .iter()
            .map(|c| FrameImage::File(self.reader.frame_path(&c.name, frame)))
            .collect();
        let mut set = FrameSet::new(frame, images);
        set.capture_time = match &self.timestamps {
            Ok(times) => times.get(&frame).map(|&seconds| CaptureTime {
                seconds,
                source: CaptureSource::Timestamps,
            }),
            Err(e) => {
                // Said once, with the first frame.
                if self.next == 1 {
                    set.warnings
                        .push(format!("{e}; capture times from the files' times"));
                }
                None
            }
        }
        .or_else(|| match set.images.first() {
            Some(FrameImage::File(path)) => CaptureTime::of_file(path),
            _ => None,
        });
        set.camera_times = match &self.camera_times {
            Ok(None) => None,
            Ok(Some(cameras)) => {
                let times: Option<Vec<f64>> =
                    cameras.iter().map(|t| t.get(&frame).copied()).collect();
                if times.is_none() {
                    set.warnings.push(format!(
                        "frame {frame} is missing from a camera's timestamps/ file: its \
                         cameras are taken as captured together"
                    ));
                }
                times
            }
            Err(e) => {
                if self.next == 1 {
                    set.warnings
                        .push(format!("{e}; the cameras are taken as captured together"));
                }
                None
            }
        };
        match self.reader.read_command(frame) {
            Ok(command) => set.command = command,
            Err(e) => set
                .warnings
                .push(format!("{e}; the frame's command is left out")),
        }
        match self.reader.read_truth(frame) {
            Ok(truth) => set.truth = truth,
            Err(e) => set
                .warnings
                .push(format!("{e}; the frame's truth is left out")),
        }
        Some(Ok(set))
    }

    fn len_hint(&self) -> Option<usize> {
        Some(self.reader.frames().len())
    }
}
