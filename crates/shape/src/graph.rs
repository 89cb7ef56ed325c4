//! The carved voxels coarsened into cells of `c³` voxels, 26-connected: small enough to search
//! quickly (a few thousand nodes for a catheter at 1 mm), fine enough to follow a tube whose
//! diameter is a few cells.

use std::cmp::Ordering;
use std::collections::{BinaryHeap, HashMap};
use std::hash::{BuildHasherDefault, Hasher};

use flexshape_carve::Occupancy;

/// Cells with their voxel centroids and 26-neighbour edges (compressed rows).
#[derive(Debug, Clone)]
pub(crate) struct CellGraph {
    /// Node of each occupied voxel (in the occupancy's order).
    pub node_of_voxel: Vec<u32>,
    /// Sum of the voxel centres of each node, world mm.
    pub sum: Vec<[f64; 3]>,
    /// Voxels per node.
    pub count: Vec<u32>,
    /// Edges of node `n`: `edges[offsets[n]..offsets[n + 1]]`, (neighbour, length mm).
    offsets: Vec<usize>,
    edges: Vec<(u32, f64)>,
}

impl CellGraph {
    pub fn new(occ: &Occupancy, cell: u32) -> Self {
        let key = |ijk: [u32; 3]| {
            let c = ijk.map(|v| (v / cell) as u64);
            c[0] | c[1] << 21 | c[2] << 42
        };
        let voxel_keys: Vec<u64> = occ.voxels.iter().map(|&v| key(occ.ijk(v))).collect();
        let mut keys = voxel_keys.clone();
        keys.sort_unstable();
        keys.dedup();
        let n = keys.len();
        let index: CellMap = keys
            .iter()
            .enumerate()
            .map(|(i, &k)| (k, i as u32))
            .collect();
        let mut sum = vec![[0.0; 3]; n];
        let mut count = vec![0u32; n];
        let mut node_of_voxel = Vec::with_capacity(voxel_keys.len());
        // Voxels come in index order, so runs of them share a cell: look each run up once.
        let mut last = (u64::MAX, 0usize);
        for (&v, &k) in occ.voxels.iter().zip(&voxel_keys) {
            if k != last.0 {
                last = (k, index.get(&k).copied().unwrap_or(0) as usize);
            }
            let node = last.1;
            let [i, j, kk] = occ.ijk(v);
            let c = occ.volume.voxel_centre(i, j, kk);
            for a in 0..3 {
                sum[node][a] += c[a];
            }
            count[node] += 1;
            node_of_voxel.push(node as u32);
        }
        let centroid = |m: usize| sum[m].map(|s| s / count[m] as f64);
        // Each pair once (the 13 neighbours after a cell in key order), stored both ways.
        let mask = (1u64 << 21) - 1;
        let mut pairs = Vec::new();
        for (m, &k) in keys.iter().enumerate() {
            let c = [k & mask, k >> 21 & mask, k >> 42].map(|v| v as i64);
            for (dx, dy, dz) in FORWARD {
                let q = [c[0] + dx, c[1] + dy, c[2] + dz];
                if q.iter().any(|&v| v < 0) {
                    continue;
                }
                let qk = q[0] as u64 | (q[1] as u64) << 21 | (q[2] as u64) << 42;
                if let Some(&o) = index.get(&qk) {
                    let (a, b) = (centroid(m), centroid(o as usize));
                    let d = ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2))
                        .sqrt();
                    pairs.push((m as u32, o, d));
                }
            }
        }
        let (offsets, edges) = rows(n, &pairs);
        CellGraph {
            node_of_voxel,
            sum,
            count,
            offsets,
            edges,
        }
    }

    /// The same graph with `links` added: edges (node, node, length mm) across gaps between
    /// pieces the graph does not join.
    pub fn linked(&self, links: &[crate::pieces::Link]) -> CellGraph {
        let mut pairs: Vec<(u32, u32, f64)> = (0..self.len())
            .flat_map(|a| {
                self.neighbours(a)
                    .iter()
                    .filter(move |&&(b, _)| (a as u32) < b)
                    .map(move |&(b, d)| (a as u32, b, d))
            })
            .collect();
        pairs.extend_from_slice(links);
        let (offsets, edges) = rows(self.len(), &pairs);
        CellGraph {
            offsets,
            edges,
            ..self.clone()
        }
    }

    /// Number of nodes.
    pub fn len(&self) -> usize {
        self.count.len()
    }

    /// Centroid of a node's voxels, world mm.
    pub fn centroid(&self, n: usize) -> [f64; 3] {
        self.sum[n].map(|s| s / self.count[n] as f64)
    }

    pub fn neighbours(&self, n: usize) -> &[(u32, f64)] {
        &self.edges[self.offsets[n]..self.offsets[n + 1]]
    }

    /// Connected components (node lists), largest (in voxels) first.
    pub fn components(&self) -> Vec<Vec<u32>> {
        let mut seen = vec![false; self.len()];
        let mut out = Vec::new();
        for start in 0..self.len() {
            if seen[start] {
                continue;
            }
            seen[start] = true;
            let mut stack = vec![start as u32];
            let mut group = Vec::new();
            while let Some(n) = stack.pop() {
                group.push(n);
                for &(m, _) in self.neighbours(n as usize) {
                    if !seen[m as usize] {
                        seen[m as usize] = true;
                        stack.push(m);
                    }
                }
            }
            out.push(group);
        }
        let voxels = |g: &Vec<u32>| g.iter().map(|&n| self.count[n as usize]).sum::<u32>();
        out.sort_by_key(|g| std::cmp::Reverse(voxels(g)));
        out
    }

    /// Voxels in a set of nodes.
    pub fn voxels_in(&self, nodes: &[u32]) -> u32 {
        nodes.iter().map(|&n| self.count[n as usize]).sum()
    }

    /// Shortest-path lengths (mm) from `source` over the graph (∞ where unreachable).
    pub fn distances(&self, source: u32) -> Vec<f64> {
        let mut dist = vec![f64::INFINITY; self.len()];
        let mut heap = BinaryHeap::new();
        dist[source as usize] = 0.0;
        heap.push(Entry(0.0, source));
        while let Some(Entry(d, n)) = heap.pop() {
            if d > dist[n as usize] {
                continue;
            }
            for &(m, w) in self.neighbours(n as usize) {
                let nd = d + w;
                if nd < dist[m as usize] {
                    dist[m as usize] = nd;
                    heap.push(Entry(nd, m));
                }
            }
        }
        dist
    }
}

/// Compressed rows of `n` nodes' edges, each of `pairs` (node, node, length) stored both ways.
fn rows(n: usize, pairs: &[(u32, u32, f64)]) -> (Vec<usize>, Vec<(u32, f64)>) {
    let mut offsets = vec![0usize; n + 1];
    for &(a, b, _) in pairs {
        offsets[a as usize + 1] += 1;
        offsets[b as usize + 1] += 1;
    }
    for i in 0..n {
        offsets[i + 1] += offsets[i];
    }
    let mut fill = offsets.clone();
    let mut edges = vec![(0u32, 0.0); 2 * pairs.len()];
    for &(a, b, d) in pairs {
        edges[fill[a as usize]] = (b, d);
        fill[a as usize] += 1;
        edges[fill[b as usize]] = (a, d);
        fill[b as usize] += 1;
    }
    (offsets, edges)
}

/// Half of the 26 neighbour offsets: those after a cell in key order (z, then y, then x).
const FORWARD: [(i64, i64, i64); 13] = [
    (1, 0, 0),
    (-1, 1, 0),
    (0, 1, 0),
    (1, 1, 0),
    (-1, -1, 1),
    (0, -1, 1),
    (1, -1, 1),
    (-1, 0, 1),
    (0, 0, 1),
    (1, 0, 1),
    (-1, 1, 1),
    (0, 1, 1),
    (1, 1, 1),
];

/// Cell key → node. Keys are packed coordinates, so one multiplication hashes them well
/// (SipHash cost more than the rest of the graph).
type CellMap = HashMap<u64, u32, BuildHasherDefault<CellHasher>>;

#[derive(Default)]
struct CellHasher(u64);

impl Hasher for CellHasher {
    fn write(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.write_u64(self.0 ^ b as u64);
        }
    }

    fn write_u64(&mut self, k: u64) {
        self.0 = (k ^ self.0)
            .wrapping_mul(0x9E37_79B9_7F4A_7C15)
            .rotate_left(29);
    }

    fn finish(&self) -> u64 {
        self.0
    }
}

/// Min-heap entry ordered by distance.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Entry(f64, u32);

impl Eq for Entry {}

impl PartialOrd for Entry {
    fn partial_cmp(&self, o: &Self) -> Option<Ordering> {
        Some(self.cmp(o))
    }
}

impl Ord for Entry {
    fn cmp(&self, o: &Self) -> Ordering {
        o.0.total_cmp(&self.0).then(o.1.cmp(&self.1))
    }
}

/// The node farthest from `source` among finite distances, and its distance.
pub(crate) fn farthest(dist: &[f64]) -> (u32, f64) {
    dist.iter()
        .enumerate()
        .filter(|(_, d)| d.is_finite())
        .fold(
            (0, -1.0),
            |best, (n, &d)| {
                if d > best.1 { (n as u32, d) } else { best }
            },
        )
}
