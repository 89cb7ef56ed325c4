//! Ordering the carved cloud along the tube, and cutting it into slices across it.
//!
//! The robust method: on the coarse cell graph, a double sweep of shortest paths finds the two
//! ends (the farthest node from anywhere, then the farthest from that); slices of equal
//! geodesic distance from one end give a first axis. Each voxel is then projected onto that
//! axis and the cloud re-sliced perpendicular to it, twice, so slices end up square to the
//! tube wherever it bends (geodesic level sets are not: they are spheres around the end).
//! A closed loop shows as slices that fall into two pieces; two objects as two components.
//!
//! The proximal end is the one whose voxels touch the volume's boundary (the tube enters
//! there), or, when neither does, the only one within 4 voxels of it. Otherwise it is the end
//! nearer `proximal_hint` if given; else it is only guessed (the end nearer the boundary) and
//! `Slices::oriented` says so — the shape stage then asks the bands, and without them the
//! frame is `ambiguous`.
//!
//! [`angle_order`] is the paper's baseline, kept for comparison.

use flexshape_carve::Occupancy;

use crate::graph::{CellGraph, farthest};
use crate::record::Status;
use crate::settings::{SPACING_MM, ShapeSettings};

/// The cloud cut into slices across the tube, proximal end first.
#[derive(Debug, Clone)]
pub(crate) struct Slices {
    /// Axis parameter of each slice (mean over its voxels), mm, increasing toward the tip.
    pub s: Vec<f64>,
    /// Centroid of each slice, world mm.
    pub centroid: Vec<[f64; 3]>,
    /// Voxels in each slice.
    pub count: Vec<f64>,
    /// Axis parameter of each occupied voxel (NaN for voxels not in the tube's component).
    pub voxel_s: Vec<f64>,
    /// Smallest and largest voxel parameter.
    pub s_range: [f64; 2],
    /// Slice spacing, mm.
    pub spacing: f64,
    /// Whether the proximal end touches the volume's boundary.
    pub enters_volume: bool,
    /// Whether the tip end touches the volume's boundary too (the tube leaves the volume).
    pub leaves_volume: bool,
    /// Whether something decided which end is proximal (the volume's boundary or the hint);
    /// false when it was only guessed (the end nearer the boundary).
    pub oriented: bool,
    /// Gaps between pieces of the hull chained into this one tube, world mm (empty unless
    /// asked for; see [`slice`]).
    pub gaps: Vec<crate::pieces::Gap>,
}

/// A polyline with cumulative chord lengths, for projecting voxels onto.
struct Axis {
    points: Vec<[f64; 3]>,
    arc: Vec<f64>,
}

impl Axis {
    fn new(points: Vec<[f64; 3]>) -> Self {
        let mut arc = vec![0.0];
        for w in points.windows(2) {
            arc.push(arc[arc.len() - 1] + dist(w[0], w[1]));
        }
        Axis { points, arc }
    }

    /// Arc parameter of the point of the axis nearest `p`, and the segment holding it,
    /// searching the segments within `reach` of segment `guess`; beyond an end the axis
    /// continues straight.
    fn project(&self, p: [f64; 3], guess: usize, reach: usize) -> (f64, usize) {
        let n = self.points.len();
        let first = guess.saturating_sub(reach).min(n - 2);
        let last = (guess + reach).min(n - 2);
        let (mut best, mut best_seg, mut best_d2) = (0.0, first, f64::INFINITY);
        for k in first..=last {
            let (a, b) = (self.points[k], self.points[k + 1]);
            let ab = sub(b, a);
            let len2 = dot(ab, ab).max(1e-18);
            let raw = dot(sub(p, a), ab) / len2;
            // Extend the first and last segments beyond the axis's ends.
            let lo = if k == 0 { f64::NEG_INFINITY } else { 0.0 };
            let hi = if k == n - 2 { f64::INFINITY } else { 1.0 };
            let t = raw.clamp(lo, hi);
            let q = [a[0] + ab[0] * t, a[1] + ab[1] * t, a[2] + ab[2] * t];
            let d2 = dot(sub(p, q), sub(p, q));
            if d2 < best_d2 {
                (best, best_seg, best_d2) = (self.arc[k] + t * len2.sqrt(), k, d2);
            }
        }
        (best, best_seg)
    }
}

/// Points cut into slices square to an axis.
struct Cut {
    /// Each point's axis parameter (NaN for points not searched).
    s: Vec<f64>,
    /// Smallest and largest parameter.
    range: [f64; 2],
    /// Per non-empty slice: weighted centroid, weighted mean parameter, total weight.
    centroid: Vec<[f64; 3]>,
    mean_s: Vec<f64>,
    weight: Vec<f64>,
    /// Each point's slice (index into the non-empty slices).
    slice_of: Vec<usize>,
}

impl Cut {
    /// Projects `points` (those whose `guess` is not `usize::MAX`) onto `axis`, searching
    /// `reach` segments either side of their guess, and slices them `spacing` mm apart.
    fn new(
        axis: &Axis,
        points: &[[f64; 3]],
        weights: &[f64],
        guess: &[usize],
        reach: usize,
        spacing: f64,
    ) -> Self {
        let s: Vec<f64> = points
            .iter()
            .zip(guess)
            .map(|(&p, &g)| {
                if g == usize::MAX {
                    f64::NAN
                } else {
                    axis.project(p, g, reach).0
                }
            })
            .collect();
        let (lo, hi) = s
            .iter()
            .filter(|v| !v.is_nan())
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| {
                (a.min(v), b.max(v))
            });
        let nb = ((hi - lo) / spacing).floor() as usize + 1;
        let bin_of = |v: f64| (((v - lo) / spacing) as usize).min(nb - 1);
        let mut acc = vec![([0.0; 3], 0.0, 0.0); nb];
        for ((p, &v), &w) in points.iter().zip(&s).zip(weights) {
            if v.is_nan() {
                continue;
            }
            let e = &mut acc[bin_of(v)];
            for (sum, x) in e.0.iter_mut().zip(p) {
                *sum += w * x;
            }
            e.1 += w * v;
            e.2 += w;
        }
        // Non-empty slices, and each bin's non-empty slice (the previous one if empty).
        let mut index = vec![0usize; nb];
        let (mut centroid, mut mean_s, mut weight) = (Vec::new(), Vec::new(), Vec::new());
        for (b, (sum, sw, w)) in acc.iter().enumerate() {
            if *w > 0.0 {
                centroid.push(sum.map(|v| v / w));
                mean_s.push(sw / w);
                weight.push(*w);
            }
            index[b] = centroid.len().saturating_sub(1);
        }
        let slice_of = s
            .iter()
            .map(|&v| {
                if v.is_nan() {
                    usize::MAX
                } else {
                    index[bin_of(v)]
                }
            })
            .collect();
        Cut {
            s,
            range: [lo, hi],
            centroid,
            mean_s,
            weight,
            slice_of,
        }
    }

    /// Guesses for projecting the same points onto the axis through these slices.
    fn next_guess(&self) -> Vec<usize> {
        self.slice_of.clone()
    }
}

/// Orders the occupancy into slices, or says why it cannot. With `across_gaps`, a hull in
/// pieces that lie end to end along one tube is chained across its gaps
/// ([`crate::pieces::chain`]), which [`Slices::gaps`] lists; without, it is two objects.
pub(crate) fn slice(
    occ: &Occupancy,
    settings: &ShapeSettings,
    across_gaps: bool,
) -> Result<Slices, Status> {
    let n = occ.voxels.len();
    if n < settings.min_voxels {
        return Err(Status::NoObject { voxels: n });
    }
    let vs = occ.volume.voxel_size;
    let voxel = vs.iter().copied().fold(f64::INFINITY, f64::min);
    // The voxel edge is held to the range a given `slice_mm` must keep: a voxel of 1e-300 mm
    // asked for more slices than an index can count.
    let spacing = if settings.slice_mm > 0.0 {
        settings.slice_mm
    } else {
        voxel.clamp(SPACING_MM.0, SPACING_MM.1)
    };
    let cell_mm = settings.cell_voxels as f64 * vs.iter().copied().fold(0.0, f64::max);
    let mut graph = CellGraph::new(occ, settings.cell_voxels);
    let mut components = graph.components();
    let main_voxels = graph.voxels_in(&components[0]) as usize;
    if main_voxels < settings.min_voxels {
        return Err(Status::NoObject { voxels: n });
    }
    // Pieces as large as a tenth of the largest count as objects; smaller ones are left out.
    let large = settings.min_voxels.max(main_voxels / 10);
    let pieces: Vec<&[u32]> = components
        .iter()
        .take_while(|c| graph.voxels_in(c) as usize >= large)
        .map(|c| c.as_slice())
        .collect();
    let mut gaps = Vec::new();
    if pieces.len() >= 2 {
        let chained = across_gaps
            .then(|| crate::pieces::chain(&graph, &pieces, cell_mm))
            .flatten();
        let Some((links, crossed)) = chained else {
            let second = graph.voxels_in(pieces[1]);
            return Err(Status::Ambiguous {
                reason: format!(
                    "two separate objects ({main_voxels} and {second} voxels); check for occluders or a second instrument in the volume"
                ),
            });
        };
        graph = graph.linked(&links);
        components = graph.components();
        gaps = crossed;
    }
    let main = &components[0];
    let main_voxels = graph.voxels_in(main) as usize;
    let (a, _) = farthest(&graph.distances(main[0]));
    let from_a = graph.distances(a);
    let (_, length) = farthest(&from_a);
    // A tube of length L holding n voxels has radius ≈ √(n·v / πL): it must be at least twice
    // as long as it is wide to be followed.
    let voxel_volume: f64 = vs.iter().product();
    let width = 2.0
        * (main_voxels as f64 * voxel_volume / (std::f64::consts::PI * length.max(1e-9))).sqrt();
    if length < 3.0 * cell_mm || length < 2.0 * width {
        return Err(Status::Ambiguous {
            reason: format!(
                "the object is {length:.1} mm long and about {width:.1} mm wide: too short to follow as a tube"
            ),
        });
    }
    check_open(&graph, main, &from_a, 2.0 * cell_mm)?;

    // First axis: centroids of geodesic slices one cell thick.
    let bins = (length / cell_mm).floor() as usize + 1;
    let mut sums = vec![([0.0; 3], 0.0); bins];
    for &m in main {
        let b = (from_a[m as usize] / cell_mm) as usize;
        for c in 0..3 {
            sums[b].0[c] += graph.sum[m as usize][c];
        }
        sums[b].1 += graph.count[m as usize] as f64;
    }
    let mut vertex_of_bin = vec![0usize; bins];
    let mut points = Vec::new();
    for (b, (s, k)) in sums.iter().enumerate() {
        if *k > 0.0 {
            points.push(s.map(|v| v / k));
        }
        vertex_of_bin[b] = points.len().saturating_sub(1);
    }
    let mut axis = Axis::new(smooth3(&points));
    // Refine the axis twice on the cells (a few per slice, cheap), then cut the voxels once.
    let nodes: Vec<usize> = main.iter().map(|&m| m as usize).collect();
    let node_points: Vec<[f64; 3]> = nodes.iter().map(|&m| graph.centroid(m)).collect();
    let node_weights: Vec<f64> = nodes.iter().map(|&m| graph.count[m] as f64).collect();
    let mut node_guess: Vec<usize> = nodes
        .iter()
        .map(|&m| vertex_of_bin[(from_a[m] / cell_mm) as usize])
        .collect();
    for _ in 0..2 {
        let cut = Cut::new(&axis, &node_points, &node_weights, &node_guess, 3, cell_mm);
        node_guess = cut.next_guess();
        axis = Axis::new(smooth3(&cut.centroid));
    }
    let mut guess = vec![usize::MAX; occ.voxels.len()];
    let mut node_at = vec![usize::MAX; graph.len()];
    for (&m, &g) in nodes.iter().zip(&node_guess) {
        node_at[m] = g;
    }
    for (g, &m) in guess.iter_mut().zip(&graph.node_of_voxel) {
        *g = node_at[m as usize];
    }
    let centres = occ.centres();
    let ones = vec![1.0; centres.len()];
    // A voxel lies within its cell's slice or the next.
    let cut = Cut::new(&axis, &centres, &ones, &guess, 1, spacing);
    let mut slices = Slices {
        s: cut.mean_s,
        centroid: cut.centroid,
        count: cut.weight,
        voxel_s: cut.s,
        s_range: cut.range,
        spacing,
        enters_volume: false,
        oriented: false,
        leaves_volume: false,
        gaps,
    };
    orient(occ, &mut slices, voxel, settings);
    Ok(slices)
}

/// Fails when many geodesic slices fall into two or more pieces: a closed loop (or a branch).
fn check_open(graph: &CellGraph, main: &[u32], dist: &[f64], width: f64) -> Result<(), Status> {
    let bins = main
        .iter()
        .map(|&m| (dist[m as usize] / width) as usize)
        .max()
        .unwrap_or(0)
        + 1;
    let bin = |m: u32| (dist[m as usize] / width) as usize;
    let mut label = vec![u32::MAX; graph.len()];
    let mut pieces = vec![0usize; bins];
    for &start in main {
        if label[start as usize] != u32::MAX {
            continue;
        }
        let b = bin(start);
        pieces[b] += 1;
        label[start as usize] = start;
        let mut stack = vec![start];
        while let Some(n) = stack.pop() {
            for &(m, _) in graph.neighbours(n as usize) {
                if label[m as usize] == u32::MAX && bin(m) == b {
                    label[m as usize] = start;
                    stack.push(m);
                }
            }
        }
    }
    // The first and last slices are left out: the ends are ragged.
    let inner = &pieces[2.min(bins)..bins.saturating_sub(2).max(2.min(bins))];
    let split = inner.iter().filter(|&&p| p >= 2).count();
    if !inner.is_empty() && split * 4 > inner.len() {
        return Err(Status::Ambiguous {
            reason: format!(
                "{split} of {} cross-sections fall into two or more pieces: a closed loop, a branch or a tube touching itself",
                inner.len()
            ),
        });
    }
    Ok(())
}

/// Makes the parameter increase from the proximal end to the tip (see the module docs).
fn orient(occ: &Occupancy, slices: &mut Slices, voxel: f64, settings: &ShapeSettings) {
    let [lo, hi] = slices.s_range;
    let dims = occ.volume.dims;
    let touches = |near: &dyn Fn(f64) -> bool| {
        occ.voxels.iter().zip(&slices.voxel_s).any(|(&v, &s)| {
            !s.is_nan()
                && near(s)
                && occ
                    .ijk(v)
                    .iter()
                    .zip(&dims)
                    .any(|(&c, &d)| c == 0 || c + 1 == d)
        })
    };
    let margin = 2.0 * voxel;
    let low = touches(&|s| s < lo + margin);
    let high = touches(&|s| s > hi - margin);
    let (first, last) = (
        slices.centroid[0],
        slices.centroid[slices.centroid.len() - 1],
    );
    // An end that stops a few voxels short of the boundary still enters there (the hull's
    // cut end can fall short), when the other end is well inside.
    let near = 4.0 * voxel;
    let depth = |p: [f64; 3]| occ.volume.depth(&p.into());
    let (d_first, d_last) = (depth(first), depth(last));
    let (flip, oriented) = match (low, high) {
        (true, false) => (false, true),
        (false, true) => (true, true),
        (false, false) if d_first <= near && d_last > near => (false, true),
        (false, false) if d_last <= near && d_first > near => (true, true),
        _ => match settings.proximal_hint {
            Some(h) => (dist(last, h) < dist(first, h), true),
            None => (d_last < d_first, false),
        },
    };
    let proximal_near = if flip { d_last } else { d_first } <= near;
    slices.enters_volume = (if flip { high } else { low }) || proximal_near;
    slices.leaves_volume = low && high;
    slices.oriented = oriented;
    if flip {
        reverse(slices);
    }
}

/// The slices seen from the other end: parameters mirrored, order reversed.
pub(crate) fn reverse(slices: &mut Slices) {
    let [lo, hi] = slices.s_range;
    let total = lo + hi;
    for v in slices.s.iter_mut().chain(slices.voxel_s.iter_mut()) {
        *v = total - *v;
    }
    slices.s.reverse();
    slices.centroid.reverse();
    slices.count.reverse();
}

/// Three-point moving average keeping the ends, to take the corners off an axis.
fn smooth3(p: &[[f64; 3]]) -> Vec<[f64; 3]> {
    crate::spline::moving_average(p, 3)
}

/// The paper's ordering (Section II-C), as a baseline: points sorted by the angle between their
/// vector from the cloud's centroid and the first point's vector, then a moving average of
/// `window` points per axis. Works while the tube bends less than a half-turn around its
/// centroid; returns the smoothed points in order.
pub fn angle_order(points: &[[f64; 3]], window: usize) -> Vec<[f64; 3]> {
    if points.is_empty() {
        return Vec::new();
    }
    let n = points.len() as f64;
    let c: [f64; 3] = std::array::from_fn(|a| points.iter().map(|p| p[a]).sum::<f64>() / n);
    let reference = sub(points[0], c);
    let angle = |p: [f64; 3]| {
        let v = sub(p, c);
        let d = (dot(v, v) * dot(reference, reference)).sqrt().max(1e-12);
        (dot(v, reference) / d).clamp(-1.0, 1.0).acos()
    };
    let mut sorted: Vec<(f64, [f64; 3])> = points.iter().map(|&p| (angle(p), p)).collect();
    sorted.sort_by(|a, b| a.0.total_cmp(&b.0));
    let ordered: Vec<[f64; 3]> = sorted.into_iter().map(|(_, p)| p).collect();
    crate::spline::moving_average(&ordered, window.max(1) | 1)
}

pub(crate) fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

pub(crate) fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

pub(crate) fn dist(a: [f64; 3], b: [f64; 3]) -> f64 {
    dot(sub(a, b), sub(a, b)).sqrt()
}
