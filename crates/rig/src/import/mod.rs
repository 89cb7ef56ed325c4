//! Cameras from other tools' calibration files, and back: the forms labs exchange
//! calibrations in, turned into flexshape's rig (OpenCV camera files and `rig.toml`).
//!
//! - [`projection`]: 3×4 projection matrices `P = K·[R | t]` (text, KITTI-style `NAME: …`
//!   lines, or NumPy `.npy`), decomposed by RQ.
//! - [`camera_info`]: ROS `sensor_msgs/CameraInfo` YAML (`camera_calibration`'s files), with
//!   a stereo pair's rectification and projection giving the poses; also written.
//! - [`kalibr`]: Kalibr's `camchain.yaml` (pinhole, radtan), chained `T_cn_cnm1`.
//! - [`colmap`]: a COLMAP text model (`cameras.txt`, `images.txt`); also written.
//! - [`opencv_stereo`]: `cv2.stereoCalibrate`'s `K1, D1, K2, D2, R, T` in a FileStorage file
//!   or a NumPy `.npz`.
//! - Middlebury `*_par.txt`: [`crate::middlebury`].
//!
//! Every reader names the file and field of a problem. Lengths come in the file's unit
//! ([`Unit`]); flexshape's are millimetres.

pub mod camera_info;
pub mod colmap;
pub mod kalibr;
mod npy;
pub mod opencv_stereo;
pub mod projection;

use std::path::{Path, PathBuf};
use std::str::FromStr;

use flexshape_camera::Camera;

use crate::{Rig, RigCamera, RigError, Volume};

/// A camera read from another tool's files.
#[derive(Debug, Clone, PartialEq)]
pub struct Imported {
    /// Its name in the rig (letters, digits, `_` and `-`; see [`sanitize`]).
    pub name: String,
    /// The camera, world frame and lengths in millimetres.
    pub camera: Camera,
}

/// The length unit of a file's translations.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Unit {
    /// Millimetres.
    Millimetre,
    /// Centimetres.
    Centimetre,
    /// Metres.
    Metre,
}

impl Unit {
    /// Millimetres per unit.
    pub fn mm(self) -> f64 {
        match self {
            Unit::Millimetre => 1.0,
            Unit::Centimetre => 10.0,
            Unit::Metre => 1000.0,
        }
    }
}

impl FromStr for Unit {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s {
            "mm" => Ok(Unit::Millimetre),
            "cm" => Ok(Unit::Centimetre),
            "m" => Ok(Unit::Metre),
            _ => Err(format!("`{s}` is not a length unit: give mm, cm or m")),
        }
    }
}

/// A name usable in a rig (and as a file name): letters, digits, `_` and `-` kept, anything
/// else (dots, spaces, slashes) made `_`; an empty name becomes `cam`.
pub fn sanitize(name: &str) -> String {
    let s: String = name
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '_' || c == '-' {
                c
            } else {
                '_'
            }
        })
        .collect();
    if s.is_empty() { "cam".into() } else { s }
}

/// The rig of imported cameras carving `volume`, each camera's file `NAME.yml` beside the rig
/// file (write it with [`Rig::save`]). Two cameras of one name are refused (`source` names
/// the input in the error).
pub fn rig_of(cameras: Vec<Imported>, volume: Volume, source: &Path) -> Result<Rig, RigError> {
    if cameras.is_empty() {
        return Err(RigError::field(source, "cameras", "no camera found"));
    }
    for (i, c) in cameras.iter().enumerate() {
        if cameras[..i].iter().any(|o| o.name == c.name) {
            return Err(RigError::field(
                source,
                "cameras",
                format!("two cameras are named `{}`", c.name),
            ));
        }
        // What the rig's loader would refuse of the file written for it (a principal point
        // outside the image, an implausible focal length or size), refused here, before a
        // rig that cannot be loaded is written.
        let file = PathBuf::from(format!("{}.yml", c.name));
        let text = crate::camera_file::to_yaml(&c.camera.intrinsics, Some(&c.camera.pose));
        if let Err(e) = crate::camera_file::parse(&text, false, &file) {
            return Err(RigError::field(
                source,
                "cameras",
                format!("camera `{}` as imported would not load: {e}", c.name),
            ));
        }
    }
    Ok(Rig {
        cameras: cameras
            .into_iter()
            .map(|c| RigCamera {
                file: PathBuf::from(format!("{}.yml", c.name)),
                name: c.name,
                camera: c.camera,
                occluded: None,
            })
            .collect(),
        volume,
        processing: Default::default(),
        refined: None,
    })
}

/// A calibration format another tool writes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Format {
    /// 3×4 projection matrices ([`projection`]); one or more files.
    Projection,
    /// Middlebury `*_par.txt` ([`crate::middlebury`]); one file.
    Middlebury,
    /// ROS CameraInfo YAML ([`camera_info`]); one file per camera.
    CameraInfo,
    /// Kalibr camchain YAML ([`kalibr`]); one file.
    Kalibr,
    /// COLMAP text model ([`colmap`]); its folder.
    Colmap,
    /// OpenCV stereo calibration ([`opencv_stereo`]); one file.
    OpencvStereo,
}

impl Format {
    /// The unit the format's files use when they follow its convention (`None`: the files
    /// do not say, so it must be given).
    pub fn default_unit(self) -> Option<Unit> {
        match self {
            Format::Projection | Format::Colmap | Format::OpencvStereo => None,
            Format::Middlebury | Format::CameraInfo | Format::Kalibr => Some(Unit::Metre),
        }
    }

    /// Whether its files hold the image size.
    pub fn has_size(self) -> bool {
        matches!(self, Format::CameraInfo | Format::Kalibr | Format::Colmap)
    }
}

/// How to read a format's files.
#[derive(Debug, Clone, Copy, Default)]
pub struct ImportOptions {
    /// Length unit of the files (default: the format's, see [`Format::default_unit`]).
    pub unit: Option<Unit>,
    /// Image size (width, height) for formats that lack it. Middlebury without it takes each
    /// view's image size from its image beside the file.
    pub size: Option<(u32, u32)>,
}

/// What an import read: the cameras, and notes for the user (what was skipped or assumed).
#[derive(Debug, Clone)]
pub struct Import {
    /// The cameras, in the files' order.
    pub cameras: Vec<Imported>,
    /// What was skipped or assumed.
    pub notes: Vec<String>,
}

/// Reads the cameras of `inputs` (files, or a COLMAP folder) in `format`.
pub fn read(
    format: Format,
    inputs: &[PathBuf],
    options: ImportOptions,
) -> Result<Import, RigError> {
    let first = inputs
        .first()
        .ok_or_else(|| RigError::field("(no input)", "inputs", "give the files to import"))?;
    let unit = match (options.unit, format.default_unit()) {
        (Some(u), _) | (None, Some(u)) => u,
        (None, None) => {
            return Err(RigError::field(
                first,
                "unit",
                "the files do not say their length unit: give it (mm, cm or m)",
            ));
        }
    };
    let one = |what: &str| -> Result<&PathBuf, RigError> {
        if inputs.len() == 1 {
            Ok(first)
        } else {
            Err(RigError::field(
                first,
                "inputs",
                format!("{what} is one file (or folder); {} given", inputs.len()),
            ))
        }
    };
    let mut notes = Vec::new();
    let cameras = match format {
        Format::Projection => {
            let Some((w, h)) = options.size else {
                return Err(RigError::field(
                    first,
                    "image size",
                    "a projection matrix does not hold the image size: give it (WxH)",
                ));
            };
            let mut all = Vec::new();
            for path in inputs {
                let (cams, skipped) = projection::read(path, w, h, unit)?;
                notes.extend(
                    skipped
                        .into_iter()
                        .map(|s| format!("{}: skipped {s}", path.display())),
                );
                all.extend(cams);
            }
            all
        }
        Format::Middlebury => {
            middlebury_cameras(one("a Middlebury *_par.txt")?, options.size, unit)?
        }
        Format::CameraInfo => {
            let mut cameras: Vec<Imported> = inputs
                .iter()
                .map(|p| camera_info::read(p, unit))
                .collect::<Result<_, _>>()?;
            notes.extend(exported_poses(first, &mut cameras)?);
            cameras
        }
        Format::Kalibr => kalibr::read(one("a Kalibr camchain")?, unit)?,
        Format::Colmap => colmap::read(one("a COLMAP model")?, unit)?,
        Format::OpencvStereo => {
            let (cameras, said) =
                opencv_stereo::read(one("an OpenCV stereo calibration")?, unit, options.size)?;
            notes.extend(said);
            cameras
        }
    };
    if options.size.is_some() && format.has_size() {
        notes.push("the files give each camera's image size; the size given was not used".into());
    }
    notes.extend(one_pose(&cameras));
    if let Some(why) = facing_away(&cameras) {
        return Err(RigError::field(first, "cameras", why));
    }
    Ok(Import { cameras, notes })
}

/// Why some of `cameras` face away from where the rig looks, if they do: the point nearest
/// every camera's optical axis (least squares) lies behind them. A projection's sign is its
/// own, so a mirrored camera (a negative focal length) or a reflected rotation reads as a
/// camera turned to face backwards, and a file of such a camera says nothing else of it.
/// `None` when the axes do not cross anywhere (fewer than two cameras, or all parallel, as a
/// stereo pair's may be) or every camera faces the point.
fn facing_away(cameras: &[Imported]) -> Option<String> {
    use flexshape_camera::nalgebra::{Matrix3, Vector3};
    if cameras.len() < 2 {
        return None;
    }
    // Σ (I − a·aᵀ)·x = Σ (I − a·aᵀ)·c over the axes (centre c, unit direction a).
    let (mut a, mut b) = (Matrix3::zeros(), Vector3::zeros());
    for c in cameras {
        let axis = c.camera.pose.optical_axis();
        let across = Matrix3::identity() - axis * axis.transpose();
        a += across;
        b += across * c.camera.centre().coords;
    }
    // Axes within a few degrees of parallel meet nowhere in particular.
    let eigen = a.symmetric_eigen();
    if eigen.eigenvalues.min() < AXES_CROSS * cameras.len() as f64 {
        return None;
    }
    let point = a.try_inverse()? * b;
    let behind: Vec<String> = cameras
        .iter()
        .filter_map(|c| {
            let depth = c
                .camera
                .pose
                .optical_axis()
                .dot(&(point - c.camera.centre().coords));
            (depth < 0.0).then(|| format!("{} ({:.0} mm behind it)", c.name, -depth))
        })
        .collect();
    (!behind.is_empty()).then(|| {
        format!(
            "the point the cameras' optical axes pass nearest, ({}, {}, {}) mm, lies behind camera {}: a camera facing away from what the others look at is how a mirrored camera (a negative focal length) or a reflected rotation (determinant −1) reads; give the matrices of the cameras as they are, unmirrored",
            crate::short(point.x.round()),
            crate::short(point.y.round()),
            crate::short(point.z.round()),
            behind.join(", ")
        )
    })
}

/// Least eigenvalue, per camera, of `Σ (I − a·aᵀ)` over the cameras' optical axes `a` for the
/// axes to cross somewhere: 0 when all are parallel, 1 for three orthogonal axes (two axes θ
/// apart give (1 − cos θ) / 2 a camera: this is 5.7°).
const AXES_CROSS: f64 = 0.0025;

/// CameraInfo files that `rig export` wrote: the poses its [`camera_info::EXTRINSICS_FILE`]
/// beside `first` holds, set on the cameras it names. What to say of it.
fn exported_poses(first: &Path, cameras: &mut [Imported]) -> Result<Option<String>, RigError> {
    let path = first
        .parent()
        .unwrap_or(Path::new("."))
        .join(camera_info::EXTRINSICS_FILE);
    if !path.is_file() {
        return Ok(None);
    }
    let poses = camera_info::read_extrinsics(&path)?;
    let mut set = Vec::new();
    for c in cameras.iter_mut() {
        if let Some(pose) = poses.get(&c.name) {
            c.camera.pose = *pose;
            set.push(c.name.clone());
        }
    }
    let unnamed: Vec<&str> = cameras
        .iter()
        .map(|c| c.name.as_str())
        .filter(|n| !poses.contains_key(*n))
        .collect();
    Ok(Some(match unnamed.is_empty() {
        true => format!("poses of {} from {}", set.join(", "), path.display()),
        false => format!(
            "poses of {} from {}; it does not name {}, which keep their CameraInfo poses",
            if set.is_empty() {
                "no camera".to_string()
            } else {
                set.join(", ")
            },
            path.display(),
            unnamed.join(", ")
        ),
    }))
}

/// What to say when several cameras were imported at one pose: files that hold no rig pose
/// (CameraInfo outside a stereo pair, as `rig export --format camera-info` writes them) put
/// every camera at the world origin, where nothing can be carved.
fn one_pose(cameras: &[Imported]) -> Option<String> {
    let same = |a: &Imported, b: &Imported| {
        let (pa, pb) = (&a.camera.pose, &b.camera.pose);
        (pa.rotation.matrix() - pb.rotation.matrix()).amax() < 1e-9
            && (pa.translation - pb.translation).amax() < 1e-6
    };
    let shared: Vec<&str> = cameras
        .iter()
        .filter(|c| cameras.iter().filter(|o| same(c, o)).count() > 1)
        .map(|c| c.name.as_str())
        .collect();
    (!shared.is_empty()).then(|| {
        format!(
            "cameras {} were imported at one pose: these files hold no rig poses (CameraInfo keeps only a stereo pair's baseline; ROS keeps poses in TF), so nothing can be carved until each camera's pose is set in its camera file (or import a format that holds them: Kalibr, COLMAP, projection matrices)",
            shared.join(", ")
        )
    })
}

/// The views of a Middlebury file, sized `size` or by their images beside the file.
fn middlebury_cameras(
    path: &Path,
    size: Option<(u32, u32)>,
    unit: Unit,
) -> Result<Vec<Imported>, RigError> {
    let (w, h) = size.unwrap_or((1, 1));
    let views = crate::middlebury::read_par(path, w, h, unit.mm())?;
    let dir = path.parent().unwrap_or(Path::new("."));
    views
        .into_iter()
        .map(|v| {
            let stem = v.image.rsplit_once('.').map_or(v.image.as_str(), |(s, _)| s);
            let mut camera = v.camera;
            if size.is_none() {
                let image = dir.join(&v.image);
                let (w, h) = image::image_dimensions(&image).map_err(|e| {
                    RigError::field(
                        path,
                        v.image.as_str(),
                        format!(
                            "the image size is not in the file and {} cannot be read for it ({e}): give the size (WxH)",
                            image.display()
                        ),
                    )
                })?;
                let i = &camera.intrinsics;
                camera.intrinsics = flexshape_camera::Intrinsics::new(w, h, i.fx, i.fy, i.cx, i.cy, i.distortion)
                    .map_err(|e| camera_error(path, &v.image, e))?;
            }
            Ok(Imported {
                name: sanitize(stem),
                camera,
            })
        })
        .collect()
}

/// A format flexshape writes a rig's cameras in.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ExportFormat {
    /// ROS CameraInfo YAML, one `NAME.yaml` per camera (intrinsics only).
    CameraInfo,
    /// A COLMAP text model (cameras and poses).
    Colmap,
}

/// Writes `rig`'s cameras into folder `dir` in `format`, lengths in `unit`; returns the files
/// written.
pub fn export(
    rig: &Rig,
    format: ExportFormat,
    dir: &Path,
    unit: Unit,
) -> Result<Vec<PathBuf>, RigError> {
    std::fs::create_dir_all(dir).map_err(|source| RigError::Write {
        file: dir.to_path_buf(),
        source,
    })?;
    let cameras: Vec<(String, Camera)> = rig
        .cameras
        .iter()
        .map(|c| (c.name.clone(), c.camera.clone()))
        .collect();
    let write = |path: &Path, text: String| {
        std::fs::write(path, text).map_err(|source| RigError::Write {
            file: path.to_path_buf(),
            source,
        })
    };
    let files = export_files(rig, format, dir);
    match format {
        ExportFormat::CameraInfo => {
            for ((name, camera), path) in cameras.iter().zip(&files) {
                write(path, camera_info::to_yaml(name, camera))?;
            }
            write(
                &dir.join(camera_info::EXTRINSICS_FILE),
                camera_info::extrinsics_yaml(&cameras),
            )?;
        }
        ExportFormat::Colmap => colmap::write(dir, &cameras, unit)?,
    }
    Ok(files)
}

/// The files [`export`] writes into `dir`, in the order it lists them.
pub fn export_files(rig: &Rig, format: ExportFormat, dir: &Path) -> Vec<PathBuf> {
    match format {
        ExportFormat::CameraInfo => rig
            .cameras
            .iter()
            .map(|c| dir.join(format!("{}.yaml", c.name)))
            .chain([dir.join(camera_info::EXTRINSICS_FILE)])
            .collect(),
        ExportFormat::Colmap => ["cameras.txt", "images.txt", "points3D.txt"]
            .iter()
            .map(|f| dir.join(f))
            .collect(),
    }
}

/// Whether a number read from a file is finite, or the error naming it.
fn finite(path: &Path, field: &str, v: f64) -> Result<f64, RigError> {
    if v.is_finite() {
        Ok(v)
    } else {
        Err(RigError::field(
            path,
            field,
            format!("{v} is not a finite number"),
        ))
    }
}

/// The camera error of a field, as the file's error.
fn camera_error(path: &Path, field: &str, e: flexshape_camera::CameraError) -> RigError {
    RigError::field(path, field, e.to_string())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_become_rig_names_and_units_parse() {
        assert_eq!(sanitize("left cam.png"), "left_cam_png");
        assert_eq!(sanitize(""), "cam");
        assert_eq!("m".parse::<Unit>().unwrap().mm(), 1000.0);
        assert!("inch".parse::<Unit>().is_err());
    }

    /// A camera the loader would refuse (here a principal point outside the image it is
    /// declared with) is refused by the import, naming the camera and why; the same camera
    /// with its image is taken.
    #[test]
    fn a_camera_the_loader_would_refuse_is_not_imported() {
        use flexshape_camera::{Camera, Distortion, Intrinsics, Pose};
        let camera = |width, height| Camera {
            intrinsics: Intrinsics::new(
                width,
                height,
                800.0,
                800.0,
                320.0,
                240.0,
                Distortion::default(),
            )
            .unwrap(),
            pose: Pose::identity(),
        };
        let imported = |width, height| {
            vec![Imported {
                name: "cam0".into(),
                camera: camera(width, height),
            }]
        };
        let source = Path::new("P0.txt");
        let e = rig_of(imported(100, 100), Volume::default(), source)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("P0.txt") && e.contains("cam0") && e.contains("principal point"),
            "{e}"
        );
        rig_of(imported(640, 480), Volume::default(), source).unwrap();
    }
}
