//! `flexshape carve`: the visual hull of every frame, for objects that are not tubes —
//! silhouettes and carving only, written as a PLY cloud and a PLY surface per frame and one
//! JSON record per frame in `hull.jsonl`.

use std::io::Write;
use std::path::Path;

use anyhow::{Context, bail};
use flexshape_carve::PlyEncoding;
use flexshape_input::FrameSet;
use flexshape_track::{Hull, Pipeline};
use serde::Serialize;

use super::frames;
use crate::cli::CarveArgs;
use crate::interrupt::Interrupt;

/// One frame's line of `hull.jsonl` (`docs/formats.md`).
#[derive(Debug, Serialize)]
struct HullRecord {
    frame: u64,
    #[serde(skip_serializing_if = "Option::is_none")]
    name: Option<String>,
    /// `ok`, `no_object`, `bad_silhouette` or `error`.
    status: &'static str,
    #[serde(skip_serializing_if = "Option::is_none")]
    reason: Option<String>,
    voxels: usize,
    volume_mm3: f64,
    surface_mm2: f64,
    /// Smallest and largest corner of the occupied voxels' box, world mm.
    #[serde(skip_serializing_if = "Option::is_none")]
    bounds: Option<[[f64; 3]; 2]>,
    /// Object pixels per camera, in the rig's order.
    silhouette_pixels: Vec<usize>,
    silhouettes_ms: f64,
    carve_ms: f64,
}

pub fn run(args: &CarveArgs) -> anyhow::Result<()> {
    let stop = Interrupt::install();
    let mut input = frames::open_input(&args.frames)?;
    let volume = frames::volume(&input.rig.volume, &args.frames)?;
    frames::warn_unseen(&input.rig, &volume);
    if input.files.iter().any(|f| frames::within(&args.out, f)) {
        bail!(
            "{} is or lies inside an input: write the output elsewhere",
            args.out.display()
        );
    }
    let pipeline = input
        .pipeline(&volume)
        .with_context(|| format!("cannot set up carving for {}", input.rig_name))?;
    let records = args.out.join("hull.jsonl");
    if records.exists() && !args.overwrite {
        bail!(
            "{} already exists: give --overwrite to replace it, or another --out",
            records.display()
        );
    }
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("cannot create {}", args.out.display()))?;
    let mut out = std::fs::File::create(&records)
        .with_context(|| format!("cannot create {}", records.display()))?;
    let (mut frames_done, mut carved) = (0usize, 0usize);
    while let Some(next) = input.source.next_frame() {
        if stop.requested() {
            break;
        }
        let record = match next {
            Ok(set) => carve_frame(
                &pipeline,
                set,
                &args.out,
                super::ply_encoding(args.ascii_ply),
            )?,
            Err(e) if e.ends_input() => bail!("the input broke after {frames_done} frames: {e}"),
            Err(e) => HullRecord::error(frames_done as u64, None, e.to_string()),
        };
        if record.status == "error" {
            eprintln!(
                "frame {:06}: {}",
                record.frame,
                record.reason.as_deref().unwrap_or("")
            );
        }
        carved += usize::from(record.status == "ok");
        let line = serde_json::to_string(&record).context("cannot encode a record")?;
        writeln!(out, "{line}")
            .and_then(|_| out.flush())
            .with_context(|| format!("cannot write {}", records.display()))?;
        frames_done += 1;
    }
    eprintln!(
        "{frames_done} frames ({carved} carved) into {}: NNNNNN.ply (voxel centres), NNNNNN.surface.ply (hull surface), hull.jsonl",
        args.out.display()
    );
    Ok(())
}

/// One frame's hull, its files written; a frame that cannot be read or carved is an `error`
/// record.
fn carve_frame(
    pipeline: &Pipeline,
    set: FrameSet,
    dir: &Path,
    encoding: PlyEncoding,
) -> anyhow::Result<HullRecord> {
    let (frame, name) = (set.frame, set.name.clone());
    let images = match pipeline.load(set.images) {
        Ok((i, _)) => i,
        Err(e) => return Ok(HullRecord::error(frame, name, e)),
    };
    let refs: Vec<_> = images.iter().collect();
    let hull = match pipeline.hull(&refs) {
        Ok(h) => h,
        Err(e) => return Ok(HullRecord::error(frame, name, e.to_string())),
    };
    let mut record = HullRecord::of(frame, name, &hull);
    if record.status == "ok" {
        let cloud = dir.join(format!("{frame:06}.ply"));
        hull.occupancy
            .to_cloud()
            .write_ply(&cloud, encoding)
            .with_context(|| format!("cannot write {}", cloud.display()))?;
        let surface = hull.occupancy.surface();
        let mesh = dir.join(format!("{frame:06}.surface.ply"));
        surface
            .write_ply(&mesh, encoding)
            .with_context(|| format!("cannot write {}", mesh.display()))?;
        record.surface_mm2 = surface.area_mm2;
    }
    Ok(record)
}

impl HullRecord {
    fn of(frame: u64, name: Option<String>, hull: &Hull) -> Self {
        let occ = &hull.occupancy;
        let (status, reason) = match (&hull.implausible, occ.is_empty()) {
            (Some(r), _) => ("bad_silhouette", Some(r.clone())),
            (None, true) => (
                "no_object",
                Some("nothing is left after carving: the object is outside the volume or missing from a camera's silhouette".into()),
            ),
            (None, false) => ("ok", None),
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
        }
    }

    fn error(frame: u64, name: Option<String>, reason: String) -> Self {
        HullRecord {
            frame,
            name,
            status: "error",
            reason: Some(reason),
            voxels: 0,
            volume_mm3: 0.0,
            surface_mm2: 0.0,
            bounds: None,
            silhouette_pixels: Vec::new(),
            silhouettes_ms: 0.0,
            carve_ms: 0.0,
        }
    }
}
