//! The visual hull of every frame, for objects that are not tubes (`flexshape carve`):
//! silhouettes and carving only, each carved frame written as a PLY cloud of its voxel centres
//! (`NNNNNN.ply`) and a PLY surface (`NNNNNN.surface.ply`), and every frame as one line of
//! `hull.jsonl` ([`HullRecord`], `docs/formats.md`), flushed as it is written.

use std::io::Write;
use std::path::Path;
use std::sync::atomic::{AtomicBool, Ordering};

use flexshape_carve::PlyEncoding;
use flexshape_input::{FrameSet, FrameSource};
use flexshape_record::{HullRecord, RecordStatus};
use flexshape_track::{Pipeline, captured_from};

use crate::LabError;

/// What [`carve_all`] did.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Carved {
    /// Frames read (each has its line in `hull.jsonl`).
    pub frames: usize,
    /// Frames whose hull was carved (`ok`).
    pub carved: usize,
    /// Frames that could not be read or carved (`error`).
    pub failed: usize,
    /// Whether `stop` ended the run before the input did.
    pub stopped: bool,
}

/// Carves every frame of `source` with `pipeline` into `dir` (which must exist): the files of
/// each carved frame and its line of `dir/hull.jsonl` (created new), `each` shown every record
/// as it is written. Ends when the input does, breaks (an error naming how many frames were
/// done) or `stop` is set; fails when a file cannot be written.
pub fn carve_all(
    source: &mut dyn FrameSource,
    pipeline: &Pipeline,
    dir: &Path,
    encoding: PlyEncoding,
    stop: &AtomicBool,
    mut each: impl FnMut(&HullRecord),
) -> Result<Carved, LabError> {
    let records = dir.join("hull.jsonl");
    let mut out = std::fs::File::create(&records).map_err(|e| written(&records, e))?;
    let mut done = Carved::default();
    while let Some(next) = source.next_frame() {
        if stop.load(Ordering::Relaxed) {
            done.stopped = true;
            break;
        }
        let record = match next {
            Ok(set) => carve_frame(pipeline, set, dir, encoding)?,
            Err(e) if e.ends_input() => {
                return Err(LabError::data(
                    "the input",
                    format!("it broke after {} frames: {e}", done.frames),
                ));
            }
            Err(e) => HullRecord::error(done.frames as u64, None, e.to_string()),
        };
        done.carved += usize::from(record.status.is_ok());
        done.failed += usize::from(record.status == RecordStatus::Error);
        // A record holds plain numbers and strings: it always encodes.
        let line = serde_json::to_string(&record).unwrap_or_default();
        writeln!(out, "{line}")
            .and_then(|_| out.flush())
            .map_err(|e| written(&records, e))?;
        each(&record);
        done.frames += 1;
    }
    Ok(done)
}

/// One frame's visual hull for any object: its voxel centres (`NNNNNN.ply`) and surface
/// (`NNNNNN.surface.ply`) written to `dir` when carved; a frame that cannot be read or carved
/// is an `error` record. Fails only when a file cannot be written.
pub fn carve_frame(
    pipeline: &Pipeline,
    set: FrameSet,
    dir: &Path,
    encoding: PlyEncoding,
) -> Result<HullRecord, LabError> {
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
            .map_err(|e| written(&cloud, e))?;
        let surface = hull.occupancy.surface();
        let mesh = dir.join(format!("{frame:06}.surface.ply"));
        surface
            .write_ply(&mesh, encoding)
            .map_err(|e| written(&mesh, e))?;
        record.surface_mm2 = surface.area_mm2;
    }
    Ok(record)
}

/// A file that could not be written.
fn written(path: &Path, e: impl std::fmt::Display) -> LabError {
    LabError::Write {
        path: path.to_path_buf(),
        reason: e.to_string(),
    }
}
