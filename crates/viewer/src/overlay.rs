//! What the page draws over each camera's image: the shape as that camera sees it — the
//! fitted tube's two outline sides and its centerline, the bands and the tip — in the image's
//! pixels (OpenCV convention, full resolution), through the camera's lens model. Where the
//! outline sits on the silhouette's edge, the shape explains the image.

use flexshape_camera::Camera;
use flexshape_fit::Tube;
use flexshape_record::TrackRecord;
use nalgebra::{Point3, Vector3};
use serde::Serialize;

/// Spacing of the outline and centerline samples along the tube, mm.
const STEP_MM: f64 = 1.5;

/// A polyline in pixels; `None` where a point cannot be projected (behind the camera, beyond
/// its lens model), which breaks the line there.
type Line = Vec<Option<[f32; 2]>>;

/// One camera's overlay, pixels.
#[derive(Debug, Clone, Default, Serialize, PartialEq)]
pub struct CameraOverlay {
    /// The centerline's image.
    pub centerline: Line,
    /// The tube's two outline sides (its contour generators), when its radius is known.
    pub sides: [Line; 2],
    /// Each marker band's centre.
    pub bands: Vec<[f32; 2]>,
    /// The tip.
    pub tip: Option<[f32; 2]>,
    /// The true centerline's image (simulated input; empty otherwise).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub truth: Line,
}

/// A point on the tube: centre, unit tangent, radius (mm; 0 when unknown).
type Station = (Point3<f64>, Vector3<f64>, f64);

/// Each camera's overlay of the frame: from the fitted `tube` when there is one (its own
/// radii, steps included), else from the record's centerline (outline sides only when the
/// record gives a radius), with the `truth` centerline's image when it is known.
pub fn overlays(
    cameras: &[Camera],
    tube: Option<&Tube>,
    record: &TrackRecord,
    truth: Option<&[[f64; 3]]>,
) -> Vec<CameraOverlay> {
    let stations = match tube {
        Some(t) => tube_stations(t),
        None => record_stations(record),
    };
    cameras
        .iter()
        .map(|camera| {
            let pixel = |p: &Point3<f64>| {
                camera
                    .project(p)
                    .ok()
                    .map(|q| [q.pixel.x as f32, q.pixel.y as f32])
            };
            let eye = camera.centre();
            let mut sides: [Line; 2] = [Vec::new(), Vec::new()];
            if stations.iter().any(|s| s.2 > 0.0) {
                for (c, t, r) in &stations {
                    let rims = rims(&eye, c, t, *r);
                    for (side, rim) in sides.iter_mut().zip(rims) {
                        side.push(rim.and_then(|p| pixel(&p)));
                    }
                }
            }
            CameraOverlay {
                centerline: stations.iter().map(|(c, _, _)| pixel(c)).collect(),
                sides,
                bands: record
                    .bands
                    .iter()
                    .filter_map(|b| pixel(&Point3::from(b.position)))
                    .collect(),
                tip: record.tip.and_then(|t| pixel(&Point3::from(t))),
                truth: truth
                    .unwrap_or_default()
                    .iter()
                    .map(|&p| pixel(&Point3::from(p)))
                    .collect(),
            }
        })
        .collect()
}

/// The fitted tube every `STEP_MM` (its parameter is proportional to arc length).
fn tube_stations(tube: &Tube) -> Vec<Station> {
    let length = tube.length();
    let n = (length / STEP_MM).ceil().max(1.0) as usize;
    (0..=n)
        .map(|i| {
            let u = i as f64 / n as f64;
            let (c, t) = tube.frame(u);
            (c, t, tube.radius_at(u, length))
        })
        .collect()
}

/// The record's centerline, thinned to about every `STEP_MM`, tangents by central
/// differences, the record's radius if any.
fn record_stations(record: &TrackRecord) -> Vec<Station> {
    let points: Vec<Point3<f64>> = record.centerline.iter().map(|&p| Point3::from(p)).collect();
    if points.len() < 2 {
        return Vec::new();
    }
    let spacing = record.arc_length / (points.len() - 1) as f64;
    let every = ((STEP_MM / spacing.max(1e-9)).floor() as usize).max(1);
    let mut picked: Vec<usize> = (0..points.len()).step_by(every).collect();
    if picked.last() != Some(&(points.len() - 1)) {
        picked.push(points.len() - 1);
    }
    let radius = record.radius.unwrap_or(0.0);
    picked
        .iter()
        .map(|&i| {
            let (a, b) = (i.saturating_sub(1), (i + 1).min(points.len() - 1));
            let d = points[b] - points[a];
            (points[i], d / d.norm().max(1e-12), radius)
        })
        .collect()
}

/// The two points of the tube's cross-section at `c` (tangent `t`, radius `r`) where the rays
/// from `eye` graze it: on the circle `c + r·m` (`m ⟂ t`), where `m·(c + r·m − eye) = 0`.
/// `None` for both when the eye is inside the tube's cylinder or looks along it.
fn rims(eye: &Point3<f64>, c: &Point3<f64>, t: &Vector3<f64>, r: f64) -> [Option<Point3<f64>>; 2] {
    let v = c - eye;
    let across = v - t * v.dot(t);
    let d = across.norm();
    if r <= 0.0 || d <= r {
        return [None, None];
    }
    let w = across / d;
    let side = t.cross(&w);
    let (toward, out) = (r / d, (1.0 - (r / d).powi(2)).sqrt());
    [1.0, -1.0].map(|s| Some(c + (-w * toward + side * (s * out)) * r))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The rim points lie on the tube's circle and the rays from the eye graze it there.
    #[test]
    fn rims_are_where_rays_graze_the_tube() {
        let eye = Point3::new(10.0, -300.0, 40.0);
        let c = Point3::new(1.0, 2.0, 3.0);
        let t = Vector3::new(0.3, 0.1, 1.0).normalize();
        let r = 3.0;
        for rim in rims(&eye, &c, &t, r) {
            let p = rim.expect("a rim seen from outside");
            let m = (p - c) / r;
            assert!((m.norm() - 1.0).abs() < 1e-12 && m.dot(&t).abs() < 1e-12);
            assert!(m.dot(&(p - eye)).abs() < 1e-9, "the ray is tangent there");
        }
        assert_eq!(rims(&c, &c, &t, r), [None, None], "from inside the tube");
    }
}
