//! The boundary of a carved hull as a closed quad mesh: every face an occupied voxel shares
//! with an empty one (or the volume's boundary), corners shared between faces, each quad
//! counter-clockwise seen from outside. Exact for the voxels (no smoothing), read by MeshLab,
//! CloudCompare, Blender and Open3D as PLY.
//!
//! Watertight and manifold: every edge is shared by exactly two faces and the faces around
//! every corner form one fan, as trimesh and Open3D require. Voxels that touch only along an
//! edge or at a corner would break that (four faces on one edge, two fans on one corner), so
//! the surface is taken around the hull with the voxels added that join such pairs through a
//! face (the set made "well-composed"): one voxel per edge contact, two per corner contact —
//! a few of thousands on a carved tube, each beside the hull, never outside its bounding box.

use std::collections::HashMap;
use std::path::Path;

use crate::{CarveError, Occupancy, PlyEncoding};

/// A quad mesh, world mm.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct SurfaceMesh {
    /// Corner positions, world mm.
    pub vertices: Vec<[f32; 3]>,
    /// Four vertex indices per face, counter-clockwise seen from outside.
    pub quads: Vec<[u32; 4]>,
    /// Total face area, mm².
    pub area_mm2: f64,
}

/// Per face direction: the neighbour's offset and the face's corners (voxel-corner offsets),
/// ordered so that the face's normal points toward the neighbour.
const FACES: [([i64; 3], [[u32; 3]; 4]); 6] = [
    ([1, 0, 0], [[1, 0, 0], [1, 1, 0], [1, 1, 1], [1, 0, 1]]),
    ([-1, 0, 0], [[0, 0, 0], [0, 0, 1], [0, 1, 1], [0, 1, 0]]),
    ([0, 1, 0], [[0, 1, 0], [0, 1, 1], [1, 1, 1], [1, 1, 0]]),
    ([0, -1, 0], [[0, 0, 0], [1, 0, 0], [1, 0, 1], [0, 0, 1]]),
    ([0, 0, 1], [[0, 0, 1], [1, 0, 1], [1, 1, 1], [0, 1, 1]]),
    ([0, 0, -1], [[0, 0, 0], [0, 1, 0], [1, 1, 0], [1, 0, 0]]),
];

impl Occupancy {
    /// The hull's surface (see the module docs).
    pub fn surface(&self) -> SurfaceMesh {
        let v = &self.volume;
        let dims = v.dims.map(|d| d as i64);
        let voxels = self.well_composed();
        let occupied = |p: [i64; 3]| {
            (0..3).all(|a| p[a] >= 0 && p[a] < dims[a])
                && voxels
                    .binary_search(&((p[0] + dims[0] * (p[1] + dims[1] * p[2])) as u32))
                    .is_ok()
        };
        let mut mesh = SurfaceMesh::default();
        let mut corner_index: HashMap<[u32; 3], u32> = HashMap::new();
        for &voxel in &voxels {
            let ijk = self.ijk(voxel);
            let at = ijk.map(|c| c as i64);
            for (offset, corners) in FACES {
                if occupied([at[0] + offset[0], at[1] + offset[1], at[2] + offset[2]]) {
                    continue;
                }
                let quad = corners.map(|c| {
                    let key = [ijk[0] + c[0], ijk[1] + c[1], ijk[2] + c[2]];
                    *corner_index.entry(key).or_insert_with(|| {
                        mesh.vertices.push(std::array::from_fn(|a| {
                            (v.origin[a] + key[a] as f64 * v.voxel_size[a]) as f32
                        }));
                        (mesh.vertices.len() - 1) as u32
                    })
                });
                mesh.quads.push(quad);
                let axis = offset.iter().position(|&o| o != 0).unwrap_or(0);
                mesh.area_mm2 += v.voxel_size[(axis + 1) % 3] * v.voxel_size[(axis + 2) % 3];
            }
        }
        mesh
    }
}

impl Occupancy {
    /// The occupied voxels (ascending indices) with those added that join every pair touching
    /// only along an edge or at a corner through a face (see the module docs).
    fn well_composed(&self) -> Vec<u32> {
        let Some(first) = self.voxels.first() else {
            return Vec::new();
        };
        let ijks: Vec<[u32; 3]> = self.voxels.iter().map(|&v| self.ijk(v)).collect();
        let (mut lo, mut hi) = (self.ijk(*first), self.ijk(*first));
        for q in &ijks {
            for a in 0..3 {
                lo[a] = lo[a].min(q[a]);
                hi[a] = hi[a].max(q[a]);
            }
        }
        // A local grid over the bounding box with one empty cell around it.
        let n: [usize; 3] = std::array::from_fn(|a| (hi[a] - lo[a]) as usize + 3);
        let stride = [1, n[0], n[0] * n[1]];
        let mut grid = vec![false; n[0] * n[1] * n[2]];
        let local = |q: [u32; 3]| {
            (0..3)
                .map(|a| (q[a] - lo[a] + 1) as usize * stride[a])
                .sum::<usize>()
        };
        for q in &ijks {
            grid[local(*q)] = true;
        }
        // Each fill can make a new contact beside it; a few passes settle it.
        while fill_contacts(&mut grid, n, stride) > 0 {}
        let dims = self.volume.dims;
        let mut voxels: Vec<u32> = (0..grid.len())
            .filter(|&k| grid[k])
            .map(|k| {
                let c = [k % n[0], (k / n[0]) % n[1], k / (n[0] * n[1])];
                // Fills stay inside the occupied voxels' bounding box (each joins two of them).
                let q: [u32; 3] = std::array::from_fn(|a| c[a] as u32 - 1 + lo[a]);
                q[0] + dims[0] * (q[1] + dims[1] * q[2])
            })
            .collect();
        voxels.sort_unstable();
        voxels
    }
}

/// One pass over a grid of occupied cells (`n` cells along each axis, `stride` apart; the
/// outer layer empty): every 2×2 square whose occupied cells share only an edge gets one of
/// its empty cells filled, every 2×2×2 block whose two occupied cells (or two empty ones)
/// share only a corner gets a face path between them. Returns how many cells it filled.
fn fill_contacts(grid: &mut [bool], n: [usize; 3], stride: [usize; 3]) -> usize {
    let mut filled = 0;
    let cells = |hi: [usize; 3]| {
        (0..hi[2])
            .flat_map(move |z| (0..hi[1]).flat_map(move |y| (0..hi[0]).map(move |x| [x, y, z])))
    };
    let at = |c: [usize; 3]| c[0] * stride[0] + c[1] * stride[1] + c[2] * stride[2];
    for axis in 0..3 {
        let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
        let mut hi = n;
        hi[u] -= 1;
        hi[v] -= 1;
        for c in cells(hi) {
            let p = at(c);
            let (pu, pv, puv) = (p + stride[u], p + stride[v], p + stride[u] + stride[v]);
            if grid[p] == grid[puv] && grid[pu] == grid[pv] && grid[p] != grid[pu] {
                grid[if grid[p] { pu } else { p }] = true;
                filled += 1;
            }
        }
    }
    for c in cells(n.map(|k| k - 1)) {
        let p = at(c);
        let corner = |k: usize| p + (0..3).map(|a| ((k >> a) & 1) * stride[a]).sum::<usize>();
        let count = (0..8).filter(|&k| grid[corner(k)]).count();
        match count {
            2 => {
                if let Some(k) = (0..8).find(|&k| grid[corner(k)] && grid[corner(7 - k)]) {
                    grid[corner(k ^ 1)] = true;
                    grid[corner(k ^ 3)] = true;
                    filled += 2;
                }
            }
            6 => {
                if let Some(k) = (0..8).find(|&k| !grid[corner(k)] && !grid[corner(7 - k)]) {
                    grid[corner(k)] = true;
                    filled += 1;
                }
            }
            _ => {}
        }
    }
    filled
}

impl SurfaceMesh {
    /// Writes a PLY mesh, whole or not at all (written beside, then renamed): vertices `x y z`
    /// (float, world mm), faces as lists of 4 vertex indices (uchar count, int indices).
    pub fn write_ply(&self, path: &Path, encoding: PlyEncoding) -> Result<(), CarveError> {
        let mut out = format!(
            "ply\n{}\ncomment flexshape carved hull surface, world frame, mm\nelement vertex {}\nproperty float x\nproperty float y\nproperty float z\nelement face {}\nproperty list uchar int vertex_indices\nend_header\n",
            encoding.format_line(),
            self.vertices.len(),
            self.quads.len()
        )
        .into_bytes();
        for p in &self.vertices {
            match encoding {
                PlyEncoding::Binary => {
                    for v in p {
                        out.extend_from_slice(&v.to_le_bytes());
                    }
                }
                PlyEncoding::Ascii => {
                    out.extend_from_slice(format!("{} {} {}\n", p[0], p[1], p[2]).as_bytes())
                }
            }
        }
        for q in &self.quads {
            match encoding {
                PlyEncoding::Binary => {
                    out.push(4);
                    for &i in q {
                        out.extend_from_slice(&(i as i32).to_le_bytes());
                    }
                }
                PlyEncoding::Ascii => out.extend_from_slice(
                    format!("4 {} {} {} {}\n", q[0], q[1], q[2], q[3]).as_bytes(),
                ),
            }
        }
        crate::cloud::write_whole(path, &out)
    }
}

#[cfg(test)]
mod tests {
    use flexshape_camera::nalgebra::Vector3;
    use flexshape_rig::Volume;

    use super::*;

    fn occupancy(voxels: Vec<u32>) -> Occupancy {
        Occupancy {
            volume: Volume::from_bounds([0.0; 3], [10.0, 10.0, 10.0], 2.0).unwrap(),
            voxels,
        }
    }

    #[test]
    fn binary_and_text_meshes_hold_the_same_vertices_and_faces() {
        let mesh = occupancy(vec![0, 1]).surface();
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("mesh.ply");
        mesh.write_ply(&path, PlyEncoding::Ascii).unwrap();
        let text = std::fs::read_to_string(&path).unwrap();
        mesh.write_ply(&path, PlyEncoding::Binary).unwrap();
        let bytes = std::fs::read(&path).unwrap();
        let end = bytes
            .windows(11)
            .position(|w| w == b"end_header\n")
            .unwrap()
            + 11;
        let body = &bytes[end..];
        let (nv, nf) = (mesh.vertices.len(), mesh.quads.len());
        assert_eq!(body.len(), 12 * nv + 17 * nf);
        let text_body: Vec<&str> = text
            .lines()
            .skip_while(|l| *l != "end_header")
            .skip(1)
            .collect();
        for (k, line) in text_body.iter().enumerate().take(nv) {
            let from_text: Vec<f32> = line.split(' ').map(|v| v.parse().unwrap()).collect();
            let f = |i: usize| {
                f32::from_le_bytes(body[12 * k + 4 * i..12 * k + 4 * i + 4].try_into().unwrap())
            };
            assert_eq!(from_text, [f(0), f(1), f(2)]);
        }
        for (k, line) in text_body[nv..].iter().enumerate() {
            let at = 12 * nv + 17 * k;
            assert_eq!(body[at], 4);
            let ids: Vec<String> = (0..4)
                .map(|i| {
                    let b = &body[at + 1 + 4 * i..at + 5 + 4 * i];
                    i32::from_le_bytes(b.try_into().unwrap()).to_string()
                })
                .collect();
            assert_eq!(*line, format!("4 {}", ids.join(" ")));
        }
    }

    #[test]
    fn a_voxel_is_a_closed_cube_with_outward_faces() {
        let mesh = occupancy(vec![0]).surface();
        assert_eq!((mesh.vertices.len(), mesh.quads.len()), (8, 6));
        assert!((mesh.area_mm2 - 24.0).abs() < 1e-12);
        // Each face's normal points away from the voxel's centre (1, 1, 1).
        for q in &mesh.quads {
            let p = q.map(|i| Vector3::from(mesh.vertices[i as usize].map(f64::from)));
            let n = (p[1] - p[0]).cross(&(p[2] - p[1]));
            let centre = (p[0] + p[1] + p[2] + p[3]) / 4.0;
            assert!(n.dot(&(centre - Vector3::new(1.0, 1.0, 1.0))) > 0.0);
        }
    }

    #[test]
    fn a_solid_block_is_watertight_and_hides_its_inner_faces() {
        // A 3×3×3 block of 2-mm voxels: 54 outer faces, area 6·36 mm².
        let voxels: Vec<u32> = (0..3u32)
            .flat_map(|k| (0..3u32).flat_map(move |j| (0..3u32).map(move |i| i + 5 * (j + 5 * k))))
            .collect();
        let mut sorted = voxels;
        sorted.sort();
        let mesh = occupancy(sorted).surface();
        assert_eq!(mesh.quads.len(), 54);
        assert!((mesh.area_mm2 - 216.0).abs() < 1e-9);
        // A closed surface of genus 0: V − E + F = 2, with E = 2F for quads.
        assert_eq!(mesh.vertices.len() as i64 - mesh.quads.len() as i64, 2);
        assert_manifold(&mesh);
    }

    /// trimesh's `is_watertight` (every edge shared by exactly two faces), with the faces'
    /// orientation agreeing across it, and Open3D's vertex-manifold test (the faces around
    /// each corner form one fan).
    fn assert_manifold(mesh: &SurfaceMesh) {
        let mut edges = HashMap::new();
        for q in &mesh.quads {
            for e in 0..4 {
                *edges.entry((q[e], q[(e + 1) % 4])).or_insert(0) += 1;
            }
        }
        for (&(a, b), &n) in &edges {
            assert_eq!((n, edges.get(&(b, a))), (1, Some(&1)), "edge {a}-{b}");
        }
        // Around each vertex: from each face, the step from the corner after it to the one
        // before it; one cycle through all of them is one fan.
        let mut link: HashMap<u32, HashMap<u32, u32>> = HashMap::new();
        for q in &mesh.quads {
            for i in 0..4 {
                let (next, prev) = (q[(i + 1) % 4], q[(i + 3) % 4]);
                let steps = link.entry(q[i]).or_default();
                assert!(steps.insert(next, prev).is_none(), "vertex {}", q[i]);
            }
        }
        for (vertex, steps) in &link {
            let start = *steps.keys().next().unwrap();
            let (mut at, mut walked) = (start, 0);
            loop {
                at = steps[&at];
                walked += 1;
                if at == start {
                    break;
                }
            }
            assert_eq!(walked, steps.len(), "vertex {vertex}: more than one fan");
        }
    }

    /// The occupancy of the voxels at these (i, j, k) of a 5×5×5 volume, indices ascending.
    fn at(cells: &[[u32; 3]]) -> Occupancy {
        let mut voxels: Vec<u32> = cells.iter().map(|c| c[0] + 5 * (c[1] + 5 * c[2])).collect();
        voxels.sort();
        occupancy(voxels)
    }

    #[test]
    fn voxels_touching_along_an_edge_or_at_a_corner_still_give_a_manifold() {
        let edge = at(&[[1, 1, 1], [2, 2, 1]]);
        let corner = at(&[[1, 1, 1], [2, 2, 2]]);
        // A 2×2×2 block with two opposite voxels missing: their faces meet at one corner.
        let hollow: Vec<[u32; 3]> = (0..8u32)
            .filter(|&k| k != 0 && k != 7)
            .map(|k| [1 + (k & 1), 1 + ((k >> 1) & 1), 1 + ((k >> 2) & 1)])
            .collect();
        for (name, occupancy, added) in [
            ("edge", edge, 1),
            ("corner", corner, 2),
            ("hollow corner", at(&hollow), 1),
        ] {
            let mesh = occupancy.surface();
            assert_manifold(&mesh);
            let voxels = occupancy.well_composed();
            assert_eq!(voxels.len(), occupancy.voxels.len() + added, "{name}");
            assert!(
                occupancy.voxels.iter().all(|v| voxels.contains(v)),
                "{name}"
            );
        }
    }

    #[test]
    fn random_blobs_give_manifolds() {
        // Seeded noise: a third of a 5³ volume occupied, contacts of every kind.
        let mut state = 0x2545_f491_4f6c_dd1d_u64;
        for _ in 0..200 {
            let voxels: Vec<u32> = (0..125u32)
                .filter(|_| {
                    state ^= state << 13;
                    state ^= state >> 7;
                    state ^= state << 17;
                    state.is_multiple_of(3)
                })
                .collect();
            let occupancy = occupancy(voxels);
            let mesh = occupancy.surface();
            assert_manifold(&mesh);
            // Closed orientable surfaces: V − E + F = 2 − 2g is even.
            let euler = mesh.vertices.len() as i64 - mesh.quads.len() as i64;
            assert_eq!(euler % 2, 0);
        }
    }
}
