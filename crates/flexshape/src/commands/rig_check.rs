//! `flexshape rig check`: validate a rig and show what each camera sees of the volume.

use std::path::Path;

use anyhow::Context;
use flexshape_camera::nalgebra::Point3;

pub fn run(path: &Path) -> anyhow::Result<()> {
    let rig = super::load_rig(path)?;
    flexshape_track::Pipeline::check_settings(&rig)
        .with_context(|| format!("{}: invalid [processing] settings", path.display()))?;
    let v = &rig.volume;
    let hi = v.max_corner();
    println!(
        "{}: {} cameras; volume {}×{}×{} voxels of {:?} mm from ({}, {}, {}) to ({}, {}, {}) mm{}",
        path.display(),
        rig.cameras.len(),
        v.dims[0],
        v.dims[1],
        v.dims[2],
        v.voxel_size,
        v.origin[0],
        v.origin[1],
        v.origin[2],
        hi.x,
        hi.y,
        hi.z,
        if path.is_dir() {
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
    for (i, a) in rig.cameras.iter().enumerate() {
        for b in &rig.cameras[i + 1..] {
            let angle = a
                .camera
                .pose
                .optical_axis()
                .angle(&b.camera.pose.optical_axis())
                .to_degrees();
            println!(
                "  angle between {} and {} axes: {angle:.1}°",
                a.name, b.name
            );
        }
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
