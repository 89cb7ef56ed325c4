//! `flexshape silhouettes`: one frame's silhouettes and fitted tube, reported and optionally
//! drawn — from a recording or any input `track` takes.

use std::time::Instant;

use anyhow::{Context, bail};
use flexshape_fit::debug_image as fit_debug_image;
use flexshape_recording::RecordingReader;
use flexshape_rig::Rig;
use flexshape_silhouette::{
    BackgroundModel, BitMask, SilhouetteSettings, debug_image, suggest_classifier, try_classifiers,
};
use flexshape_track::{Pipeline, TrackRecord, Tracked};

use super::frames;
use crate::cli::SilhouettesArgs;

pub fn run(args: &SilhouettesArgs) -> anyhow::Result<()> {
    let mut input = frames::open_input(&args.frames)?;
    let volume = frames::volume(&input.rig.volume, &args.frames)?;
    let pipeline = input
        .pipeline(&volume)
        .with_context(|| format!("cannot set up tracking for {}", input.rig_name))?;
    let set = pick_frame(input.source.as_mut(), args)?;
    let (frame, name) = (set.frame, set.name.clone());
    let (images, warnings) = pipeline.load(set.images).map_err(|e| anyhow::anyhow!(e))?;
    for w in warnings {
        eprintln!("warning: {w}");
    }
    if let Some(out) = &args.out {
        std::fs::create_dir_all(out).with_context(|| format!("cannot create {}", out.display()))?;
    }
    println!(
        "frame {frame:06}{}",
        name.map(|n| format!(" ({n})")).unwrap_or_default()
    );
    let refs: Vec<&image::RgbImage> = images.iter().collect();
    let t = Instant::now();
    let tracked = pipeline
        .process(&refs)
        .with_context(|| format!("frame {frame:06}"))?;
    let ms = t.elapsed().as_secs_f64() * 1e3;
    let truth = args
        .frames
        .recording
        .as_ref()
        .map(|r| RecordingReader::open(r))
        .transpose()?;
    for (i, (cam, s)) in input
        .rig
        .cameras
        .iter()
        .zip(&tracked.silhouettes)
        .enumerate()
    {
        let truth = truth
            .as_ref()
            .map(|r| r.read_truth_mask(i, frame))
            .transpose()?
            .flatten();
        report_camera(&cam.name, s, truth, &images[i], args.out.as_deref())?;
    }
    println!("  (the whole chain: {ms:.1} ms)");
    if let Some(backgrounds) = &input.backgrounds {
        compare_classifiers(&input.rig, backgrounds, &images, &tracked)?;
    }
    fitted(&pipeline, &input.rig, &refs, &tracked, frame, args)?;
    if let Some(out) = &args.out {
        println!("debug images written to {}", out.display());
    }
    Ok(())
}

/// The frame asked for: by number in a recording, by position elsewhere.
fn pick_frame(
    source: &mut dyn flexshape_input::FrameSource,
    args: &SilhouettesArgs,
) -> anyhow::Result<flexshape_input::FrameSet> {
    let numbered = args.frames.recording.is_some();
    let mut position = 0u64;
    loop {
        let Some(next) = source.next_frame() else {
            bail!(
                "the input has no frame {:06} ({} frames{})",
                args.frame,
                position,
                if numbered { "" } else { ", counted from 0" }
            );
        };
        let set = next.with_context(|| format!("frame {position}"))?;
        let wanted = if numbered { set.frame } else { position };
        position += 1;
        if wanted == args.frame {
            return Ok(set);
        }
    }
}

/// One camera's silhouette: its line (with the IoU against the true mask when known), and
/// with `out` its object, marker and debug images.
fn report_camera(
    name: &str,
    s: &flexshape_silhouette::Silhouette,
    truth: Option<image::GrayImage>,
    image: &image::RgbImage,
    out: Option<&std::path::Path>,
) -> anyhow::Result<()> {
    let truth = match truth {
        Some(mask) => format!(
            "  IoU vs truth {:.4}",
            s.object.iou(&BitMask::from_gray(&mask))
        ),
        None => String::new(),
    };
    println!(
        "  {:<8} {:?}: {} object px in {} component(s), {} marker px{truth}",
        name,
        s.status,
        s.object.count(),
        s.components,
        s.markers.count()
    );
    let Some(out) = out else {
        return Ok(());
    };
    let save = |file: String, img: image::DynamicImage| -> anyhow::Result<()> {
        let path = out.join(file);
        img.save(&path)
            .with_context(|| format!("cannot write {}", path.display()))
    };
    save(format!("{name}_object.png"), s.object.to_gray().into())?;
    save(format!("{name}_markers.png"), s.markers.to_gray().into())?;
    save(format!("{name}_debug.png"), debug_image(image, s).into())
}

/// Every classifier's silhouette of each camera's frame (object share, components), and a
/// suggestion where the rig's classifier gives an implausible one and another would not.
fn compare_classifiers(
    rig: &Rig,
    backgrounds: &[BackgroundModel],
    images: &[image::RgbImage],
    tracked: &Tracked,
) -> anyhow::Result<()> {
    println!("classifiers on this frame (object share of the image, components):");
    for (i, cam) in rig.cameras.iter().enumerate() {
        let settings = SilhouetteSettings::from_processing(&rig.processing, &cam.name)
            .with_context(|| format!("camera {}", cam.name))?;
        let trials = try_classifiers(&backgrounds[i], &images[i], &settings)
            .with_context(|| format!("camera {}", cam.name))?;
        let row: Vec<String> = trials
            .iter()
            .map(|t| format!("{} {:.2} % ({})", t.kind, 100.0 * t.share, t.components))
            .collect();
        println!("  {:<8} {}", cam.name, row.join(", "));
        let own = &tracked.silhouettes[i];
        let pixels = u64::from(images[i].width()) * u64::from(images[i].height());
        if let Some(kind) = suggest_classifier(own, pixels, &settings, &trials) {
            println!(
                "  suggestion for {0}: its silhouette looks wrong ({1:.1} % of the image in {2} component(s)); try in the rig file:\n    [processing.silhouette.per_camera.{0}]\n    classifier = {{ kind = \"{kind}\" }}",
                cam.name,
                100.0 * own.object.count() as f64 / pixels as f64,
                own.components
            );
        }
    }
    Ok(())
}

/// The shape's status, how well the fitted tube explains each camera, and (with `--out`)
/// `camK_fit.png` showing it.
fn fitted(
    pipeline: &Pipeline,
    rig: &Rig,
    images: &[&image::RgbImage],
    t: &Tracked,
    frame: u64,
    args: &SilhouettesArgs,
) -> anyhow::Result<()> {
    let record = TrackRecord::from_tracked(frame, t);
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
    let backgrounds = pipeline.backgrounds();
    let views = pipeline.views(images, &t.silhouettes, &backgrounds);
    let outlines = pipeline.fitter().outline_residuals(&views, &fit.tube)?;
    for (i, cam) in rig.cameras.iter().enumerate() {
        let Some(rendered) = pipeline.fitter().render(i, &fit.tube) else {
            continue;
        };
        let img = fit_debug_image(images[i], &outlines[i], &rendered, &t.silhouettes[i].object);
        let path = out.join(format!("{}_fit.png", cam.name));
        img.save(&path)
            .with_context(|| format!("cannot write {}", path.display()))?;
    }
    Ok(())
}
