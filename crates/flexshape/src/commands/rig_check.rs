//! `flexshape rig check`: validate a rig and show what each camera sees of the volume.

use anyhow::Context;
use flexshape_camera::Camera;
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
    let why = if given {
        " (--volume / --voxel)"
    } else if path.is_dir() {
        " (default volume: a folder has none)"
    } else {
        ""
    };
    println!(
        "{}: {} cameras; {}{why}",
        path.display(),
        rig.cameras.len(),
        describe_volume(&rig.volume)
    );
    let v = &rig.volume;
    let corners = v.corners();
    let centre = Point3::from((Point3::from(v.origin).coords + v.max_corner().coords) / 2.0);
    let mut all_ok = true;
    let mut blind = Vec::new();
    for c in &rig.cameras {
        let view = camera_view(&c.camera, &corners, &centre);
        println!("  {:<8} {}", c.name, view.line);
        all_ok &= view.corners_seen == 8;
        if view.corners_seen == 0 && !view.centre_seen {
            blind.push(c.name.clone());
        }
    }
    for line in pair_lines(&rig) {
        println!("  {line}");
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

/// `volume N×N×N voxels of S mm from (…) to (…) mm`.
fn describe_volume(v: &Volume) -> String {
    let hi = v.max_corner();
    let size = if v.voxel_size.iter().all(|&s| s == v.voxel_size[0]) {
        short(v.voxel_size[0])
    } else {
        v.voxel_size.map(short).join(" × ")
    };
    format!(
        "volume {}×{}×{} voxels of {size} mm from ({}, {}, {}) to ({}, {}, {}) mm",
        v.dims[0],
        v.dims[1],
        v.dims[2],
        short(v.origin[0]),
        short(v.origin[1]),
        short(v.origin[2]),
        short(hi.x),
        short(hi.y),
        short(hi.z),
    )
}

/// What one camera sees of the volume.
struct CameraView {
    /// Its line of the report (without the name).
    line: String,
    corners_seen: usize,
    centre_seen: bool,
}

fn camera_view(cam: &Camera, corners: &[Point3<f64>], centre: &Point3<f64>) -> CameraView {
    let k = &cam.intrinsics;
    let corners_seen = corners
        .iter()
        .filter(|p| cam.project(p).is_ok_and(|q| k.contains(q.pixel)))
        .count();
    let centre_px = cam.project(centre).ok().filter(|p| k.contains(p.pixel));
    let o = cam.centre();
    let a = cam.pose.optical_axis();
    let line = format!(
        "{}×{}  fx {:.1} fy {:.1}  centre ({:.1}, {:.1}, {:.1}) mm  axis ({:.3}, {:.3}, {:.3})  volume corners in view {corners_seen}/8  volume centre {}",
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
        match &centre_px {
            Some(p) => format!(
                "at pixel ({:.0}, {:.0}), depth {:.0} mm",
                p.pixel.x, p.pixel.y, p.depth
            ),
            None => "NOT IN VIEW".into(),
        }
    );
    CameraView {
        line,
        corners_seen,
        centre_seen: centre_px.is_some(),
    }
}

/// The angles between camera axes: each pair for a few cameras, the narrowest and widest
/// beyond.
fn pair_lines(rig: &flexshape_rig::Rig) -> Vec<String> {
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
        return pairs
            .iter()
            .map(|(angle, a, b)| format!("angle between {a} and {b} axes: {angle:.1}°"))
            .collect();
    }
    pairs.sort_by(|x, y| x.0.total_cmp(&y.0));
    let narrow = pairs.iter().filter(|p| p.0 < NARROW_DEG).count();
    let name = |p: &(f64, &String, &String)| format!("{} and {} {:.1}°", p.1, p.2, p.0);
    vec![format!(
        "angles between camera axes, {} pairs: narrowest {}, widest {}; {narrow} pair{} under {NARROW_DEG:.0}°",
        pairs.len(),
        pairs.first().map(name).unwrap_or_default(),
        pairs.last().map(name).unwrap_or_default(),
        if narrow == 1 { "" } else { "s" }
    )]
}
