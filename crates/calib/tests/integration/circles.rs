//! Circle grids (OpenCV's symmetric and asymmetric layouts) rendered through the simulated
//! rig's distorted cameras: every dot's centre against its true projection, and a camera
//! calibrated from them.

use crate::common;

use flexshape_calib::{Board, Detection, detect};
use flexshape_camera::Camera;
use flexshape_camera::nalgebra::{Isometry3, Point2};
use flexshape_sim::{BoardRenderer, PrintedBoard, PrintedPattern, calibration_views};

/// Largest distance of a detection's dots from where the truth projects their board points,
/// px: as labelled, and with the labels half-turned (a symmetric grid cannot tell its ends
/// apart).
fn errors(cam: &Camera, pose: &Isometry3<f64>, d: &Detection) -> (f64, f64) {
    let truth: Vec<Point2<f64>> = d
        .points
        .iter()
        .map(|p| cam.project(&(pose * p)).unwrap().pixel)
        .collect();
    let worst = |order: &mut dyn Iterator<Item = &Point2<f64>>| {
        order
            .zip(&d.corners)
            .map(|(t, c)| (t - c).norm())
            .fold(0.0, f64::max)
    };
    (worst(&mut truth.iter()), worst(&mut truth.iter().rev()))
}

fn calibrates(spec: &str, asymmetric: bool, diameter: f64) {
    let cameras = common::rig_cameras();
    let board = Board::from_spec(spec, 20.0, None, "").unwrap();
    let printed = PrintedBoard {
        cols: board.cols,
        rows: board.rows,
        square: board.square,
        pattern: PrintedPattern::Circles {
            asymmetric,
            diameter,
        },
    };
    let cam = &cameras[0];
    let renderer = BoardRenderer::new(cam).unwrap();
    let mut detections = Vec::new();
    let views = calibration_views(&cameras, &printed, 8, 0, 11);
    for (i, v) in views.iter().filter(|v| v.cameras == [0]).enumerate() {
        let img = renderer.render(&printed, &v.pose, 1.0, i as u64);
        let d = detect(&img, &board).unwrap_or_else(|e| panic!("{spec} {}: {e}", v.name));
        let (labelled, turned) = errors(cam, &v.pose, &d);
        println!(
            "{spec} {}: worst {labelled:.3} px ({turned:.3} half-turned)",
            v.name
        );
        if asymmetric {
            assert!(labelled < 0.15, "{spec} {}: {labelled:.3} px", v.name);
        } else {
            assert!(labelled.min(turned) < 0.15, "{spec} {}", v.name);
        }
        detections.push((v.name.clone(), d));
    }
    common::intrinsics_recovered(spec, cam, &detections);
}

#[test]
fn symmetric_circle_grids_calibrate_a_camera() {
    calibrates("circles:7x5", false, 10.0);
}

#[test]
fn asymmetric_circle_grids_are_labelled_and_calibrate_a_camera() {
    calibrates("acircles:4x11", true, 14.0);
}

/// A board partly out of view, or a grid of another size, is not taken for the board.
#[test]
fn a_circle_grid_of_another_size_is_refused() {
    let cam = common::rig_cameras().remove(0);
    let printed = PrintedBoard {
        cols: 4,
        rows: 11,
        square: 20.0,
        pattern: PrintedPattern::Circles {
            asymmetric: true,
            diameter: 14.0,
        },
    };
    let pose = calibration_views(std::slice::from_ref(&cam), &printed, 1, 0, 3)[0].pose;
    let img = BoardRenderer::new(&cam)
        .unwrap()
        .render(&printed, &pose, 1.0, 1);
    for spec in ["acircles:4x12", "acircles:5x11", "circles:4x11"] {
        let board = Board::from_spec(spec, 20.0, None, "").unwrap();
        let e = detect(&img, &board).unwrap_err().to_string();
        println!("{spec}: {e}");
        assert!(e.contains("circle grid"), "{spec}: {e}");
    }
}
