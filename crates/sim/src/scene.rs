//! What the renderer draws: tubes (swept spheres along a centerline, with marker bands) and
//! spherical occluders, in world coordinates (mm).

use flexshape_camera::nalgebra::Point3;
use flexshape_curve::{Polyline, RadiusStep, radius_at};
use serde::{Deserialize, Serialize};

/// Linear RGB reflectance in `[0, 1]`.
pub type Albedo = [f64; 3];

/// Default catheter body: dark blue plastic, like many sheaths (a neutral black would be
/// indistinguishable from a shadow by colour).
pub const BODY_ALBEDO: Albedo = [0.14, 0.20, 0.40];
/// Default marker tape: red.
pub const BAND_ALBEDO: Albedo = [0.78, 0.09, 0.08];
/// Default occluder: neutral grey.
pub const OCCLUDER_ALBEDO: Albedo = [0.45, 0.43, 0.41];

/// A tube around a centerline, ending in hemispherical caps: of constant radius, or stepping
/// up in radius going back from the tip (each thicker section ends in a rounded shoulder).
#[derive(Debug, Clone)]
pub struct Tube {
    /// Centerline (world mm). It is drawn as a chain of capsules through its vertices, so
    /// vertices about 1 mm apart keep the chord error below 0.01 mm for bend radii ≥ 15 mm.
    pub centerline: Polyline,
    /// Radius, mm (the tip section's when it steps).
    pub radius: f64,
    /// Where the radius steps, by arc length from the tip (empty: constant).
    pub steps: Vec<RadiusStep>,
    /// Marker bands as arc-length intervals `[start, end]` (mm along the centerline).
    pub bands: Vec<[f64; 2]>,
    /// Body colour.
    pub albedo: Albedo,
    /// Band colour.
    pub band_albedo: Albedo,
    /// How the surface shines where it reflects the lamp toward the camera.
    pub gloss: Gloss,
    /// The material of everything behind the first radius step (an outer tube of another
    /// material around the inner one: a dark sheath around a silvery wire); `None`, or no
    /// steps: the body's throughout.
    pub outer: Option<Material>,
}

/// What a surface is made of, as the renderer shades it.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Material {
    /// Diffuse reflectance.
    pub albedo: Albedo,
    /// Specular highlight.
    pub gloss: Gloss,
}

/// A surface's specular highlight (Blinn–Phong): `strength · (n·h)^shininess` of white light
/// added to the diffuse colour (linear RGB, 1 the backdrop-white level).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Gloss {
    /// Brightness of the highlight's peak.
    pub strength: f64,
    /// Its sharpness (higher: smaller and sharper).
    pub shininess: f64,
}

impl Default for Gloss {
    /// A faint sheen, as on matt plastic.
    fn default() -> Self {
        Gloss {
            strength: 0.15,
            shininess: 30.0,
        }
    }
}

impl Tube {
    /// The radius of the capsule between arc lengths `a` and `b` (mm from the proximal end).
    pub fn radius_between(&self, a: f64, b: f64) -> f64 {
        radius_at(
            self.radius,
            &self.steps,
            self.centerline.length() - (a + b) / 2.0,
        )
    }

    /// True when the surface point whose nearest centerline point is at arc length `s` lies on
    /// a band. A band reaching the tube's end also colours its end cap (a marked tip).
    pub fn is_band(&self, s: f64) -> bool {
        self.bands.iter().any(|&[a, b]| s >= a && s <= b)
    }

    /// The body's material at arc length `s` (mm from the proximal end): the outer tube's
    /// behind the first radius step, if it has its own.
    pub fn material_at(&self, s: f64) -> Material {
        match (self.outer, self.steps.first()) {
            (Some(outer), Some(step)) if self.centerline.length() - s > step.from_tip_mm => outer,
            _ => Material {
                albedo: self.albedo,
                gloss: self.gloss,
            },
        }
    }
}

/// A sphere that hides what is behind it (a clamp, a hand, a cable).
#[derive(Debug, Clone)]
pub struct Occluder {
    /// Centre, world mm.
    pub centre: Point3<f64>,
    /// Radius, mm.
    pub radius: f64,
    /// Colour.
    pub albedo: Albedo,
}

/// Everything in front of the backdrops.
#[derive(Debug, Clone, Default)]
pub struct Scene {
    /// Objects whose silhouettes are measured (their pixels form the truth mask).
    pub tubes: Vec<Tube>,
    /// Objects that only hide and shadow (never in the truth mask).
    pub occluders: Vec<Occluder>,
}

#[cfg(test)]
mod tests {
    use super::*;
    use flexshape_curve::RadiusStep;

    #[test]
    fn an_outer_tube_of_its_own_material_begins_at_the_first_step() {
        let line =
            Polyline::new((0..=100).map(|i| Point3::new(0.0, 0.0, i as f64)).collect()).unwrap();
        let dark = Material {
            albedo: [0.08, 0.08, 0.09],
            gloss: Gloss::default(),
        };
        let mut tube = Tube {
            centerline: line,
            radius: 1.2,
            steps: vec![RadiusStep {
                from_tip_mm: 30.0,
                radius_mm: 3.0,
            }],
            bands: Vec::new(),
            albedo: [0.35; 3],
            band_albedo: BAND_ALBEDO,
            gloss: Gloss {
                strength: 0.9,
                shininess: 20.0,
            },
            outer: Some(dark),
        };
        // Arc length from the proximal end: the step is 30 mm from the tip, at 70 mm.
        assert_eq!(tube.material_at(10.0), dark);
        assert_eq!(tube.material_at(69.0), dark);
        assert_eq!(tube.material_at(71.0).albedo, [0.35; 3]);
        assert_eq!(tube.material_at(100.0).gloss.strength, 0.9);
        tube.steps.clear();
        assert_eq!(tube.material_at(10.0).albedo, [0.35; 3]);
    }
}
