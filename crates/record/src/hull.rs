//! A line of `hull.jsonl`, what `flexshape carve` writes per frame of the visual hull alone
//! (`docs/formats.md`).

use serde::{Deserialize, Serialize};

use crate::{CapturedFrom, RecordStatus};

/// One frame's line of `hull.jsonl` (`docs/formats.md`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct HullRecord {
    /// Frame number.
    pub frame: u64,
    #[serde(skip_serializing_if = "Option::is_none")]
    /// The frame's name, when its input has one.
    pub name: Option<String>,
    /// `ok`, `no_object`, `bad_silhouette` or `error` (as `track`'s records write them).
    pub status: RecordStatus,
    #[serde(skip_serializing_if = "Option::is_none")]
    /// Why, when not `ok`.
    pub reason: Option<String>,
    /// Occupied voxels.
    pub voxels: usize,
    /// Their volume, mm³.
    pub volume_mm3: f64,
    /// The watertight hull surface's area, mm² (0 unless `ok`; see
    /// `flexshape_carve::Occupancy::surface`).
    pub surface_mm2: f64,
    /// Smallest and largest corner of the occupied voxels' box, world mm.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub bounds: Option<[[f64; 3]; 2]>,
    /// Object pixels per camera, in the rig's order.
    pub silhouette_pixels: Vec<usize>,
    /// Time of the silhouette stage, ms.
    pub silhouettes_ms: f64,
    /// Time of the carving stage, ms.
    pub carve_ms: f64,
    /// When the frame was captured, seconds, and where that comes from, as in `track`'s
    /// records (`captured_s`, `captured_from`; additive; absent when the input does not say).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub captured_s: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    /// Where `captured_s` comes from (`timestamps`, `file_time`, `stream`, `clock`).
    pub captured_from: Option<CapturedFrom>,
}

impl HullRecord {
    /// The record of a frame that could not be carved, and why.
    pub fn error(frame: u64, name: Option<String>, reason: String) -> Self {
        HullRecord {
            frame,
            name,
            status: RecordStatus::Error,
            reason: Some(reason),
            voxels: 0,
            volume_mm3: 0.0,
            surface_mm2: 0.0,
            bounds: None,
            silhouette_pixels: Vec::new(),
            silhouettes_ms: 0.0,
            carve_ms: 0.0,
            captured_s: None,
            captured_from: None,
        }
    }
}
