//! The visual hull alone, for any object (`flexshape carve`): one frame's hull as files and
//! as its line of `hull.jsonl` ([`HullRecord`], `docs/formats.md`).

use std::path::Path;

use flexshape_carve::PlyEncoding;
use flexshape_input::FrameSet;
use flexshape_record::{HullRecord, RecordStatus};

use crate::recorded::captured_from;
use crate::{Hull, Pipeline, TrackError};

/// One frame's visual hull for any object: its voxel centres (`NNNNNN.ply`) and surface
/// (`NNNNNN.surface.ply`) written to `dir` when carved; a frame that cannot be read or carved
/// is an `error` record. Fails only when a file cannot be written.
pub fn carve_frame(
    pipeline: &Pipeline,
    set: FrameSet,
    dir: &Path,
    encoding: PlyEncoding,
) -> Result<HullRecord, TrackError> {
    let (frame, name) = (set.frame, set.name.clone());
    let captured = set.capture_time;
    let timed = |record: HullRecord| HullRecord {
        captured_s: captured.map(|c| c.seconds),
        captured_from: captured.map(|c| captured_from(c.source)),
        ..record
    };
    let images = match pipeline.load(set.images) {
        Ok((i, _)) => i,
        Err(e) => return Ok(timed(HullRecord::error(frame, name, e))),
    };
    let refs: Vec<_> = images.iter().collect();
    let hull = match pipeline.hull(&refs) {
        Ok(h) => h,
        Err(e) => return Ok(timed(HullRecord::error(frame, name, e.to_string()))),
    };
    let mut record = timed(hull.record(frame, name));
    if record.status.is_ok() {
        let cloud = dir.join(format!("{frame:06}.ply"));
        hull.occupancy
            .to_cloud()
            .write_ply(&cloud, encoding)
            .map_err(|e| TrackError::Output(format!("cannot write {}: {e}", cloud.display())))?;
        let surface = hull.occupancy.surface();
        let mesh = dir.join(format!("{frame:06}.surface.ply"));
        surface
            .write_ply(&mesh, encoding)
            .map_err(|e| TrackError::Output(format!("cannot write {}: {e}", mesh.display())))?;
        record.surface_mm2 = surface.area_mm2;
    }
    Ok(record)
}

impl Hull {
    /// This hull's line of `hull.jsonl` (frame `frame`, named `name`).
    pub fn record(&self, frame: u64, name: Option<String>) -> HullRecord {
        let hull = self;
        let occ = &hull.occupancy;
        let (status, reason) = match (&hull.implausible, occ.is_empty()) {
            (Some(r), _) => (RecordStatus::BadSilhouette, Some(r.clone())),
            (None, true) => (
                RecordStatus::NoObject,
                Some("nothing is left after carving: the object is outside the volume or missing from a camera's silhouette".into()),
            ),
            (None, false) => (RecordStatus::Ok, None),
        };
        let bounds = (!occ.is_empty()).then(|| {
            let v = &occ.volume;
            let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
            for &i in &occ.voxels {
                let ijk = occ.ijk(i);
                for a in 0..3 {
                    lo[a] = lo[a].min(v.origin[a] + ijk[a] as f64 * v.voxel_size[a]);
                    hi[a] = hi[a].max(v.origin[a] + (ijk[a] + 1) as f64 * v.voxel_size[a]);
                }
            }
            [lo, hi]
        });
        HullRecord {
            frame,
            name,
            status,
            reason,
            voxels: occ.len(),
            volume_mm3: occ.volume_mm3(),
            surface_mm2: 0.0,
            bounds,
            silhouette_pixels: hull.silhouettes.iter().map(|s| s.object.count()).collect(),
            silhouettes_ms: hull.timings.silhouettes,
            carve_ms: hull.timings.carve,
            captured_s: None,
            captured_from: None,
        }
    }
}
