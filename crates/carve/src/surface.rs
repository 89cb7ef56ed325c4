//! The boundary of a carved hull as a closed quad mesh: every face an occupied voxel shares
//! with an empty one (or the volume's boundary), corners shared between faces, each quad
//! counter-clockwise seen from outside. Exact for the voxels (no smoothing), watertight, and
//! read by MeshLab, CloudCompare, Blender and Open3D as PLY.

use std::collections::HashMap;
use std::path::Path;

use crate::{CarveError, Occupancy};

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
        let occupied = |p: [i64; 3]| {
            (0..3).all(|a| p[a] >= 0 && p[a] < dims[a])
                && self
                    .voxels
                    .binary_search(&((p[0] + dims[0] * (p[1] + dims[1] * p[2])) as u32))
                    .is_ok()
        };
        let mut mesh = SurfaceMesh::default();
        let mut corner_index: HashMap<[u32; 3], u32> = HashMap::new();
        for &voxel in &self.voxels {
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

impl SurfaceMesh {
    /// Writes an ASCII PLY mesh, whole or not at all (written beside, then renamed).
    pub fn write_ply(&self, path: &Path) -> Result<(), CarveError> {
        let mut text = format!(
            "ply\nformat ascii 1.0\ncomment flexshape carved hull surface, world frame, mm\nelement vertex {}\nproperty float x\nproperty float y\nproperty float z\nelement face {}\nproperty list uchar int vertex_indices\nend_header\n",
            self.vertices.len(),
            self.quads.len()
        );
        for p in &self.vertices {
            text.push_str(&format!("{} {} {}\n", p[0], p[1], p[2]));
        }
        for q in &self.quads {
            text.push_str(&format!("4 {} {} {} {}\n", q[0], q[1], q[2], q[3]));
        }
        crate::cloud::write_whole(path, &text)
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
        // Every edge is shared by exactly two faces, once each way.
        let mut edges = HashMap::new();
        for q in &mesh.quads {
            for e in 0..4 {
                *edges.entry((q[e], q[(e + 1) % 4])).or_insert(0) += 1;
            }
        }
        for (&(a, b), &n) in &edges {
            assert_eq!((n, edges.get(&(b, a))), (1, Some(&1)));
        }
    }
}
