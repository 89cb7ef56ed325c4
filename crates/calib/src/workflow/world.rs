//! The rig's world frame: the reference camera's, a board's, or one registered to measured
//! board corners.

use std::path::{Path, PathBuf};

use flexshape_camera::Pose;
use flexshape_camera::nalgebra::Point3;

use super::RigCalibError;
use super::images::{CameraImages, stem};
use crate::{Board, BoardPose, Calibration};

/// Where the rig's world frame is.
#[derive(Debug, Clone, PartialEq)]
pub enum WorldFrame {
    /// The reference (first) camera's frame.
    Reference,
    /// The board's frame in one of the reference camera's images (named by its file name
    /// without extension, or its instant).
    Board(String),
    /// The frame of measured board corners: a file of lines `IMAGE,COL,ROW,X,Y,Z` — corner
    /// (COL, ROW) of the board in the reference camera's image IMAGE lies at world (X, Y, Z)
    /// mm; an optional header line and `#` comments are skipped.
    Points(PathBuf),
}

impl WorldFrame {
    /// Reads `CAMERA` (the reference camera's name), `board:IMAGE` or `points:FILE`.
    pub fn parse(spec: &str, reference: &str) -> Result<Self, RigCalibError> {
        if spec == reference {
            Ok(Self::Reference)
        } else if let Some(image) = spec.strip_prefix("board:") {
            Ok(Self::Board(image.to_string()))
        } else if let Some(file) = spec.strip_prefix("points:") {
            Ok(Self::Points(PathBuf::from(file)))
        } else {
            Err(world_error(
                spec,
                format!("give the reference camera ({reference}), board:IMAGE or points:FILE"),
            ))
        }
    }

    /// What was given, as [`WorldFrame::parse`] reads it.
    fn spec(&self) -> String {
        match self {
            Self::Reference => "the reference camera".to_string(),
            Self::Board(image) => format!("board:{image}"),
            Self::Points(file) => format!("points:{}", file.display()),
        }
    }

    /// The world frame as the reference camera sees it (`x_ref = R·x_world + t`), and for
    /// measured points a note of how well they registered.
    pub(super) fn resolve(
        &self,
        camera: &CameraImages,
        reference: &Calibration,
        board: &Board,
    ) -> Result<(Pose, Option<String>), RigCalibError> {
        let view_pose = |image: &str| -> Result<BoardPose, RigCalibError> {
            reference
                .views
                .iter()
                .find(|v| stem(&v.name) == image || camera.instant(&v.name) == image)
                .map(|v| v.board_pose())
                .ok_or_else(|| {
                    world_error(
                        &self.spec(),
                        format!(
                            "camera {} has no detected board in an image named {image}",
                            camera.name
                        ),
                    )
                })
        };
        match self {
            Self::Reference => Ok((Pose::identity(), None)),
            Self::Board(image) => Ok((view_pose(image)?, None)),
            Self::Points(file) => {
                let (world, seen) = measured_points(file, board, &view_pose)?;
                let (t, res) = flexshape_register::register(&world, &seen).map_err(|e| {
                    world_error(
                        &self.spec(),
                        format!("cannot register the measured points: {e}"),
                    )
                })?;
                let note = format!(
                    "world frame from {} measured points: rms {:.3} mm, max {:.3} mm",
                    world.len(),
                    res.rms,
                    res.max
                );
                Ok((t, Some(note)))
            }
        }
    }
}

/// The measured corners' world points and where the reference camera saw them (its frame),
/// mm.
type Paired = (Vec<Point3<f64>>, Vec<Point3<f64>>);

/// Reads a points file (see [`WorldFrame::Points`]).
fn measured_points(
    file: &Path,
    board: &Board,
    view_pose: &dyn Fn(&str) -> Result<BoardPose, RigCalibError>,
) -> Result<Paired, RigCalibError> {
    let spec = format!("points:{}", file.display());
    let text = flexshape_rig::files::read_text(file, "points file")
        .map_err(|e| world_error(&spec, format!("cannot read {}: {e}", file.display())))?;
    let line_error = |i: usize, reason: String| {
        world_error(
            &spec,
            format!("{} line {}: {reason}", file.display(), i + 1),
        )
    };
    let (mut world, mut seen) = (Vec::new(), Vec::new());
    for (number, line, f) in flexshape_rig::files::csv_lines(&text) {
        let i = number - 1;
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
            return Err(line_error(
                i,
                format!("expected IMAGE,COL,ROW,X,Y,Z, found `{line}`"),
            ));
        };
        if c >= board.cols || r >= board.rows {
            return Err(line_error(
                i,
                format!(
                    "corner ({c}, {r}) is not on a {}×{} board",
                    board.cols, board.rows
                ),
            ));
        }
        let b = view_pose(f[0])?;
        seen.push(Point3::from(
            b.rotation * board.point(c, r).coords + b.translation,
        ));
        world.push(Point3::new(xyz[0], xyz[1], xyz[2]));
    }
    Ok((world, seen))
}

fn world_error(spec: &str, reason: String) -> RigCalibError {
    RigCalibError::World {
        spec: spec.to_string(),
        reason,
    }
}
