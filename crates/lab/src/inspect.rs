//! One frame looked at closely (`flexshape silhouettes`): each camera's silhouette (against
//! the true mask when known), every classifier's on the same frame with a suggestion when the
//! rig's looks wrong, the shape's status and how well the fitted tube explains each camera —
//! printed, and drawn as debug images.

use std::fmt::{self, Write as _};
use std::path::{Path, PathBuf};
use std::time::Instant;

use flexshape_fit::debug_image as fit_debug_image;
use flexshape_rig::Rig;
use flexshape_silhouette::{
    BackgroundModel, BitMask, SilhouetteSettings, debug_image, suggest_classifier, try_classifiers,
};
use image::{GrayImage, RgbImage};

use flexshape_record::TrackRecord;

use flexshape_track::{Pipeline, TrackError, Tracked};

use crate::LabError;

/// A frame tracked and looked at; printing it gives the report.
pub struct Inspection {
    /// The frame's number.
    pub frame: u64,
    /// What the chain made of it.
    pub tracked: Tracked,
    /// Its record.
    pub record: TrackRecord,
    /// The whole chain's time, ms.
    pub chain_ms: f64,
    report: String,
}

impl Inspection {
    /// Tracks `images` (frame `frame`) with `pipeline` (set up from `rig`) and looks at the
    /// result; `truth` holds each camera's true mask where known, `backgrounds` the empty
    /// scene's models to try every classifier against.
    pub fn of(
        pipeline: &Pipeline,
        rig: &Rig,
        images: &[RgbImage],
        frame: u64,
        truth: &[Option<GrayImage>],
        backgrounds: Option<&[BackgroundModel]>,
    ) -> Result<Self, LabError> {
        let refs: Vec<&RgbImage> = images.iter().collect();
        let started = Instant::now();
        let tracked = pipeline.process(&refs)?;
        let chain_ms = started.elapsed().as_secs_f64() * 1e3;
        let record = tracked.record(frame);
        let mut report = String::new();
        for (i, (name, s)) in pipeline
            .camera_names()
            .iter()
            .zip(&tracked.silhouettes)
            .enumerate()
        {
            let iou = match truth.get(i).and_then(Option::as_ref) {
                Some(mask) => format!(
                    "  IoU vs truth {:.4}",
                    s.object.iou(&BitMask::from_gray(mask))
                ),
                None => String::new(),
            };
            let _ = writeln!(
                report,
                "  {:<8} {:?}: {} object px in {} component(s), {} marker px{iou}",
                name,
                s.status,
                s.object.count(),
                s.components,
                s.markers.count()
            );
        }
        let _ = writeln!(report, "  (the whole chain: {chain_ms:.1} ms)");
        if let Some(backgrounds) = backgrounds {
            classifiers(&mut report, rig, backgrounds, images, &tracked)?;
        }
        fitted(&mut report, &record, &tracked);
        Ok(Inspection {
            frame,
            tracked,
            record,
            chain_ms,
            report,
        })
    }

    /// Writes `NAME_object.png`, `NAME_markers.png`, `NAME_debug.png` (the silhouette over
    /// the frame) and, when a tube was fitted, `NAME_fit.png` (its outline against the
    /// measured one) per camera to `out`; returns the files written.
    pub fn write_images(
        &self,
        pipeline: &Pipeline,
        images: &[RgbImage],
        out: &Path,
    ) -> Result<Vec<PathBuf>, LabError> {
        let failed = |path: &Path, e: &dyn fmt::Display| LabError::Write {
            path: path.to_path_buf(),
            reason: e.to_string(),
        };
        std::fs::create_dir_all(out).map_err(|e| failed(out, &e))?;
        let mut written = Vec::new();
        let mut save = |file: String, img: image::DynamicImage| -> Result<(), LabError> {
            let path = out.join(file);
            img.save(&path).map_err(|e| failed(&path, &e))?;
            written.push(path);
            Ok(())
        };
        let names = pipeline.camera_names();
        for ((name, s), image) in names.iter().zip(&self.tracked.silhouettes).zip(images) {
            save(format!("{name}_object.png"), s.object.to_gray().into())?;
            save(format!("{name}_markers.png"), s.markers.to_gray().into())?;
            save(format!("{name}_debug.png"), debug_image(image, s).into())?;
        }
        let Some(fit) = &self.tracked.fit else {
            return Ok(written);
        };
        let refs: Vec<&RgbImage> = images.iter().collect();
        let backgrounds = pipeline.backgrounds();
        let views = pipeline.views(&refs, &self.tracked.silhouettes, &backgrounds);
        let outlines = pipeline.fitter().outline_residuals(&views, &fit.tube)?;
        for (i, name) in names.iter().enumerate() {
            let Some(rendered) = pipeline.fitter().render(i, &fit.tube) else {
                continue;
            };
            let object = &self.tracked.silhouettes[i].object;
            let img = fit_debug_image(refs[i], &outlines[i], &rendered, object);
            save(format!("{name}_fit.png"), img.into())?;
        }
        Ok(written)
    }
}

impl fmt::Display for Inspection {
    fn fmt(&self, f: &mut fmt::Formatter) -> fmt::Result {
        f.write_str(&self.report)
    }
}

/// Every classifier's silhouette of each camera's frame (object share, components), and a
/// suggestion where the rig's classifier gives an implausible one and another would not.
fn classifiers(
    report: &mut String,
    rig: &Rig,
    backgrounds: &[BackgroundModel],
    images: &[RgbImage],
    tracked: &Tracked,
) -> Result<(), LabError> {
    let _ = writeln!(
        report,
        "classifiers on this frame (object share of the image, components):"
    );
    for (i, cam) in rig.cameras.iter().enumerate() {
        let failed = |source| TrackError::Silhouette {
            camera: cam.name.clone(),
            source,
        };
        let settings =
            SilhouetteSettings::from_processing(&rig.processing, &cam.name).map_err(failed)?;
        let trials = try_classifiers(&backgrounds[i], &images[i], &settings).map_err(failed)?;
        let row: Vec<String> = trials
            .iter()
            .map(|t| format!("{} {:.2} % ({})", t.kind, 100.0 * t.share, t.components))
            .collect();
        let _ = writeln!(report, "  {:<8} {}", cam.name, row.join(", "));
        let own = &tracked.silhouettes[i];
        let pixels = u64::from(images[i].width()) * u64::from(images[i].height());
        if let Some(kind) = suggest_classifier(own, pixels, &settings, &trials) {
            let _ = writeln!(
                report,
                "  suggestion for {0}: its silhouette looks wrong ({1:.1} % of the image in {2} component(s)); try in the rig file:\n    [processing.silhouette.per_camera.{0}]\n    classifier = {{ kind = \"{kind}\" }}",
                cam.name,
                100.0 * own.object.count() as f64 / pixels as f64,
                own.components
            );
        }
    }
    Ok(())
}

/// The shape's status and how well the fitted tube explains each camera.
fn fitted(report: &mut String, record: &TrackRecord, t: &Tracked) {
    let _ = writeln!(
        report,
        "shape: {}{} ({} method)",
        record.status,
        record
            .reason
            .as_deref()
            .map(|r| format!(": {r}"))
            .unwrap_or_default(),
        record.method.as_ref().map_or("-", |m| m.as_str())
    );
    for c in t.fit.iter().flat_map(|fit| &fit.cameras) {
        let _ = writeln!(
            report,
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
}
