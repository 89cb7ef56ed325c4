//! Circle grids (OpenCV's symmetric and asymmetric layouts): dark dots on a light board.
//!
//! Dots are the dark connected regions below Otsu's threshold whose second moments say they
//! are filled ellipses (a circle seen in perspective) of a plausible size; each is placed at
//! its grey-weighted centroid. The centres grow into a lattice as chessboard corners do
//! (`lattice`, with no junction to check), and the board is the one window of the lattice
//! that holds every dot: for a symmetric grid a `cols × rows` rectangle (the origin taken as
//! the corner dot nearer the image's top left: the grid itself cannot tell the two ends
//! apart); for an asymmetric grid — whose nearest neighbours are diagonal — the rows offset by
//! half a spacing, which fixes its orientation.

use image::GrayImage;
use nalgebra::Point2;
use std::collections::HashMap;

use crate::lattice::{label_bounds, only_one};
use crate::{Board, Detection};

/// Smallest dot, pixels.
const MIN_AREA: usize = 12;
/// Longest ratio of a dot's axes (a circle tilted by 75°).
const MAX_ELONGATION: f64 = 4.0;

/// The circle grid of `board` in `image`, or why not.
pub(crate) fn detect(
    image: &GrayImage,
    board: &Board,
    asymmetric: bool,
) -> Result<Detection, String> {
    let count = board.cols * board.rows;
    let dots = dots(image, count);
    if dots.len() < count {
        return Err(format!(
            "{} dots found, the {}×{} circle grid has {count}",
            dots.len(),
            board.cols,
            board.rows
        ));
    }
    for grid in crate::lattice::grown(&dots) {
        let labelled = if asymmetric {
            asymmetric_window(&grid, board)
        } else {
            symmetric_window(&grid, board)
        };
        if let Some(corners) = labelled {
            return Ok(Detection {
                corners,
                points: board.points(),
            });
        }
    }
    Err(format!(
        "{} dots found but no whole {}×{} {}circle grid among them",
        dots.len(),
        board.cols,
        board.rows,
        if asymmetric { "asymmetric " } else { "" }
    ))
}

/// The dots of a symmetric grid in board order, from a grown lattice.
fn symmetric_window(grid: &[([i32; 2], Point2<f64>)], board: &Board) -> Option<Vec<Point2<f64>>> {
    let window = crate::lattice::board_window(grid, board.cols as i32, board.rows as i32)?;
    let (lo, hi) = label_bounds(window.iter().map(|(l, _)| l));
    let w = (hi[0] - lo[0] + 1) as usize;
    // The long side is `cols` (turned, never mirrored); on a square grid the image's u is.
    let turned = w != board.cols;
    let mut ordered = vec![Point2::origin(); board.cols * board.rows];
    for (l, p) in window {
        let (u, v) = ((l[0] - lo[0]) as usize, (l[1] - lo[1]) as usize);
        let (c, r) = if turned { (v, w - 1 - u) } else { (u, v) };
        ordered[r * board.cols + c] = p;
    }
    // A half turn gives the same grid: start at the end nearer the image's top left.
    let (first, last) = (ordered[0], ordered[ordered.len() - 1]);
    if last.x + last.y < first.x + first.y {
        ordered.reverse();
    }
    Some(ordered)
}

/// The dots of an asymmetric grid in board order, from a grown lattice: its steps are the
/// board's diagonals, so lattice label `(u, v)` (in one of four quarter turns) is board
/// position `(u + v, v − u)` in half-spacings, and the board is the one offset at which every
/// `(2c + r mod 2, r)` is there.
fn asymmetric_window(grid: &[([i32; 2], Point2<f64>)], board: &Board) -> Option<Vec<Point2<f64>>> {
    let (cols, rows) = (board.cols as i32, board.rows as i32);
    // Board positions of the lattice's dots, in each of its four quarter turns.
    let turns: Vec<HashMap<[i32; 2], Point2<f64>>> = (0..4)
        .map(|turn| {
            grid.iter()
                .map(|&(l, p)| {
                    let (mut u, mut v) = (l[0], l[1]);
                    for _ in 0..turn {
                        (u, v) = (-v, u);
                    }
                    ([u + v, v - u], p)
                })
                .collect()
        })
        .collect();
    only_one(turns.iter().flat_map(|at| {
        let (lo, hi) = label_bounds(at.keys());
        (lo[0]..=hi[0] - (2 * cols - 1) + 1).flat_map(move |x0| {
            (lo[1]..=hi[1] - rows + 1).map(move |y0| {
                (0..rows)
                    .flat_map(|r| (0..cols).map(move |c| [x0 + 2 * c + r % 2, y0 + r]))
                    .map(|l| at.get(&l).copied())
                    .collect::<Option<Vec<Point2<f64>>>>()
            })
        })
    }))
}

/// Dark blobs shaped like filled ellipses, each no larger than a `count`-th of the image:
/// (grey-weighted centre, area in pixels).
fn dots(image: &GrayImage, count: usize) -> Vec<(Point2<f64>, f64)> {
    let (w, h) = (image.width() as usize, image.height() as usize);
    let pixels = image.as_raw();
    let threshold = otsu(pixels);
    let largest = w * h / count.max(1);
    let mut seen = vec![false; w * h];
    let mut stack = Vec::new();
    let mut out = Vec::new();
    for start in 0..w * h {
        if seen[start] || pixels[start] >= threshold {
            continue;
        }
        // One 4-connected dark region: its pixels, bounds and moments.
        let mut region = Vec::new();
        seen[start] = true;
        stack.push(start);
        let mut touches_border = false;
        while let Some(i) = stack.pop() {
            region.push(i);
            let (x, y) = (i % w, i / w);
            touches_border |= x == 0 || y == 0 || x + 1 == w || y + 1 == h;
            let mut visit = |j: usize| {
                if !seen[j] && pixels[j] < threshold {
                    seen[j] = true;
                    stack.push(j);
                }
            };
            if x > 0 {
                visit(i - 1);
            }
            if x + 1 < w {
                visit(i + 1);
            }
            if y > 0 {
                visit(i - w);
            }
            if y + 1 < h {
                visit(i + w);
            }
        }
        if touches_border || region.len() < MIN_AREA || region.len() > largest {
            continue;
        }
        if let Some(centre) = ellipse_centre(image, &region, threshold) {
            out.push((centre, region.len() as f64));
        }
    }
    out
}

/// The grey-weighted centre of a dark `region` (pixel indices) if its second moments are
/// those of a filled ellipse.
fn ellipse_centre(image: &GrayImage, region: &[usize], threshold: u8) -> Option<Point2<f64>> {
    let w = image.width() as usize;
    let n = region.len() as f64;
    let (mut sx, mut sy) = (0.0, 0.0);
    for &i in region {
        sx += (i % w) as f64;
        sy += (i / w) as f64;
    }
    let (mx, my) = (sx / n, sy / n);
    let (mut cxx, mut cyy, mut cxy) = (0.0, 0.0, 0.0);
    for &i in region {
        let (dx, dy) = ((i % w) as f64 - mx, (i / w) as f64 - my);
        cxx += dx * dx;
        cyy += dy * dy;
        cxy += dx * dy;
    }
    let (cxx, cyy, cxy) = (cxx / n, cyy / n, cxy / n);
    // A filled ellipse of semi-axes a ≥ b has second moments a²/4 and b²/4 along its axes,
    // and area πab.
    let mean = (cxx + cyy) / 2.0;
    let spread = ((cxx - cyy) * (cxx - cyy) / 4.0 + cxy * cxy).sqrt();
    let (l1, l2) = (mean + spread, mean - spread);
    if l2 <= 0.0 || (l1 / l2).sqrt() > MAX_ELONGATION {
        return None;
    }
    let area = 4.0 * std::f64::consts::PI * (l1 * l2).sqrt();
    if !(0.8..=1.25).contains(&(n / area)) {
        return None;
    }
    // Grey-weighted over the region and a two-pixel ring around it: each pixel weighs by how
    // much darker than the threshold's light side it is, so the boundary's partly covered
    // pixels count by their share.
    let radius = 2.0 * l1.sqrt() + 2.0;
    let (x0, x1) = ((mx - radius).floor().max(0.0), (mx + radius).ceil());
    let (y0, y1) = ((my - radius).floor().max(0.0), (my + radius).ceil());
    let x1 = x1.min(image.width() as f64 - 1.0);
    let y1 = y1.min(image.height() as f64 - 1.0);
    let dark: f64 = region
        .iter()
        .map(|&i| image.as_raw()[i] as f64)
        .sum::<f64>()
        / n;
    let light = (2.0 * threshold as f64 - dark).clamp(threshold as f64, 255.0);
    let (mut wsum, mut wx, mut wy) = (0.0, 0.0, 0.0);
    for y in y0 as u32..=y1 as u32 {
        for x in x0 as u32..=x1 as u32 {
            let (dx, dy) = (x as f64 - mx, y as f64 - my);
            // Inside the ellipse grown by two pixels (Mahalanobis distance in its moments).
            let det = cxx * cyy - cxy * cxy;
            let m = (cyy * dx * dx - 2.0 * cxy * dx * dy + cxx * dy * dy) / det;
            let grown = (2.0 + 2.0 / l2.sqrt()).powi(2);
            if m > grown {
                continue;
            }
            let g = image.get_pixel(x, y).0[0] as f64;
            let wt = ((light - g) / (light - dark)).clamp(0.0, 1.0);
            wsum += wt;
            wx += wt * x as f64;
            wy += wt * y as f64;
        }
    }
    (wsum > 0.0).then(|| Point2::new(wx / wsum, wy / wsum))
}

/// Otsu's threshold of an 8-bit image: the grey level that best splits its histogram in two.
fn otsu(pixels: &[u8]) -> u8 {
    let mut hist = [0u64; 256];
    for &p in pixels {
        hist[p as usize] += 1;
    }
    let total = pixels.len() as f64;
    let sum: f64 = hist
        .iter()
        .enumerate()
        .map(|(g, &c)| g as f64 * c as f64)
        .sum();
    let (mut below, mut below_sum) = (0.0, 0.0);
    let (mut best, mut best_var) = (128u8, -1.0);
    for (g, &c) in hist.iter().enumerate() {
        below += c as f64;
        below_sum += g as f64 * c as f64;
        let above = total - below;
        if below == 0.0 || above == 0.0 {
            continue;
        }
        let (m0, m1) = (below_sum / below, (sum - below_sum) / above);
        let var = below * above * (m0 - m1) * (m0 - m1);
        if var > best_var {
            best_var = var;
            // Pixels below `g + 1` are dark.
            best = (g + 1).min(255) as u8;
        }
    }
    best
}
