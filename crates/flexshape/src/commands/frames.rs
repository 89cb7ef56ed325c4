//! Where frames come from, shared by `track` and `carve`: a recording folder, image or mask
//! folders, videos or live cameras, with the rig, backgrounds and volume the options name.

use std::path::{Path, PathBuf};

use anyhow::{Context, bail};
use flexshape_input::{FolderSource, FrameSource, LiveSource, VideoSource};
use flexshape_rig::{Rig, Volume};
use flexshape_silhouette::BackgroundModel;
use flexshape_track::{Pipeline, Recording, TrackError, load_backgrounds};

use crate::cli::FramesArgs;

/// The rig, its backgrounds and where frames come from.
pub struct Input {
    /// The rig (its volume replaced by --volume / --voxel when given).
    pub rig: Rig,
    /// What to name when the rig is wrong.
    pub rig_name: String,
    /// `None`: the frames are masks (no background model).
    pub backgrounds: Option<Vec<BackgroundModel>>,
    /// Where the frames come from.
    pub source: Box<dyn FrameSource>,
    /// Files and folders read: no output may replace them.
    pub files: Vec<PathBuf>,
}

impl Input {
    /// The sensing chain for this input's rig and backgrounds carving `volume`: from images
    /// against the background models, or from masks when the frames are masks.
    pub fn pipeline(&self, volume: &Volume) -> Result<Pipeline, TrackError> {
        match &self.backgrounds {
            Some(b) => Pipeline::new(&self.rig, b, volume),
            None => Pipeline::for_masks(&self.rig, volume),
        }
    }
}

/// Whether output `path` is `input` or lies inside it (compared as canonical paths; an
/// output that does not exist yet by its folder's).
pub fn within(path: &Path, input: &Path) -> bool {
    if path == Path::new("-") {
        return false;
    }
    let Ok(input) = input.canonicalize() else {
        return false;
    };
    let canonical = path.canonicalize().ok().or_else(|| {
        let parent = match path.parent() {
            Some(p) if !p.as_os_str().is_empty() => p,
            _ => Path::new("."),
        };
        Some(parent.canonicalize().ok()?.join(path.file_name()?))
    });
    canonical.is_some_and(|c| c == input || (input.is_dir() && c.starts_with(&input)))
}

/// What `args` reads besides the recording or frames: the rig and backgrounds.
fn named_inputs(args: &FramesArgs) -> Vec<PathBuf> {
    [&args.rig, &args.backgrounds]
        .into_iter()
        .flatten()
        .cloned()
        .collect()
}

/// The rig, backgrounds and frame source the arguments name; `--classifier` replaces the
/// rig's silhouette classifier.
pub fn open_input(args: &FramesArgs) -> anyhow::Result<Input> {
    let mut input = open_input_as_given(args)?;
    if let Some(classifier) = &args.classifier {
        // Said against the option, not the rig file it overrides.
        classifier
            .clone()
            .try_into::<flexshape_silhouette::Classifier>()
            .map_err(|e| anyhow::anyhow!("--classifier: {}", e.message()))?;
        let silhouette = input
            .rig
            .processing
            .entry("silhouette")
            .or_insert_with(|| toml::Value::Table(toml::Table::new()));
        let toml::Value::Table(table) = silhouette else {
            bail!("{}: [processing.silhouette] is not a table", input.rig_name);
        };
        table.insert("classifier".into(), classifier.clone());
    }
    Ok(input)
}

fn open_input_as_given(args: &FramesArgs) -> anyhow::Result<Input> {
    if let Some(dir) = &args.recording {
        let opened = Recording::open_with(dir, args.backgrounds.as_deref())
            .with_context(|| format!("cannot open the recording {}", dir.display()))?;
        for s in opened.skipped() {
            eprintln!("warning: {s}");
        }
        let rec = opened.source.reader();
        let mut rig = opened.rig.clone();
        let mut rig_name = rec.layout().rig().display().to_string();
        if let Some(path) = &args.rig {
            let other = super::load_rig(path)?;
            let names = |r: &Rig| r.cameras.iter().map(|c| c.name.clone()).collect::<Vec<_>>();
            if names(&other) != names(&rig) {
                bail!(
                    "--rig {} has cameras {:?} but the recording has {:?}; give a rig of the same cameras",
                    path.display(),
                    names(&other),
                    names(&rig)
                );
            }
            (rig, rig_name) = (other, path.display().to_string());
        }
        let mut files = named_inputs(args);
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
        return Ok(Input {
            rig,
            rig_name,
            backgrounds: opened.backgrounds,
            source: Box::new(opened.source),
            files,
        });
    }
    let what = if !args.images.is_empty() {
        "--images"
    } else if !args.masks.is_empty() {
        "--masks"
    } else if !args.video.is_empty() {
        "--video"
    } else {
        "--camera"
    };
    let Some(rig_path) = &args.rig else {
        bail!("{what} needs the rig: give --rig RIG.toml or --rig CALIBRATION_DIR");
    };
    let rig = super::load_rig(rig_path)?;
    let mut files = named_inputs(args);
    for given in [&args.images, &args.masks, &args.video, &args.camera] {
        files.extend(given.iter().map(|(_, p)| p.clone()));
    }
    if !args.masks.is_empty() {
        return Ok(Input {
            source: folders(&rig, &args.masks, what)?,
            rig,
            rig_name: rig_path.display().to_string(),
            backgrounds: None,
            files,
        });
    }
    let Some(bg_dir) = &args.backgrounds else {
        bail!(
            "{what} needs a background image per camera: give --backgrounds DIR holding NAME.png for each camera (make them with `flexshape background`)"
        );
    };
    let backgrounds = load_backgrounds(&rig, |name| bg_dir.join(format!("{name}.png")))?;
    let size = |name: &str| {
        rig.camera(name)
            .map(|c| (c.camera.intrinsics.width, c.camera.intrinsics.height))
    };
    let source: Box<dyn FrameSource> = if !args.images.is_empty() {
        folders(&rig, &args.images, what)?
    } else if !args.video.is_empty() {
        let videos: Vec<_> = per_camera(&rig, &args.video, what)?
            .into_iter()
            .map(|(name, path)| {
                let s = size(&name).unwrap_or_default();
                (name, path, s)
            })
            .collect();
        Box::new(VideoSource::open(&videos)?)
    } else {
        let cameras: Vec<_> = per_camera(&rig, &args.camera, what)?
            .into_iter()
            .map(|(name, input)| {
                let s = size(&name).unwrap_or_default();
                (name, input.display().to_string(), s)
            })
            .collect();
        Box::new(LiveSource::open(&cameras)?)
    };
    Ok(Input {
        rig,
        rig_name: rig_path.display().to_string(),
        backgrounds: Some(backgrounds),
        source,
        files,
    })
}

/// Frames from one folder (or file) per camera, `what` the option that named them.
fn folders(
    rig: &Rig,
    given: &[(String, PathBuf)],
    what: &str,
) -> anyhow::Result<Box<dyn FrameSource>> {
    let source = FolderSource::open(&per_camera(rig, given, what)?)?;
    if !source.unpaired().is_empty() {
        eprintln!(
            "left out {} images not present for every camera: {}",
            source.unpaired().len(),
            source.unpaired().join(", ")
        );
    }
    Ok(Box::new(source))
}

/// Each camera's background model, from the image `path_of(name)`.
/// The inputs in the rig's camera order, each camera exactly once.
fn per_camera(
    rig: &Rig,
    given: &[(String, PathBuf)],
    what: &str,
) -> anyhow::Result<Vec<(String, PathBuf)>> {
    for (name, _) in given {
        if rig.camera(name).is_none() {
            bail!(
                "{what} {name}=…: the rig has no camera `{name}` (its cameras: {})",
                rig.cameras
                    .iter()
                    .map(|c| c.name.as_str())
                    .collect::<Vec<_>>()
                    .join(", ")
            );
        }
        if given.iter().filter(|(n, _)| n == name).count() > 1 {
            bail!("{what} names camera `{name}` twice");
        }
    }
    rig.cameras
        .iter()
        .map(|c| {
            given
                .iter()
                .find(|(n, _)| *n == c.name)
                .cloned()
                .with_context(|| {
                    format!(
                        "camera `{}` of the rig has no input: give {what} {}=…",
                        c.name, c.name
                    )
                })
        })
        .collect()
}

/// Warns when most of the volume's corners are seen by no camera: the rig's volume is likely
/// not where the cameras look (an imported calibration with the default volume).
pub fn warn_unseen(rig: &Rig, volume: &Volume) {
    let cameras: Vec<_> = rig.cameras.iter().map(|c| c.camera.clone()).collect();
    let unseen = flexshape_rig::coverage::corners_seen(&cameras, volume)
        .iter()
        .filter(|&&n| n == 0)
        .count();
    if unseen > 4 {
        eprintln!(
            "warning: {unseen} of the volume's 8 corners are seen by no camera: the volume may not be where the cameras look{}",
            super::suggested_volume(&cameras, volume.voxel_size[0])
                .map(|s| format!("; every camera sees {s}"))
                .unwrap_or_default()
        );
    }
}

/// The volume to carve: the rig's, or the one given on the command line.
pub fn volume(rig: &Volume, args: &FramesArgs) -> anyhow::Result<Volume> {
    let (min, max) = match args.volume {
        Some(b) => ([b[0], b[1], b[2]], [b[3], b[4], b[5]]),
        None if args.voxel.is_none() => return Ok(*rig),
        None => {
            let m = rig.max_corner();
            (rig.origin, [m.x, m.y, m.z])
        }
    };
    let voxel = args.voxel.unwrap_or(rig.voxel_size[0]);
    Volume::from_bounds(min, max, voxel).context("invalid --volume / --voxel")
}
