//! `flexshape calibrate`: cameras from target images, written as OpenCV files and a rig
//! (`flexshape_calib::workflow`).

use anyhow::Context;
use flexshape_calib::Board;
use flexshape_calib::workflow::{CameraImages, RigSettings, WorldFrame, calibrate_rig};
use indicatif::{ProgressBar, ProgressStyle};

use crate::cli::CalibrateArgs;

pub fn run(args: &CalibrateArgs) -> anyhow::Result<()> {
    let board = Board::from_spec(&args.board, args.square, args.marker, &args.dictionary)
        .map_err(|e| anyhow::anyhow!("--board: {e}"))?;
    let cameras = CameraImages::find_all(&args.images).context("--images")?;
    // The calibration's files (camera files, rig, residual plots) never go among the images:
    // the next calibration from that folder would read them as views.
    let image_folders: Vec<_> = args.images.iter().map(|(_, p)| p.clone()).collect();
    flexshape_track::output::refuse_inputs([args.out.join("rig.toml")], &image_folders)
        .context("--out")?;
    let world = match &args.world {
        None => WorldFrame::Reference,
        Some(w) => {
            let reference = cameras.first().map_or("", |c| c.name.as_str());
            WorldFrame::parse(w, reference).context("--world")?
        }
    };
    let settings = RigSettings {
        calibration: flexshape_calib::CalibrationSettings {
            drop_outliers: args.drop_outliers,
            fix_k3: args.fix_k3,
            ..Default::default()
        },
        joint_intrinsics: args.joint_intrinsics,
        world,
    };
    let total: usize = cameras.iter().map(|c| c.files.len()).sum();
    let bar = ProgressBar::new(total as u64).with_style(
        ProgressStyle::with_template("detecting boards [{bar:40}] {pos}/{len} images, eta {eta}")
            .unwrap_or_else(|_| ProgressStyle::default_bar())
            .progress_chars("=> "),
    );
    let calibrated = calibrate_rig(&cameras, &board, &settings, &mut || bar.inc(1))?;
    bar.finish_and_clear();
    for note in &calibrated.notes {
        eprintln!("note: {note}");
    }
    calibrated.write(&args.out)?;
    print!("{}", calibrated.summary(&args.out));
    Ok(())
}
