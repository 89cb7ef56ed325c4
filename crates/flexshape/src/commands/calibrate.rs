//! `flexshape calibrate`: cameras from chessboard images, written as OpenCV files and a rig.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use anyhow::{Context, bail};
use flexshape_calib::{
    Board, BoardPose, CalibError, Calibration, CalibrationSettings, Detection, JointIntrinsics,
    RelativePose, adjust_rig, calibrate, detect, half_turned_views, relative_pose,
};
use flexshape_camera::nalgebra::{Matrix3, Rotation3, Vector3};
use flexshape_camera::{Camera, Pose};
use flexshape_plot::{HistogramSeries, PALETTE, histograms};
use flexshape_rig::{ProcessingTable, Rig, RigCamera, Volume};
use indicatif::{ProgressBar, ProgressStyle};
use serde::Serialize;

use crate::cli::CalibrateArgs;

/// One camera's images.
struct CameraImages {
    name: String,
    files: Vec<PathBuf>,
    /// The file-name pattern the images were given by (`left*.jpg`), if any.
    pattern: Option<String>,
}

impl CameraImages {
    /// Which instant an image of this camera shows: images of different cameras with the same
    /// instant were taken together. From a folder, the file name without its extension; from
    /// a pattern, what its wildcards matched (`left07.jpg` by `left*.jpg`: `07`, the instant of
    /// `right07.jpg` by `right*.jpg` too).
    fn instant(&self, image: &str) -> String {
        match &self.pattern {
            Some(p) => wildcards(p, image).unwrap_or_else(|| stem(image).to_string()),
            None => stem(image).to_string(),
        }
    }
}

/// What the wildcards of `pattern` (`*` any run of characters, `?` one) matched in `name`,
/// joined, or `None` when `name` does not match.
fn wildcards(pattern: &str, name: &str) -> Option<String> {
    fn go(p: &[char], n: &[char], out: &mut String) -> bool {
        match p.first() {
            None => n.is_empty(),
            Some('*') => (0..=n.len()).rev().any(|k| {
                let len = out.len();
                out.extend(&n[..k]);
                if go(&p[1..], &n[k..], out) {
                    return true;
                }
                out.truncate(len);
                false
            }),
            Some('?') => {
                let Some(&c) = n.first() else { return false };
                out.push(c);
                go(&p[1..], &n[1..], out) || {
                    out.pop();
                    false
                }
            }
            Some(&c) => n.first() == Some(&c) && go(&p[1..], &n[1..], out),
        }
    }
    let (p, n): (Vec<char>, Vec<char>) = (pattern.chars().collect(), name.chars().collect());
    let mut out = String::new();
    go(&p, &n, &mut out).then_some(out)
}

#[derive(Serialize)]
struct CameraReport {
    name: String,
    rms_px: f64,
    fx: f64,
    fy: f64,
    cx: f64,
    cy: f64,
    distortion_k1_k2_p1_p2_k3: Vec<f64>,
    /// Standard deviations of fx, fy, cx, cy, k1, k2, p1, p2, k3.
    std_dev: [f64; 9],
    views: Vec<ViewReport>,
    rejected: Vec<String>,
    dropped: Vec<String>,
    /// Pose relative to the reference camera from the shared views (absent for the
    /// reference); the written pose is the joint adjustment's.
    relative_to_reference: Option<RelativePose>,
    /// Reprojection RMS over this camera's views after the joint adjustment of the rig, px.
    joint_rms_px: Option<f64>,
}

#[derive(Serialize)]
struct ViewReport {
    image: String,
    rms_px: f64,
    outlier: bool,
}

pub fn run(args: &CalibrateArgs) -> anyhow::Result<()> {
    let board = Board::from_spec(&args.board, args.square, args.marker, &args.dictionary)
        .map_err(|e| anyhow::anyhow!("--board: {e}"))?;
    let cameras = cameras(&args.images)?;
    let total: usize = cameras.iter().map(|c| c.files.len()).sum();
    let bar = ProgressBar::new(total as u64).with_style(
        ProgressStyle::with_template("detecting boards [{bar:40}] {pos}/{len} images, eta {eta}")
            .unwrap_or_else(|_| ProgressStyle::default_bar())
            .progress_chars("=> "),
    );
    let settings = CalibrationSettings {
        drop_outliers: args.drop_outliers,
        fix_k3: args.fix_k3,
        ..CalibrationSettings::default()
    };
    let mut results: Vec<(Calibration, Vec<String>)> = Vec::new();
    let mut detections = Vec::new();
    for cam in &cameras {
        let (views, rejected, size) = detect_all(cam, &board, &bar)?;
        let cal = calibrate(&views, size.0, size.1, &settings)
            .with_context(|| format!("camera {}", cam.name))?;
        // The views the calibration kept (outliers may have been dropped), by instant.
        let kept: Vec<(String, Detection)> = views
            .into_iter()
            .filter(|(name, _)| cal.views.iter().any(|v| &v.name == name))
            .map(|(name, d)| (cam.instant(&name), d))
            .collect();
        detections.push(kept);
        results.push((cal, rejected));
    }
    bar.finish_and_clear();
    // A board that looks the same turned (a symmetric circle grid) may be labelled the other
    // way round by a camera: such shared views are turned to agree with the others.
    if let Some(half_turn) = board.half_turn() {
        for k in 1..results.len() {
            let (names, pairs) = shared_views(&results[0].0, &results[k].0, &cameras, k);
            let turned = half_turned_views(&pairs, &half_turn);
            for (name, _) in names.iter().zip(&turned).filter(|(_, t)| **t) {
                if let Some(v) = results[k].0.views.iter_mut().find(|v| &v.name == name) {
                    v.half_turn(&half_turn);
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
    // Poses: each camera relative to the reference from the views both saw.
    let reference = &results[0].0;
    let mut relative = vec![None];
    let mut poses = vec![Pose::identity()];
    for (k, (cal, _)) in results.iter().enumerate().skip(1) {
        let (names, pairs) = shared_views(reference, cal, &cameras, k);
        let rel = match relative_pose(&pairs) {
            Ok(rel) => rel,
            Err(e) => {
                if let CalibError::SharedViews { disagreeing, .. } = &e {
                    bail!(
                        "cameras {} and {}: {e}: {} of {}; they were not taken at the same instant as the first camera's views of the same name, or a board was misdetected — remove or rename them",
                        cameras[0].name,
                        cameras[k].name,
                        disagreeing
                            .iter()
                            .map(|&i| names[i].as_str())
                            .collect::<Vec<_>>()
                            .join(", "),
                        cameras[k].name
                    );
                }
                return Err(anyhow::Error::new(e).context(format!(
                    "cameras {} and {}: images with the same file name in both folders are views of the same instant",
                    cameras[0].name, cameras[k].name
                )));
            }
        };
        poses.push(pose_of(&rel));
        relative.push(Some(rel));
    }
    let world = world_frame(args.world.as_deref(), &cameras, reference, &board)?;
    // One joint adjustment of everything, from these starts.
    let mut joint = None;
    if cameras.len() > 1 {
        let named: Vec<Calibration> = results
            .iter()
            .zip(&cameras)
            .map(|((cal, _), cam)| {
                let mut c = cal.clone();
                for v in &mut c.views {
                    v.name = cam.instant(&v.name);
                }
                c
            })
            .collect();
        let rig: Vec<flexshape_calib::RigCamera> = named
            .iter()
            .zip(&detections)
            .zip(&poses)
            .map(|((cal, views), pose)| flexshape_calib::RigCamera {
                calibration: cal,
                views,
                pose: BoardPose {
                    rotation: pose.rotation,
                    translation: pose.translation,
                },
            })
            .collect();
        let intrinsics = if args.joint_intrinsics {
            JointIntrinsics::Refined {
                fix_k3: args.fix_k3,
            }
        } else {
            JointIntrinsics::Fixed
        };
        match adjust_rig(&rig, intrinsics) {
            Ok(a) => {
                for ((cal, _), k) in results.iter_mut().zip(&a.intrinsics) {
                    cal.intrinsics = k.clone();
                }
                poses = a
                    .poses
                    .iter()
                    .map(|p| Pose {
                        rotation: p.rotation,
                        translation: p.translation,
                    })
                    .collect();
                joint = Some(a);
            }
            Err(e) => eprintln!(
                "warning: the joint adjustment failed ({e}); writing the per-camera results"
            ),
        }
    }
    // x_cam = R_c·x_ref + t_c and x_ref = R_w·x_world + t_w.
    let poses: Vec<Pose> = poses
        .iter()
        .map(|p| Pose {
            rotation: p.rotation * world.rotation,
            translation: p.rotation * world.translation + p.translation,
        })
        .collect();
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("cannot create {}", args.out.display()))?;
    let mut rig = Rig {
        cameras: cameras
            .iter()
            .zip(&results)
            .zip(&poses)
            .map(|((c, (cal, _)), pose)| RigCamera {
                name: c.name.clone(),
                file: PathBuf::from(format!("{}.yml", c.name)),
                camera: Camera::new(cal.intrinsics.clone(), *pose),
            })
            .collect(),
        volume: Volume::default(),
        processing: ProcessingTable::new(),
    };
    // The default volume sits at the world origin (the reference camera's centre, unless
    // --world moved it): when some camera sees none of it, the box every camera sees instead.
    let calibrated: Vec<Camera> = rig.cameras.iter().map(|c| c.camera.clone()).collect();
    let seen = flexshape_rig::coverage::corners_seen(&calibrated, &rig.volume);
    if seen.iter().any(|&n| n < calibrated.len())
        && let Some(v) = flexshape_rig::coverage::suggest_volume(&calibrated, 1.0)
    {
        eprintln!(
            "note: the rig's volume is the box every camera sees (rig.toml; change it with `[volume]` or track --volume)"
        );
        rig.volume = v;
    }
    let rig_path = args.out.join("rig.toml");
    rig.save(&rig_path)
        .with_context(|| format!("cannot write {}", rig_path.display()))?;
    let reports: Vec<CameraReport> = cameras
        .iter()
        .zip(&results)
        .zip(relative)
        .enumerate()
        .map(|(k, ((c, (cal, rejected)), rel))| {
            let mut r = report(c, cal, rejected, rel);
            r.joint_rms_px = joint.as_ref().map(|a| a.rms_px[k]);
            r
        })
        .collect();
    let json = args.out.join("calibration.json");
    std::fs::write(&json, serde_json::to_string_pretty(&reports)?)
        .with_context(|| format!("cannot write {}", json.display()))?;
    let series: Vec<HistogramSeries> = reports
        .iter()
        .zip(&results)
        .enumerate()
        .map(|(k, (r, (cal, _)))| HistogramSeries {
            label: format!("{} residuals (x and y)", r.name),
            values: cal
                .views
                .iter()
                .flat_map(|v| v.residuals.iter().flat_map(|e| [e[0], e[1]]))
                .collect(),
            colour: PALETTE[k % PALETTE.len()],
        })
        .collect();
    histograms(
        "Reprojection residuals per camera",
        "px",
        &series,
        &args.out.join("residuals"),
    )?;
    let text = summary(&reports, &args.out);
    let txt = args.out.join("calibration.txt");
    std::fs::write(&txt, &text).with_context(|| format!("cannot write {}", txt.display()))?;
    print!("{text}");
    Ok(())
}

/// `NAME=DIR` (or `NAME=DIR/PATTERN`, e.g. `left=imgs/left*.jpg`) arguments → cameras and
/// their image files (sorted by name). Two cameras given the same images are refused.
fn cameras(specs: &[(String, PathBuf)]) -> anyhow::Result<Vec<CameraImages>> {
    let mut seen = BTreeMap::new();
    let mut out: Vec<CameraImages> = Vec::new();
    for (name, given) in specs {
        if seen.insert(name.to_string(), ()).is_some() {
            bail!("--images: camera {name} is given twice");
        }
        let pattern = given
            .file_name()
            .and_then(|f| f.to_str())
            .filter(|f| f.contains(['*', '?']))
            .map(str::to_string);
        let dir = match &pattern {
            Some(_) => match given.parent() {
                Some(p) if !p.as_os_str().is_empty() => p,
                _ => Path::new("."),
            },
            None => given.as_path(),
        };
        let mut files: Vec<PathBuf> = std::fs::read_dir(dir)
            .with_context(|| format!("camera {name}: cannot read the folder {}", dir.display()))?
            .filter_map(|e| e.ok().map(|e| e.path()))
            .filter(|p| {
                p.extension().and_then(|e| e.to_str()).is_some_and(|e| {
                    matches!(
                        e.to_ascii_lowercase().as_str(),
                        "png" | "jpg" | "jpeg" | "bmp" | "tif" | "tiff"
                    )
                })
            })
            .filter(|p| {
                pattern.as_deref().is_none_or(|pat| {
                    p.file_name()
                        .and_then(|f| f.to_str())
                        .is_some_and(|f| wildcards(pat, f).is_some())
                })
            })
            .collect();
        files.sort();
        if files.is_empty() {
            bail!(
                "camera {name}: no images (png, jpg, bmp, tif) {} {}",
                if pattern.is_some() { "match" } else { "in" },
                given.display()
            );
        }
        if let Some(other) = out.iter().find(|c| c.files == files) {
            bail!(
                "--images: cameras {} and {name} are given the same images ({}); each camera needs its own (a folder each, or a pattern each: left=DIR/left*.jpg right=DIR/right*.jpg)",
                other.name,
                given.display()
            );
        }
        out.push(CameraImages {
            name: name.to_string(),
            files,
            pattern,
        });
    }
    Ok(out)
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

type Detected = (Vec<(String, Detection)>, Vec<String>, (u32, u32));

fn detect_all(cam: &CameraImages, board: &Board, bar: &ProgressBar) -> anyhow::Result<Detected> {
    let (mut views, mut rejected, mut size) = (Vec::new(), Vec::new(), None);
    for f in &cam.files {
        bar.inc(1);
        let name = f
            .file_name()
            .map(|n| n.to_string_lossy().to_string())
            .unwrap_or_default();
        let img = match image::open(f) {
            Ok(i) => i.to_luma8(),
            Err(e) => {
                rejected.push(format!("{name}: cannot read the image ({e})"));
                continue;
            }
        };
        match size {
            None => size = Some(img.dimensions()),
            Some(s) if s != img.dimensions() => bail!(
                "camera {}: {} is {}×{} but the camera's first image is {}×{}; one camera's images must share a size",
                cam.name,
                f.display(),
                img.width(),
                img.height(),
                s.0,
                s.1
            ),
            Some(_) => {}
        }
        match detect(&img, board) {
            Ok(d) => views.push((name, d)),
            Err(e) => rejected.push(format!("{name}: {e}")),
        }
    }
    let size = size.unwrap_or((0, 0));
    Ok((views, rejected, size))
}

fn stem(name: &str) -> &str {
    name.rsplit_once('.').map_or(name, |(s, _)| s)
}

fn pose_of(rel: &RelativePose) -> Pose {
    Pose {
        rotation: Rotation3::from_matrix_unchecked(Matrix3::from_fn(|r, c| rel.rotation[r][c])),
        translation: Vector3::from(rel.translation),
    }
}

/// The world frame as the reference camera sees it (`x_ref = R·x_world + t`).
fn world_frame(
    world: Option<&str>,
    cameras: &[CameraImages],
    reference: &Calibration,
    board: &Board,
) -> anyhow::Result<Pose> {
    let Some(w) = world else {
        return Ok(Pose::identity());
    };
    if w == cameras[0].name {
        return Ok(Pose::identity());
    }
    let view_pose = |image: &str| -> anyhow::Result<BoardPose> {
        reference
            .views
            .iter()
            .find(|v| stem(&v.name) == image || cameras[0].instant(&v.name) == image)
            .map(|v| v.board_pose())
            .with_context(|| {
                format!(
                    "--world {w}: camera {} has no detected board in an image named {image}",
                    cameras[0].name
                )
            })
    };
    if let Some(image) = w.strip_prefix("board:") {
        let b = view_pose(image)?;
        return Ok(Pose {
            rotation: b.rotation,
            translation: b.translation,
        });
    }
    if let Some(file) = w.strip_prefix("points:") {
        // Lines `IMAGE,COL,ROW,X,Y,Z`: board corner (COL, ROW) in the first camera's image
        // IMAGE lies at world (X, Y, Z) mm.
        let text = flexshape_rig::files::read_text(Path::new(file), "points file")
            .with_context(|| format!("--world {w}: cannot read {file}"))?;
        let (mut world_points, mut camera_points) = (Vec::new(), Vec::new());
        for (i, line) in text.lines().enumerate() {
            let line = line.trim();
            if line.is_empty() || line.starts_with('#') {
                continue;
            }
            let f: Vec<&str> = line.split(',').map(str::trim).collect();
            let parsed = (f.len() == 6)
                .then(|| {
                    let c = f[1].parse::<usize>().ok()?;
                    let r = f[2].parse::<usize>().ok()?;
                    let xyz: Vec<f64> = f[3..]
                        .iter()
                        .map(|v| v.parse().ok())
                        .collect::<Option<_>>()?;
                    Some((c, r, xyz))
                })
                .flatten();
            let Some((c, r, xyz)) = parsed else {
                if i == 0 {
                    continue; // a header
                }
                bail!(
                    "{file} line {}: expected IMAGE,COL,ROW,X,Y,Z, found `{line}`",
                    i + 1
                );
            };
            if c >= board.cols || r >= board.rows {
                bail!(
                    "{file} line {}: corner ({c}, {r}) is not on a {}×{} board",
                    i + 1,
                    board.cols,
                    board.rows
                );
            }
            let b = view_pose(f[0])?;
            camera_points.push(flexshape_camera::nalgebra::Point3::from(
                b.rotation * board.point(c, r).coords + b.translation,
            ));
            world_points.push(flexshape_camera::nalgebra::Point3::new(
                xyz[0], xyz[1], xyz[2],
            ));
        }
        let (t, res) = flexshape_register::register(&world_points, &camera_points)
            .with_context(|| format!("--world {w}: cannot register the measured points"))?;
        eprintln!(
            "world frame from {} measured points: rms {:.3} mm, max {:.3} mm",
            world_points.len(),
            res.rms,
            res.max
        );
        return Ok(Pose {
            rotation: t.rotation,
            translation: t.translation,
        });
    }
    bail!(
        "--world {w}: give the reference camera ({}), board:IMAGE or points:FILE",
        cameras[0].name
    )
}

fn report(
    c: &CameraImages,
    cal: &Calibration,
    rejected: &[String],
    rel: Option<RelativePose>,
) -> CameraReport {
    let k = &cal.intrinsics;
    CameraReport {
        name: c.name.clone(),
        rms_px: cal.rms_px,
        fx: k.fx,
        fy: k.fy,
        cx: k.cx,
        cy: k.cy,
        distortion_k1_k2_p1_p2_k3: k.distortion.to_opencv().into_iter().take(5).collect(),
        std_dev: cal.std_dev,
        views: cal
            .views
            .iter()
            .map(|v| ViewReport {
                image: v.name.clone(),
                rms_px: v.rms_px,
                outlier: v.outlier,
            })
            .collect(),
        rejected: rejected.to_vec(),
        dropped: cal.dropped.clone(),
        relative_to_reference: rel,
        joint_rms_px: None,
    }
}

fn summary(reports: &[CameraReport], out: &Path) -> String {
    use std::fmt::Write as _;
    let mut text = String::new();
    for r in reports {
        let _ = writeln!(
            text,
            "{}: {} views, rms {:.3} px; fx {:.2} ± {:.2}, fy {:.2} ± {:.2}, cx {:.2} ± {:.2}, cy {:.2} ± {:.2}; k1..k3 {:?}",
            r.name,
            r.views.len(),
            r.rms_px,
            r.fx,
            r.std_dev[0],
            r.fy,
            r.std_dev[1],
            r.cx,
            r.std_dev[2],
            r.cy,
            r.std_dev[3],
            r.distortion_k1_k2_p1_p2_k3
                .iter()
                .map(|v| (v * 1e5).round() / 1e5)
                .collect::<Vec<_>>()
        );
        for v in r.views.iter().filter(|v| v.outlier) {
            let _ = writeln!(
                text,
                "  outlier view {} (rms {:.3} px); --drop-outliers leaves it out",
                v.image, v.rms_px
            );
        }
        for d in &r.dropped {
            let _ = writeln!(text, "  dropped outlier view {d}");
        }
        for why in &r.rejected {
            let _ = writeln!(text, "  rejected {why}");
        }
        if let Some(j) = r.joint_rms_px {
            let _ = writeln!(
                text,
                "  after the joint adjustment of the rig: rms {j:.3} px"
            );
        }
        if let Some(rel) = &r.relative_to_reference {
            let _ = writeln!(
                text,
                "  pose relative to the reference: t [{:.2}, {:.2}, {:.2}] mm from {} shared views (spread {:.3}°, {:.2} mm)",
                rel.translation[0],
                rel.translation[1],
                rel.translation[2],
                rel.shared_views,
                rel.rotation_spread_deg,
                rel.translation_spread_mm
            );
        }
    }
    let _ = writeln!(
        text,
        "wrote {} (rig.toml, one .yml per camera, calibration.json, calibration.txt, residuals.png/svg)",
        out.display()
    );
    text
}
