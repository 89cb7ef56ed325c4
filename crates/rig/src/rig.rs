//! The rig file: named cameras, the working volume and per-stage processing settings, in TOML.
//!
//! ```toml
//! [volume]
//! origin = [-128.0, -128.0, -128.0]  # world mm, minimum corner
//! voxel_size = 1.0                   # mm; or [sx, sy, sz]
//! dims = [256, 256, 256]
//!
//! [[cameras]]
//! name = "cam0"
//! file = "calibration/cam0.yml"      # relative to the rig file
//! image_size = [640, 480]            # optional; must match the camera file
//! occluded = "calibration/cam0_occluded.png"  # optional; where a fixture hides the volume
//!
//! [processing.silhouette]            # each stage reads its own table
//! ```

use std::collections::HashSet;
use std::path::{Path, PathBuf};

use flexshape_camera::Camera;
use serde::{Deserialize, Serialize};

use crate::camera_file;
use crate::error::RigError;
use crate::volume::Volume;

/// A file in a calibration folder that is not a camera file, and why.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SkippedFile {
    /// The file.
    pub file: PathBuf,
    /// Why it is not a camera file.
    pub reason: String,
}

impl std::fmt::Display for SkippedFile {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}: {}", self.file.display(), self.reason)
    }
}

/// `None` when `file` is (meant as) a camera file: `camera_matrix` is one of its top-level
/// entries (a JSON object's key; a YAML key at the start of a line), or it names
/// `camera_matrix` but cannot be parsed as JSON. Otherwise why not: another tool's rig or
/// notes beside the camera files may name `camera_matrix` inside entries of their own.
/// Unreadable files are left to the camera reader's error.
fn camera_file_or_why_not(file: &Path) -> Option<String> {
    let text = crate::files::read_bytes(file, crate::files::MAX_TEXT_BYTES, "camera file").ok()?;
    let text = String::from_utf8_lossy(&text);
    if !text.contains("camera_matrix") {
        return Some("not a camera file (no camera_matrix); skipped".to_string());
    }
    let top_level = if crate::camera_file::is_json(file) {
        match serde_json::from_str::<serde_json::Value>(&text) {
            Ok(value) => value.get("camera_matrix").is_some(),
            // Meant as a camera file, broken: the reader says where.
            Err(_) => true,
        }
    } else {
        text.lines().any(|l| {
            l.strip_prefix("camera_matrix")
                .is_some_and(|rest| rest.trim_start().starts_with(':'))
        })
    };
    (!top_level).then(|| {
        "not a camera file (camera_matrix only inside other entries: another tool's file?); skipped"
            .to_string()
    })
}

/// One camera of a rig.
#[derive(Debug, Clone, PartialEq)]
pub struct RigCamera {
    /// Name used for folders and records (`cam0`, …).
    pub name: String,
    /// Calibration file, relative to the rig file (as written in it).
    pub file: PathBuf,
    /// The calibrated camera (world frame, mm).
    pub camera: Camera,
    /// Where something in front of the working volume hides it from this camera, if the rig
    /// says (`occluded`).
    pub occluded: Option<Occluded>,
}

/// The pixels of a camera's image where something between the camera and the working volume
/// (a fixture, a clamp, the robot's base, a lamp's housing) hides the volume: the camera can
/// say nothing of what lies behind them, so they neither carve the hull away nor count for or
/// against a fitted tube. A mask the size of the camera's image (PNG or JPEG, any colour
/// type), hidden where its brightest channel is at least [`Occluded::LEVEL`].
#[derive(Debug, Clone, PartialEq)]
pub struct Occluded {
    /// The mask file, relative to the rig file (as written in it).
    pub file: PathBuf,
    /// The mask: 255 where hidden, 0 where seen (pixel (x, y) at row y, column x).
    pub mask: image::GrayImage,
}

impl Occluded {
    /// Level of a mask's brightest channel from which its pixel is hidden.
    pub const LEVEL: u8 = 128;

    /// Reads the mask `file` (relative to the rig file's folder `dir`), which must be
    /// `width`×`height`.
    fn read(
        dir: &Path,
        file: PathBuf,
        (width, height): (u32, u32),
    ) -> Result<Self, crate::files::FileError> {
        let image = crate::files::read_image(&dir.join(&file), Some((width, height)))?;
        let rgb = image.to_rgb8();
        let mask = image::GrayImage::from_fn(width, height, |x, y| {
            let p = rgb.get_pixel(x, y).0;
            image::Luma([if p.into_iter().max().unwrap_or(0) >= Self::LEVEL {
                255
            } else {
                0
            }])
        });
        Ok(Occluded { file, mask })
    }

    /// Whether pixel (x, y) is hidden (false outside the mask).
    pub fn hides(&self, x: u32, y: u32) -> bool {
        x < self.mask.width() && y < self.mask.height() && self.mask.get_pixel(x, y).0[0] > 0
    }

    /// The share of the image hidden, 0–1.
    pub fn share(&self) -> f64 {
        let (w, h) = self.mask.dimensions();
        let hidden = (0..h)
            .flat_map(|y| (0..w).map(move |x| (x, y)))
            .filter(|&(x, y)| self.hides(x, y))
            .count();
        hidden as f64 / (f64::from(w) * f64::from(h)).max(1.0)
    }
}

/// Cameras, working volume and processing settings.
#[derive(Debug, Clone, PartialEq)]
pub struct Rig {
    /// The cameras, in file order.
    pub cameras: Vec<RigCamera>,
    /// The volume to carve.
    pub volume: Volume,
    /// Per-stage settings (`[processing.<stage>]` tables), interpreted by each stage.
    pub processing: toml::Table,
    /// What `flexshape rig refine` did to the poses, when this rig came from it
    /// (`[refined]`).
    pub refined: Option<Refined>,
}

/// The `[refined]` table a refined rig carries: which cameras `flexshape rig refine` moved,
/// and how far the world frame may have moved with them.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Refined {
    /// The cameras whose poses were refined, by name; the others kept their calibrated poses.
    pub moved: Vec<String>,
    /// How far the world frame may have moved, mm at the tubes: 0 when the images told which
    /// cameras had moved (the held ones keep the world frame where the calibration put it);
    /// otherwise how far it would have gone had a held camera been the one knocked.
    pub world_open_mm: f64,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawRig {
    volume: Option<RawVolume>,
    #[serde(default)]
    cameras: Vec<RawRigCamera>,
    #[serde(default)]
    processing: toml::Table,
    refined: Option<Refined>,
}

#[derive(Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
struct RawVolume {
    origin: [f64; 3],
    voxel_size: VoxelSize,
    dims: [u32; 3],
}

#[derive(Debug, Deserialize, Serialize)]
#[serde(untagged)]
enum VoxelSize {
    Cubic(f64),
    PerAxis([f64; 3]),
}

#[derive(Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
struct RawRigCamera {
    name: String,
    file: PathBuf,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    image_size: Option<[u32; 2]>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    occluded: Option<PathBuf>,
}

#[derive(Serialize)]
struct RigOut<'a> {
    volume: RawVolume,
    cameras: Vec<RawRigCamera>,
    processing: &'a toml::Table,
    #[serde(skip_serializing_if = "Option::is_none")]
    refined: Option<&'a Refined>,
}

impl Rig {
    /// Reads and validates a rig file and every camera file it names.
    pub fn load(path: &Path) -> Result<Rig, RigError> {
        let text = crate::files::read_text(path, "rig file").map_err(RigError::from)?;
        Self::parse(&text, path)
    }

    /// A rig TOML, or a folder of OpenCV camera files (with the default volume), and the
    /// files in such a folder skipped as not being camera files.
    pub fn open(path: &Path) -> Result<(Rig, Vec<SkippedFile>), RigError> {
        let named_toml = path
            .extension()
            .is_some_and(|e| e.eq_ignore_ascii_case("toml"));
        match (path.is_dir(), named_toml) {
            (true, true) => Err(RigError::Syntax {
                file: path.to_path_buf(),
                message:
                    "is a folder, not a rig file: give the rig TOML, or a folder of camera files"
                        .to_string(),
            }),
            (true, false) => Self::from_calibration_dir_skipping(path, Volume::default()),
            (false, _) => Ok((Self::load(path)?, Vec::new())),
        }
    }

    /// Parses rig TOML; camera files are resolved relative to `path`'s folder.
    pub fn parse(text: &str, path: &Path) -> Result<Rig, RigError> {
        let raw: RawRig = toml::from_str(text).map_err(|e| RigError::Syntax {
            file: path.to_path_buf(),
            message: format!("invalid rig TOML: {e}"),
        })?;
        let volume = match raw.volume {
            None => Volume::default(),
            Some(v) => {
                let size = match v.voxel_size {
                    VoxelSize::Cubic(s) => [s; 3],
                    VoxelSize::PerAxis(s) => s,
                };
                Volume::new(v.origin, size, v.dims)
                    .map_err(|e| RigError::field(path, format!("volume.{}", e.field), e.problem))?
            }
        };
        if raw.cameras.is_empty() {
            return Err(RigError::field(
                path,
                "cameras",
                "no cameras; add one [[cameras]] table (name, file) per camera",
            ));
        }
        let dir = path.parent().unwrap_or(Path::new("."));
        let mut seen = HashSet::new();
        let mut cameras = Vec::with_capacity(raw.cameras.len());
        for (i, c) in raw.cameras.into_iter().enumerate() {
            if !valid_name(&c.name) {
                return Err(RigError::field(
                    path,
                    format!("cameras[{i}].name"),
                    format!(
                        "`{}` is not usable as a folder name; use letters, digits, `_` or `-`",
                        c.name
                    ),
                ));
            }
            if !seen.insert(c.name.clone()) {
                return Err(RigError::field(
                    path,
                    format!("cameras[{i}].name"),
                    format!(
                        "camera name `{}` appears twice; names must be unique",
                        c.name
                    ),
                ));
            }
            let file_path = dir.join(&c.file);
            let cam_file = camera_file::read(&file_path)?;
            let Some(pose) = cam_file.pose else {
                return Err(RigError::field(
                    &file_path,
                    "R",
                    "no extrinsics: a rig camera needs `R` (or `rvec`) and `T` (or `tvec`) in \
                     the world frame; calibrate the rig's extrinsics",
                ));
            };
            let k = &cam_file.intrinsics;
            if let Some([w, h]) = c.image_size
                && (w, h) != (k.width, k.height)
            {
                return Err(RigError::field(
                    path,
                    format!("cameras[{i}].image_size"),
                    format!(
                        "[{w}, {h}] does not match {}×{} in {}; the calibration belongs to \
                         another image size",
                        k.width,
                        k.height,
                        file_path.display()
                    ),
                ));
            }
            let occluded = c
                .occluded
                .map(|file| Occluded::read(dir, file, (k.width, k.height)))
                .transpose()
                .map_err(|e| {
                    RigError::field(
                        path,
                        format!("cameras[{i}].occluded"),
                        format!(
                            "{e}; the mask must be the camera's image size, white where \
                             something hides the volume"
                        ),
                    )
                })?;
            cameras.push(RigCamera {
                name: c.name,
                file: c.file,
                camera: Camera::new(cam_file.intrinsics, pose),
                occluded,
            });
        }
        Ok(Rig {
            cameras,
            volume,
            processing: raw.processing,
            refined: raw.refined,
        })
    }

    /// Builds a rig from a folder of camera files (`*.yml`, `*.yaml`, `*.json`), one camera per
    /// file named after the file stem, sorted by name. Files of those extensions that are not
    /// camera files (no `camera_matrix`: another tool's rig, notes) are skipped; see
    /// [`Rig::from_calibration_dir_skipping`] to learn which.
    pub fn from_calibration_dir(dir: &Path, volume: Volume) -> Result<Rig, RigError> {
        Self::from_calibration_dir_skipping(dir, volume).map(|(rig, _)| rig)
    }

    /// As [`Rig::from_calibration_dir`], and the files skipped as not being camera files, each
    /// with the reason. A file that mentions `camera_matrix` is a camera file: its problems
    /// are errors. Refused when no camera file is found.
    pub fn from_calibration_dir_skipping(
        dir: &Path,
        volume: Volume,
    ) -> Result<(Rig, Vec<SkippedFile>), RigError> {
        let entries = std::fs::read_dir(dir).map_err(|source| RigError::Read {
            file: dir.to_path_buf(),
            source,
        })?;
        let mut files: Vec<PathBuf> = entries
            .filter_map(|e| e.ok().map(|e| e.path()))
            .filter(|p| {
                p.is_file()
                    && p.extension().and_then(|e| e.to_str()).is_some_and(|e| {
                        matches!(e.to_ascii_lowercase().as_str(), "yml" | "yaml" | "json")
                    })
            })
            .collect();
        files.sort();
        let mut skipped = Vec::new();
        files.retain(|f| match camera_file_or_why_not(f) {
            None => true,
            Some(reason) => {
                skipped.push(SkippedFile {
                    file: f.clone(),
                    reason,
                });
                false
            }
        });
        if files.is_empty() {
            let also = if skipped.is_empty() {
                String::new()
            } else {
                format!(
                    " ({} other file{} skipped: {})",
                    skipped.len(),
                    if skipped.len() == 1 { "" } else { "s" },
                    skipped
                        .iter()
                        .map(|s| s.to_string())
                        .collect::<Vec<_>>()
                        .join("; ")
                )
            };
            return Err(RigError::field(
                dir,
                "cameras",
                format!(
                    "no camera files (*.yml, *.yaml, *.json with a camera_matrix) in this folder{also}"
                ),
            ));
        }
        let toml = files
            .iter()
            .map(|f| {
                let name = f.file_stem().and_then(|s| s.to_str()).unwrap_or_default();
                let file = f.file_name().and_then(|s| s.to_str()).unwrap_or_default();
                format!("[[cameras]]\nname = {name:?}\nfile = {file:?}\n")
            })
            .collect::<String>();
        let mut rig = Self::parse(&toml, &dir.join("(calibration folder)"))?;
        rig.volume = volume;
        Ok((rig, skipped))
    }

    /// The rig as TOML text.
    pub fn to_toml(&self) -> String {
        let v = &self.volume;
        let voxel_size = if v.voxel_size.iter().all(|&s| s == v.voxel_size[0]) {
            VoxelSize::Cubic(v.voxel_size[0])
        } else {
            VoxelSize::PerAxis(v.voxel_size)
        };
        let out = RigOut {
            volume: RawVolume {
                origin: v.origin,
                voxel_size,
                dims: v.dims,
            },
            cameras: self
                .cameras
                .iter()
                .map(|c| RawRigCamera {
                    name: c.name.clone(),
                    file: c.file.clone(),
                    image_size: Some([c.camera.intrinsics.width, c.camera.intrinsics.height]),
                    occluded: c.occluded.as_ref().map(|o| o.file.clone()),
                })
                .collect(),
            processing: &self.processing,
            refined: self.refined.as_ref(),
        };
        let body = toml::to_string(&out).unwrap_or_default();
        format!(
            "# flexshape rig: cameras (OpenCV files, paths relative to this file) and the working\n\
             # volume (world frame, mm; origin = minimum corner). See docs/formats.md.\n{body}"
        )
    }

    /// Writes the rig TOML to `path`, every camera file (OpenCV YAML/JSON by extension) to its
    /// `file` and every occlusion mask to its own, relative to `path`'s folder, creating
    /// folders as needed.
    pub fn save(&self, path: &Path) -> Result<(), RigError> {
        let dir = path.parent().unwrap_or(Path::new("."));
        // `dir.join(relative)`, its folder created.
        let placed = |relative: &Path| -> Result<PathBuf, RigError> {
            let file = dir.join(relative);
            if let Some(parent) = file.parent() {
                std::fs::create_dir_all(parent).map_err(|source| RigError::Write {
                    file: parent.to_path_buf(),
                    source,
                })?;
            }
            Ok(file)
        };
        for c in &self.cameras {
            camera_file::write_camera(&placed(&c.file)?, &c.camera)?;
            if let Some(o) = &c.occluded {
                let file = placed(&o.file)?;
                o.mask.save(&file).map_err(|e| RigError::Write {
                    file: file.clone(),
                    source: std::io::Error::other(e.to_string()),
                })?;
            }
        }
        std::fs::write(path, self.to_toml()).map_err(|source| RigError::Write {
            file: path.to_path_buf(),
            source,
        })
    }

    /// The camera named `name`.
    pub fn camera(&self, name: &str) -> Option<&RigCamera> {
        self.cameras.iter().find(|c| c.name == name)
    }
}

/// Whether `name` can name a camera: letters, digits, `_` and `-` only (it names files and
/// folders, so no separators, dots or spaces).
pub fn valid_name(name: &str) -> bool {
    !name.is_empty()
        && name
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-')
}
