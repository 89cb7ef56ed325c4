//! A hull in pieces along one tube: where a camera's silhouette lost a stretch of the tube (a
//! highlight as light as the backdrop, a grey tube on white paper taken for a shadow), the
//! carved hull breaks there, and two pieces lie end to end, each running on toward the other.
//! Chained across their gaps they give the whole tube's start; whether the tube really runs
//! through each gap is for the images to say (the fit's outline there, in every camera), not
//! for the hull, which lost it.

use crate::graph::{CellGraph, farthest};
use crate::order::{dist, dot, sub};

/// Most pieces a hull may be chained from.
const MAX_PIECES: usize = 4;

/// Largest angle between a piece's direction at its end and the gap it would cross, radians
/// (35°): a tube lost over 20 mm of a bend of 60 mm radius turns by 19° across the gap, each
/// end's direction off the chord by half of that, and a piece's direction from a few cells of
/// 1 mm voxels is good to a few degrees more. Two instruments side by side, or a shadow's
/// ghost beside the tube, do not point at each other.
const MAX_TURN: f64 = 35.0 * std::f64::consts::PI / 180.0;

/// How far back from its end a piece's direction there is read, in cells.
const DIRECTION_CELLS: f64 = 5.0;

/// A gap the chain crosses: the two end cells' centroids, world mm.
pub(crate) type Gap = [[f64; 3]; 2];

/// An edge added across a gap: (node, node, length mm).
pub(crate) type Link = (u32, u32, f64);

/// One piece: its nodes' two ends and the unit direction out of each (`None` for a piece too
/// short to have one: a stretch of the tube a few cells long, between two lost ones).
struct Piece {
    ends: [u32; 2],
    out: [Option<[f64; 3]>; 2],
}

/// Links (node, node, gap length mm) that chain `pieces` (node lists, each a component of
/// `graph`, the largest first) into one open tube, end to end, each link crossing a gap its
/// two ends point across, with the gaps crossed; `None` when some piece cannot be chained so
/// (too many pieces, one too short to have a direction, or none whose end points at the
/// chain's ends).
pub(crate) fn chain(
    graph: &CellGraph,
    pieces: &[&[u32]],
    cell_mm: f64,
) -> Option<(Vec<Link>, Vec<Gap>)> {
    if pieces.len() < 2 || pieces.len() > MAX_PIECES {
        return None;
    }
    let pieces: Vec<Piece> = pieces
        .iter()
        .map(|nodes| piece(graph, nodes, cell_mm))
        .collect::<Option<_>>()?;
    // The chain's two free ends: (node, outward direction).
    let [Some(first), Some(second)] = pieces[0].out else {
        return None;
    };
    let mut free = [(pieces[0].ends[0], first), (pieces[0].ends[1], second)];
    let mut left: Vec<&Piece> = pieces[1..].iter().collect();
    let (mut links, mut gaps) = (Vec::new(), Vec::new());
    while !left.is_empty() {
        // The shortest gap that a free end of the chain and an end of a piece left both point
        // across.
        let mut best: Option<(usize, usize, usize, f64)> = None;
        for (i, p) in left.iter().enumerate() {
            for (f, &(node, out)) in free.iter().enumerate() {
                for e in 0..2 {
                    let (a, b) = (
                        graph.centroid(node as usize),
                        graph.centroid(p.ends[e] as usize),
                    );
                    let gap = sub(b, a);
                    let length = dist(a, b);
                    if length <= 0.0 {
                        continue;
                    }
                    // Ahead of the end, and off its line by no more than the turn allows,
                    // give or take a cell (where a cap's end cell lies is good to a cell,
                    // which across a gap of a few mm is a large angle).
                    let towards = |dir: [f64; 3], g: [f64; 3]| {
                        let ahead = dot(dir, g);
                        let aside = (length * length - ahead * ahead).max(0.0).sqrt();
                        ahead > 0.0 && aside <= length * MAX_TURN.sin() + cell_mm
                    };
                    let back = gap.map(|v| -v);
                    if towards(out, gap)
                        && p.out[e].is_none_or(|o| towards(o, back))
                        && best.is_none_or(|(_, _, _, l)| length < l)
                    {
                        best = Some((i, f, e, length));
                    }
                }
            }
        }
        let (i, f, e, length) = best?;
        let p = left.remove(i);
        links.push((free[f].0, p.ends[e], length));
        gaps.push([
            graph.centroid(free[f].0 as usize),
            graph.centroid(p.ends[e] as usize),
        ]);
        // A short piece goes on the way the chain came (its own direction unknown).
        let on = p.out[1 - e].unwrap_or(free[f].1);
        free[f] = (p.ends[1 - e], on);
    }
    Some((links, gaps))
}

/// A piece's two ends (a double sweep of shortest paths) and its direction out of each, read
/// from the cells [`DIRECTION_CELLS`] back along it (none for a piece too short to have one).
fn piece(graph: &CellGraph, nodes: &[u32], cell_mm: f64) -> Option<Piece> {
    let (a, _) = farthest(&graph.distances(*nodes.first()?));
    let from_a = graph.distances(a);
    let (b, length) = farthest(&from_a);
    let back = DIRECTION_CELLS * cell_mm;
    if length < 2.0 * back {
        return Some(Piece {
            ends: [a, b],
            out: [None, None],
        });
    }
    let from_b = graph.distances(b);
    let out = |end: u32, from_end: &[f64]| {
        // The centroid of the cells about `back` along the piece from `end`.
        let (mut sum, mut n) = ([0.0; 3], 0.0);
        for &m in nodes {
            let d = from_end[m as usize];
            if (d - back).abs() <= cell_mm {
                let c = graph.centroid(m as usize);
                let w = graph.count[m as usize] as f64;
                for k in 0..3 {
                    sum[k] += w * c[k];
                }
                n += w;
            }
        }
        let inner = sum.map(|v| v / n.max(1e-300));
        let d = sub(graph.centroid(end as usize), inner);
        let norm = dot(d, d).sqrt();
        (n > 0.0 && norm > 0.0).then(|| d.map(|v| v / norm))
    };
    Some(Piece {
        ends: [a, b],
        out: [out(a, &from_a), out(b, &from_b)],
    })
}
