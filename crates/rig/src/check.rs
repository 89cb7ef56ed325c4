//! A rig looked at as a whole (`flexshape rig check`): what each camera sees of the volume,
//! the angles between their axes, and the box they all see.

use std::fmt::{self, Write as _};

use flexshape_camera::Camera;
use flexshape_camera::nalgebra::Point3;

use crate::{Rig, Volume, coverage};

/// Pair angles are listed one by one up to this many cameras, summarised beyond.
const LISTED_CAMERAS: usize = 4;

/// Camera pairs whose axes are closer than this see the volume from nearly the same side,
/// degrees: together they pin down little that one of them does not.
const NARROW_DEG: f64 = 15.0;

/// A number for people: at most three decimals, no trailing zeros (`0.30000000000000004` →
/// `0.3`, `-128` → `-128`).
pub fn short(x: f64) -> String {
    let s = format!("{x:.3}");
    let s = s.trim_end_matches('0').trim_end_matches('.');
    if s == "-0" { "0".into() } else { s.into() }
}

/// A number as a message quotes a value someone wrote: as Rust writes it for magnitudes from
/// 10⁻⁴ up to 10⁷ (and 0, NaN, ∞), in scientific notation beyond (`1e300`, not 301 digits;
/// `1e-300`, not 300 zeros).
pub fn quoted<T>(x: T) -> String
where
    T: Into<f64> + Copy + std::fmt::Display + std::fmt::LowerExp,
{
    let a = x.into().abs();
    if a == 0.0 || !a.is_finite() || (1e-4..1e7).contains(&a) {
        format!("{x}")
    } else {
        format!("{x:e}")
    }
}

impl Volume {
    /// `volume N×N×N voxels of S mm from (…) to (…) mm`.
    pub fn describe(&self) -> String {
        let hi = self.max_corner();
        let size = if self.voxel_size.iter().all(|&s| s == self.voxel_size[0]) {
            short(self.voxel_size[0])
        } else {
            self.voxel_size.map(short).join(" × ")
        };
        format!(
            "volume {}×{}×{} voxels of {size} mm from ({}, {}, {}) to ({}, {}, {}) mm",
            self.dims[0],
            self.dims[1],
            self.dims[2],
            short(self.origin[0]),
            short(self.origin[1]),
            short(self.origin[2]),
            short(hi.x),
            short(hi.y),
            short(hi.z),
        )
    }

    /// The command-line options that give this volume, e.g.
    /// `--volume -60,-60,-60,60,60,60 --voxel 1` (whole millimetres).
    pub fn as_options(&self) -> String {
        let hi = self.max_corner();
        format!(
            "--volume {:.0},{:.0},{:.0},{:.0},{:.0},{:.0} --voxel {}",
            self.origin[0],
            self.origin[1],
            self.origin[2],
            hi.x,
            hi.y,
            hi.z,
            short(self.voxel_size[0])
        )
    }
}

/// What one camera sees of the volume.
#[derive(Debug, Clone, PartialEq)]
pub struct CameraView {
    /// The camera's name.
    pub name: String,
    /// Its line of the report (without the name).
    pub line: String,
    /// Volume corners inside its image (of 8).
    pub corners_seen: usize,
    /// The volume's centre is inside its image.
    pub centre_seen: bool,
}

/// The rig against its volume; printing it gives the report.
#[derive(Debug, Clone, PartialEq)]
pub struct RigCheck {
    /// The rig's volume.
    pub volume: Volume,
    /// Per camera, in the rig's order.
    pub cameras: Vec<CameraView>,
    /// The angles between camera axes: each pair for a few cameras, the narrowest and widest
    /// beyond.
    pub pairs: Vec<String>,
    /// The box every camera sees whole ([`coverage::suggest_volume`]) at the volume's voxel
    /// size, if any.
    pub common: Option<Volume>,
}

impl RigCheck {
    /// Looks at `rig`.
    pub fn of(rig: &Rig) -> Self {
        let v = &rig.volume;
        let corners = v.corners();
        let centre = Point3::from((Point3::from(v.origin).coords + v.max_corner().coords) / 2.0);
        let cameras: Vec<Camera> = rig.cameras.iter().map(|c| c.camera.clone()).collect();
        RigCheck {
            volume: *v,
            cameras: rig
                .cameras
                .iter()
                .map(|c| {
                    let mut view = camera_view(&c.name, &c.camera, &corners, &centre);
                    if let Some(o) = &c.occluded {
                        view.line.push_str(&occlusion_note(o, &c.camera, &centre));
                    }
                    view
                })
                .collect(),
            pairs: pair_lines(rig),
            common: coverage::suggest_volume(&cameras, v.voxel_size[0]),
        }
    }

    /// Cameras that see none of the volume (no corner, not its centre).
    pub fn blind(&self) -> Vec<&str> {
        self.cameras
            .iter()
            .filter(|c| c.corners_seen == 0 && !c.centre_seen)
            .map(|c| c.name.as_str())
            .collect()
    }
}

/// A line per camera, the pair angles, a note when some camera misses part of the volume,
/// and the box they all see.
impl fmt::Display for RigCheck {
    fn fmt(&self, f: &mut fmt::Formatter) -> fmt::Result {
        for c in &self.cameras {
            writeln!(f, "  {:<8} {}", c.name, c.line)?;
        }
        for line in &self.pairs {
            writeln!(f, "  {line}")?;
        }
        if self.cameras.iter().any(|c| c.corners_seen < 8) {
            writeln!(
                f,
                "  note: some cameras do not see the whole volume; parts of the volume outside a camera's view are not constrained by it"
            )?;
        }
        match &self.common {
            Some(s) => writeln!(f, "  every camera sees the box {}", s.as_options()),
            None => writeln!(
                f,
                "  the cameras see no box in common around where their axes meet"
            ),
        }
    }
}

fn camera_view(
    name: &str,
    cam: &Camera,
    corners: &[Point3<f64>],
    centre: &Point3<f64>,
) -> CameraView {
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
        name: name.to_string(),
        line,
        corners_seen,
        centre_seen: centre_px.is_some(),
    }
}

/// What a camera's occlusion mask hides: its share of the image and its file, and whether the
/// volume's centre is behind it.
fn occlusion_note(o: &crate::Occluded, cam: &Camera, centre: &Point3<f64>) -> String {
    let share = 100.0 * o.share();
    let centre_hidden = cam
        .project(centre)
        .ok()
        .filter(|p| p.pixel.x >= -0.5 && p.pixel.y >= -0.5)
        .is_some_and(|p| o.hides((p.pixel.x + 0.5) as u32, (p.pixel.y + 0.5) as u32));
    format!(
        "  occluded {share:.1} % of the image ({}){}",
        o.file.display(),
        if centre_hidden {
            ", the volume centre among it"
        } else {
            ""
        }
    )
}

fn pair_lines(rig: &Rig) -> Vec<String> {
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

impl Rig {
    /// A line per camera (size, focal length, centre), the volume, and how far apart the
    /// cameras are (to see at a glance whether an imported unit was right).
    pub fn summary(&self) -> String {
        let rig = self;
        let mut out = String::new();
        for c in &rig.cameras {
            let i = &c.camera.intrinsics;
            let o = c.camera.centre();
            let _ = writeln!(
                out,
                "  {:<12} {}×{}  fx {:.1} fy {:.1}  centre ({:.1}, {:.1}, {:.1}) mm",
                c.name, i.width, i.height, i.fx, i.fy, o.x, o.y, o.z
            );
        }
        let v = &rig.volume;
        let hi = v.max_corner();
        let _ = writeln!(
            out,
            "  volume ({:.1}, {:.1}, {:.1}) to ({:.1}, {:.1}, {:.1}) mm, voxels of {} mm",
            v.origin[0], v.origin[1], v.origin[2], hi.x, hi.y, hi.z, v.voxel_size[0]
        );
        let centres: Vec<_> = rig.cameras.iter().map(|c| c.camera.centre()).collect();
        let mut gaps = Vec::new();
        for a in 0..centres.len() {
            for b in a + 1..centres.len() {
                gaps.push((centres[a] - centres[b]).norm());
            }
        }
        if !gaps.is_empty() {
            let (lo, hi) = gaps
                .iter()
                .fold((f64::INFINITY, 0.0f64), |(l, h), &g| (l.min(g), h.max(g)));
            let _ = writeln!(
                out,
                "  cameras {lo:.1}–{hi:.1} mm apart (if that is off by 10× or 1000×, give --unit)"
            );
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::{quoted, short};

    #[test]
    fn quoted_numbers_are_short_at_any_size() {
        assert_eq!(quoted(0.5), "0.5");
        assert_eq!(quoted(-128.0), "-128");
        assert_eq!(quoted(157.5), "157.5");
        assert_eq!(quoted(0.0), "0");
        assert_eq!(quoted(1e300), "1e300");
        assert_eq!(quoted(-1e-300), "-1e-300");
        assert_eq!(quoted(12_345_678.0), "1.2345678e7");
        assert_eq!(quoted(f64::NAN), "NaN");
        assert_eq!(quoted(f64::INFINITY), "inf");
        // A 32-bit setting as it was written, not widened.
        assert_eq!(quoted(1e30f32), "1e30");
        assert_eq!(quoted(40.5f32), "40.5");
    }

    #[test]
    fn short_numbers_drop_trailing_zeros() {
        assert_eq!(short(0.1 + 0.2), "0.3");
        assert_eq!(short(-128.0), "-128");
        assert_eq!(short(-0.0001), "0");
        assert_eq!(short(2.5), "2.5");
    }
}
