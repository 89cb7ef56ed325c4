//! Accuracy against a reference instrument (paper, Section III-A).

use flexshape_register::{RigidTransform, register};
use nalgebra::Point3;
use serde::Serialize;

use crate::ValidateError;

/// Sensed points against reference points after rigid registration (reference → sensed).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct AccuracyReport {
    /// Point pairs.
    pub points: usize,
    /// RMS error along world x, mm.
    pub rms_x: f64,
    /// Along world y, mm.
    pub rms_y: f64,
    /// Along world z, mm.
    pub rms_z: f64,
    /// 3-D RMS error, mm.
    pub rms: f64,
    /// Largest 3-D error, mm.
    pub max: f64,
    /// Reference → sensed: rotation (rows) and translation (mm).
    pub rotation: [[f64; 3]; 3],
    /// See `rotation`.
    pub translation: [f64; 3],
    /// Per pair: the 3-D error after registration, mm.
    pub errors: Vec<f64>,
    /// Per pair: sensed − registered reference, mm.
    pub error_vectors: Vec<[f64; 3]>,
    /// The reference points in the sensed frame.
    pub registered_reference: Vec<[f64; 3]>,
}

impl AccuracyReport {
    /// `[rms_x, rms_y, rms_z]`.
    pub fn rms_axis(&self) -> [f64; 3] {
        [self.rms_x, self.rms_y, self.rms_z]
    }
}

/// Registers `reference` onto `sensed` (pairs by index) and measures the residuals.
pub fn accuracy(
    sensed: &[Point3<f64>],
    reference: &[Point3<f64>],
) -> Result<AccuracyReport, ValidateError> {
    let (t, res) = register(reference, sensed)?;
    Ok(report(
        &t,
        sensed,
        reference,
        res.rms_axis,
        res.rms,
        res.max,
    ))
}

fn report(
    t: &RigidTransform,
    sensed: &[Point3<f64>],
    reference: &[Point3<f64>],
    rms_axis: [f64; 3],
    rms: f64,
    max: f64,
) -> AccuracyReport {
    let m = t.rotation.matrix();
    let registered: Vec<Point3<f64>> = reference.iter().map(|r| t.apply(r)).collect();
    AccuracyReport {
        points: sensed.len(),
        rms_x: rms_axis[0],
        rms_y: rms_axis[1],
        rms_z: rms_axis[2],
        rms,
        max,
        rotation: std::array::from_fn(|r| std::array::from_fn(|c| m[(r, c)])),
        translation: [t.translation.x, t.translation.y, t.translation.z],
        errors: sensed
            .iter()
            .zip(&registered)
            .map(|(s, r)| (s - r).norm())
            .collect(),
        error_vectors: sensed
            .iter()
            .zip(&registered)
            .map(|(s, r)| (s - r).into())
            .collect(),
        registered_reference: registered.iter().map(|p| [p.x, p.y, p.z]).collect(),
    }
}
