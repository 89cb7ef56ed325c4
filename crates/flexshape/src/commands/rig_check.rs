//! `flexshape rig check`: validate a rig and show what each camera sees of the volume.

use anyhow::Context;
use flexshape_camera::nalgebra::Point3;
use flexshape_rig::Volume;

use super::short;
use crate::cli::RigCheckArgs;

/// Pair angles are listed one by one up to this many cameras, summarised beyond.
const LISTED_CAMERAS: usize = 4;

/// Camera pairs whose axes are closer than this see the volume from nearly the same side,
/// degrees: together they pin down little that one of them does not.
const NARROW_DEG: f64 = 15.0;

pub fn run(args: &RigCheckArgs) -> anyhow::Result<()> {
    let path = args.path.as_path();
    let mut rig = super::load_rig(path)?;
    flexshape_track::Pipeline::check_settings(&rig)
        .with_context(|| format!("{}: invalid [processing] settings", path.display()))?;
    let given = args.volume.is_some() || args.voxel.is_some();
    if given {
        let (lo, hi) = match args.volume {
            Some(b) => ([b[0], b[1], b[2]], [b[3], b[4], b[5]]),
            None => (rig.volume.origin, rig.volume.max_corner().into()),
        };
        let voxel = args.voxel.unwrap_or(rig.volume.voxel_size[0]);
        rig.volume = Volume::from_bounds(lo, hi, voxel).context("invalid --volume / --voxel")?;
    }
    let v = &rig.volume;
    let hi = v.max_corner();
    let size = if v.voxel_size.iter().all(|&s| s == v.voxel_size[0]) {
        short(v.voxel_size[0])
    } else {
        v.voxel_size.map(short).join(" × ")
    };
    println!(
        "{}: {} cameras; volume {}×{}×{} voxels of {size} mm from ({}, {}, {}) to ({}, {}, {}) mm{}",
        path.display(),
        rig.cameras.len(),
        v.dims[0],
        v.dims[1],
        v.dims[2],
        short(v.origin[0]),
        short(v.origin[1]),
        short(v.origin[2]),
        short(hi.x),
        short(hi.y),
        short(hi.z),
        if given {
            " (--volume / --voxel)"
        } else if path.is_dir() {
            " (default volume: a folder has none)"
        } else {
            ""
        }
    );
    let corners = v.corners();
    let centre = Point3::from((Point3::from(v.origin).coords + hi.coords) / 2.0);
    let mut all_ok = true;
    let mut blind = Vec::new();
    for c in &rig.cameras {
        let cam = &c.camera;
        let k = &cam.intrinsics;
        let seen = corners
            .iter()
            .filter(|p| cam.project(p).is_ok_and(|q| k.contains(q.pixel)))
            .count();
        let centre_px = cam.project(&centre);
        let o = cam.centre();
        let a = cam.pose.optical_axis();
        println!(
            "  {:<8} {}×{}  fx {:.1} fy {:.1}  centre ({:.1}, {:.1}, {:.1}) mm  axis ({:.3}, {:.3}, {:.3})  volume corners in view {seen}/8  volume centre {}",
            c.name,
            k.width,
            k.height,
            k.fx,
            k.fy,
            o.x,
            o.y,
            o.z,
            a.x,
            a.y,
            a.z,
            match centre_px {
                Ok(p) if k.contains(p.pixel) => format!(
                    "at pixel ({:.0}, {:.0}), depth {:.0} mm",
                    p.pixel.x, p.pixel.y, p.depth
                ),
                _ => "NOT IN VIEW".into(),
            }
        );
        all_ok &= seen == 8;
        if seen == 0 && !centre_px.is_ok_and(|p| k.contains(p.pixel)) {
            blind.push(c.name.clone());
        }
    }
    let mut pairs = Vec::new();
    for (i, a) in rig.cameras.iter().enumerate() {
        for b in &rig.cameras[i + 1..] {
            let angle = a
                .camera
                .pose
                .optical_axis()
                .angle(&b.camera.pose.optical_axis())
                .to_degrees();
            pairs.push((angle, &a.name, &b.name));
        }
    }
    if rig.cameras.len() <= LISTED_CAMERAS {
        for (angle, a, b) in &pairs {
            println!("  angle between {a} and {b} axes: {angle:.1}°");
        }
    } else {
        pairs.sort_by(|x, y| x.0.total_cmp(&y.0));
        let narrow = pairs.iter().filter(|p| p.0 < NARROW_DEG).count();
        let name = |p: &(f64, &String, &String)| format!("{} and {} {:.1}°", p.1, p.2, p.0);
        println!(
            "  angles between camera axes, {} pairs: narrowest {}, widest {}; {narrow} pair{} under {NARROW_DEG:.0}°",
            pairs.len(),
            pairs.first().map(name).unwrap_or_default(),
            pairs.last().map(name).unwrap_or_default(),
            if narrow == 1 { "" } else { "s" }
        );
    }
    if !all_ok {
        println!(
            "  note: some cameras do not see the whole volume; parts of the volume outside a camera's view are not constrained by it"
        );
    }
    let cameras: Vec<_> = rig.cameras.iter().map(|c| c.camera.clone()).collect();
    match super::suggested_volume(&cameras, v.voxel_size[0]) {
        Some(s) => println!("  every camera sees the box {s}"),
        None => println!("  the cameras see no box in common around where their axes meet"),
    }
    if !blind.is_empty() {
        anyhow::bail!(
            "{}: camera{} {} see{} none of the volume (no corner, not its centre): the calibration or the volume is wrong",
            path.display(),
            if blind.len() > 1 { "s" } else { "" },
            blind.join(", "),
            if blind.len() > 1 { "" } else { "s" }
        );
    }
    Ok(())
}
