//! What a program embedding flexshape opens to track: a recording folder (its rig, its
//! backgrounds or masks, its frames) set up as `flexshape track REC` sets it up, and the JSON
//! Lines records `flexshape track` writes, read back.

use std::path::{Path, PathBuf};

use flexshape_input::RecordingSource;
use flexshape_recording::RecordingReader;
use flexshape_rig::Rig;
use flexshape_silhouette::BackgroundModel;

use crate::{Pipeline, TrackError};

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
