//! The per-camera silhouette pipeline: classify, hysteresis, closing, components (a
//! shadow-coloured part apart from a coloured object dropped as its shadow), thin holes
//! filled, markers.

use flexshape_rig::quoted;
use image::{DynamicImage, RgbImage};
use serde::{Deserialize, Serialize};

use crate::background::BackgroundModel;
use crate::bitmask::BitMask;
use crate::classify::{Area, Classifier, Prepared, Region};
use crate::components::{KeepComponents, keep_components, touching};
use crate::error::SilhouetteError;
use crate::holes::fill_thin_holes;
use crate::markers::{MarkerSettings, find_markers};

/// Settings of one camera's silhouettes (the rig's `[processing.silhouette]`, see
/// [`SilhouetteSettings::from_processing`]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SilhouetteSettings {
    /// Foreground test.
    pub classifier: Classifier,
    /// Radius of the closing that fills holes (square window `2r + 1`); it does not move
    /// straight boundaries, so the mask stays at half contrast.
    pub close_radius: usize,
    /// Whether holes the object encloses that are thinner than the object is wide are
    /// filled (a silvery tube's highlight in the backdrop's colour; see `holes`).
    pub fill_holes: bool,
    /// Which connected components are the object.
    pub keep: KeepComponents,
    /// Marker tape.
    pub markers: MarkerSettings,
    /// Largest share of the image the object may cover; beyond it the silhouette is
    /// implausible (a dark or changed backdrop the classifier takes for foreground).
    pub max_foreground: f64,
    /// Largest multiple of its usual share (what the run's first right frames covered) a
    /// silhouette may cover, once it covers at least [`GROWTH_FLOOR`] of the image more; beyond
    /// it the frame is implausible (light changed, something entered the view). 0: no limit.
    pub max_foreground_growth: f64,
    /// Whether the background may follow the backdrop where it changed since it was captured
    /// (cloth whose folds moved, a lamp moved): when a frame's fitted tube is where the images
    /// show it but the rest of the image does not match the background, the background takes
    /// the frame's colours away from the tube (see the tracking pipeline).
    pub adapt: bool,
}

/// Share of the image a silhouette may grow by, whatever its usual share, before
/// `max_foreground_growth` applies (a thin tube's share moves by a large factor as it turns
/// toward a camera).
pub const GROWTH_FLOOR: f64 = 0.01;

impl Default for SilhouetteSettings {
    fn default() -> Self {
        SilhouetteSettings {
            classifier: Classifier::colour_shadow(),
            close_radius: 1,
            fill_holes: true,
            keep: KeepComponents::MinArea(40),
            markers: MarkerSettings::default(),
            max_foreground: 0.5,
            max_foreground_growth: 5.0,
            adapt: true,
        }
    }
}

impl SilhouetteSettings {
    /// Settings of camera `camera` from a rig's `[processing]` table: the defaults, overridden
    /// by `[processing.silhouette]`, overridden by `[processing.silhouette.per_camera.<camera>]`.
    ///
    /// ```toml
    /// [processing.silhouette]
    /// classifier = { kind = "colour_shadow", dark_weak = 0.55 }
    /// close_radius = 1
    /// fill_holes = true                 # holes thinner than the object is wide
    /// keep = { min_area = 40 }          # or keep = "largest"
    /// adapt = true                      # the background follows a changed backdrop
    /// [processing.silhouette.per_camera.cam2]
    /// classifier = { kind = "green_matte" }
    /// ```
    pub fn from_processing(
        processing: &toml::Table,
        camera: &str,
    ) -> Result<Self, SilhouetteError> {
        let setting = |problem: String| SilhouetteError::Setting {
            field: "processing.silhouette",
            problem,
        };
        let Some(section) = processing.get("silhouette") else {
            return Ok(Self::default());
        };
        let toml::Value::Table(base) = section else {
            return Err(setting("must be a table".into()));
        };
        let mut merged = base.clone();
        match merged.remove("per_camera") {
            None => {}
            Some(toml::Value::Table(cams)) => {
                if let Some(over) = cams.get(camera) {
                    let toml::Value::Table(over) = over else {
                        return Err(setting(format!("per_camera.{camera} must be a table")));
                    };
                    for (k, v) in over {
                        merged.insert(k.clone(), v.clone());
                    }
                }
            }
            Some(_) => return Err(setting("per_camera must be a table of camera names".into())),
        }
        let settings: SilhouetteSettings = toml::Value::Table(merged)
            .try_into()
            .map_err(|e: toml::de::Error| setting(format!("{} (camera {camera})", e.message())))?;
        settings.validate()?;
        Ok(settings)
    }
}

impl SilhouetteSettings {
    /// The settings that read masks given as the frames (the object white or light on black,
    /// binary or 8-bit): a pixel whose brightest channel is at least 128 is object, against a
    /// black [`BackgroundModel::uniform`] backdrop; no closing (the mask is taken as it is).
    /// Which components are kept and the plausibility limit come from `rig`, the settings the
    /// rig file gives the camera; no marker bands are read (a mask has no colour).
    pub fn for_masks(rig: &SilhouetteSettings) -> Self {
        SilhouetteSettings {
            classifier: Classifier::Difference(crate::classify::Difference {
                min_difference: MASK_LEVEL - 1.0,
                noise_factor: 0.0,
            }),
            close_radius: 0,
            // A segmentation's holes (a CNN's, a threshold's) are what a highlight leaves.
            fill_holes: rig.fill_holes,
            keep: rig.keep,
            markers: MarkerSettings {
                // Brighter than anything: no pixel of a mask is tested as tape.
                min_level: crate::markers::MARKERS_OFF,
                ..rig.markers.clone()
            },
            max_foreground: rig.max_foreground,
            max_foreground_growth: rig.max_foreground_growth,
            // A mask is the lab's segmentation, not a scene: nothing to follow.
            adapt: false,
        }
    }

    /// Checks every value's range, as the rig file's reader and [`Silhouetter::new`] both do
    /// (so `rig check` refuses what tracking would).
    pub fn validate(&self) -> Result<(), SilhouetteError> {
        self.classifier.validate()?;
        self.markers.validate()?;
        if self.close_radius > 16 {
            return Err(SilhouetteError::Setting {
                field: "close_radius",
                problem: "must be at most 16 pixels".into(),
            });
        }
        if !(self.max_foreground_growth == 0.0
            || (self.max_foreground_growth >= 1.0 && self.max_foreground_growth <= 1e6))
        {
            return Err(SilhouetteError::Setting {
                field: "max_foreground_growth",
                problem: format!(
                    "{} must be 0 (no limit) or a factor from 1 to 10⁶",
                    quoted(self.max_foreground_growth)
                ),
            });
        }
        if !(self.max_foreground > 0.0 && self.max_foreground <= 1.0) {
            return Err(SilhouetteError::Setting {
                field: "max_foreground",
                problem: format!(
                    "{} must be a share of the image above 0 and at most 1",
                    quoted(self.max_foreground)
                ),
            });
        }
        Ok(())
    }
}

/// The grey level from which a mask's pixel is object: the one level for every mask a lab
/// draws, a rig's occlusion masks' too ([`flexshape_rig::Occluded::LEVEL`]).
pub const MASK_LEVEL: f32 = flexshape_rig::Occluded::LEVEL as f32;

/// What a frame's silhouette found.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SilhouetteStatus {
    /// An object with marker pixels.
    Ok,
    /// No object pixels survived (nothing in view, or only specks).
    NoObject,
    /// An object but no marker pixels.
    NoMarkers,
    /// The object covers more of the image than `max_foreground`: the background model does
    /// not describe the scene (a dark backdrop, lights changed, the camera moved).
    Implausible {
        /// Share of the image marked as object.
        fraction: f64,
    },
}

/// One camera's silhouette of one frame.
#[derive(Debug, Clone)]
pub struct Silhouette {
    /// Object pixels (boundary at half contrast).
    pub object: BitMask,
    /// Marker-band pixels, a subset of `object`.
    pub markers: BitMask,
    /// The part of `object` that is shadow-coloured (the background's chromaticity, darker)
    /// and was kept for its sharp edges: a grey object, or a shadow sharp enough to pass for
    /// one. Empty for classifiers other than `colour_shadow`.
    pub shadow_like: BitMask,
    /// Number of object components kept.
    pub components: usize,
    /// Summary.
    pub status: SilhouetteStatus,
}

/// Computes silhouettes for one camera against its background model.
#[derive(Debug, Clone)]
pub struct Silhouetter {
    prepared: Prepared,
    settings: SilhouetteSettings,
    width: u32,
    height: u32,
}

impl Silhouetter {
    /// Prepares the per-pixel thresholds of `settings` for `background`.
    pub fn new(
        background: &BackgroundModel,
        settings: SilhouetteSettings,
    ) -> Result<Self, SilhouetteError> {
        settings.validate()?;
        Ok(Silhouetter {
            prepared: Prepared::new(background, &settings.classifier),
            settings,
            width: background.width(),
            height: background.height(),
        })
    }

    /// The settings in use.
    pub fn settings(&self) -> &SilhouetteSettings {
        &self.settings
    }

    /// The pixels of `frame` that show the backdrop in shadow (darker than the background
    /// beyond its noise, with its chromaticity), for the colour-shadow classifier, which never
    /// takes a soft shadow for foreground; `None` for the others. A frame of another size is
    /// refused.
    pub fn shadowed(&self, frame: &RgbImage) -> Result<Option<BitMask>, SilhouetteError> {
        self.check_size(frame)?;
        Ok(self.prepared.shadowed(frame))
    }

    /// A frame of no pixels, or of another size than the background, is refused.
    fn check_size(&self, frame: &RgbImage) -> Result<(), SilhouetteError> {
        let (w, h) = frame.dimensions();
        if w == 0 || h == 0 {
            return Err(SilhouetteError::EmptyFrame);
        }
        if (w, h) != (self.width, self.height) {
            return Err(SilhouetteError::SizeMismatch {
                width: w,
                height: h,
                expected_width: self.width,
                expected_height: self.height,
            });
        }
        Ok(())
    }

    /// Silhouette of an 8-bit RGB frame.
    pub fn process(&self, frame: &RgbImage) -> Result<Silhouette, SilhouetteError> {
        self.process_within(frame, &Region::ALL)
    }

    /// Silhouette of an 8-bit RGB frame within `region` (a [`Region`] or [`Rows`](crate::Rows);
    /// each row's columns rounded out to whole 64-pixel words): pixels outside it are
    /// background. A tracker that knows where the object is looks only around it.
    pub fn process_within(
        &self,
        frame: &RgbImage,
        region: &impl Area,
    ) -> Result<Silhouette, SilhouetteError> {
        self.check_size(frame)?;
        let (w, h) = frame.dimensions();
        let (foreground, shade) = self.prepared.foreground_and_shade(frame, region);
        let closed = foreground.close(self.settings.close_radius);
        let (mut object, mut components) = keep_components(&closed, self.settings.keep);
        // A shadow-coloured part apart from a coloured object is its shadow (or a grey thing
        // that is not the instrument): what stays is the parts that are not shadow-coloured
        // throughout. (Shade closed as the foreground was: closing fills its gaps too.) When
        // every part is shadow-coloured — a grey tube on a white backdrop — colour tells
        // nothing, and all stay.
        let shadow_like = if shade.count() == 0 {
            shade
        } else {
            let shade = shade.close(self.settings.close_radius);
            let coloured = object.and_not(&shade);
            if coloured.count() > 0 {
                let kept = touching(&object, &coloured);
                if kept.count() < object.count() {
                    components = keep_components(&kept, KeepComponents::MinArea(1)).1;
                    object = kept;
                }
            }
            object.and(&shade)
        };
        if self.settings.fill_holes {
            object = fill_thin_holes(&object);
        }
        let markers = find_markers(frame, &object, &self.settings.markers);
        let fraction = object.count() as f64 / (w as f64 * h as f64);
        let status = if fraction > self.settings.max_foreground {
            SilhouetteStatus::Implausible { fraction }
        } else if object.count() == 0 {
            SilhouetteStatus::NoObject
        } else if markers.count() == 0 {
            SilhouetteStatus::NoMarkers
        } else {
            SilhouetteStatus::Ok
        };
        Ok(Silhouette {
            object,
            markers,
            shadow_like,
            components,
            status,
        })
    }

    /// Silhouette of a decoded image, which must be 8-bit RGB (RGBA is accepted, its alpha
    /// ignored).
    pub fn process_image(&self, image: &DynamicImage) -> Result<Silhouette, SilhouetteError> {
        match image {
            DynamicImage::ImageRgb8(rgb) => self.process(rgb),
            DynamicImage::ImageRgba8(_) => self.process(&image.to_rgb8()),
            other => Err(SilhouetteError::ChannelCount {
                channels: other.color().channel_count(),
                bits: other.color().bits_per_pixel() / other.color().channel_count() as u16,
            }),
        }
    }
}

/// The frame with the silhouette drawn on it: background dimmed, object tinted cyan, markers
/// magenta.
pub fn debug_image(frame: &RgbImage, s: &Silhouette) -> RgbImage {
    let mut out = frame.clone();
    for (x, y, p) in out.enumerate_pixels_mut() {
        let (x, y) = (x as usize, y as usize);
        let [r, g, b] = p.0;
        p.0 = if s.markers.get(x, y) {
            [255, 0, 255]
        } else if s.object.get(x, y) {
            [r / 3, 200, 255]
        } else {
            [r / 2, g / 2, b / 2]
        };
    }
    out
}
