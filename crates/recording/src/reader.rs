//! Reading a recording folder, checking its structure up front.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

use flexshape_rig::{Rig, SkippedFile, Volume};
use image::{GrayImage, RgbImage};

use crate::command::Command;
use crate::error::RecordingError;
use crate::layout::Layout;
use crate::truth::Truth;

/// An opened recording: its rig and the frame numbers present for every camera.
#[derive(Debug)]
pub struct RecordingReader {
    layout: Layout,
    rig: Rig,
    frames: Vec<u64>,
    skipped: Vec<SkippedFile>,
    masks: bool,
}

impl RecordingReader {
    /// Opens the recording at `root`: the rig from `rig.toml` if present (a `rig.toml` that is
    /// not a regular file — a folder, a device — is an error, not skipped), otherwise from the
    /// camera files in `calibration/` (with the default volume); then lists
    /// `frames/<cam>/NNNNNN.png` for every camera and checks they hold the same frame numbers.
    /// A recording without `frames/` but with `masks/` is one of masks: the same, from
    /// `masks/<cam>/NNNNNN.png`.
    pub fn open(root: &Path) -> Result<Self, RecordingError> {
        let layout = Layout::new(root);
        if !root.is_dir() {
            return Err(RecordingError::Layout {
                path: root.to_path_buf(),
                problem: "not a folder; give the recording folder (with calibration/ and frames/)"
                    .into(),
            });
        }
        // `exists`, not `is_file`: a rig.toml that is a folder or a device is refused by the
        // loader, naming it, instead of being passed over for the defaults.
        let (rig, skipped) = if layout.rig().exists() {
            (Rig::load(&layout.rig())?, Vec::new())
        } else {
            Rig::from_calibration_dir_skipping(&layout.calibration_dir(), Volume::default())?
        };
        let masks = !root.join("frames").exists() && root.join("masks").is_dir();
        let mut frames: Option<(String, BTreeSet<u64>)> = None;
        for cam in &rig.cameras {
            let (dir, what) = if masks {
                (layout.masks_dir(&cam.name), "masks")
            } else {
                (layout.frames_dir(&cam.name), "frames")
            };
            let entries = std::fs::read_dir(&dir).map_err(|e| RecordingError::Layout {
                path: dir.clone(),
                problem: format!("camera `{}` has no {what} folder ({e})", cam.name),
            })?;
            let numbers: BTreeSet<u64> = entries
                .filter_map(|e| e.ok())
                .filter_map(|e| frame_number(&e.path()))
                .collect();
            match &frames {
                None => frames = Some((cam.name.clone(), numbers)),
                Some((first, set)) if *set != numbers => {
                    let only_first = set.difference(&numbers).next();
                    let only_this = numbers.difference(set).next();
                    let detail = match (only_first, only_this) {
                        (Some(f), _) => format!(
                            "frame {f:06} exists for `{first}` but not for `{}`",
                            cam.name
                        ),
                        (_, Some(f)) => format!(
                            "frame {f:06} exists for `{}` but not for `{first}`",
                            cam.name
                        ),
                        _ => String::new(),
                    };
                    return Err(RecordingError::Layout {
                        path: root.to_path_buf(),
                        problem: format!(
                            "cameras have different frames ({} for `{first}`, {} for `{}`): {detail}",
                            set.len(),
                            numbers.len(),
                            cam.name
                        ),
                    });
                }
                Some(_) => {}
            }
        }
        let frames = frames
            .map(|(_, s)| s.into_iter().collect())
            .unwrap_or_default();
        Ok(RecordingReader {
            layout,
            rig,
            frames,
            skipped,
            masks,
        })
    }

    /// Files in `calibration/` that were not camera files and were skipped (only when the rig
    /// came from that folder), for the caller to report.
    pub fn skipped_files(&self) -> &[SkippedFile] {
        &self.skipped
    }

    /// The recording's rig.
    pub fn rig(&self) -> &Rig {
        &self.rig
    }

    /// The layout (paths).
    pub fn layout(&self) -> &Layout {
        &self.layout
    }

    /// Frame numbers present for every camera, ascending.
    pub fn frames(&self) -> &[u64] {
        &self.frames
    }

    /// Whether the recording holds masks (`masks/`) instead of frames.
    pub fn has_masks(&self) -> bool {
        self.masks
    }

    /// The file of frame `frame` of camera `cam` (by name): its image, or its mask in a
    /// recording of masks.
    pub fn frame_path(&self, cam: &str, frame: u64) -> PathBuf {
        if self.masks {
            self.layout.mask(cam, frame)
        } else {
            self.layout.frame(cam, frame)
        }
    }

    /// Reads frame `frame` of camera number `cam` as 8-bit RGB (a mask in a recording of
    /// masks), checking its size.
    pub fn read_frame(&self, cam: usize, frame: u64) -> Result<RgbImage, RecordingError> {
        let name = &self.rig.cameras[cam].name;
        self.read_rgb(cam, &self.frame_path(name, frame))
    }

    /// Reads camera `cam`'s background image, if the recording has one.
    pub fn read_background(&self, cam: usize) -> Result<Option<RgbImage>, RecordingError> {
        let path = self.layout.background(&self.rig.cameras[cam].name);
        if !path.is_file() {
            return Ok(None);
        }
        self.read_rgb(cam, &path).map(Some)
    }

    fn read_rgb(&self, cam: usize, path: &Path) -> Result<RgbImage, RecordingError> {
        let k = &self.rig.cameras[cam].camera.intrinsics;
        match flexshape_rig::files::read_image(path, Some((k.width, k.height))) {
            Ok(img) => Ok(img.to_rgb8()),
            Err(flexshape_rig::files::FileError::Size { width, height, .. }) => {
                Err(RecordingError::ImageSize {
                    path: path.to_path_buf(),
                    camera: self.rig.cameras[cam].name.clone(),
                    width,
                    height,
                    expected_width: k.width,
                    expected_height: k.height,
                })
            }
            Err(e) => Err(RecordingError::Image {
                path: path.to_path_buf(),
                message: e.reason(),
            }),
        }
    }

    fn check_size(
        &self,
        cam: usize,
        path: &Path,
        (width, height): (u32, u32),
    ) -> Result<(), RecordingError> {
        let c = &self.rig.cameras[cam];
        let k = &c.camera.intrinsics;
        if (width, height) != (k.width, k.height) {
            return Err(RecordingError::ImageSize {
                path: path.to_path_buf(),
                camera: c.name.clone(),
                width,
                height,
                expected_width: k.width,
                expected_height: k.height,
            });
        }
        Ok(())
    }

    /// Each frame's capture time from `timestamps.csv` (lines `frame,seconds`; a header line
    /// and `#` comments are skipped), or an empty map when there is none.
    pub fn read_timestamps(&self) -> Result<BTreeMap<u64, f64>, RecordingError> {
        crate::timestamps::read(&self.layout.timestamps())
    }

    /// Each camera's own capture times, rig order, from `timestamps/<cam>.csv` (as
    /// `timestamps.csv`), or `None` when no camera has such a file (the cameras were triggered
    /// together). A camera without one, when others have one, is an error naming its file:
    /// its frames' times would be unknown.
    pub fn read_camera_timestamps(
        &self,
    ) -> Result<Option<Vec<BTreeMap<u64, f64>>>, RecordingError> {
        let paths: Vec<PathBuf> = self
            .rig
            .cameras
            .iter()
            .map(|c| self.layout.camera_timestamps(&c.name))
            .collect();
        if !paths.iter().any(|p| p.exists()) {
            return Ok(None);
        }
        paths
            .iter()
            .map(|path| {
                if path.exists() {
                    crate::timestamps::read(path)
                } else {
                    Err(RecordingError::Layout {
                        path: path.clone(),
                        problem: "missing, while other cameras have their own capture times \
                                  in timestamps/: write one for every camera, or none"
                            .into(),
                    })
                }
            })
            .collect::<Result<Vec<_>, _>>()
            .map(Some)
    }

    /// Reads `truth/<frame>.json`, if present (simulated recordings).
    pub fn read_truth(&self, frame: u64) -> Result<Option<Truth>, RecordingError> {
        Truth::read(&self.layout, frame)
    }

    /// Reads `commands/<frame>.json`, if present (model experiments).
    pub fn read_command(&self, frame: u64) -> Result<Option<Command>, RecordingError> {
        read_json(self.layout.command(frame), |path, message| {
            RecordingError::Command { path, message }
        })
    }

    /// Reads camera `cam`'s exact object mask of `frame`, if present (simulated recordings).
    pub fn read_truth_mask(
        &self,
        cam: usize,
        frame: u64,
    ) -> Result<Option<GrayImage>, RecordingError> {
        let path = self.layout.truth_mask(&self.rig.cameras[cam].name, frame);
        if !path.is_file() {
            return Ok(None);
        }
        let img = decode(&path)?.to_luma8();
        self.check_size(cam, &path, img.dimensions())?;
        Ok(Some(img))
    }
}

fn decode(path: &Path) -> Result<image::DynamicImage, RecordingError> {
    flexshape_rig::files::read_image(path, None).map_err(|e| RecordingError::Image {
        path: path.to_path_buf(),
        message: e.reason(),
    })
}

/// `NNNNNN.png` → `Some(NNNNNN)`.
fn frame_number(path: &Path) -> Option<u64> {
    if !path.extension()?.eq_ignore_ascii_case("png") {
        return None;
    }
    let stem = path.file_stem()?.to_str()?;
    if stem.is_empty() || !stem.bytes().all(|b| b.is_ascii_digit()) {
        return None;
    }
    stem.parse().ok()
}

/// The JSON file at `path`, or `None` when there is none; `invalid` names a parse failure.
pub(crate) fn read_json<T: serde::de::DeserializeOwned>(
    path: PathBuf,
    invalid: impl FnOnce(PathBuf, String) -> RecordingError,
) -> Result<Option<T>, RecordingError> {
    if !path.is_file() {
        return Ok(None);
    }
    let text = std::fs::read(&path).map_err(|e| RecordingError::io(&path, e))?;
    serde_json::from_slice(&text)
        .map(Some)
        .map_err(|e| invalid(path, e.to_string()))
}
