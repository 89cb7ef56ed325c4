//! Each camera's background model and the silhouetter prepared for it: part of the run's state
//! (`state`), which a frame that found the backdrop changed gives a new one (see
//! [`crate::Pipeline::process`]).

use std::sync::{Arc, OnceLock};

use flexshape_camera::Camera;
use flexshape_camera::nalgebra::Point3;
use flexshape_carve::Occupancy;
use flexshape_silhouette::{
    BackgroundModel, BitMask, Classifier, ColourShadow, SilhouetteSettings, Silhouetter,
};

/// One camera's background and its prepared silhouetter.
#[derive(Debug)]
pub(crate) struct Backdrop {
    pub model: Arc<BackgroundModel>,
    pub silhouetter: Silhouetter,
    /// Whether the background is in colour ([`BackgroundModel::in_colour`]).
    pub colour: bool,
    /// See [`Backdrop::bootstrap`]; prepared when first needed.
    bootstrap: OnceLock<Option<Silhouetter>>,
}

impl Backdrop {
    pub fn new(model: BackgroundModel, silhouetter: Silhouetter) -> Self {
        Backdrop {
            colour: model.in_colour(),
            model: Arc::new(model),
            silhouetter,
            bootstrap: OnceLock::new(),
        }
    }

    /// The silhouetter that finds the tube while the backdrop has changed too much for the
    /// usual one: the colour classifier without its brightening test, so that a backdrop
    /// grown brighter (folds that slid away, a lamp moved closer) without changing its
    /// chromaticity is not foreground; the tube still is by its colour or by being darker.
    /// `None` for the other classifiers, which have no such test.
    pub fn bootstrap(&self) -> Option<&Silhouetter> {
        self.bootstrap
            .get_or_init(|| {
                let settings = self.silhouetter.settings();
                let Classifier::ColourShadow(c) = &settings.classifier else {
                    return None;
                };
                let settings = SilhouetteSettings {
                    classifier: Classifier::ColourShadow(ColourShadow {
                        bright: MAX_BRIGHT,
                        ..c.clone()
                    }),
                    ..settings.clone()
                };
                Silhouetter::new(&self.model, settings).ok()
            })
            .as_ref()
    }
}

/// Each backdrop's background model.
pub(crate) fn models(backdrops: &[Arc<Backdrop>]) -> Vec<Arc<BackgroundModel>> {
    backdrops.iter().map(|b| Arc::clone(&b.model)).collect()
}

/// The brightness ratio the bootstrap silhouetter takes for foreground: the classifier's
/// largest (no backdrop brightens a hundredfold).
const MAX_BRIGHT: f32 = 100.0;

/// Attempts to locate the tube with the bootstrap silhouettes that may fail in a row before
/// they stop (until a frame comes out right or a background follows its backdrop): a frame
/// that is wrong for another reason (no tube in view) would pay for a second chain each time.
pub(crate) const BOOTSTRAP_ATTEMPTS: usize = 3;

/// The pixels `camera` sees carved voxels of `occupancy` in: a disc per voxel (half its
/// diagonal across, at its depth). What every camera sees at one place is in the volume, not
/// on a backdrop behind it: the background never takes those pixels.
pub(crate) fn hull_pixels(camera: &Camera, occupancy: &Occupancy) -> BitMask {
    let k = &camera.intrinsics;
    let (w, h) = (k.width as usize, k.height as usize);
    let mut mask = BitMask::new(w, h);
    let half_diagonal = occupancy
        .volume
        .voxel_size
        .iter()
        .map(|s| s * s)
        .sum::<f64>()
        .sqrt()
        / 2.0;
    for c in occupancy.centres() {
        let Ok(p) = camera.project(&Point3::from(c)) else {
            continue;
        };
        if p.depth <= 0.0 {
            continue;
        }
        let r = half_diagonal * k.fx.max(k.fy) / p.depth;
        let (cx, cy) = (p.pixel.x, p.pixel.y);
        let y0 = (cy - r).ceil().max(0.0);
        let y1 = (cy + r).floor().min(h as f64 - 1.0);
        let mut y = y0;
        while y <= y1 {
            let half = (r * r - (y - cy) * (y - cy)).max(0.0).sqrt();
            let (x0, x1) = (
                (cx - half).ceil().max(0.0),
                (cx + half).floor().min(w as f64 - 1.0),
            );
            if x0 <= x1 {
                mask.set_span(y as usize, x0 as usize, x1 as usize);
            }
            y += 1.0;
        }
    }
    mask
}

#[cfg(test)]
mod tests {
    use super::*;
    use flexshape_camera::nalgebra::Vector3;
    use flexshape_camera::{Distortion, Intrinsics, Pose};
    use flexshape_rig::Volume;

    #[test]
    fn hull_pixels_cover_each_voxel_as_the_camera_sees_it() {
        let intrinsics =
            Intrinsics::new(640, 480, 800.0, 800.0, 320.0, 240.0, Distortion::default()).unwrap();
        // 500 mm in front of the camera, looking along +y.
        let camera = Camera::new(
            intrinsics,
            Pose::look_at(
                Point3::new(0.0, -500.0, 0.0),
                Point3::origin(),
                Vector3::z(),
            ),
        );
        let volume = Volume {
            origin: [-8.0; 3],
            voxel_size: [2.0; 3],
            dims: [8; 3],
        };
        let mut occupancy = Occupancy {
            volume,
            voxels: Vec::new(),
        };
        let voxel = occupancy.index_of(&Point3::new(1.0, 1.0, 1.0)).unwrap();
        occupancy.voxels.push(voxel);
        let mask = hull_pixels(&camera, &occupancy);
        // The voxel's centre (1, 1, 1) mm at depth 501 mm: pixel (321.6, 238.4); half its
        // diagonal (√3 mm) is 2.77 px there.
        let p = camera.project(&Point3::new(1.0, 1.0, 1.0)).unwrap().pixel;
        assert!(
            (p.x - 321.6).abs() < 0.01 && (p.y - 238.4).abs() < 0.01,
            "{p:?}"
        );
        assert!(mask.get(322, 238) && mask.get(324, 238) && mask.get(322, 236));
        assert!(mask.get(319, 238) && mask.get(322, 241));
        assert!(!mask.get(325, 238) && !mask.get(322, 242) && !mask.get(318, 238));
        assert!((20..=28).contains(&mask.count()), "{}", mask.count());
        assert_eq!(
            hull_pixels(
                &camera,
                &Occupancy {
                    volume,
                    voxels: Vec::new()
                }
            )
            .count(),
            0
        );
    }
}
