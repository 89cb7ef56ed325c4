//! `flexshape rig check`: validate a rig and show what each camera sees of the volume.

use anyhow::Context;
use flexshape_rig::{RigCheck, Volume};

use crate::cli::RigCheckArgs;

pub fn run(args: &RigCheckArgs) -> anyhow::Result<()> {
    let path = args.path.as_path();
    let mut rig = super::load_rig(path)?;
    flexshape_track::Pipeline::check_settings(&rig)
        .with_context(|| format!("{}: invalid [processing] settings", path.display()))?;
    let given = args.volume.is_some() || args.voxel.is_some();
    if given {
        let (lo, hi) = match args.volume {
            Some(b) => ([b[0], b[1], b[2]], [b[3], b[4], b[5]]),
            None => (rig.volume.origin, rig.volume.max_corner().into()),
        };
        let voxel = args.voxel.unwrap_or(rig.volume.voxel_size[0]);
        rig.volume = Volume::from_bounds(lo, hi, voxel).context("invalid --volume / --voxel")?;
    }
    let why = if given {
        " (--volume / --voxel)"
    } else if path.is_dir() {
        " (default volume: a folder has none)"
    } else {
        ""
    };
    println!(
        "{}: {} cameras; {}{why}",
        path.display(),
        rig.cameras.len(),
        rig.volume.describe()
    );
    let check = RigCheck::of(&rig);
    print!("{check}");
    let shape = flexshape_shape::ShapeSettings::from_processing(&rig.processing)
        .with_context(|| format!("{}: invalid [processing.shape]", path.display()))?;
    println!("direction: {}", shape.direction_cues());
    let blind = check.blind();
    if !blind.is_empty() {
        anyhow::bail!(
            "{}: camera{} {} see{} none of the volume (no corner, not its centre): the calibration or the volume is wrong",
            path.display(),
            if blind.len() > 1 { "s" } else { "" },
            blind.join(", "),
            if blind.len() > 1 { "" } else { "s" }
        );
    }
    Ok(())
}
