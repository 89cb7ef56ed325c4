//! The tip told from the proximal end by a band that runs into it. A start that found neither
//! end open (the tube floats in the volume and stays in every view) guesses its direction;
//! when the rig says a band marks the tip (`tip_band`), the images along the fitted tube
//! decide it, whatever the start: the hull's voxels may miss a band (a thin tube, a band
//! narrower than a voxel) and the two-view start has no voxels at all.

use flexshape_shape::{ShapeEstimator, ShapeRecord, Status};
use flexshape_silhouette::BitMask;
use image::RgbImage;

use crate::outline::Spheres;
use crate::{Fit, FitError, ONE_MEASUREMENT_MM, Tube, TubeFitter, View};

impl TubeFitter {
    /// The fit (and its visibility spheres) the right way round, and `base` (what the start
    /// said before the fit) no longer `ambiguous` for its direction, when its direction was a
    /// guess and a band is seen running into one end of the fitted tube and not into the
    /// other: that end is the tip. A tube found the wrong way round is fitted again from its
    /// other end (`fit_radius` as the first fit). Otherwise everything is returned as it was.
    pub(crate) fn orient_by_band(
        &self,
        estimator: &ShapeEstimator,
        views: &[View<'_>],
        (fit, spheres): (Fit, Vec<Spheres>),
        base: &mut ShapeRecord,
        fit_radius: bool,
    ) -> Result<(Fit, Vec<Spheres>), FitError> {
        if !base.direction_guessed || !estimator.settings().tip_band {
            return Ok((fit, spheres));
        }
        let Some(back) = fit.tube.reversed() else {
            return Ok((fit, spheres));
        };
        let back_spheres = self.spheres(crate::solve::Seen::All(&back), back.length());
        let forward = self.band_at_tip(views, &fit.tube, &spheres);
        let backward = self.band_at_tip(views, &back, &back_spheres);
        if forward == backward {
            return Ok((fit, spheres));
        }
        base.status = Status::Ok;
        base.direction_guessed = false;
        if forward {
            return Ok((fit, spheres));
        }
        // Fitted again so that every figure of the fit (its uncertainty along the curve, its
        // cameras' samples) belongs to the tube as it is now taken; it starts where the first
        // fit settled, so this costs an iteration or two.
        let (mut again, spheres) =
            self.fit_with(&self.settings, views, back, fit_radius, ONE_MEASUREMENT_MM)?;
        again.iterations += fit.iterations;
        again.measurements += fit.measurements;
        Ok((again, spheres))
    }

    /// Whether the images show a band running into `tube`'s tip (`spheres`: its visibility
    /// spheres in each camera).
    fn band_at_tip(&self, views: &[View<'_>], tube: &Tube, spheres: &[Spheres]) -> bool {
        let images: Vec<&RgbImage> = views.iter().map(|v| v.image).collect();
        let markers: Vec<&BitMask> = views.iter().map(|v| v.markers).collect();
        crate::bands::locate(&self.cameras, &images, &markers, (tube, None), spheres)
            .iter()
            .any(|b| b.at_tip)
    }
}
