//! A recording folder in the project's layout (`docs/formats.md`).

use flexshape_recording::RecordingReader;

use crate::{FrameImage, FrameSet, FrameSource, InputError};

/// Every frame of a recording, in order, with its command and truth when present.
pub struct RecordingSource {
    reader: RecordingReader,
    next: usize,
}

impl RecordingSource {
    /// Reads the frames of `reader`'s recording.
    pub fn new(reader: RecordingReader) -> Self {
        RecordingSource { reader, next: 0 }
    }

    /// The recording.
    pub fn reader(&self) -> &RecordingReader {
        &self.reader
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
