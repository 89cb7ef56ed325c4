//! Paths of everything in a recording folder.

use std::path::{Path, PathBuf};

/// The paths of a recording rooted at one folder. Frame `i` of camera `cam` is
/// `frames/<cam>/<i:06>.png`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Layout {
    root: PathBuf,
}

impl Layout {
    /// The layout of the recording at `root`.
    pub fn new(root: impl Into<PathBuf>) -> Self {
        Layout { root: root.into() }
    }

    /// The recording folder.
    pub fn root(&self) -> &Path {
        &self.root
    }

    /// `DIR/rig.toml`.
    pub fn rig(&self) -> PathBuf {
        self.root.join("rig.toml")
    }

    /// `DIR/calibration`.
    pub fn calibration_dir(&self) -> PathBuf {
        self.root.join("calibration")
    }

    /// `DIR/calibration/<cam>.yml`, relative to the folder (as the rig file names it).
    pub fn calibration_file_relative(cam: &str) -> PathBuf {
        Path::new("calibration").join(format!("{cam}.yml"))
    }

    /// `calibration/<cam>_occluded.png`, relative to the recording: the camera's occlusion
    /// mask (the rig's `occluded`), when it has one.
    pub fn occlusion_file_relative(cam: &str) -> PathBuf {
        Path::new("calibration").join(format!("{cam}_occluded.png"))
    }

    /// `DIR/background/<cam>.png`.
    pub fn background(&self, cam: &str) -> PathBuf {
        self.root.join("background").join(format!("{cam}.png"))
    }

    /// `DIR/frames/<cam>`.
    pub fn frames_dir(&self, cam: &str) -> PathBuf {
        self.root.join("frames").join(cam)
    }

    /// `DIR/frames/<cam>/<frame:06>.png`.
    pub fn frame(&self, cam: &str, frame: u64) -> PathBuf {
        self.frames_dir(cam).join(format!("{frame:06}.png"))
    }

    /// `DIR/masks/<cam>`: masks from the lab's own segmentation, in a recording that has them
    /// instead of frames.
    pub fn masks_dir(&self, cam: &str) -> PathBuf {
        self.root.join("masks").join(cam)
    }

    /// `DIR/masks/<cam>/<frame:06>.png`.
    pub fn mask(&self, cam: &str, frame: u64) -> PathBuf {
        self.masks_dir(cam).join(format!("{frame:06}.png"))
    }

    /// `DIR/timestamps.csv`: each frame's capture time (`frame,seconds`), when the recorder
    /// wrote one.
    pub fn timestamps(&self) -> PathBuf {
        self.root.join("timestamps.csv")
    }

    /// `DIR/timestamps/<cam>.csv`: camera `cam`'s own capture time of each of its frames
    /// (`frame,seconds`, in `timestamps.csv`'s time base), when the cameras are not triggered
    /// together and the recorder wrote them.
    pub fn camera_timestamps(&self, cam: &str) -> PathBuf {
        self.root.join("timestamps").join(format!("{cam}.csv"))
    }

    /// `DIR/truth/<frame:06>.json`.
    pub fn truth(&self, frame: u64) -> PathBuf {
        self.root.join("truth").join(format!("{frame:06}.json"))
    }

    /// `DIR/truth/rig.toml`: the true rig of a simulated recording whose calibration was
    /// written off on purpose (its camera files beside it, `DIR/truth/calibration/`).
    pub fn true_rig(&self) -> PathBuf {
        self.root.join("truth").join("rig.toml")
    }

    /// `DIR/truth/masks/<cam>/<frame:06>.png`.
    pub fn truth_mask(&self, cam: &str, frame: u64) -> PathBuf {
        self.root
            .join("truth/masks")
            .join(cam)
            .join(format!("{frame:06}.png"))
    }

    /// `DIR/truth/markers/<cam>/<frame:06>.png`.
    pub fn truth_markers(&self, cam: &str, frame: u64) -> PathBuf {
        self.root
            .join("truth/markers")
            .join(cam)
            .join(format!("{frame:06}.png"))
    }

    /// `DIR/commands/<frame:06>.json`.
    pub fn command(&self, frame: u64) -> PathBuf {
        self.root.join("commands").join(format!("{frame:06}.json"))
    }
}
