//! The boundary of a carved hull as a closed quad mesh: every face an occupied voxel shares
//! with an empty one (or the volume's boundary), corners shared between faces, each quad
//! counter-clockwise seen from outside. Exact for the voxels (no smoothing), watertight, and
//! read by MeshLab, CloudCompare, Blender and Open3D as PLY.

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
