//! A whole rig calibrated from target images, as `flexshape calibrate` does it: each
//! camera's intrinsics, each camera's pose relative to the first from the views both saw, one
//! joint adjustment of everything, the world frame placed, and the rig and its report
//! written.
//!
//! ```no_run
//! use flexshape_calib::{Board, workflow::{CameraImages, RigSettings, calibrate_rig}};
//! # fn main() -> Result<(), Box<dyn std::error::Error>> {
//! let cameras = CameraImages::find_all(&[
//!     ("left".into(), "images/left*.jpg".into()),
//!     ("right".into(), "images/right*.jpg".into()),
//! ])?;
//! let board = Board::parse("9x6", 25.0)?; // inner corners, square side in mm
//! let calibrated = calibrate_rig(&cameras, &board, &RigSettings::default(), &mut || {})?;
//! calibrated.write("calibration".as_ref())?;
//! print!("{}", calibrated.summary("calibration".as_ref()));
//! # Ok(())
//! # }
//! ```

mod images;
mod report;
mod world;

use std::path::{Path, PathBuf};

use flexshape_camera::nalgebra::{Matrix3, Rotation3, Vector3};
use flexshape_camera::{Camera, Pose};
use flexshape_rig::{ProcessingTable, Rig, Volume};
use thiserror::Error;

pub use images::CameraImages;
pub use report::{CameraReport, ViewReport};
pub use world::WorldFrame;

use crate::{
    Board, BoardPose, CalibError, Calibration, CalibrationSettings, Detection, JointIntrinsics,
    RelativePose, adjust_rig, calibrate, detect, half_turned_views, relative_pose,
};

/// Why a rig could not be calibrated or written; each names the camera, image or file.
#[derive(Debug, Error)]
pub enum RigCalibError {
    /// No camera given.
    #[error("no camera given; give each camera's images")]
    NoCameras,
    /// One camera given twice.
    #[error("camera {camera} is given twice")]
    CameraTwice {
        /// The camera.
        camera: String,
    },
    /// A camera's image folder could not be read.
    #[error("camera {camera}: cannot read the folder {}: {source}", dir.display())]
    Folder {
        /// The camera.
        camera: String,
        /// The folder.
        dir: PathBuf,
        /// Why.
        source: std::io::Error,
    },
    /// No images in a camera's folder, or none match its pattern.
    #[error("camera {camera}: no images (png, jpg) {} {}", if *pattern { "match" } else { "in" }, given.display())]
    NoImages {
        /// The camera.
        camera: String,
        /// The folder or pattern given.
        given: PathBuf,
        /// Whether a pattern was given.
        pattern: bool,
    },
    /// Two cameras given the same images.
    #[error("cameras {first} and {second} are given the same images ({}); each camera needs its own (a folder each, or a pattern each: left=DIR/left*.jpg right=DIR/right*.jpg)", given.display())]
    SameImages {
        /// The camera given them first.
        first: String,
        /// The other.
        second: String,
        /// What the second was given.
        given: PathBuf,
    },
    /// A camera's images of different sizes.
    #[error("camera {camera}: {} is {}×{} but the camera's first image is {}×{}; one camera's images must share a size", file.display(), size.0, size.1, first.0, first.1)]
    ImageSize {
        /// The camera.
        camera: String,
        /// The image.
        file: PathBuf,
        /// Its size, px.
        size: (u32, u32),
        /// The camera's first image's size, px.
        first: (u32, u32),
    },
    /// A camera could not be calibrated.
    #[error("camera {camera}: {source}")]
    Camera {
        /// The camera.
        camera: String,
        /// Why.
        source: CalibError,
    },
    /// Shared views disagree about where a camera is.
    #[error("cameras {reference} and {camera}: {source}: {}; they were not taken at the same instant as the first camera's views of the same name, or a board was misdetected — remove or rename them", views.join(", "))]
    Disagreeing {
        /// The reference camera.
        reference: String,
        /// The other.
        camera: String,
        /// The images of `camera` that disagree.
        views: Vec<String>,
        /// The disagreement.
        source: CalibError,
    },
    /// A camera's pose relative to the reference could not be found.
    #[error(
        "cameras {reference} and {camera}: images with the same file name in both folders are views of the same instant: {source}"
    )]
    Relative {
        /// The reference camera.
        reference: String,
        /// The other.
        camera: String,
        /// Why.
        source: CalibError,
    },
    /// The world frame could not be placed.
    #[error("world frame {spec}: {reason}")]
    World {
        /// The world frame as given.
        spec: String,
        /// Why.
        reason: String,
    },
    /// A file could not be written.
    #[error("cannot write {}: {reason}", path.display())]
    Write {
        /// The file or folder.
        path: PathBuf,
        /// Why.
        reason: String,
    },
}

/// How a rig is calibrated.
#[derive(Debug, Clone, PartialEq)]
pub struct RigSettings {
    /// Each camera's own calibration.
    pub calibration: CalibrationSettings,
    /// Refine the intrinsics in the joint adjustment too (otherwise they stay as calibrated
    /// per camera).
    pub joint_intrinsics: bool,
    /// Where the world frame is.
    pub world: WorldFrame,
}

impl Default for RigSettings {
    fn default() -> Self {
        Self {
            calibration: CalibrationSettings::default(),
            joint_intrinsics: false,
            world: WorldFrame::Reference,
        }
    }
}

/// A calibrated rig and what it rests on.
#[derive(Debug, Clone)]
pub struct RigCalibration {
    /// The rig: every camera in the world frame (files `NAME.yml`), and a volume every camera
    /// sees.
    pub rig: Rig,
    /// Per camera, in the order given: its calibration's report.
    pub reports: Vec<CameraReport>,
    /// Per camera: the reprojection residuals (x, y) of every kept corner, px.
    pub residuals: Vec<Vec<[f64; 2]>>,
    /// What the user should know (the joint adjustment failed, the volume was moved, how
    /// well measured world points registered).
    pub notes: Vec<String>,
}

/// Calibrates every camera from its images of `board` and places them in one world frame.
/// `on_image` is called after each image is read (for progress). Images without a usable
/// board are reported (`CameraReport::rejected`), not fatal.
pub fn calibrate_rig(
    cameras: &[CameraImages],
    board: &Board,
    settings: &RigSettings,
    on_image: &mut dyn FnMut(),
) -> Result<RigCalibration, RigCalibError> {
    if cameras.is_empty() {
        return Err(RigCalibError::NoCameras);
    }
    let mut results: Vec<(Calibration, Vec<String>)> = Vec::new();
    let mut detections = Vec::new();
    for cam in cameras {
        let (views, rejected, size) = detect_all(cam, board, on_image)?;
        let cal = calibrate(&views, size.0, size.1, &settings.calibration).map_err(|source| {
            RigCalibError::Camera {
                camera: cam.name.clone(),
                source,
            }
        })?;
        // The views the calibration kept (outliers may have been dropped), by instant.
        let kept: Vec<(String, Detection)> = views
            .into_iter()
            .filter(|(name, _)| cal.views.iter().any(|v| &v.name == name))
            .map(|(name, d)| (cam.instant(&name), d))
            .collect();
        detections.push(kept);
        results.push((cal, rejected));
    }
    if let Some(half_turn) = board.half_turn() {
        agree_on_turns(cameras, &mut results, &mut detections, &half_turn);
    }
    let mut notes = Vec::new();
    // Poses: each camera relative to the reference from the views both saw.
    let mut relative = vec![None];
    let mut poses = vec![Pose::identity()];
    for k in 1..results.len() {
        let rel = relative_to_reference(cameras, &results, k)?;
        poses.push(pose_of(&rel));
        relative.push(Some(rel));
    }
    let (world, note) = settings.world.resolve(&cameras[0], &results[0].0, board)?;
    notes.extend(note);
    // One joint adjustment of everything, from these starts.
    let mut joint_rms = vec![None; cameras.len()];
    if cameras.len() > 1 {
        match adjust(cameras, &results, &detections, &poses, settings) {
            Ok(a) => {
                for ((cal, _), k) in results.iter_mut().zip(&a.intrinsics) {
                    cal.intrinsics = k.clone();
                }
                poses = a.poses.clone();
                joint_rms = a.rms_px.iter().map(|r| Some(*r)).collect();
            }
            Err(e) => notes.push(format!(
                "the joint adjustment failed ({e}); writing the per-camera results"
            )),
        }
    }
    // x_cam = R_c·x_ref + t_c and x_ref = R_w·x_world + t_w.
    let cameras_in_world: Vec<flexshape_rig::RigCamera> = cameras
        .iter()
        .zip(&results)
        .zip(&poses)
        .map(|((c, (cal, _)), p)| flexshape_rig::RigCamera {
            name: c.name.clone(),
            file: PathBuf::from(format!("{}.yml", c.name)),
            camera: Camera::new(
                cal.intrinsics.clone(),
                Pose {
                    rotation: p.rotation * world.rotation,
                    translation: p.rotation * world.translation + p.translation,
                },
            ),
            occluded: None,
        })
        .collect();
    let mut rig = Rig {
        cameras: cameras_in_world,
        volume: Volume::default(),
        processing: ProcessingTable::new(),
        refined: None,
    };
    notes.extend(seen_volume(&mut rig));
    let reports = cameras
        .iter()
        .zip(&results)
        .zip(relative)
        .zip(joint_rms)
        .map(|(((c, (cal, rejected)), rel), joint)| {
            CameraReport::new(&c.name, cal, rejected, rel, joint)
        })
        .collect();
    let residuals = results
        .iter()
        .map(|(cal, _)| {
            cal.views
                .iter()
                .flat_map(|v| v.residuals.iter().copied())
                .collect()
        })
        .collect();
    Ok(RigCalibration {
        rig,
        reports,
        residuals,
        notes,
    })
}

impl RigCalibration {
    /// Writes `rig.toml` with one OpenCV `NAME.yml` per camera, `calibration.json` (the
    /// reports), `calibration.txt` (the summary) and `residuals.png`/`.svg` into `dir`
    /// (created if missing).
    pub fn write(&self, dir: &Path) -> Result<(), RigCalibError> {
        let failed = |path: &Path| {
            let path = path.to_path_buf();
            move |e: &dyn std::fmt::Display| RigCalibError::Write {
                path,
                reason: e.to_string(),
            }
        };
        std::fs::create_dir_all(dir).map_err(|e| failed(dir)(&e))?;
        let rig_path = dir.join("rig.toml");
        self.rig
            .save(&rig_path)
            .map_err(|e| failed(&rig_path)(&e))?;
        // Beside OpenCV's files, ROS's: CameraInfo YAML per camera (intrinsics only).
        let ros = dir.join("ros");
        flexshape_rig::import::export(
            &self.rig,
            flexshape_rig::import::ExportFormat::CameraInfo,
            &ros,
            flexshape_rig::import::Unit::Millimetre,
        )
        .map_err(|e| failed(&ros)(&e))?;
        let json = dir.join("calibration.json");
        let text = serde_json::to_string_pretty(&self.reports).map_err(|e| failed(&json)(&e))?;
        std::fs::write(&json, text).map_err(|e| failed(&json)(&e))?;
        let series: Vec<flexshape_plot::HistogramSeries> = self
            .reports
            .iter()
            .zip(&self.residuals)
            .enumerate()
            .map(|(k, (r, res))| flexshape_plot::HistogramSeries {
                label: format!("{} residuals (x and y)", r.name),
                values: res.iter().flat_map(|e| [e[0], e[1]]).collect(),
                colour: flexshape_plot::PALETTE[k % flexshape_plot::PALETTE.len()],
            })
            .collect();
        let figure = dir.join("residuals");
        flexshape_plot::histograms("Reprojection residuals per camera", "px", &series, &figure)
            .map_err(|e| failed(&figure)(&e))?;
        let txt = dir.join("calibration.txt");
        std::fs::write(&txt, self.summary(dir)).map_err(|e| failed(&txt)(&e))?;
        Ok(())
    }

    /// The text of `calibration.txt`: per camera its intrinsics with standard deviations,
    /// outlier, dropped and rejected views, joint RMS and relative pose; then what was
    /// written to `dir`.
    pub fn summary(&self, dir: &Path) -> String {
        let mut text: String = self.reports.iter().map(CameraReport::summary).collect();
        text.push_str(&format!(
            "wrote {} (rig.toml, one .yml per camera, ros/NAME.yaml (ROS CameraInfo), calibration.json, calibration.txt, residuals.png/svg)\n",
            dir.display()
        ));
        text
    }
}

/// A camera's kept detections (by image file name), its rejected images with the reason, and
/// its image size.
type Detected = (Vec<(String, Detection)>, Vec<String>, (u32, u32));

/// The board in every image of one camera.
fn detect_all(
    cam: &CameraImages,
    board: &Board,
    on_image: &mut dyn FnMut(),
) -> Result<Detected, RigCalibError> {
    let (mut views, mut rejected, mut size) = (Vec::new(), Vec::new(), None);
    for f in &cam.files {
        on_image();
        let name = f
            .file_name()
            .map(|n| n.to_string_lossy().to_string())
            .unwrap_or_default();
        let img = match flexshape_rig::files::read_image(f, None) {
            Ok(i) => i.to_luma8(),
            Err(e) => {
                rejected.push(format!("{name}: cannot read the image ({})", e.reason()));
                continue;
            }
        };
        match size {
            None => size = Some(img.dimensions()),
            Some(s) if s != img.dimensions() => {
                return Err(RigCalibError::ImageSize {
                    camera: cam.name.clone(),
                    file: f.clone(),
                    size: img.dimensions(),
                    first: s,
                });
            }
            Some(_) => {}
        }
        match detect(&img, board) {
            Ok(d) => views.push((name, d)),
            Err(e) => rejected.push(format!("{name}: {e}")),
        }
    }
    Ok((views, rejected, size.unwrap_or((0, 0))))
}

/// A board that looks the same turned (a symmetric circle grid) may be labelled the other
/// way round by a camera: such shared views are turned to agree with the reference's.
fn agree_on_turns(
    cameras: &[CameraImages],
    results: &mut [(Calibration, Vec<String>)],
    detections: &mut [Vec<(String, Detection)>],
    half_turn: &BoardPose,
) {
    for k in 1..results.len() {
        let (names, pairs) = shared_views(&results[0].0, &results[k].0, cameras, k);
        let turned = half_turned_views(&pairs, half_turn);
        for (name, _) in names.iter().zip(&turned).filter(|(_, t)| **t) {
            if let Some(v) = results[k].0.views.iter_mut().find(|v| &v.name == name) {
                v.half_turn(half_turn);
            }
            let instant = cameras[k].instant(name);
            for (view, d) in detections[k].iter_mut() {
                if *view == instant {
                    *d = d.half_turned();
                }
            }
        }
    }
}

/// Camera `k`'s pose relative to the reference from the views both saw.
fn relative_to_reference(
    cameras: &[CameraImages],
    results: &[(Calibration, Vec<String>)],
    k: usize,
) -> Result<RelativePose, RigCalibError> {
    let (names, pairs) = shared_views(&results[0].0, &results[k].0, cameras, k);
    relative_pose(&pairs).map_err(|source| match &source {
        CalibError::SharedViews { disagreeing, .. } => RigCalibError::Disagreeing {
            reference: cameras[0].name.clone(),
            camera: cameras[k].name.clone(),
            views: disagreeing.iter().map(|&i| names[i].clone()).collect(),
            source,
        },
        _ => RigCalibError::Relative {
            reference: cameras[0].name.clone(),
            camera: cameras[k].name.clone(),
            source,
        },
    })
}

/// The joint adjustment of every camera and board pose.
fn adjust(
    cameras: &[CameraImages],
    results: &[(Calibration, Vec<String>)],
    detections: &[Vec<(String, Detection)>],
    poses: &[Pose],
    settings: &RigSettings,
) -> Result<crate::RigAdjustment, CalibError> {
    let named: Vec<Calibration> = results
        .iter()
        .zip(cameras)
        .map(|((cal, _), cam)| {
            let mut c = cal.clone();
            for v in &mut c.views {
                v.name = cam.instant(&v.name);
            }
            c
        })
        .collect();
    let rig: Vec<crate::RigCamera> = named
        .iter()
        .zip(detections)
        .zip(poses)
        .map(|((calibration, views), pose)| crate::RigCamera {
            calibration,
            views,
            pose: *pose,
        })
        .collect();
    let intrinsics = if settings.joint_intrinsics {
        JointIntrinsics::Refined {
            fix_k3: settings.calibration.fix_k3,
        }
    } else {
        JointIntrinsics::Fixed
    };
    adjust_rig(&rig, intrinsics)
}

/// The default volume sits at the world origin (the reference camera's centre, unless the
/// world frame moved it): when some camera sees none of it, the box every camera sees
/// instead.
fn seen_volume(rig: &mut Rig) -> Option<String> {
    let calibrated: Vec<Camera> = rig.cameras.iter().map(|c| c.camera.clone()).collect();
    let seen = flexshape_rig::coverage::corners_seen(&calibrated, &rig.volume);
    if seen.iter().all(|&n| n >= calibrated.len()) {
        return None;
    }
    rig.volume = flexshape_rig::coverage::suggest_volume(&calibrated, 1.0)?;
    Some(
        "the rig's volume is the box every camera sees (rig.toml; change it with `[volume]` or track --volume)"
            .to_string(),
    )
}

/// The views camera `k` shares with the reference (its view names) and both board poses of
/// each.
fn shared_views(
    reference: &Calibration,
    cal: &Calibration,
    cameras: &[CameraImages],
    k: usize,
) -> (Vec<String>, Vec<(BoardPose, BoardPose)>) {
    reference
        .views
        .iter()
        .filter_map(|a| {
            cal.views
                .iter()
                .find(|b| cameras[k].instant(&b.name) == cameras[0].instant(&a.name))
                .map(|b| (b.name.clone(), (a.board_pose(), b.board_pose())))
        })
        .unzip()
}

fn pose_of(rel: &RelativePose) -> Pose {
    Pose {
        rotation: Rotation3::from_matrix_unchecked(Matrix3::from_fn(|r, c| rel.rotation[r][c])),
        translation: Vector3::from(rel.translation),
    }
}
