//! Chessboard corners in an image, labelled in the board's frame.
//!
//! calib-targets finds the ChESS corners (refined by its saddle-point fit) and grows a grid
//! with labels relative to the image. A detection is accepted only when its labels form the
//! whole `cols × rows` rectangle; it is then turned (never mirrored) so the grid's long side
//! is the board's `cols`, and turned by 180° when needed so the origin is the inner corner
//! whose outer corner square is dark — the board's own corner, the same in every camera
//! that sees its front. When calib-targets' grid growth gives no whole board, our own
//! assembly (`lattice`) tries its corner cloud.
//!
//! A ChArUco board's corners are identified by its markers (calib-targets' ChArUco detector,
//! with the same saddle-point refiner), so a view of part of the board is enough.

use calib_targets::charuco::{CharucoBoardSpec, CharucoParams};
use calib_targets::chessboard::ChessboardParams;
use calib_targets::core::ImageRefiner;
use calib_targets::detect as ct;
use image::GrayImage;
use nalgebra::{Point2, Point3, Vector2};

use crate::board::{Markers, Pattern};
use crate::lattice::label_bounds;
use crate::{Board, CalibError};

/// A board found in an image: corners and where each lies on the board.
#[derive(Debug, Clone, PartialEq)]
pub struct Detection {
    /// Pixel positions (OpenCV convention). For a chessboard every corner, row by row (`c`
    /// fastest), as [`Board::points`] orders them.
    pub corners: Vec<Point2<f64>>,
    /// Each corner in the board frame, mm.
    pub points: Vec<Point3<f64>>,
}

impl Detection {
    /// The same corners labelled the other way round (for a board that looks the same turned
    /// half a turn, see [`Board::half_turn`]): corner `i` is the one that was `n − 1 − i`.
    pub fn half_turned(&self) -> Detection {
        Detection {
            corners: self.corners.iter().rev().copied().collect(),
            points: self.points.clone(),
        }
    }
}

/// Fewest ChArUco corners a view must show, on at least two rows and two columns (a
/// homography needs four off one line; a few more keep a poorly seen corner from deciding).
pub const MIN_CHARUCO_CORNERS: usize = 8;

/// Finds `board` in `image`, or says why not.
pub fn detect(image: &GrayImage, board: &Board) -> Result<Detection, CalibError> {
    let chess = ct::default_chess_config().with_refiner(ImageRefiner::saddle_point());
    match &board.pattern {
        Pattern::Chessboard => {}
        Pattern::Charuco(markers) => return detect_charuco(image, board, markers, chess),
        Pattern::Circles { asymmetric } => {
            return crate::circles::detect(image, board, *asymmetric)
                .map_err(CalibError::NotDetected);
        }
    }
    let mut configs = vec![ChessboardParams::default()];
    configs.extend(ChessboardParams::sweep_default());
    let mut why = String::from("no chessboard grid found");
    for params in configs {
        let Ok(found) = ct::detect_chessboard(image, &chess, &params) else {
            continue;
        };
        let labelled: Vec<([i32; 2], Point2<f64>)> = found
            .corners
            .iter()
            .map(|c| {
                (
                    [c.grid.u, c.grid.v],
                    Point2::new(c.position.x as f64, c.position.y as f64),
                )
            })
            .collect();
        match label(&labelled, board, image) {
            Ok(d) => return Ok(d),
            Err(e) => why = e,
        }
    }
    // calib-targets stitched no whole board: assemble one ourselves from its corner cloud.
    let candidates: Vec<(Point2<f64>, f64)> = ct::detect_corners(image, &chess)
        .iter()
        .map(|c| {
            (
                Point2::new(c.position.x as f64, c.position.y as f64),
                c.strength as f64,
            )
        })
        .collect();
    if let Some(grid) = crate::lattice::assemble(image, &candidates, board.cols, board.rows)
        && let Ok(d) = label(&grid, board, image)
    {
        return Ok(d);
    }
    Err(CalibError::NotDetected(why))
}

/// The board-frame order of a detection whose grid labels are `(u, v)` (u rightward, v
/// downward in the image), or why it is not the whole board.
fn label(
    found: &[([i32; 2], Point2<f64>)],
    board: &Board,
    image: &GrayImage,
) -> Result<Detection, String> {
    let (lo, hi) = label_bounds(found.iter().map(|(l, _)| l));
    let (w, h) = ((hi[0] - lo[0] + 1) as usize, (hi[1] - lo[1] + 1) as usize);
    let whole = found.len() == board.corners()
        && ((w, h) == (board.cols, board.rows) || (w, h) == (board.rows, board.cols));
    if !whole {
        return Err(format!(
            "{} corners spanning {w}×{h}, expected the whole {}×{} board (partial or ambiguous view)",
            found.len(),
            board.cols,
            board.rows
        ));
    }
    let mut grid = vec![None; board.corners()];
    // Turn the image-relative labels into board labels without mirroring: the long side is
    // `cols`; on a square board the image's u is.
    let turned = w != board.cols;
    for &(g, p) in found {
        let (u, v) = ((g[0] - lo[0]) as usize, (g[1] - lo[1]) as usize);
        let (c, r) = if turned { (v, w - 1 - u) } else { (u, v) };
        let slot = &mut grid[r * board.cols + c];
        if slot.is_some() {
            return Err("two corners with the same grid label".into());
        }
        *slot = Some(p);
    }
    let mut corners: Vec<Point2<f64>> = grid
        .into_iter()
        .collect::<Option<Vec<_>>>()
        .ok_or("a grid label is missing")?;
    // The outer corner square at the origin, half a square diagonally out from it.
    let outside = |origin: usize, along_c: usize, along_r: usize| -> Option<f64> {
        let o = corners[origin];
        let dc: Vector2<f64> = corners[along_c] - o;
        let dr: Vector2<f64> = corners[along_r] - o;
        mean_grey(
            image,
            o - (dc + dr) * 0.5,
            (dc.norm().min(dr.norm()) * 0.25).max(1.0),
        )
    };
    // The four outer corner squares: dark where their square's parity is even (the origin's
    // always). A 180° turn swaps opposite corners; keep the labelling whose expected shades
    // agree better with the image's.
    let (cols, rows) = (board.cols, board.rows);
    let last = cols * rows - 1;
    let samples = [
        (outside(0, 1, cols), true),
        (outside(cols - 1, cols - 2, 2 * cols - 1), cols % 2 == 0),
        (outside(last, last - 1, last - cols), (cols + rows) % 2 == 0),
        (
            outside(last + 1 - cols, last + 2 - cols, last + 1 - 2 * cols),
            rows % 2 == 0,
        ),
    ];
    let seen: Vec<f64> = samples.iter().filter_map(|(g, _)| *g).collect();
    if !seen.is_empty() {
        let mean = seen.iter().sum::<f64>() / seen.len() as f64;
        let shade = |dark: bool| if dark { -1.0 } else { 1.0 };
        let (mut keep, mut turn) = (0.0, 0.0);
        for (i, (g, dark)) in samples.iter().enumerate() {
            if let Some(g) = g {
                keep += shade(*dark) * (g - mean);
                turn += shade(samples[(i + 2) % 4].1) * (g - mean);
            }
        }
        if turn > keep {
            corners.reverse();
        }
    }
    Ok(Detection {
        corners,
        points: board.points(),
    })
}

/// The ChArUco corners `image` shows of `board`.
fn detect_charuco(
    image: &GrayImage,
    board: &Board,
    markers: &Markers,
    chess: calib_targets::core::DetectorConfig,
) -> Result<Detection, CalibError> {
    let dictionary =
        calib_targets::aruco::resolve_dictionary(markers.dictionary).ok_or_else(|| {
            CalibError::NotDetected(format!("unknown dictionary {}", markers.dictionary))
        })?;
    let spec = CharucoBoardSpec::new(
        (board.rows + 1) as u32,
        (board.cols + 1) as u32,
        board.square as f32,
        (markers.side / board.square) as f32,
        dictionary,
    );
    let configs: Vec<CharucoParams> = CharucoParams::sweep_for_board(&spec)
        .into_iter()
        .map(|mut p| {
            p.chess = chess;
            p
        })
        .collect();
    let found = ct::detect_charuco_best(image, &configs)
        .map_err(|e| CalibError::NotDetected(format!("no ChArUco board found ({e})")))?;
    let (mut corners, mut points) = (Vec::new(), Vec::new());
    for c in &found.corners {
        let id = c.id as usize;
        let (i, j) = (id % board.cols, id / board.cols);
        if j >= board.rows {
            continue;
        }
        corners.push(Point2::new(c.position.x as f64, c.position.y as f64));
        points.push(board.point(i, j));
    }
    let (corners, points) = consistent(corners, points, board.square);
    // Distinct board columns (x) and rows (y) among the corners.
    let distinct = |along: fn(&Point3<f64>) -> f64| {
        let mut v: Vec<i64> = points
            .iter()
            .map(|p| (along(p) / board.square).round() as i64)
            .collect();
        v.sort_unstable();
        v.dedup();
        v.len()
    };
    if corners.len() < MIN_CHARUCO_CORNERS || distinct(|p| p.x) < 2 || distinct(|p| p.y) < 2 {
        return Err(CalibError::NotDetected(format!(
            "{} ChArUco corners identified (at least {MIN_CHARUCO_CORNERS}, on two rows and two columns, needed)",
            corners.len()
        )));
    }
    Ok(Detection { corners, points })
}

/// Farthest a corner may lie from where its neighbours put it, px.
const NEIGHBOUR_TOLERANCE_PX: f64 = 1.0;

/// The corners that agree with their neighbours: each is predicted by a homography through the
/// other corners within two squares of it (a lens bends the board's image too little over two
/// squares to matter); the one farthest from its prediction is dropped while it lies more than
/// [`NEIGHBOUR_TOLERANCE_PX`] away, and corners with too few neighbours to be checked go too.
/// The ChArUco detector now and then labels a point a few pixels off as a board corner.
fn consistent(
    mut corners: Vec<Point2<f64>>,
    mut points: Vec<Point3<f64>>,
    square: f64,
) -> (Vec<Point2<f64>>, Vec<Point3<f64>>) {
    loop {
        let off: Vec<Option<f64>> = (0..corners.len())
            .map(|k| off_neighbours(&corners, &points, k, square))
            .collect();
        let worst = off
            .iter()
            .enumerate()
            .filter_map(|(k, d)| d.map(|d| (k, d)))
            .max_by(|a, b| a.1.total_cmp(&b.1));
        match worst {
            Some((k, d)) if d > NEIGHBOUR_TOLERANCE_PX => {
                corners.remove(k);
                points.remove(k);
            }
            _ => {
                return corners
                    .into_iter()
                    .zip(points)
                    .zip(off)
                    .filter_map(|(c, d)| d.is_some().then_some(c))
                    .unzip();
            }
        }
    }
}

/// How far corner `k` lies from where the corners within two squares of it put it, px;
/// `None` with fewer than six of them.
fn off_neighbours(
    corners: &[Point2<f64>],
    points: &[Point3<f64>],
    k: usize,
    square: f64,
) -> Option<f64> {
    let near: Vec<usize> = (0..corners.len())
        .filter(|&j| {
            j != k
                && (points[j].x - points[k].x).abs() <= 2.0 * square + 1e-9
                && (points[j].y - points[k].y).abs() <= 2.0 * square + 1e-9
        })
        .collect();
    if near.len() < 6 {
        return None;
    }
    let plane: Vec<Point2<f64>> = near
        .iter()
        .map(|&j| Point2::new(points[j].x, points[j].y))
        .collect();
    let pixels: Vec<Point2<f64>> = near.iter().map(|&j| corners[j]).collect();
    let h = crate::homography::fit(&plane, &pixels)?;
    let p = h * nalgebra::Vector3::new(points[k].x, points[k].y, 1.0);
    Some((Point2::new(p.x / p.z, p.y / p.z) - corners[k]).norm())
}

/// Mean grey level in a square of half-width `radius` around `centre`, if inside the image.
fn mean_grey(image: &GrayImage, centre: Point2<f64>, radius: f64) -> Option<f64> {
    let (x0, x1) = ((centre.x - radius).round(), (centre.x + radius).round());
    let (y0, y1) = ((centre.y - radius).round(), (centre.y + radius).round());
    if x0 < 0.0 || y0 < 0.0 || x1 >= image.width() as f64 || y1 >= image.height() as f64 {
        return None;
    }
    let (mut sum, mut n) = (0.0, 0.0);
    for y in y0 as u32..=y1 as u32 {
        for x in x0 as u32..=x1 as u32 {
            sum += image.get_pixel(x, y).0[0] as f64;
            n += 1.0;
        }
    }
    Some(sum / n)
}
