//! `flexshape rig import` and `rig export`: other tools' calibrations in and out.

use std::path::{Path, PathBuf};

use anyhow::Context;
use flexshape_rig::Volume;
use flexshape_rig::coverage;
use flexshape_rig::import::{self, ImportOptions};
use flexshape_track::output::{refuse_existing, refuse_inputs};

use crate::cli::{RigExportArgs, RigImportArgs};

pub fn import(args: &RigImportArgs) -> anyhow::Result<()> {
    let format = args.format.into();
    let read = import::read(
        format,
        &args.inputs,
        ImportOptions {
            unit: args.unit,
            size: args.size,
        },
    )?;
    let cameras: Vec<_> = read.cameras.iter().map(|c| c.camera.clone()).collect();
    let volume = match args.volume {
        Some(b) => Volume::from_bounds([b[0], b[1], b[2]], [b[3], b[4], b[5]], args.voxel)
            .context("invalid --volume / --voxel")?,
        None => match coverage::suggest_volume(&cameras, args.voxel) {
            Some(v) => {
                eprintln!(
                    "note: the volume is the box every camera sees (give --volume to choose another)"
                );
                v
            }
            None => {
                eprintln!(
                    "note: the cameras see no box in common; the volume is the default 256 mm cube at the origin (give --volume)"
                );
                Volume::default()
            }
        },
    };
    let source = args.inputs.first().map_or(Path::new("."), PathBuf::as_path);
    let rig = import::rig_of(read.cameras, volume, source)?;
    let rig_path = args.out.join("rig.toml");
    let mut files: Vec<PathBuf> = rig.cameras.iter().map(|c| args.out.join(&c.file)).collect();
    files.push(rig_path.clone());
    refuse_inputs(&files, &args.inputs)?;
    refuse_existing(&files, args.overwrite)?;
    rig.save(&rig_path)?;
    for note in &read.notes {
        eprintln!("note: {note}");
    }
    print!("{}", rig.summary());
    println!(
        "wrote {} ({} camera files and rig.toml); check what each camera sees of the volume with: flexshape rig check {}",
        args.out.display(),
        rig.cameras.len(),
        rig_path.display()
    );
    Ok(())
}

pub fn export(args: &RigExportArgs) -> anyhow::Result<()> {
    let rig = super::load_rig(&args.rig)?;
    let format = args.format.into();
    let planned = import::export_files(&rig, format, &args.out);
    // The rig read (a folder of camera files as a whole, or a rig file and the camera files
    // it names): an export written among them would replace them, or be loaded with them.
    let mut inputs = vec![args.rig.clone()];
    if !args.rig.is_dir() {
        let folder = args.rig.parent().unwrap_or(Path::new("."));
        inputs.extend(rig.cameras.iter().map(|c| folder.join(&c.file)));
    }
    let mut written_to = planned.clone();
    if args.rig.is_dir() {
        written_to.push(args.out.join(".")); // the folder itself
    }
    refuse_inputs(&written_to, &inputs)?;
    refuse_existing(&planned, args.overwrite)?;
    let written = import::export(&rig, format, &args.out, args.unit)?;
    println!(
        "wrote {}{}",
        written
            .iter()
            .map(|p| p.display().to_string())
            .collect::<Vec<_>>()
            .join(", "),
        if format == import::ExportFormat::CameraInfo {
            " (CameraInfo holds intrinsics only; the poses are in extrinsics.yaml, as TF has them, with the static_transform_publisher line for each camera, and rig import camera-info reads them back)"
        } else {
            ""
        }
    );
    Ok(())
}
