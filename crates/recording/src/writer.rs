//! Writing a recording folder. Every file is written whole (to a temporary name, then renamed),
//! so an interrupted run never leaves a truncated frame behind.

use std::io::Cursor;
use std::path::{Path, PathBuf};

use flexshape_rig::{Occluded, Rig, RigCamera};
use image::codecs::png::{CompressionType, FilterType, PngEncoder};
use image::{ExtendedColorType, GrayImage, ImageEncoder, RgbImage};

use crate::command::Command;
use crate::error::RecordingError;
use crate::layout::Layout;
use crate::truth::Truth;

/// Writes one recording: calibration and rig first, then frames and truth as they come.
#[derive(Debug)]
pub struct RecordingWriter {
    layout: Layout,
}

impl RecordingWriter {
    /// Creates the folder tree at `root` and writes `rig.toml` and `calibration/<cam>.yml`
    /// for every camera of `rig`. A non-empty `root` is refused unless `overwrite` is set, so
    /// an earlier recording is never clobbered by accident; with `overwrite`, the parts of a
    /// recording (`rig.toml`, `timestamps.csv`, `calibration/`, `background/`, `frames/`,
    /// `masks/`, `truth/`, `commands/`) are removed
    /// first so no stale frame of the old recording survives, and nothing else is touched.
    pub fn create(root: &Path, rig: &Rig, overwrite: bool) -> Result<Self, RecordingError> {
        Self::create_parts(root, rig, overwrite, false)
    }

    /// As [`RecordingWriter::create`], for a recording of masks ([`RecordingWriter::write_mask`])
    /// instead of frames and backgrounds.
    pub fn create_for_masks(
        root: &Path,
        rig: &Rig,
        overwrite: bool,
    ) -> Result<Self, RecordingError> {
        Self::create_parts(root, rig, overwrite, true)
    }

    fn create_parts(
        root: &Path,
        rig: &Rig,
        overwrite: bool,
        masks: bool,
    ) -> Result<Self, RecordingError> {
        let layout = Layout::new(root);
        if let Ok(mut entries) = std::fs::read_dir(root)
            && entries.next().is_some()
        {
            if !overwrite {
                return Err(RecordingError::Layout {
                    path: root.to_path_buf(),
                    problem:
                        "folder exists and is not empty; choose a new folder or pass --overwrite"
                            .into(),
                });
            }
            for part in [
                "calibration",
                "background",
                "frames",
                "masks",
                "truth",
                "commands",
                "timestamps",
            ] {
                let dir = root.join(part);
                if dir.is_dir() {
                    std::fs::remove_dir_all(&dir).map_err(|e| RecordingError::io(&dir, e))?;
                }
            }
            for file in [layout.rig(), layout.timestamps()] {
                if file.is_file() {
                    std::fs::remove_file(&file).map_err(|e| RecordingError::io(&file, e))?;
                }
            }
        }
        let mut dirs = vec![layout.calibration_dir(), root.join("truth")];
        if !masks {
            dirs.push(root.join("background"));
        }
        for c in &rig.cameras {
            dirs.push(if masks {
                layout.masks_dir(&c.name)
            } else {
                layout.frames_dir(&c.name)
            });
        }
        for d in &dirs {
            std::fs::create_dir_all(d).map_err(|e| RecordingError::io(d, e))?;
        }
        let rebased = Rig {
            cameras: rig
                .cameras
                .iter()
                .map(|c| RigCamera {
                    file: Layout::calibration_file_relative(&c.name),
                    occluded: c.occluded.as_ref().map(|o| Occluded {
                        file: Layout::occlusion_file_relative(&c.name),
                        mask: o.mask.clone(),
                    }),
                    ..c.clone()
                })
                .collect(),
            ..rig.clone()
        };
        rebased.save(&layout.rig())?;
        Ok(RecordingWriter { layout })
    }

    /// A writer adding files to the recording this process created at `root` (with
    /// [`RecordingWriter::create`]).
    pub fn reopen(root: &Path) -> Self {
        RecordingWriter {
            layout: Layout::new(root),
        }
    }

    /// The layout being written.
    pub fn layout(&self) -> &Layout {
        &self.layout
    }

    /// Writes `background/<cam>.png`.
    pub fn write_background(&self, cam: &str, image: &RgbImage) -> Result<(), RecordingError> {
        write_rgb(&self.layout.background(cam), image)
    }

    /// Writes `frames/<cam>/<frame:06>.png`.
    pub fn write_frame(
        &self,
        cam: &str,
        frame: u64,
        image: &RgbImage,
    ) -> Result<(), RecordingError> {
        write_rgb(&self.layout.frame(cam, frame), image)
    }

    /// Writes `masks/<cam>/<frame:06>.png` (0 = background, 255 = object), in a recording
    /// made by [`RecordingWriter::create_for_masks`].
    pub fn write_mask(
        &self,
        cam: &str,
        frame: u64,
        mask: &GrayImage,
    ) -> Result<(), RecordingError> {
        write_gray(&self.layout.mask(cam, frame), mask)
    }

    /// Writes `timestamps.csv`: each frame's capture time, seconds (`frame,seconds` lines after
    /// a header).
    pub fn write_timestamps(&self, times: &[(u64, f64)]) -> Result<(), RecordingError> {
        write_atomic(
            &self.layout.timestamps(),
            crate::timestamps::text(times).as_bytes(),
        )
    }

    /// Writes `timestamps/<cam>.csv`: camera `cam`'s own capture time of each of its frames,
    /// seconds in `timestamps.csv`'s time base (`frame,seconds` lines after a header).
    pub fn write_camera_timestamps(
        &self,
        cam: &str,
        times: &[(u64, f64)],
    ) -> Result<(), RecordingError> {
        let path = self.layout.camera_timestamps(cam);
        if let Some(dir) = path.parent() {
            std::fs::create_dir_all(dir).map_err(|e| RecordingError::io(dir, e))?;
        }
        write_atomic(&path, crate::timestamps::text(times).as_bytes())
    }

    /// Writes `truth/<frame:06>.json`.
    pub fn write_truth(&self, truth: &Truth) -> Result<(), RecordingError> {
        write_json(&self.layout.truth(truth.frame), truth, |path, message| {
            RecordingError::Truth { path, message }
        })
    }

    /// Writes `commands/<frame:06>.json`.
    pub fn write_command(&self, command: &Command) -> Result<(), RecordingError> {
        // `commands/` exists only in model experiments: made on first use.
        let path = self.layout.command(command.frame);
        if let Some(dir) = path.parent() {
            std::fs::create_dir_all(dir).map_err(|e| RecordingError::io(dir, e))?;
        }
        write_json(&path, command, |path, message| RecordingError::Command {
            path,
            message,
        })
    }

    /// Writes `truth/masks/<cam>/<frame:06>.png` (0 = background, 255 = object).
    pub fn write_truth_mask(
        &self,
        cam: &str,
        frame: u64,
        mask: &GrayImage,
    ) -> Result<(), RecordingError> {
        write_gray(&self.layout.truth_mask(cam, frame), mask)
    }

    /// Writes `truth/markers/<cam>/<frame:06>.png` (0 = not a band, 255 = band).
    pub fn write_truth_markers(
        &self,
        cam: &str,
        frame: u64,
        mask: &GrayImage,
    ) -> Result<(), RecordingError> {
        write_gray(&self.layout.truth_markers(cam, frame), mask)
    }
}

/// `value` as JSON at `path` (atomically); `invalid` names an encoding failure.
fn write_json(
    path: &Path,
    value: &impl serde::Serialize,
    invalid: impl FnOnce(PathBuf, String) -> RecordingError,
) -> Result<(), RecordingError> {
    let text = serde_json::to_vec(value).map_err(|e| invalid(path.to_path_buf(), e.to_string()))?;
    write_atomic(path, &text)
}

fn write_rgb(path: &Path, image: &RgbImage) -> Result<(), RecordingError> {
    write_png(
        path,
        image.as_raw(),
        image.dimensions(),
        ExtendedColorType::Rgb8,
    )
}

fn write_gray(path: &Path, mask: &GrayImage) -> Result<(), RecordingError> {
    write_png(
        path,
        mask.as_raw(),
        mask.dimensions(),
        ExtendedColorType::L8,
    )
}

fn write_png(
    path: &Path,
    data: &[u8],
    (w, h): (u32, u32),
    color: ExtendedColorType,
) -> Result<(), RecordingError> {
    let mut bytes = Vec::with_capacity(data.len() / 2);
    PngEncoder::new_with_quality(
        Cursor::new(&mut bytes),
        CompressionType::Fast,
        FilterType::Adaptive,
    )
    .write_image(data, w, h, color)
    .map_err(|e| RecordingError::Image {
        path: path.to_path_buf(),
        message: e.to_string(),
    })?;
    write_atomic(path, &bytes)
}

/// Writes `bytes` to `path` via a temporary sibling and a rename, creating the parent folder.
pub(crate) fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), RecordingError> {
    if let Some(parent) = path.parent() {
        std::fs::create_dir_all(parent).map_err(|e| RecordingError::io(parent, e))?;
    }
    let mut tmp: PathBuf = path.to_path_buf();
    tmp.as_mut_os_string().push(".partial");
    std::fs::write(&tmp, bytes).map_err(|e| RecordingError::io(&tmp, e))?;
    std::fs::rename(&tmp, path).map_err(|e| RecordingError::io(path, e))
}
