//! Precision against a known shape (paper, Section III-B): the sensed centerline of a rigid
//! object is paired with its known (CAD) centerline along the length, registered per pose,
//! and the residuals are measured along the whole length and at the marked points.
//!
//! Pairing runs from the distal tip back (the sensed curve begins wherever the object enters
//! the volume); an arc-length offset between the two (the tip's placement along the tube) is
//! found by a 1-D search, so it does not masquerade as error.

use flexshape_curve::Polyline;
use flexshape_register::{RigidTransform, kabsch, refine};
use nalgebra::{Point3, Vector3};
use serde::Serialize;

use crate::ValidateError;

/// The object's known shape in its own frame, mm.
#[derive(Debug, Clone, PartialEq)]
pub struct KnownShape {
    /// Centerline, proximal to distal.
    pub centerline: Polyline,
    /// Marked points (band centres), proximal to distal.
    pub marks: Vec<Point3<f64>>,
}

/// One pose compared with the known shape.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PoseComparison {
    /// Known → world (rotation rows, translation mm).
    pub rotation: [[f64; 3]; 3],
    /// See `rotation`.
    pub translation: [f64; 3],
    /// Arc-length offset of the pairing (known minus sensed, from the tip), mm.
    pub offset_mm: f64,
    /// Sensed − registered known, per paired sample (1 mm apart), world mm.
    pub errors: Vec<[f64; 3]>,
    /// Sensed − registered known mark, per mark, world mm.
    pub mark_errors: Vec<[f64; 3]>,
    /// The registered known centerline (world), for plots.
    pub registered: Vec<[f64; 3]>,
    /// The registered marks (world).
    pub registered_marks: Vec<[f64; 3]>,
}

/// The paper's precision figures over several poses.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PrecisionReport {
    /// Poses compared.
    pub poses: usize,
    /// Per-axis RMS along the whole length, mm.
    pub rms_along: [f64; 3],
    /// 3-D RMS along the length, mm.
    pub rms_along_3d: f64,
    /// Largest 3-D error along the length, mm.
    pub max_along: f64,
    /// Per-axis RMS at the marks, mm.
    pub rms_marks: [f64; 3],
    /// 3-D RMS at the marks, mm.
    pub rms_marks_3d: f64,
    /// Largest 3-D error at a mark, mm.
    pub max_marks: f64,
}

/// Spacing of the paired samples, mm.
const STEP: f64 = 1.0;
/// Largest arc-length offset searched, mm.
const MAX_OFFSET: f64 = 4.0;

/// Compares one sensed centerline (proximal → tip, world) and its band centres with `known`.
pub fn compare_shape(
    known: &KnownShape,
    sensed: &Polyline,
    sensed_marks: &[Point3<f64>],
) -> Result<PoseComparison, ValidateError> {
    if sensed_marks.len() != known.marks.len() {
        return Err(ValidateError::Input(format!(
            "{} bands sensed but the known shape has {} marks",
            sensed_marks.len(),
            known.marks.len()
        )));
    }
    let pairs = |offset: f64| -> (Vec<Point3<f64>>, Vec<Point3<f64>>) {
        let (ls, lk) = (sensed.length(), known.centerline.length());
        let n = ((ls.min(lk - offset.max(0.0)) - offset.min(0.0).abs()) / STEP).floor() as usize;
        (0..=n)
            .map(|i| {
                let d = i as f64 * STEP;
                (
                    known.centerline.point_at(lk - d - offset),
                    sensed.point_at(ls - d),
                )
            })
            .unzip()
    };
    let cost = |offset: f64| -> f64 {
        let (k, s) = pairs(offset);
        match kabsch(&k, &s) {
            Ok(t) => rms(&t, &k, &s),
            Err(_) => f64::INFINITY,
        }
    };
    // Golden-section search for the offset.
    let g = (5f64.sqrt() - 1.0) / 2.0;
    let (mut a, mut b) = (-MAX_OFFSET, MAX_OFFSET);
    let (mut c, mut d) = (b - g * (b - a), a + g * (b - a));
    let (mut fc, mut fd) = (cost(c), cost(d));
    while b - a > 1e-3 {
        if fc < fd {
            (b, d, fd) = (d, c, fc);
            c = b - g * (b - a);
            fc = cost(c);
        } else {
            (a, c, fc) = (c, d, fd);
            d = a + g * (b - a);
            fd = cost(d);
        }
    }
    let offset = (a + b) / 2.0;
    let (k, s) = pairs(offset);
    if k.len() < 3 {
        return Err(ValidateError::Input(format!(
            "only {} samples pair up; is the sensed curve the known object?",
            k.len()
        )));
    }
    let t = refine(&k, &s, &[], &kabsch(&k, &s)?)?;
    let m = t.rotation.matrix();
    let world = |p: &Point3<f64>| -> [f64; 3] { t.apply(p).into() };
    Ok(PoseComparison {
        rotation: std::array::from_fn(|r| std::array::from_fn(|c| m[(r, c)])),
        translation: t.translation.into(),
        offset_mm: offset,
        errors: k
            .iter()
            .zip(&s)
            .map(|(k, s)| (s - t.apply(k)).into())
            .collect(),
        mark_errors: known
            .marks
            .iter()
            .zip(sensed_marks)
            .map(|(k, s)| (s - t.apply(k)).into())
            .collect(),
        registered: known.centerline.points().iter().map(world).collect(),
        registered_marks: known.marks.iter().map(world).collect(),
    })
}

fn rms(t: &RigidTransform, k: &[Point3<f64>], s: &[Point3<f64>]) -> f64 {
    let sum: f64 = k
        .iter()
        .zip(s)
        .map(|(k, s)| (s - t.apply(k)).norm_squared())
        .sum();
    (sum / k.len() as f64).sqrt()
}

/// Pools the residuals of several poses.
pub fn precision(poses: &[PoseComparison]) -> PrecisionReport {
    let pool = |get: &dyn Fn(&PoseComparison) -> &Vec<[f64; 3]>| {
        let all: Vec<Vector3<f64>> = poses
            .iter()
            .flat_map(|p| get(p).iter().map(|e| Vector3::from(*e)))
            .collect();
        let n = all.len().max(1) as f64;
        let axis =
            std::array::from_fn(|a| (all.iter().map(|e| e[a] * e[a]).sum::<f64>() / n).sqrt());
        let rms = (all.iter().map(|e| e.norm_squared()).sum::<f64>() / n).sqrt();
        let max = all.iter().map(|e| e.norm()).fold(0.0, f64::max);
        (axis, rms, max)
    };
    let (rms_along, rms_along_3d, max_along) = pool(&|p| &p.errors);
    let (rms_marks, rms_marks_3d, max_marks) = pool(&|p| &p.mark_errors);
    PrecisionReport {
        poses: poses.len(),
        rms_along,
        rms_along_3d,
        max_along,
        rms_marks,
        rms_marks_3d,
        max_marks,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Rotation3, Translation3};

    fn s_bend() -> Polyline {
        let points = (0..=300)
            .map(|i| {
                let s = i as f64 * 0.5;
                Point3::new(20.0 * (s / 30.0).sin(), s, 0.02 * s * s)
            })
            .collect();
        Polyline::new(points).unwrap()
    }

    #[test]
    fn a_moved_copy_matches_exactly_and_a_shortened_one_is_paired_from_the_tip() {
        let known = KnownShape {
            centerline: s_bend(),
            marks: vec![s_bend().point_at(10.0), s_bend().point_at(100.0)],
        };
        let r = Rotation3::from_euler_angles(0.4, -0.2, 1.0);
        let t = Translation3::new(10.0, -50.0, 30.0);
        let moved = |p: &Point3<f64>| t * (r * p);
        // The sensed curve starts 40 mm in (it entered the volume there) and its tip sits
        // 0.5 mm short.
        let length = known.centerline.length();
        let sensed = Polyline::new(
            (0..=1000)
                .map(|i| {
                    moved(
                        &known
                            .centerline
                            .point_at(40.0 + i as f64 * (length - 40.5) / 1000.0),
                    )
                })
                .collect(),
        )
        .unwrap();
        let marks: Vec<_> = known.marks.iter().map(moved).collect();
        let c = compare_shape(&known, &sensed, &marks).unwrap();
        assert!((c.offset_mm - 0.5).abs() < 0.01, "{}", c.offset_mm);
        let p = precision(&[c]);
        assert!(p.rms_along_3d < 0.01 && p.rms_marks_3d < 0.01, "{p:?}");
        // A mark count that does not match is an error naming both counts.
        let e = compare_shape(&known, &sensed, &marks[..1]).unwrap_err();
        assert!(e.to_string().contains("1 bands sensed") && e.to_string().contains("2 marks"));
    }
}
