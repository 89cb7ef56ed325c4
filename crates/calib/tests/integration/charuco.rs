//! ChArUco boards rendered through the simulated rig's distorted cameras: every identified
//! corner against its true projection, partial views, and one camera calibrated from them.

use crate::common;

use flexshape_calib::{Board, MIN_CHARUCO_CORNERS, detect};
use flexshape_camera::nalgebra::{Isometry3, Point3, Translation3, UnitQuaternion, Vector3};
use flexshape_sim::{
    BoardRenderer, PrintedBoard, PrintedMarkers, PrintedPattern, calibration_views,
};

/// The board of the test: 10 × 7 squares of 25 mm, 18-mm markers of DICT_4X4_50 (the
/// OpenCV check in `fixtures/charuco_opencv.py` uses the same).
fn boards() -> (Board, PrintedBoard) {
    let board = Board::from_spec("charuco:10x7", 25.0, Some(18.0), "DICT_4X4_50").unwrap();
    let printed = PrintedBoard {
        cols: board.cols,
        rows: board.rows,
        square: board.square,
        pattern: PrintedPattern::Charuco(PrintedMarkers::new(18.0, "DICT_4X4_50").unwrap()),
    };
    (board, printed)
}

/// Largest distance of a detection's corners from where the truth projects their board
/// points, px.
fn worst_error(
    cam: &flexshape_camera::Camera,
    pose: &Isometry3<f64>,
    d: &flexshape_calib::Detection,
) -> f64 {
    d.corners
        .iter()
        .zip(&d.points)
        .map(|(c, p)| {
            let truth = cam.project(&(pose * p)).unwrap().pixel;
            (truth - c).norm()
        })
        .fold(0.0, f64::max)
}

#[test]
fn charuco_corners_are_identified_and_placed_to_a_fraction_of_a_pixel() {
    let cameras = common::rig_cameras();
    let (board, printed) = boards();
    let session = calibration_views(&cameras, &printed, 8, 0, 5);
    let cam = &cameras[0];
    let renderer = BoardRenderer::new(cam).unwrap();
    let mut detections = Vec::new();
    for (i, v) in session.iter().filter(|v| v.cameras == [0]).enumerate() {
        let img = renderer.render(&printed, &v.pose, 1.0, i as u64);
        let d = detect(&img, &board).unwrap_or_else(|e| panic!("{}: {e}", v.name));
        let worst = worst_error(cam, &v.pose, &d);
        println!(
            "{}: {} corners, worst {worst:.3} px",
            v.name,
            d.corners.len()
        );
        assert!(d.corners.len() >= 40, "{}: {}", v.name, d.corners.len());
        assert!(worst < 0.3, "{}: {worst:.3} px", v.name);
        detections.push((v.name.clone(), d));
    }
    common::intrinsics_recovered("charuco", cam, &detections);
}

/// A board half out of the image still gives its visible corners, each with the right
/// label; a chessboard detector needs the whole board.
#[test]
fn a_partly_seen_charuco_board_gives_its_visible_corners() {
    let cam = common::rig_cameras().remove(0);
    let (board, printed) = boards();
    // Facing the camera, turned 25° in its plane and tilted 20°, 150 mm off its axis
    // sideways: about half the board out.
    let eye = cam.centre();
    let towards = (Point3::origin() - eye).normalize();
    let rotation = UnitQuaternion::rotation_between(&Vector3::z(), &towards).unwrap()
        * UnitQuaternion::from_euler_angles(0.35, 0.0, 0.44);
    let side = rotation * Vector3::x();
    let centre = Point3::origin() + side * 150.0;
    let half = Vector3::new(board.cols as f64 - 1.0, board.rows as f64 - 1.0, 0.0) * 12.5;
    let pose = Isometry3::from_parts(
        Translation3::from(centre.coords - rotation * half),
        rotation,
    );
    let img = BoardRenderer::new(&cam)
        .unwrap()
        .render(&printed, &pose, 1.0, 9);
    let d = detect(&img, &board).unwrap();
    let all = board.corners();
    println!("{} of {all} corners", d.corners.len());
    assert!(d.corners.len() >= MIN_CHARUCO_CORNERS && d.corners.len() < all);
    let worst = worst_error(&cam, &pose, &d);
    println!("worst {worst:.3} px");
    assert!(worst < 0.3, "{worst}");
}
