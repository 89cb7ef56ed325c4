//! What a program embedding flexshape opens to track: a recording folder (its rig, its
//! backgrounds or masks, its frames) set up as `flexshape track REC` sets it up, and the JSON
//! Lines records `flexshape track` writes, read back.

use std::path::{Path, PathBuf};

use flexshape_input::RecordingSource;
use flexshape_recording::RecordingReader;
use flexshape_rig::Rig;
use flexshape_silhouette::BackgroundModel;

use crate::{Pipeline, SummaryLine, TrackError, TrackRecord, TrackSummary};

/// A recording folder ready to track (see `docs/formats.md` for its layout).
pub struct Recording {
    /// The recording's rig (`rig.toml`, or the camera files in `calibration/`).
    pub rig: Rig,
    /// Each camera's background model, in the rig's order; `None` when the recording holds
    /// masks (`masks/`), which need none.
    pub backgrounds: Option<Vec<BackgroundModel>>,
    /// Its frame sets, in order (also the reader of its other files).
    pub source: RecordingSource,
}

impl Recording {
    /// Opens the recording at `dir` with its own backgrounds (`background/NAME.png`).
    pub fn open(dir: &Path) -> Result<Self, TrackError> {
        Self::open_with(dir, None)
    }

    /// Opens the recording at `dir`, its backgrounds from `backgrounds` (a folder of
    /// `NAME.png`, as `flexshape background` writes them) when given, else its own.
    pub fn open_with(dir: &Path, backgrounds: Option<&Path>) -> Result<Self, TrackError> {
        let reader = RecordingReader::open(dir)?;
        let rig = reader.rig().clone();
        let backgrounds = match backgrounds {
            Some(_) if reader.has_masks() => {
                return Err(TrackError::Input(format!(
                    "{} holds masks (masks/) instead of frames: it needs no backgrounds; give none (leave out --backgrounds)",
                    dir.display()
                )));
            }
            _ if reader.has_masks() => None,
            Some(folder) => Some(load_backgrounds(&rig, |name| {
                folder.join(format!("{name}.png"))
            })?),
            None => Some(load_backgrounds(&rig, |name| {
                reader.layout().background(name)
            })?),
        };
        Ok(Recording {
            rig,
            backgrounds,
            source: RecordingSource::new(reader),
        })
    }

    /// Files in the folder that were not read, each with why (to warn about).
    pub fn skipped(&self) -> Vec<String> {
        self.source
            .reader()
            .skipped_files()
            .iter()
            .map(ToString::to_string)
            .collect()
    }

    /// The sensing chain for this recording, carving its rig's volume: from images against
    /// the background models, or from masks.
    pub fn pipeline(&self) -> Result<Pipeline, TrackError> {
        match &self.backgrounds {
            Some(b) => Pipeline::new(&self.rig, b, &self.rig.volume),
            None => Pipeline::for_masks(&self.rig, &self.rig.volume),
        }
    }
}

/// Every camera's background model of `rig`, camera `NAME`'s from `path_of(NAME)`.
pub fn load_backgrounds(
    rig: &Rig,
    path_of: impl Fn(&str) -> PathBuf,
) -> Result<Vec<BackgroundModel>, TrackError> {
    rig.cameras
        .iter()
        .map(|cam| {
            let path = path_of(&cam.name);
            BackgroundModel::load(&path).map_err(|source| TrackError::Background {
                camera: cam.name.clone(),
                path,
                source,
            })
        })
        .collect()
}

/// One line of what `flexshape track` writes.
#[derive(Debug, Clone, PartialEq)]
pub enum TrackLine {
    /// A frame's record.
    Record(Box<TrackRecord>),
    /// The run's summary (the last line).
    Summary(Box<TrackSummary>),
}

/// One line of a JSON Lines tracking output: a record, the summary, or `None` for a blank
/// line; else what is wrong with it.
pub fn parse_line(line: &str) -> Result<Option<TrackLine>, String> {
    let Some(value) = json_of(line)? else {
        return Ok(None);
    };
    if value.get("summary").is_some() {
        let s: SummaryLine =
            serde_json::from_value(value).map_err(|e| format!("not a summary ({e})"))?;
        return Ok(Some(TrackLine::Summary(Box::new(s.summary))));
    }
    record_of(value).map(|r| Some(TrackLine::Record(Box::new(r))))
}

/// The tracking records of a JSON Lines file (as `flexshape track` writes it) with their line
/// numbers; summary lines (whatever they hold) and blank lines are skipped.
pub fn read_records(path: &Path) -> Result<Vec<(usize, TrackRecord)>, TrackError> {
    let bad = |line: Option<usize>, problem: String| TrackError::Records {
        path: path.to_path_buf(),
        line,
        problem,
    };
    // Not opened unless a regular file: a FIFO blocks the open, a device reads for ever.
    let meta = std::fs::metadata(path).map_err(|e| bad(None, e.to_string()))?;
    if !meta.is_file() {
        return Err(bad(
            None,
            "not a regular file (a folder, device, FIFO or socket): give a `flexshape track` JSON Lines file".into(),
        ));
    }
    let text = std::fs::read_to_string(path).map_err(|e| bad(None, e.to_string()))?;
    let mut out = Vec::new();
    for (i, line) in text.lines().enumerate() {
        let value = json_of(line).map_err(|e| bad(Some(i + 1), e))?;
        if let Some(value) = value.filter(|v| v.get("summary").is_none()) {
            out.push((i + 1, record_of(value).map_err(|e| bad(Some(i + 1), e))?));
        }
    }
    Ok(out)
}

/// A line's JSON, `None` for a blank line.
fn json_of(line: &str) -> Result<Option<serde_json::Value>, String> {
    if line.trim().is_empty() {
        return Ok(None);
    }
    serde_json::from_str(line)
        .map(Some)
        .map_err(|e| format!("not JSON ({e})"))
}

fn record_of(value: serde_json::Value) -> Result<TrackRecord, String> {
    serde_json::from_value(value).map_err(|e| format!("not a tracking record ({e})"))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `flexshape view /dev/zero` read 1.9 GB before running out of memory, and a FIFO held
    /// the open for ever: neither is opened.
    #[cfg(unix)]
    #[test]
    fn records_are_read_from_regular_files_only() {
        let dir = tempfile::tempdir().unwrap();
        let fifo = dir.path().join("fifo");
        let made = std::process::Command::new("mkfifo").arg(&fifo).status();
        let mut paths = vec![
            Path::new("/dev/zero").to_path_buf(),
            dir.path().to_path_buf(),
        ];
        if made.is_ok_and(|s| s.success()) {
            paths.push(fifo);
        }
        for path in paths {
            let e = read_records(&path).unwrap_err().to_string();
            assert!(e.contains("not a regular file"), "{}: {e}", path.display());
        }
    }
}
