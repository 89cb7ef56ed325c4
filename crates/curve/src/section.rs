//! Piecewise constant-curvature curves with closed-form frames.
//!
//! Convention (the paper's, Fig. 8 and the moment-arm matrix D): each section has a local frame
//! whose +y axis is the tangent at its base. Curvature `κ = [κx, κz]` (1/mm) is the rate of
//! rotation of the frame about its own x and z axes per mm of arc, so a positive κx bends the
//! curve toward local +z and a positive κz toward local −x. Axial strain ε (compression
//! positive, dimensionless) shortens a section of material length L to an arc of L·(1 − ε).

use nalgebra::{Point3, Rotation3, Unit, Vector3};
use serde::{Deserialize, Serialize};

use crate::polyline::{CurveError, Polyline};

/// Below this bend angle (radians) the closed form switches to its Taylor series.
const SMALL_ANGLE: f64 = 1e-5;

/// A position and orientation; the rotation's columns are the frame's x, y (tangent) and z axes
/// in the parent (usually world) frame. Positions in mm.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Frame {
    /// Origin, mm.
    pub position: Point3<f64>,
    /// Orientation: local → parent.
    pub rotation: Rotation3<f64>,
}

impl Frame {
    /// The parent frame itself.
    pub fn identity() -> Self {
        Frame {
            position: Point3::origin(),
            rotation: Rotation3::identity(),
        }
    }

    /// Unit tangent (local +y) in the parent frame.
    pub fn tangent(&self) -> Vector3<f64> {
        self.rotation * Vector3::y()
    }

    /// `self ∘ local`: a frame given relative to `self`, expressed in `self`'s parent.
    pub fn compose(&self, local: &Frame) -> Frame {
        Frame {
            position: self.position + self.rotation * local.position.coords,
            rotation: self.rotation * local.rotation,
        }
    }
}

/// One constant-curvature section.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Section {
    /// Material (unstrained) length, mm.
    pub length: f64,
    /// `[κx, κz]`, 1/mm, about the section's local x and z axes.
    pub kappa: [f64; 2],
    /// Axial strain ε, compression positive.
    pub strain: f64,
}

impl Section {
    /// Arc length of the strained section, `L · (1 − ε)`, mm.
    pub fn arc_length(&self) -> f64 {
        self.length * (1.0 - self.strain)
    }

    /// Frame at arc length `s` (mm, from the section's base) relative to the base frame.
    pub fn local_frame(&self, s: f64) -> Frame {
        let [kx, kz] = self.kappa;
        let k = kx.hypot(kz);
        let angle = k * s;
        if angle.abs() < SMALL_ANGLE {
            // sin(θ)/k ≈ s (1 − θ²/6), (1 − cos θ)/k ≈ s θ/2 (1 − θ²/12); the bend direction
            // a × ŷ = (−κz, 0, κx)/k times θ/2 · s needs no division by k.
            let along = s * (1.0 - angle * angle / 6.0);
            let side = 0.5 * s * s * (1.0 - angle * angle / 12.0);
            let position = Point3::new(-kz * side, along, kx * side);
            let rotation = Rotation3::from_scaled_axis(Vector3::new(kx, 0.0, kz) * s);
            return Frame { position, rotation };
        }
        let axis = Vector3::new(kx / k, 0.0, kz / k);
        let bend = Vector3::new(-axis.z, 0.0, axis.x); // axis × ŷ
        // 1 − cos θ = 2 sin²(θ/2), without the cancellation at small angles.
        let side = 2.0 * (angle / 2.0).sin().powi(2) / k;
        let position = Vector3::y() * (angle.sin() / k) + bend * side;
        Frame {
            position: Point3::from(position),
            rotation: Rotation3::from_axis_angle(&Unit::new_unchecked(axis), angle),
        }
    }
}

/// Sections joined end to end from a base frame (each section's local frame is the previous
/// one's tip frame). Arc length `s` runs from the base.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SectionChain {
    /// Frame at the start of the first section, in the parent (world) frame.
    pub base: Frame,
    /// The sections, base to tip.
    pub sections: Vec<Section>,
}

impl SectionChain {
    /// A chain approximating a smoothly varying curvature `kappa(s)` (1/mm, at arc length
    /// `s`) over `length` mm, as unstrained constant-curvature pieces of at most `step` mm,
    /// each taking the curvature at its midpoint.
    pub fn from_curvature(
        base: Frame,
        length: f64,
        step: f64,
        kappa: impl Fn(f64) -> [f64; 2],
    ) -> Self {
        let n = (length / step).ceil().max(1.0) as usize;
        let h = length / n as f64;
        let sections = (0..n)
            .map(|i| Section {
                length: h,
                kappa: kappa((i as f64 + 0.5) * h),
                strain: 0.0,
            })
            .collect();
        SectionChain { base, sections }
    }

    /// Total arc length, mm.
    pub fn arc_length(&self) -> f64 {
        self.sections.iter().map(Section::arc_length).sum()
    }

    /// Arc length where section `i` starts, mm.
    pub fn section_start(&self, i: usize) -> f64 {
        self.sections[..i].iter().map(Section::arc_length).sum()
    }

    /// Arc length (mm) of the point at material coordinate `sigma` (unstrained mm from the
    /// base): each section maps its material length onto its strained arc.
    pub fn arc_of_material(&self, sigma: f64) -> f64 {
        let mut rest = sigma;
        let mut s = 0.0;
        for (i, sec) in self.sections.iter().enumerate() {
            let last = i + 1 == self.sections.len();
            if rest <= sec.length || last {
                return s + rest * (1.0 - sec.strain);
            }
            rest -= sec.length;
            s += sec.arc_length();
        }
        s + rest
    }

    /// Frame at arc length `s` (mm; clamped to the chain), in the parent frame.
    pub fn frame_at(&self, s: f64) -> Frame {
        let mut frame = self.base;
        let mut rest = s.max(0.0);
        for (i, sec) in self.sections.iter().enumerate() {
            let len = sec.arc_length();
            if rest <= len || i + 1 == self.sections.len() {
                return frame.compose(&sec.local_frame(rest.min(len)));
            }
            frame = frame.compose(&sec.local_frame(len));
            rest -= len;
        }
        frame
    }

    /// Frame at the tip.
    pub fn tip(&self) -> Frame {
        self.frame_at(self.arc_length())
    }

    /// Points every `step` mm or less along the whole chain (section joints included),
    /// with their frames; computed section by section so the cost is linear.
    pub fn sample_frames(&self, step: f64) -> Vec<(f64, Frame)> {
        let mut out = Vec::new();
        let mut frame = self.base;
        let mut s0 = 0.0;
        for sec in &self.sections {
            let len = sec.arc_length();
            let n = (len / step).ceil().max(1.0) as usize;
            let start = if out.is_empty() { 0 } else { 1 };
            for k in start..=n {
                let s = len * k as f64 / n as f64;
                out.push((s0 + s, frame.compose(&sec.local_frame(s))));
            }
            frame = frame.compose(&sec.local_frame(len));
            s0 += len;
        }
        out
    }

    /// The chain as a polyline sampled every `step` mm or less; fails for a chain of zero
    /// length or with non-finite parameters.
    pub fn polyline(&self, step: f64) -> Result<Polyline, CurveError> {
        let pts = self
            .sample_frames(step)
            .into_iter()
            .map(|(_, f)| f.position)
            .collect();
        Polyline::new(pts)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    fn sec(length: f64, kx: f64, kz: f64) -> Section {
        Section {
            length,
            kappa: [kx, kz],
            strain: 0.0,
        }
    }

    #[test]
    fn quarter_circles_about_x_and_z() {
        let r = 50.0;
        let l = PI / 2.0 * r;
        let tip = sec(l, 1.0 / r, 0.0).local_frame(l);
        assert!(
            (tip.position - Point3::new(0.0, r, r)).norm() < 1e-12,
            "{tip:?}"
        );
        assert!((tip.tangent() - Vector3::z()).norm() < 1e-12);
        let tip = sec(l, 0.0, 1.0 / r).local_frame(l);
        assert!(
            (tip.position - Point3::new(-r, r, 0.0)).norm() < 1e-12,
            "{tip:?}"
        );
        assert!((tip.tangent() + Vector3::x()).norm() < 1e-12);
    }

    #[test]
    fn straight_and_small_curvature_limits_are_continuous() {
        let straight = sec(160.0, 0.0, 0.0).local_frame(160.0);
        assert_eq!(straight.position, Point3::new(0.0, 160.0, 0.0));
        // Either side of the series threshold the two formulas agree.
        for &k in &[0.9e-5 / 160.0, 1.1e-5 / 160.0, 1e-9] {
            let a = sec(160.0, k * 0.6, k * 0.8).local_frame(160.0);
            // Exact circle: deviation from straight is L²κ/2 for small κ.
            let side = a.position - Point3::new(0.0, 160.0, 0.0);
            let expect = 160.0 * 160.0 * k / 2.0;
            assert!((side.norm() - expect).abs() < 1e-12 + 1e-6 * expect, "{k}");
        }
    }

    #[test]
    fn every_point_is_on_the_circle_and_arc_length_is_preserved() {
        let s = Section {
            length: 160.0,
            kappa: [0.012, -0.005],
            strain: 0.02,
        };
        let chain = SectionChain {
            base: Frame::identity(),
            sections: vec![s],
        };
        let line = chain.polyline(0.05).unwrap();
        assert!((line.length() - 160.0 * 0.98).abs() < 1e-3);
        let k = 0.013;
        // Centre of curvature: base + (bend direction)/k.
        let centre = Point3::new(0.005, 0.0, 0.012) / k / k;
        for p in line.points() {
            assert!(((p - centre).norm() - 1.0 / k).abs() < 1e-9);
        }
    }

    #[test]
    fn chain_composes_and_maps_material_to_arc() {
        let chain = SectionChain {
            base: Frame {
                position: Point3::new(1.0, 2.0, 3.0),
                rotation: Rotation3::from_euler_angles(0.2, 0.1, -0.3),
            },
            sections: vec![
                Section {
                    length: 100.0,
                    kappa: [0.0, 0.0],
                    strain: 0.01,
                },
                Section {
                    length: 160.0,
                    kappa: [0.01, 0.0],
                    strain: 0.03,
                },
            ],
        };
        assert!((chain.section_start(1) - 99.0).abs() < 1e-12);
        assert!((chain.arc_of_material(100.0) - 99.0).abs() < 1e-12);
        assert!((chain.arc_of_material(180.0) - (99.0 + 80.0 * 0.97)).abs() < 1e-12);
        let joint = chain.frame_at(99.0);
        let expect = chain.base.position + chain.base.tangent() * 99.0;
        assert!((joint.position - expect).norm() < 1e-12);
        let samples = chain.sample_frames(0.5);
        for (s, f) in samples.iter().step_by(37) {
            assert!((chain.frame_at(*s).position - f.position).norm() < 1e-9);
        }
        let tip = chain.tip();
        assert!((samples.last().unwrap().1.position - tip.position).norm() < 1e-12);
    }

    #[test]
    fn smooth_profile_converges_to_the_exact_arc() {
        let exact = SectionChain {
            base: Frame::identity(),
            sections: vec![sec(100.0, 0.01, 0.004)],
        }
        .tip();
        let approx =
            SectionChain::from_curvature(Frame::identity(), 100.0, 1.0, |_| [0.01, 0.004]).tip();
        assert!((exact.position - approx.position).norm() < 1e-9);
    }
}
