//! Our own grid assembly from a cloud of corner candidates: the fallback when calib-targets'
//! grid growth stitches a board wrongly (a spurious corner joining two rows, as in OpenCV's
//! sample `left12.jpg`). From a seed and its two nearest non-parallel neighbours the grid is
//! grown one step at a time, each new corner predicted by extrapolating its row or column
//! (which follows perspective and lens curvature locally) and accepted only when a candidate
//! lies close to the prediction and shows the chessboard's X-junction — two opposite squares
//! dark, the other two light, the dark pair alternating from corner to corner — so the outer
//! corners of the border squares and clutter beyond the board are left out. Labels are
//! right-handed in the image (never mirrored). Circle grids grow the same way from their
//! circles' centres, with no junction to check.

use image::GrayImage;
use nalgebra::{Point2, Vector2};
use std::collections::{HashMap, VecDeque};

/// Largest distance from a predicted corner to the candidate taken, as a share of the local
/// grid step.
const TOLERANCE: f64 = 0.25;

/// Seeds tried, strongest candidates first.
const SEEDS: usize = 40;

/// A complete `cols × rows` grid of candidates with `(u, v)` labels (u × v right-handed in the
/// image; either side may run along u), grown from the strongest seeds; `None` when no seed
/// gives exactly one complete window. `candidates` are (position, strength).
pub(crate) fn assemble(
    image: &GrayImage,
    candidates: &[(Point2<f64>, f64)],
    cols: usize,
    rows: usize,
) -> Option<Vec<([i32; 2], Point2<f64>)>> {
    grids(Some(image), candidates).find_map(|grid| board_window(&grid, cols as i32, rows as i32))
}

/// The lattices grown from the strongest `candidates` (position, strength) as seeds, with no
/// image check: every candidate near a prediction is taken.
pub(crate) fn grown(
    candidates: &[(Point2<f64>, f64)],
) -> impl Iterator<Item = Vec<([i32; 2], Point2<f64>)>> {
    grids(None, candidates)
}

/// The grids grown from the [`SEEDS`] strongest candidates, strongest first; with `image`,
/// only through chessboard X-junctions.
fn grids<'a>(
    image: Option<&'a GrayImage>,
    candidates: &[(Point2<f64>, f64)],
) -> impl Iterator<Item = Vec<([i32; 2], Point2<f64>)>> + 'a {
    let mut order: Vec<usize> = (0..candidates.len()).collect();
    order.sort_by(|&a, &b| candidates[b].1.total_cmp(&candidates[a].1));
    let points: Vec<Point2<f64>> = candidates.iter().map(|c| c.0).collect();
    order
        .into_iter()
        .take(SEEDS)
        .filter_map(move |seed| grow(image, &points, seed))
}

/// The smallest and largest of each coordinate of `labels`.
pub(crate) fn label_bounds<'a>(
    labels: impl IntoIterator<Item = &'a [i32; 2]>,
) -> ([i32; 2], [i32; 2]) {
    let (mut lo, mut hi) = ([i32::MAX; 2], [i32::MIN; 2]);
    for l in labels {
        for a in 0..2 {
            lo[a] = lo[a].min(l[a]);
            hi[a] = hi[a].max(l[a]);
        }
    }
    (lo, hi)
}

/// The only complete `cols × rows` (or `rows × cols`) window of a grown grid: corners grown
/// past the board's edge onto clutter fall outside it. Two complete windows are ambiguous.
pub(crate) fn board_window(
    grid: &[([i32; 2], Point2<f64>)],
    cols: i32,
    rows: i32,
) -> Option<Vec<([i32; 2], Point2<f64>)>> {
    let at: HashMap<[i32; 2], Point2<f64>> = grid.iter().copied().collect();
    let at = &at;
    let (lo, hi) = label_bounds(grid.iter().map(|(l, _)| l));
    let sizes = if cols == rows {
        vec![(cols, rows)]
    } else {
        vec![(cols, rows), (rows, cols)]
    };
    let windows = sizes.into_iter().flat_map(|(w, h)| {
        (lo[0]..=hi[0] - w + 1).flat_map(move |u0| {
            (lo[1]..=hi[1] - h + 1).map(move |v0| {
                (v0..v0 + h)
                    .flat_map(|v| (u0..u0 + w).map(move |u| [u, v]))
                    .map(|l| at.get(&l).map(|&p| (l, p)))
                    .collect::<Option<Vec<_>>>()
            })
        })
    });
    only_one(windows)
}

/// The one `Some` among `candidates`; `None` when there is none, or more than one (ambiguous).
pub(crate) fn only_one<T>(candidates: impl IntoIterator<Item = Option<T>>) -> Option<T> {
    let mut found = candidates.into_iter().flatten();
    let first = found.next()?;
    found.next().is_none().then_some(first)
}

/// The grid grown from `seed`; with `image`, only through chessboard X-junctions.
fn grow(
    image: Option<&GrayImage>,
    points: &[Point2<f64>],
    seed: usize,
) -> Option<Vec<([i32; 2], Point2<f64>)>> {
    let origin = points[seed];
    let mut near: Vec<(f64, usize)> = points
        .iter()
        .enumerate()
        .filter(|&(i, _)| i != seed)
        .map(|(i, p)| ((p - origin).norm(), i))
        .collect();
    near.sort_by(|a, b| a.0.total_cmp(&b.0));
    let &(d1, first) = near.first()?;
    let step_u = points[first] - origin;
    // The nearest neighbour clearly off the first one's line (and about as far) is the other
    // axis.
    let &(_, second) = near.iter().find(|&&(d, i)| {
        let v = points[i] - origin;
        d < 1.8 * d1 && (v.dot(&step_u) / (v.norm() * d1)).abs() < 0.5
    })?;
    let step_v = points[second] - origin;
    // The seed's X-junction: which diagonal is dark, and how strongly.
    let seed_checker = match image {
        Some(image) => checker(image, origin, step_u, step_v)?,
        None => MIN_CONTRAST,
    };
    if seed_checker.abs() < MIN_CONTRAST {
        return None;
    }
    let mut grid: HashMap<[i32; 2], usize> = HashMap::new();
    let mut used = vec![false; points.len()];
    for (label, i) in [([0, 0], seed), ([1, 0], first), ([0, 1], second)] {
        grid.insert(label, i);
        used[i] = true;
    }
    let mut queue: VecDeque<[i32; 2]> = [[0, 0], [1, 0], [0, 1]].into();
    while let Some(at) = queue.pop_front() {
        for dir in [[1, 0], [-1, 0], [0, 1], [0, -1]] {
            let next = [at[0] + dir[0], at[1] + dir[1]];
            if grid.contains_key(&next) {
                continue;
            }
            let Some((predicted, step)) = predict(points, &grid, at, dir, step_u, step_v) else {
                continue;
            };
            let nearest = points
                .iter()
                .enumerate()
                .filter(|&(i, _)| !used[i])
                .map(|(i, p)| ((p - predicted).norm(), i))
                .min_by(|a, b| a.0.total_cmp(&b.0));
            // The dark diagonal flips with every step along the grid.
            let parity = if (next[0] + next[1]) % 2 == 0 {
                1.0
            } else {
                -1.0
            };
            if let Some((d, i)) = nearest
                && d <= TOLERANCE * step
                && image.is_none_or(|image| {
                    checker(image, points[i], step_u, step_v).is_some_and(|c| {
                        c * seed_checker.signum() * parity >= 0.4 * seed_checker.abs()
                    })
                })
            {
                grid.insert(next, i);
                used[i] = true;
                queue.push_back(next);
            }
        }
    }
    let at = |l: [i32; 2]| grid.get(&l).map(|&i| points[i]);
    // Right-handed in the image (x right, y down): u × v > 0, else swap the labels.
    let (o, u, v) = (at([0, 0])?, at([1, 0])?, at([0, 1])?);
    let (a, b) = (u - o, v - o);
    let swap = a.x * b.y - a.y * b.x < 0.0;
    Some(
        grid.into_iter()
            .map(|(l, i)| (if swap { [l[1], l[0]] } else { l }, points[i]))
            .collect(),
    )
}

/// Least grey-level difference between a seed's dark and light squares.
const MIN_CONTRAST: f64 = 30.0;

/// The X-junction at `p` for lattice steps `a` and `b`: the mean grey of the squares along
/// `a + b` minus that along `a − b` (positive: the `a − b` diagonal is dark); `None` near the
/// image border.
fn checker(image: &GrayImage, p: Point2<f64>, a: Vector2<f64>, b: Vector2<f64>) -> Option<f64> {
    let (d1, d2) = ((a + b) * 0.3, (a - b) * 0.3);
    let grey = |q: Point2<f64>| -> Option<f64> {
        let (x, y) = (q.x.round() as i64, q.y.round() as i64);
        let (w, h) = (image.width() as i64, image.height() as i64);
        if x < 1 || y < 1 || x + 1 >= w || y + 1 >= h {
            return None;
        }
        let mut sum = 0.0;
        for yy in y - 1..=y + 1 {
            for xx in x - 1..=x + 1 {
                sum += image.get_pixel(xx as u32, yy as u32).0[0] as f64;
            }
        }
        Some(sum / 9.0)
    };
    let along = |d: Vector2<f64>| Some((grey(p + d)? + grey(p - d)?) / 2.0);
    Some(along(d1)? - along(d2)?)
}

/// Where the corner one step `dir` from `at` should be, and the local step length: the row or
/// column through `at` extrapolated (second order when three corners are known), else the
/// neighbouring rows' step, else the seed's.
fn predict(
    points: &[Point2<f64>],
    grid: &HashMap<[i32; 2], usize>,
    at: [i32; 2],
    dir: [i32; 2],
    step_u: Vector2<f64>,
    step_v: Vector2<f64>,
) -> Option<(Point2<f64>, f64)> {
    let get = |l: [i32; 2]| grid.get(&l).map(|&i| points[i]);
    let back = |k: i32| [at[0] - k * dir[0], at[1] - k * dir[1]];
    let here = get(at)?;
    if let Some(b1) = get(back(1)) {
        let step = here - b1;
        let curve = get(back(2)).map_or(Vector2::zeros(), |b2| step - (b1 - b2));
        return Some((here + step + curve, step.norm()));
    }
    // No corner behind: borrow the step of a neighbouring row or column.
    let side = [dir[1], dir[0]];
    for s in [1, -1] {
        let n = [at[0] + s * side[0], at[1] + s * side[1]];
        let ahead = [n[0] + dir[0], n[1] + dir[1]];
        if let (Some(p), Some(q)) = (get(n), get(ahead)) {
            let step = q - p;
            return Some((here + step, step.norm()));
        }
    }
    let seed = if dir[0] != 0 { step_u } else { step_v } * (dir[0] + dir[1]) as f64;
    Some((here + seed, seed.norm()))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Board (x, y) in squares → pixels: an affine view of a 9 × 6 inner-corner board.
    fn to_pixel(x: f64, y: f64) -> Point2<f64> {
        Point2::new(100.0 + 30.0 * x + 6.0 * y, 80.0 + 4.0 * x + 28.0 * y)
    }

    /// The board drawn (10 × 7 squares, white margin, grey room) and its 54 corners plus
    /// `spurious` candidates.
    fn scene(spurious: &[Point2<f64>]) -> (GrayImage, Vec<(Point2<f64>, f64)>) {
        let image = GrayImage::from_fn(420, 320, |px, py| {
            let (u, v) = (px as f64 - 100.0, py as f64 - 80.0);
            let det = 30.0 * 28.0 - 6.0 * 4.0;
            let (x, y) = ((28.0 * u - 6.0 * v) / det, (30.0 * v - 4.0 * u) / det);
            let value = if (-1.0..9.0).contains(&x) && (-1.0..6.0).contains(&y) {
                if (x.floor() + y.floor()) as i64 % 2 == 0 {
                    30
                } else {
                    220
                }
            } else if (-1.6..9.6).contains(&x) && (-1.6..6.6).contains(&y) {
                220
            } else {
                120
            };
            image::Luma([value])
        });
        let mut c = Vec::new();
        for r in 0..6 {
            for k in 0..9 {
                c.push((to_pixel(k as f64, r as f64), 1.0 + (k + r) as f64 * 0.01));
            }
        }
        c.extend(spurious.iter().map(|&p| (p, 0.5)));
        (image, c)
    }

    #[test]
    fn grows_the_whole_grid_past_clutter_right_handed() {
        let clutter = [
            Point2::new(20.0, 20.0),
            // The outer corners of two border squares: on the lattice, but no X-junction.
            to_pixel(-1.0, -1.0),
            to_pixel(9.0, 1.0),
            // Halfway between two corners of the second row.
            to_pixel(3.5, 1.0),
        ];
        let (image, c) = scene(&clutter);
        let grid = assemble(&image, &c, 9, 6).expect("the board");
        let (lo, hi) = label_bounds(grid.iter().map(|(l, _)| l));
        let span = ((hi[0] - lo[0] + 1), (hi[1] - lo[1] + 1));
        assert!(span == (9, 6) || span == (6, 9), "{span:?}");
        let get = |l: [i32; 2]| grid.iter().find(|g| g.0 == l).unwrap().1;
        let (o, u, v) = (get(lo), get([lo[0] + 1, lo[1]]), get([lo[0], lo[1] + 1]));
        let (a, b) = (u - o, v - o);
        assert!(a.x * b.y - a.y * b.x > 0.0, "right-handed");
        assert!(grid.iter().all(|(_, p)| !clutter.contains(p)));
    }

    #[test]
    fn an_incomplete_board_is_not_a_grid() {
        let (image, mut c) = scene(&[]);
        c.remove(20);
        assert!(assemble(&image, &c, 9, 6).is_none());
    }
}
