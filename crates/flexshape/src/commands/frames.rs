//! Where frames come from, shared by `track` and `carve`: a recording folder, image or mask
//! folders, videos or live cameras, with the rig, backgrounds and volume the options name.

use anyhow::Context;
use flexshape_rig::{Rig, Volume};
use flexshape_track::{Input, SourceSpec};

use crate::cli::FramesArgs;

/// The rig, backgrounds and frame source the arguments name (warnings printed); see
/// [`flexshape_track::Input::open`].
pub fn open_input(args: &FramesArgs) -> anyhow::Result<Input> {
    if let Some(ms) = args.pair_within {
        anyhow::ensure!(
            ms.is_finite() && ms > 0.0 && ms <= 10_000.0,
            "--pair-within {ms}: give how far apart (ms) the cameras' frames of one set may be captured, above 0 and at most 10 s"
        );
    }
    let input = Input::open(&SourceSpec {
        recording: args.recording.clone(),
        images: args.images.clone(),
        masks: args.masks.clone(),
        video: args.video.clone(),
        camera: args.camera.clone(),
        pair_within_s: args.pair_within.map(|ms| ms / 1e3),
        rig: args.rig.clone(),
        backgrounds: args.backgrounds.clone(),
        classifier: args.classifier.clone(),
    })?;
    for w in &input.warnings {
        eprintln!("warning: {w}");
    }
    Ok(input)
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
            flexshape_rig::coverage::suggest_volume(&cameras, volume.voxel_size[0])
                .map(|s| format!("; every camera sees {}", s.as_options()))
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
