//! The simulated catheter: a straight proximal section entering the volume, then a bending
//! section (160 mm nominal) of one or more constant-curvature pieces, with red bands at the
//! proximal end of the bending section and at the tip.

use flexshape_camera::nalgebra::{Matrix3, Point3, Rotation3, Vector3};
use flexshape_curve::{Frame, RadiusStep, Section, SectionChain, check_steps};
use flexshape_recording::{BendBase, Truth, TruthBand, TruthSection};
use serde::{Deserialize, Serialize};

use crate::error::{SimError, config_error};
use crate::scene::{Albedo, BAND_ALBEDO, BODY_ALBEDO, Gloss, Material, Tube};

/// Spacing of the ground-truth centerline samples, mm (the contract asks for ≤ 0.5 mm).
pub const TRUTH_STEP: f64 = 0.25;
/// Spacing of the capsules the tube is rendered with, mm.
pub const RENDER_STEP: f64 = 1.0;

/// The catheter's fixed geometry.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Catheter {
    /// Tube radius, mm.
    pub radius: f64,
    /// Frame of the proximal end (world): local +y is the insertion direction; local x and z
    /// are the axes of the bending section's κx and κz when it is straight.
    pub base: Frame,
    /// Material length of the straight proximal section, mm.
    pub proximal_length: f64,
    /// Material length of the bending section, mm.
    pub bend_length: f64,
    /// Width of each marker band along the tube, mm (material).
    pub band_width: f64,
    /// Centres of additional bands, mm of material from the bending section's base.
    pub extra_bands: Vec<f64>,
    /// Where the tube steps up in radius going back from the tip, by arc length from the tip
    /// (concentric tubes; empty: constant radius). `radius` is then the tip section's.
    #[serde(default)]
    pub radius_steps: Vec<RadiusStep>,
    /// Diffuse reflectance of the body, RGB in 0–1 (the bands keep theirs).
    #[serde(default = "body_albedo")]
    pub albedo: Albedo,
    /// The body's specular highlight (default a faint sheen; strong and sharp for a metal or
    /// silvery coating).
    #[serde(default)]
    pub gloss: Gloss,
    /// The material behind the first radius step, when the outer tube is of another material
    /// than the inner one (`None`: the body's throughout).
    #[serde(default)]
    pub outer: Option<Material>,
}

fn body_albedo() -> Albedo {
    BODY_ALBEDO
}

impl Default for Catheter {
    /// Enters the default 256 mm volume through its bottom face: base at z = −240 mm pointing
    /// up (+z), bending section from z ≈ −90 mm; local x = world +x, local z = world −y.
    fn default() -> Self {
        let axes = Matrix3::from_columns(&[Vector3::x(), Vector3::z(), -Vector3::y()]);
        Catheter {
            radius: 3.0,
            base: Frame {
                position: Point3::new(0.0, 0.0, -240.0),
                rotation: Rotation3::from_matrix_unchecked(axes),
            },
            proximal_length: 150.0,
            bend_length: 160.0,
            band_width: 5.0,
            extra_bands: Vec::new(),
            radius_steps: Vec::new(),
            albedo: BODY_ALBEDO,
            gloss: Gloss::default(),
            outer: None,
        }
    }
}

/// The variable part of one frame.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CatheterPose {
    /// How far the catheter has been advanced along the base axis, mm.
    pub insertion: f64,
    /// Axial strain of the proximal section ε0 (compression positive).
    pub eps0: f64,
    /// The bending section's pieces, base to tip; their material lengths must add up to the
    /// catheter's `bend_length`. One piece is the paper's constant-curvature case.
    pub bend: Vec<Section>,
    /// True when `bend` approximates a free-form curve (its truth has no single κ, ε).
    pub free_form: bool,
}

impl CatheterPose {
    /// A single constant-curvature bending section (the paper's model).
    pub fn arc(catheter: &Catheter, kappa: [f64; 2], eps: [f64; 2], insertion: f64) -> Self {
        CatheterPose {
            insertion,
            eps0: eps[0],
            bend: vec![Section {
                length: catheter.bend_length,
                kappa,
                strain: eps[1],
            }],
            free_form: false,
        }
    }

    /// Two constant-curvature pieces splitting the bending section at `split` mm of material.
    pub fn two_section(
        catheter: &Catheter,
        first: [f64; 2],
        second: [f64; 2],
        split: f64,
        eps: [f64; 2],
        insertion: f64,
    ) -> Self {
        let piece = |length, kappa| Section {
            length,
            kappa,
            strain: eps[1],
        };
        CatheterPose {
            insertion,
            eps0: eps[0],
            bend: vec![
                piece(split, first),
                piece(catheter.bend_length - split, second),
            ],
            free_form: false,
        }
    }

    /// A smooth free-form bend whose curvature varies along the tube as `kappa(s)` (1/mm, at
    /// `s` mm of material from the bending base), built from 1 mm constant-curvature pieces.
    pub fn smooth(
        catheter: &Catheter,
        kappa: impl Fn(f64) -> [f64; 2],
        eps: [f64; 2],
        insertion: f64,
    ) -> Self {
        let mut chain =
            SectionChain::from_curvature(Frame::identity(), catheter.bend_length, 1.0, kappa);
        for s in &mut chain.sections {
            s.strain = eps[1];
        }
        CatheterPose {
            insertion,
            eps0: eps[0],
            bend: chain.sections,
            free_form: true,
        }
    }
}

/// A gloss the renderer can shade: strength in [0, 10], shininess in [1, 10⁴].
fn check_gloss(field: &str, g: Gloss) -> Result<(), SimError> {
    if (0.0..=10.0).contains(&g.strength) && (1.0..=1e4).contains(&g.shininess) {
        return Ok(());
    }
    Err(config_error(
        field,
        format!(
            "strength {} must lie in [0, 10] and shininess {} in [1, 10⁴]",
            g.strength, g.shininess
        ),
    ))
}

/// The catheter in one pose: its centerline and where its bands are.
#[derive(Debug, Clone)]
pub struct CatheterState {
    /// Proximal section followed by the bending pieces.
    pub chain: SectionChain,
    /// Band intervals along the centerline, arc-length mm `[start, end]`, proximal first.
    pub bands: Vec<[f64; 2]>,
    /// Band centres, arc-length mm.
    pub band_centres: Vec<f64>,
}

impl Catheter {
    /// The default catheter with a silvery (metal) coating: grey, reflectance 0.35, with a
    /// strong sharp highlight (strength 0.9, shininess 20) as light as a white backdrop where
    /// it reflects the lamp (`simulate --body-albedo 0.35,0.35,0.35 --gloss 0.9,20`).
    pub fn silvery() -> Self {
        Catheter {
            albedo: [0.35; 3],
            gloss: Gloss {
                strength: 0.9,
                shininess: 20.0,
            },
            ..Catheter::default()
        }
    }

    fn validate(&self, pose: &CatheterPose) -> Result<(), SimError> {
        let positive = |field: &str, v: f64| {
            if v.is_finite() && v > 0.0 {
                Ok(())
            } else {
                Err(config_error(
                    field,
                    format!(
                        "{} must be a positive length in mm",
                        flexshape_rig::quoted(v)
                    ),
                ))
            }
        };
        positive("radius", self.radius)?;
        positive("proximal_length", self.proximal_length)?;
        positive("bend_length", self.bend_length)?;
        positive("band_width", self.band_width)?;
        check_steps(&self.radius_steps, (1e-3, 1e3))
            .map_err(|e| config_error("radius_steps", e.0))?;
        check_gloss("gloss", self.gloss)?;
        if let Some(outer) = self.outer {
            if self.radius_steps.is_empty() {
                return Err(config_error(
                    "outer",
                    "an outer tube's material needs radius_steps (where the outer tube begins)",
                ));
            }
            check_gloss("outer.gloss", outer.gloss)?;
        }
        let total: f64 = pose.bend.iter().map(|s| s.length).sum();
        if pose.bend.is_empty() || (total - self.bend_length).abs() > 1e-6 * self.bend_length {
            return Err(config_error(
                "bend",
                format!(
                    "pieces add up to {total} mm but the bending section is {} mm",
                    self.bend_length
                ),
            ));
        }
        for (field, e) in std::iter::once(("eps0", pose.eps0))
            .chain(pose.bend.iter().map(|s| ("strain", s.strain)))
        {
            if !(e.is_finite() && e > -0.5 && e < 0.5) {
                return Err(config_error(
                    field,
                    format!("axial strain {e} is outside (−0.5, 0.5)"),
                ));
            }
        }
        if pose
            .bend
            .iter()
            .any(|s| !(s.kappa[0].is_finite() && s.kappa[1].is_finite()))
        {
            return Err(config_error("kappa", "curvature must be finite"));
        }
        if !pose.insertion.is_finite() {
            return Err(config_error("insertion", "must be finite"));
        }
        Ok(())
    }

    /// Material positions of the band centres, mm from the bending section's base, proximal
    /// first.
    pub fn band_centres(&self) -> Vec<f64> {
        let mut centres = vec![0.0, self.bend_length - self.band_width / 2.0];
        centres.extend(self.extra_bands.iter().copied());
        centres.sort_by(f64::total_cmp);
        centres
    }

    /// The `[processing.shape]` table that describes this catheter to the shape stage
    /// (`docs/formats.md`): its bands, and the bending section's compression measured between
    /// the first and last band's centres.
    pub fn shape_settings(&self) -> toml::Table {
        let centres = self.band_centres();
        let last = centres.len() - 1;
        let mut section = toml::Table::new();
        section.insert("name".into(), "bending".into());
        section.insert("from_band".into(), 0.into());
        section.insert("to_band".into(), (last as i64).into());
        section.insert("nominal_mm".into(), (centres[last] - centres[0]).into());
        let mut shape = toml::Table::new();
        shape.insert("expected_bands".into(), (centres.len() as i64).into());
        // The simulated catheter's last band ends at its tip.
        shape.insert("tip_band".into(), true.into());
        shape.insert(
            "sections".into(),
            toml::Value::Array(vec![toml::Value::Table(section)]),
        );
        // A stepped tube's radii are part of the instrument's description.
        if !self.radius_steps.is_empty() {
            shape.insert("radius_mm".into(), self.radius.into());
            let steps = self
                .radius_steps
                .iter()
                .map(|s| {
                    let mut t = toml::Table::new();
                    t.insert("from_tip_mm".into(), s.from_tip_mm.into());
                    t.insert("radius_mm".into(), s.radius_mm.into());
                    toml::Value::Table(t)
                })
                .collect();
            shape.insert("radius_steps".into(), toml::Value::Array(steps));
        }
        shape
    }

    /// The centerline and bands of `pose`.
    pub fn state(&self, pose: &CatheterPose) -> Result<CatheterState, SimError> {
        self.validate(pose)?;
        let base = Frame {
            position: self.base.position + self.base.tangent() * pose.insertion,
            rotation: self.base.rotation,
        };
        let mut sections = vec![Section {
            length: self.proximal_length,
            kappa: [0.0, 0.0],
            strain: pose.eps0,
        }];
        sections.extend_from_slice(&pose.bend);
        let chain = SectionChain { base, sections };
        let half = self.band_width / 2.0;
        let centres = self.band_centres();
        let material = |sigma: f64| chain.arc_of_material(self.proximal_length + sigma);
        let bands = centres
            .iter()
            .map(|&c| {
                [
                    material(c - half),
                    material((c + half).min(self.bend_length)),
                ]
            })
            .collect();
        let band_centres = centres.iter().map(|&c| material(c)).collect();
        Ok(CatheterState {
            chain,
            bands,
            band_centres,
        })
    }

    /// The tube to render for `state`.
    pub fn tube(&self, state: &CatheterState) -> Result<Tube, SimError> {
        Ok(Tube {
            centerline: state.chain.polyline(RENDER_STEP)?,
            radius: self.radius,
            steps: self.radius_steps.clone(),
            bands: state.bands.clone(),
            albedo: self.albedo,
            band_albedo: BAND_ALBEDO,
            gloss: self.gloss,
            outer: self.outer,
        })
    }

    /// The ground-truth record of `state` in `pose` for frame `frame`.
    pub fn truth(
        &self,
        frame: u64,
        pose: &CatheterPose,
        state: &CatheterState,
    ) -> Result<Truth, SimError> {
        let chain = &state.chain;
        let centerline: Vec<[f64; 3]> = chain
            .polyline(TRUTH_STEP)?
            .points()
            .iter()
            .map(|p| [p.x, p.y, p.z])
            .collect();
        let tip = chain.tip();
        let bands = state
            .band_centres
            .iter()
            .zip(&state.bands)
            .map(|(&s, &[a, b])| {
                let p = chain.frame_at(s).position;
                TruthBand {
                    position: [p.x, p.y, p.z],
                    arc_length: s,
                    width: b - a,
                }
            })
            .collect();
        let single = (pose.bend.len() == 1 && !pose.free_form).then(|| &pose.bend[0]);
        let bend_start = chain.section_start(1);
        let bend_frame = chain.frame_at(bend_start);
        let m = bend_frame.rotation.matrix();
        Ok(Truth {
            frame,
            centerline,
            radius: self.radius,
            tip: tip.position.into(),
            tip_direction: tip.tangent().into(),
            bands,
            kappa: single.map(|s| s.kappa),
            eps: single.map(|s| [pose.eps0, s.strain]),
            bend_start_arc_length: Some(bend_start),
            sections: chain
                .sections
                .iter()
                .map(|s| TruthSection {
                    length: s.length,
                    kappa: s.kappa,
                    strain: s.strain,
                })
                .collect(),
            bend_base: Some(BendBase {
                origin: bend_frame.position.into(),
                rotation: std::array::from_fn(|r| std::array::from_fn(|c| m[(r, c)])),
            }),
        })
    }
}
