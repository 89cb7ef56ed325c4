//! Where frames come from, as `flexshape track`, `carve`, `silhouettes` and `rig refine`
//! take them: a recording folder, per-camera image or mask folders, videos or live cameras,
//! with the rig and backgrounds they need.

use std::path::PathBuf;

use flexshape_input::{FolderSource, FrameSource, LiveSource, VideoSource};
use flexshape_rig::{Rig, Volume};
use flexshape_silhouette::BackgroundModel;

use crate::{Pipeline, Recording, TrackError, load_backgrounds};

/// What to track, as the command line names it: one of a recording, images, masks, videos
/// or live cameras (each `(camera name, path)`), and the rig and backgrounds they need (a
/// recording has its own). Errors name the fields by their options (`--images`, `--rig`, …).
#[derive(Debug, Clone, Default)]
pub struct SourceSpec {
    /// A recording folder (`docs/formats.md`).
    pub recording: Option<PathBuf>,
    /// An image folder (or one image) per camera (`--images NAME=DIR`): images with the same
    /// file name in every folder make one frame.
    pub images: Vec<(String, PathBuf)>,
    /// A mask folder (or one mask) per camera (`--masks`), the lab's own segmentation.
    pub masks: Vec<(String, PathBuf)>,
    /// A video file per camera (`--video`), decoded by the `ffmpeg` program.
    pub video: Vec<(String, PathBuf)>,
    /// A live camera per camera (`--camera`): a V4L2 device, a stream URL or a video played
    /// in real time, read by `ffmpeg`.
    pub camera: Vec<(String, PathBuf)>,
    /// How far apart live cameras' frames of one set may be captured, seconds
    /// (`--pair-within`; `None`: from their frame intervals, see [`LiveSource`]).
    pub pair_within_s: Option<f64>,
    /// The rig (`--rig`): a rig TOML or a folder of camera files; replaces a recording's.
    pub rig: Option<PathBuf>,
    /// A folder of background images, `NAME.png` per camera (`--backgrounds`); replaces a
    /// recording's.
    pub backgrounds: Option<PathBuf>,
    /// The silhouette classifier table (`--classifier`), replacing the rig's
    /// `[processing.silhouette] classifier`.
    pub classifier: Option<toml::Value>,
}

/// The rig, its backgrounds and where frames come from.
pub struct Input {
    /// The rig.
    pub rig: Rig,
    /// The rig's file, to name when the rig is wrong.
    pub rig_name: String,
    /// `None`: the frames are masks (no background model).
    pub backgrounds: Option<Vec<BackgroundModel>>,
    /// Where the frames come from.
    pub source: Box<dyn FrameSource>,
    /// Files and folders read: no output may replace them.
    pub files: Vec<PathBuf>,
    /// What the user should know: files skipped, images not present for every camera.
    pub warnings: Vec<String>,
}

impl Input {
    /// Opens what `spec` names.
    pub fn open(spec: &SourceSpec) -> Result<Self, TrackError> {
        let mut input = match &spec.recording {
            Some(dir) => open_recording(dir, spec)?,
            None => open_per_camera(spec)?,
        };
        if let Some(classifier) = &spec.classifier {
            // Said against the option, not the rig file it overrides.
            classifier
                .clone()
                .try_into::<flexshape_silhouette::Classifier>()
                .map_err(|e| TrackError::Input(format!("--classifier: {}", e.message())))?;
            let silhouette = input
                .rig
                .processing
                .entry("silhouette")
                .or_insert_with(|| toml::Value::Table(toml::Table::new()));
            let toml::Value::Table(table) = silhouette else {
                return Err(TrackError::Input(format!(
                    "{}: [processing.silhouette] is not a table",
                    input.rig_name
                )));
            };
            table.insert("classifier".into(), classifier.clone());
        }
        Ok(input)
    }

    /// The sensing chain for this input's rig and backgrounds carving `volume`: from images
    /// against the background models, or from masks when the frames are masks.
    pub fn pipeline(&self, volume: &Volume) -> Result<Pipeline, TrackError> {
        match &self.backgrounds {
            Some(b) => Pipeline::new(&self.rig, b, volume),
            None => Pipeline::for_masks(&self.rig, volume),
        }
    }
}

/// A rig file or folder, named in its error.
fn load_rig(path: &std::path::Path) -> Result<(Rig, Vec<String>), TrackError> {
    let (rig, skipped) = Rig::open(path).map_err(|source| TrackError::Rig {
        path: path.to_path_buf(),
        source,
    })?;
    Ok((rig, skipped.iter().map(ToString::to_string).collect()))
}

/// The camera files a rig file at `path` names (relative to its folder): inputs no output
/// may replace. (A folder of camera files is an input as a whole.)
fn camera_files(path: &std::path::Path, rig: &Rig) -> Vec<PathBuf> {
    if path.is_dir() {
        return Vec::new();
    }
    let folder = path.parent().unwrap_or(std::path::Path::new("."));
    rig.cameras.iter().map(|c| folder.join(&c.file)).collect()
}

/// What `spec` reads besides the recording or frames: the rig and backgrounds.
fn named_inputs(spec: &SourceSpec) -> Vec<PathBuf> {
    [&spec.rig, &spec.backgrounds]
        .into_iter()
        .flatten()
        .cloned()
        .collect()
}

fn open_recording(dir: &std::path::Path, spec: &SourceSpec) -> Result<Input, TrackError> {
    let opened = Recording::open_with(dir, spec.backgrounds.as_deref()).map_err(|e| {
        TrackError::Input(format!("cannot open the recording {}: {e}", dir.display()))
    })?;
    let mut warnings = opened.skipped();
    let rec = opened.source.reader();
    let mut rig = opened.rig.clone();
    let mut rig_name = rec.layout().rig().display().to_string();
    if let Some(path) = &spec.rig {
        let (other, skipped) = load_rig(path)?;
        warnings.extend(skipped);
        let names = |r: &Rig| r.cameras.iter().map(|c| c.name.clone()).collect::<Vec<_>>();
        if names(&other) != names(&rig) {
            return Err(TrackError::Input(format!(
                "--rig {} has cameras {:?} but the recording has {:?}; give a rig of the same cameras",
                path.display(),
                names(&other),
                names(&rig)
            )));
        }
        (rig, rig_name) = (other, path.display().to_string());
    }
    let mut files = named_inputs(spec);
    if let Some(path) = &spec.rig {
        files.extend(camera_files(path, &rig));
    }
    files.push(rec.layout().rig());
    for sub in [
        "calibration",
        "frames",
        "masks",
        "background",
        "truth",
        "commands",
    ] {
        files.push(rec.layout().root().join(sub));
    }
    Ok(Input {
        rig,
        rig_name,
        backgrounds: opened.backgrounds,
        source: Box::new(opened.source),
        files,
        warnings,
    })
}

fn open_per_camera(spec: &SourceSpec) -> Result<Input, TrackError> {
    let what = if !spec.images.is_empty() {
        "--images"
    } else if !spec.masks.is_empty() {
        "--masks"
    } else if !spec.video.is_empty() {
        "--video"
    } else {
        "--camera"
    };
    let Some(rig_path) = &spec.rig else {
        return Err(TrackError::Input(format!(
            "{what} needs the rig: give --rig RIG.toml or --rig CALIBRATION_DIR"
        )));
    };
    let (rig, mut warnings) = load_rig(rig_path)?;
    let rig_name = rig_path.display().to_string();
    let mut files = named_inputs(spec);
    files.extend(camera_files(rig_path, &rig));
    for given in [&spec.images, &spec.masks, &spec.video, &spec.camera] {
        files.extend(given.iter().map(|(_, p)| p.clone()));
    }
    if !spec.masks.is_empty() {
        return Ok(Input {
            source: folders(&rig, &spec.masks, what, &mut warnings)?,
            rig,
            rig_name,
            backgrounds: None,
            files,
            warnings,
        });
    }
    let Some(bg_dir) = &spec.backgrounds else {
        return Err(TrackError::Input(format!(
            "{what} needs a background image per camera: give --backgrounds DIR holding NAME.png for each camera (make them with `flexshape background`)"
        )));
    };
    let backgrounds = load_backgrounds(&rig, |name| bg_dir.join(format!("{name}.png")))?;
    let size = |name: &str| {
        rig.camera(name)
            .map(|c| (c.camera.intrinsics.width, c.camera.intrinsics.height))
            .unwrap_or_default()
    };
    let source: Box<dyn FrameSource> = if !spec.images.is_empty() {
        folders(&rig, &spec.images, what, &mut warnings)?
    } else if !spec.video.is_empty() {
        let videos: Vec<_> = per_camera(&rig, &spec.video, what)?
            .into_iter()
            .map(|(name, path)| {
                let s = size(&name);
                (name, path, s)
            })
            .collect();
        Box::new(VideoSource::open(&videos)?)
    } else {
        let cameras: Vec<_> = per_camera(&rig, &spec.camera, what)?
            .into_iter()
            .map(|(name, input)| {
                let s = size(&name);
                (name, input.display().to_string(), s)
            })
            .collect();
        Box::new(LiveSource::open(&cameras)?.pair_within(spec.pair_within_s))
    };
    Ok(Input {
        rig,
        rig_name,
        backgrounds: Some(backgrounds),
        source,
        files,
        warnings,
    })
}

/// Frames from one folder (or file) per camera, `what` the option that named them.
fn folders(
    rig: &Rig,
    given: &[(String, PathBuf)],
    what: &str,
    warnings: &mut Vec<String>,
) -> Result<Box<dyn FrameSource>, TrackError> {
    let source = FolderSource::open(&per_camera(rig, given, what)?)?;
    if !source.unpaired().is_empty() {
        warnings.push(format!(
            "left out {} images not present for every camera: {}",
            source.unpaired().len(),
            source.unpaired().join(", ")
        ));
    }
    Ok(Box::new(source))
}

/// The inputs in the rig's camera order, each camera exactly once.
fn per_camera(
    rig: &Rig,
    given: &[(String, PathBuf)],
    what: &str,
) -> Result<Vec<(String, PathBuf)>, TrackError> {
    for (name, _) in given {
        if rig.camera(name).is_none() {
            return Err(TrackError::Input(format!(
                "{what} {name}=…: the rig has no camera `{name}` (its cameras: {})",
                rig.cameras
                    .iter()
                    .map(|c| c.name.as_str())
                    .collect::<Vec<_>>()
                    .join(", ")
            )));
        }
        if given.iter().filter(|(n, _)| n == name).count() > 1 {
            return Err(TrackError::Input(format!(
                "{what} names camera `{name}` twice"
            )));
        }
    }
    rig.cameras
        .iter()
        .map(|c| {
            given
                .iter()
                .find(|(n, _)| *n == c.name)
                .cloned()
                .ok_or_else(|| {
                    TrackError::Input(format!(
                        "camera `{}` of the rig has no input: give {what} {}=…",
                        c.name, c.name
                    ))
                })
        })
        .collect()
}
