//! Tracked frames of a rigid object compared with its known shape (`flexshape validate
//! shape`): each usable record's centerline (and bands, when marks are known) paired with the
//! known shape and registered per pose.

use std::path::Path;

use flexshape_curve::Polyline;
use flexshape_record::{RecordStatus, TrackRecord};
use nalgebra::Point3;

use crate::{KnownShape, PoseComparison, ValidateError, compare_shape};

/// The records compared with the known shape.
#[derive(Debug, Clone, Default)]
pub struct ShapeRun {
    /// Each compared pose.
    pub poses: Vec<PoseComparison>,
    /// Its frame number.
    pub frames: Vec<u64>,
    /// Its sensed centerline, world mm.
    pub sensed: Vec<Vec<[f64; 3]>>,
    /// Its sensed bands (when the known shape has marks), world mm.
    pub sensed_marks: Vec<Vec<[f64; 3]>>,
    /// Records left out, each with why (`line N (frame F): why`).
    pub skipped: Vec<String>,
}

impl ShapeRun {
    /// Per pose: frame, arc-length offset (mm) and 3-D RMS along the length (mm).
    pub fn per_pose(&self) -> Vec<(u64, f64, f64)> {
        self.poses
            .iter()
            .zip(&self.frames)
            .map(|(p, &f)| {
                let n = p.errors.len().max(1) as f64;
                let sum: f64 = p
                    .errors
                    .iter()
                    .map(|e| e.iter().map(|v| v * v).sum::<f64>())
                    .sum();
                (f, p.offset_mm, (sum / n).sqrt())
            })
            .collect()
    }
}

/// Compares the records of `source` (pairs of line and record, as
/// `flexshape_record::read_records` gives them) with `known`: records whose status is `ok` or
/// `bands_missing` and that have a centerline. None comparable is an error listing why.
pub fn compare_records(
    known: &KnownShape,
    records: Vec<(usize, TrackRecord)>,
    source: &Path,
) -> Result<ShapeRun, ValidateError> {
    let mut run = ShapeRun::default();
    for (line, r) in records {
        let usable = matches!(r.status, RecordStatus::Ok | RecordStatus::BandsMissing)
            && r.centerline.len() > 2;
        if !usable {
            run.skipped.push(format!(
                "line {line} (frame {}): status {}",
                r.frame, r.status
            ));
            continue;
        }
        let curve = Polyline::new(r.centerline.iter().map(|p| Point3::from(*p)).collect())
            .map_err(|e| ValidateError::Input(format!("{} line {line}: {e}", source.display())))?;
        let bands: Vec<Point3<f64>> = if known.marks.is_empty() {
            Vec::new()
        } else {
            r.bands.iter().map(|b| Point3::from(b.position)).collect()
        };
        match compare_shape(known, &curve, &bands) {
            Ok(c) => {
                run.frames.push(r.frame);
                run.sensed.push(r.centerline.clone());
                run.sensed_marks
                    .push(bands.iter().map(|p| [p.x, p.y, p.z]).collect());
                run.poses.push(c);
            }
            Err(e) => run
                .skipped
                .push(format!("line {line} (frame {}): {e}", r.frame)),
        }
    }
    if run.poses.is_empty() {
        return Err(ValidateError::Input(format!(
            "{}: no pose could be compared with the known shape ({})",
            source.display(),
            run.skipped.join("; ")
        )));
    }
    Ok(run)
}
