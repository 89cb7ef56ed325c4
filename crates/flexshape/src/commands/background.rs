//! `flexshape background`: a background model from a folder of empty-scene frames.

use anyhow::{Context, bail};
use flexshape_silhouette::BackgroundModel;

use crate::cli::BackgroundArgs;

pub fn run(args: &BackgroundArgs) -> anyhow::Result<()> {
    let files = flexshape_rig::files::images_in(&args.images)
        .with_context(|| format!("cannot read the folder {}", args.images.display()))?;
    if files.is_empty() {
        bail!(
            "{}: no PNG or JPEG images; give a folder of background frames",
            args.images.display()
        );
    }
    let mut frames = Vec::with_capacity(files.len());
    for f in &files {
        let img =
            image::open(f).with_context(|| format!("{}: cannot decode image", f.display()))?;
        frames.push(img.to_rgb8());
    }
    let model = BackgroundModel::from_frames(&frames).with_context(|| {
        format!(
            "cannot build a background model from {}",
            args.images.display()
        )
    })?;
    if let Some(parent) = args.out.parent().filter(|p| !p.as_os_str().is_empty()) {
        std::fs::create_dir_all(parent)
            .with_context(|| format!("cannot create {}", parent.display()))?;
    }
    model
        .save(&args.out)
        .context("cannot save the background model")?;
    let n = (model.width() * model.height()) as usize;
    let mut spreads: Vec<f32> = (0..n).map(|i| model.spread(i)).collect();
    spreads.sort_by(f32::total_cmp);
    println!(
        "background model of {}×{} from {} frame(s) written to {} (+ {}); spread median {:.2}, 99th percentile {:.2} grey levels{}",
        model.width(),
        model.height(),
        frames.len(),
        args.out.display(),
        BackgroundModel::spread_path(&args.out).display(),
        spreads[n / 2],
        spreads[n * 99 / 100],
        if frames.len() == 1 {
            " (one frame: uniform default spread; use several frames to measure it)"
        } else {
            ""
        }
    );
    Ok(())
}
