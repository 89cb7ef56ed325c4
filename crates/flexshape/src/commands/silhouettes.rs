//! `flexshape silhouettes`: one recorded frame's silhouettes, reported and optionally drawn.

use std::time::Instant;

use anyhow::{Context, bail};
use flexshape_fit::debug_image as fit_debug_image;
use flexshape_recording::RecordingReader;
use flexshape_silhouette::{
    BackgroundModel, BitMask, SilhouetteSettings, Silhouetter, debug_image,
};
use flexshape_track::{Pipeline, TrackRecord};

use crate::cli::SilhouettesArgs;

pub fn run(args: &SilhouettesArgs) -> anyhow::Result<()> {
    let rec = RecordingReader::open(&args.recording)
        .with_context(|| format!("cannot open the recording {}", args.recording.display()))?;
    for s in rec.skipped_files() {
        eprintln!("warning: {s}");
    }
    if !rec.frames().contains(&args.frame) {
        bail!(
            "{}: no frame {:06} (frames {} to {})",
            args.recording.display(),
            args.frame,
            rec.frames()
                .first()
                .map_or("none".into(), |f| format!("{f:06}")),
            rec.frames()
                .last()
                .map_or("none".into(), |f| format!("{f:06}"))
        );
    }
    if let Some(out) = &args.out {
        std::fs::create_dir_all(out).with_context(|| format!("cannot create {}", out.display()))?;
    }
    println!("frame {:06} of {}", args.frame, args.recording.display());
    let mut models = Vec::new();
    let mut frames = Vec::new();
    for (i, cam) in rec.rig().cameras.iter().enumerate() {
        let bg_path = rec.layout().background(&cam.name);
        let model = BackgroundModel::load(&bg_path).with_context(|| {
            format!(
                "camera {}: a silhouette needs its background image {}",
                cam.name,
                bg_path.display()
            )
        })?;
        let settings = SilhouetteSettings::from_processing(&rec.rig().processing, &cam.name)
            .with_context(|| format!("{}: camera {}", rec.layout().rig().display(), cam.name))?;
        let sil =
            Silhouetter::new(&model, settings).with_context(|| format!("camera {}", cam.name))?;
        let frame = rec.read_frame(i, args.frame)?;
        let t = Instant::now();
        let s = sil
            .process(&frame)
            .with_context(|| format!("camera {} frame {:06}", cam.name, args.frame))?;
        let ms = t.elapsed().as_secs_f64() * 1e3;
        let truth = match rec.read_truth_mask(i, args.frame)? {
            Some(mask) => format!(
                "  IoU vs truth {:.4}",
                s.object.iou(&BitMask::from_gray(&mask))
            ),
            None => String::new(),
        };
        println!(
            "  {:<8} {:?}: {} object px in {} component(s), {} marker px, {ms:.2} ms{truth}",
            cam.name,
            s.status,
            s.object.count(),
            s.components,
            s.markers.count()
        );
        if let Some(out) = &args.out {
            let save = |name: String, img: image::DynamicImage| -> anyhow::Result<()> {
                let path = out.join(name);
                img.save(&path)
                    .with_context(|| format!("cannot write {}", path.display()))
            };
            save(
                format!("{}_object.png", cam.name),
                s.object.to_gray().into(),
            )?;
            save(
                format!("{}_markers.png", cam.name),
                s.markers.to_gray().into(),
            )?;
            save(
                format!("{}_debug.png", cam.name),
                debug_image(&frame, &s).into(),
            )?;
        }
        models.push(model);
        frames.push(frame);
    }
    fitted(&rec, &models, &frames, args)?;
    if let Some(out) = &args.out {
        println!("debug images written to {}", out.display());
    }
    Ok(())
}

/// The whole chain on the frame: the shape's status, how well the fitted tube explains each
/// camera, and (with `--out`) `camK_fit.png` showing it.
fn fitted(
    rec: &RecordingReader,
    models: &[BackgroundModel],
    frames: &[image::RgbImage],
    args: &SilhouettesArgs,
) -> anyhow::Result<()> {
    let rig = rec.rig();
    let pipeline = Pipeline::new(rig, models, &rig.volume)
        .with_context(|| format!("{}", rec.layout().rig().display()))?;
    let images: Vec<&image::RgbImage> = frames.iter().collect();
    let t = pipeline
        .process(&images)
        .with_context(|| format!("frame {:06}", args.frame))?;
    let record = TrackRecord::from_tracked(args.frame, &t);
    println!(
        "shape: {}{} ({} method)",
        record.status,
        record
            .reason
            .as_deref()
            .map(|r| format!(": {r}"))
            .unwrap_or_default(),
        record.method.as_deref().unwrap_or("-")
    );
    let Some(fit) = &t.fit else {
        return Ok(());
    };
    for c in &fit.cameras {
        println!(
            "  {:<8} outline {}/{} found, residual {:.3} px RMS (mean {:+.3}, image shift {:+.2}, {:+.2}), IoU {:.3}, {} px unexplained",
            c.camera,
            c.found,
            c.samples,
            c.residual_px,
            c.offset_px,
            c.shift_px[0],
            c.shift_px[1],
            c.iou,
            c.unexplained_px
        );
    }
    let Some(out) = &args.out else {
        return Ok(());
    };
    let views = pipeline.views(&images, &t.silhouettes);
    let outlines = pipeline.fitter().outline_residuals(&views, &fit.tube)?;
    for (i, cam) in rig.cameras.iter().enumerate() {
        let Some(rendered) = pipeline.fitter().render(i, &fit.tube) else {
            continue;
        };
        let img = fit_debug_image(
            &frames[i],
            &outlines[i],
            &rendered,
            &t.silhouettes[i].object,
        );
        let path = out.join(format!("{}_fit.png", cam.name));
        img.save(&path)
            .with_context(|| format!("cannot write {}", path.display()))?;
    }
    Ok(())
}
