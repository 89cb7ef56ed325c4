//! A frame's visual hull alone as its line of `flexshape carve`'s `hull.jsonl` ([`HullRecord`],
//! `docs/formats.md`).

use flexshape_record::{HullRecord, RecordStatus};

use crate::Hull;

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
