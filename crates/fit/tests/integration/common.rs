//! The simulated chain up to the hull's shape, and errors against truth, for the fit's tests.

#![allow(dead_code)]

use flexshape_camera::Camera;
use flexshape_carve::{BandRule, HierarchicalCarver, OutsideImage, find_bands};
use flexshape_fit::{Fit, FitSettings, TubeFitter, View};
use flexshape_recording::Truth;
use flexshape_shape::{ShapeEstimator, ShapeRecord, ShapeSettings};
use flexshape_silhouette::{BackgroundModel, Silhouette, SilhouetteSettings, Silhouetter};
use flexshape_sim::{SimConfig, SimFrame, Simulator};
use nalgebra::{Matrix3, Point3, Vector3};

/// A simulated rig with the hull chain and the fitter set up for it.
pub struct Chain {
    pub sim: Simulator,
    pub backgrounds: Vec<BackgroundModel>,
    pub silhouetters: Vec<Silhouetter>,
    pub carver: HierarchicalCarver,
    pub estimator: ShapeEstimator,
    pub fitter: TubeFitter,
    pub cameras: Vec<Camera>,
}

/// One frame through both methods.
pub struct Both {
    pub frame: SimFrame,
    pub hull: ShapeRecord,
    pub fitted: ShapeRecord,
    pub fit: Option<Fit>,
}

impl Chain {
    pub fn new(config: SimConfig) -> Chain {
        Chain::calibrated_as(config, |_| {})
    }

    /// The chain with camera `camera`'s calibrated pose turned by `degrees` about the world's
    /// y axis (0.2° is about 2.8 px at the default 800 px focal length): a calibration error
    /// the images do not share.
    pub fn with_camera_turned(config: SimConfig, camera: usize, degrees: f64) -> Chain {
        Chain::calibrated_as(config, |cams| {
            let turn =
                nalgebra::Rotation3::from_axis_angle(&Vector3::y_axis(), degrees.to_radians());
            let pose = &mut cams[camera].pose;
            pose.rotation = turn * pose.rotation;
            pose.translation = turn * pose.translation;
        })
    }

    /// The chain carving and fitting with the rig's cameras as `calibrate` leaves them (the
    /// images still come from the true cameras): a calibration error.
    pub fn calibrated_as(config: SimConfig, calibrate: impl Fn(&mut Vec<Camera>)) -> Chain {
        let sim = Simulator::new(config).unwrap();
        let mut cameras = sim.cameras();
        calibrate(&mut cameras);
        let backgrounds: Vec<BackgroundModel> = BackgroundModel::each(&sim.backgrounds()).unwrap();
        let rig = sim.rig();
        let silhouetters = rig
            .cameras
            .iter()
            .zip(&backgrounds)
            .map(|(c, b)| {
                let s = SilhouetteSettings::from_processing(&rig.processing, &c.name).unwrap();
                Silhouetter::new(b, s).unwrap()
            })
            .collect();
        let carver = HierarchicalCarver::new(&cameras, &rig.volume).unwrap();
        let estimator =
            ShapeEstimator::new(ShapeSettings::from_processing(&rig.processing).unwrap()).unwrap();
        let names = rig.cameras.iter().map(|c| c.name.clone()).collect();
        let fitter = TubeFitter::new(cameras.clone(), names, FitSettings::default()).unwrap();
        Chain {
            sim,
            backgrounds,
            silhouetters,
            carver,
            estimator,
            fitter,
            cameras,
        }
    }

    pub fn silhouettes(&self, frame: &SimFrame) -> Vec<Silhouette> {
        self.silhouetters
            .iter()
            .zip(&frame.views)
            .map(|(s, v)| s.process(&v.image).unwrap())
            .collect()
    }

    /// How the fit sees a rendered frame with its silhouettes.
    pub fn views<'a>(&'a self, frame: &'a SimFrame, sil: &'a [Silhouette]) -> Vec<View<'a>> {
        frame
            .views
            .iter()
            .zip(&self.backgrounds)
            .zip(sil)
            .map(|((v, b), s)| View {
                image: &v.image,
                background: b.means(),
                silhouette: &s.object,
                markers: &s.markers,
                shadow_like: Some(&s.shadow_like),
                hidden: None,
            })
            .collect()
    }

    /// The hull's shape and the fitted one, for a rendered frame.
    pub fn run(&self, frame: SimFrame) -> Both {
        self.run_from(frame, |_| {})
    }

    /// As `run`, and when the hull's start gives no right shape, the two-view start's shape
    /// (if it finds one) replaces it: what the tracking pipeline does on two-camera rigs.
    /// The flag says whether the two-view start gave the shape.
    pub fn run_two_views(&self, frame: SimFrame) -> (Both, bool) {
        let mut b = self.run(frame);
        if b.fitted.status.is_right() {
            return (b, false);
        }
        let sil = self.silhouettes(&b.frame);
        let views = self.views(&b.frame, &sil);
        let found = self
            .fitter
            .from_two_views(&self.estimator, &self.sim.rig().volume, &views, None)
            .unwrap();
        let Some((record, fit)) = found else {
            return (b, false);
        };
        b.fitted = record;
        b.fit = Some(fit);
        (b, true)
    }

    /// As `run`, with the hull's record changed by `edit` before the fit starts from it.
    pub fn run_from(&self, frame: SimFrame, edit: impl Fn(&mut ShapeRecord)) -> Both {
        let sil = self.silhouettes(&frame);
        self.run_with(frame, sil, edit)
    }

    /// As `run_from`, from silhouettes `sil` (the frame's own, edited: a segmentation that
    /// lost part of the tube).
    pub fn run_with(
        &self,
        frame: SimFrame,
        sil: Vec<Silhouette>,
        edit: impl Fn(&mut ShapeRecord),
    ) -> Both {
        let objects: Vec<_> = sil.iter().map(|s| &s.object).collect();
        let markers: Vec<_> = sil.iter().map(|s| &s.markers).collect();
        let occ = self.carver.carve(&objects, OutsideImage::Carve).unwrap();
        let bands = find_bands(&occ, &self.cameras, &markers, &BandRule::default()).unwrap();
        let mut hull = self.estimator.estimate(&occ, &bands);
        edit(&mut hull);
        let views = self.views(&frame, &sil);
        let (fitted, fit) = self
            .fitter
            .refine(
                &self.estimator,
                &self.sim.rig().volume,
                &views,
                &hull,
                &occ.centres(),
                None,
            )
            .unwrap();
        Both {
            frame,
            hull,
            fitted,
            fit,
        }
    }
}

impl Both {
    /// The fitted shape's centerline RMS and tip error against the frame's truth, mm.
    pub fn fitted_errors(&self, sim: &Simulator) -> (f64, f64) {
        let truth = &self.frame.truth;
        (
            centerline_rms(truth, sim, &self.fitted.points),
            tip_error(truth, &self.fitted),
        )
    }
}

/// RMS distance from the truth centerline samples inside the volume to a curve, mm.
pub fn centerline_rms(truth: &Truth, sim: &Simulator, curve: &[[f64; 3]]) -> f64 {
    let volume = &sim.rig().volume;
    let tip = curve.last().copied().unwrap_or_default();
    truth
        .errors(curve, tip, |p| volume.contains(p))
        .map_or(f64::INFINITY, |e| e.centerline_rms)
}

/// Distance between the record's tip and the true one, mm.
pub fn tip_error(truth: &Truth, r: &ShapeRecord) -> f64 {
    truth.tip_off(r.tip)
}

/// Worst distance from a true band centre in the volume to the nearest estimated one, mm.
pub fn band_error(truth: &Truth, sim: &Simulator, r: &ShapeRecord) -> f64 {
    truth
        .bands
        .iter()
        .filter(|b| sim.rig().volume.contains(&Point3::from(b.position)))
        .map(|t| {
            r.bands
                .iter()
                .map(|b| (Point3::from(b.position) - Point3::from(t.position)).norm())
                .fold(f64::INFINITY, f64::min)
        })
        .fold(0.0, f64::max)
}

/// Relative error of the arc fit's curvature, for frames bent more than 1/200 mm⁻¹.
pub fn curvature_error(truth: &Truth, r: &ShapeRecord) -> Option<f64> {
    let k = truth.kappa?;
    let fit = r.arc_fit.as_ref()?;
    let kt = k[0].hypot(k[1]);
    (kt >= 1.0 / 200.0).then(|| (fit.curvature - kt) / kt)
}

/// Angle between the fitted and the true bending planes, radians.
pub fn plane_error(truth: &Truth, r: &ShapeRecord) -> Option<f64> {
    let k = truth.kappa?;
    let base = truth.bend_base.as_ref()?;
    let fit = r.arc_fit.as_ref()?;
    let kt = k[0].hypot(k[1]);
    let rot = Matrix3::from_fn(|i, j| base.rotation[i][j]);
    let truth_dir = rot * Vector3::new(-k[1], 0.0, k[0]) / kt;
    let axes = Matrix3::from_fn(|i, j| fit.axes[j][i]);
    let kf = fit.curvature;
    let fit_dir = axes * Vector3::new(-fit.kappa[1], 0.0, fit.kappa[0]) / kf;
    Some(truth_dir.angle(&fit_dir))
}

/// Median of a list.
pub fn median(v: &[f64]) -> f64 {
    let mut s = v.to_vec();
    s.sort_by(f64::total_cmp);
    s[s.len() / 2]
}
