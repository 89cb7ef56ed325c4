//! Carving results: occupied voxels and the point cloud of their centres.

use std::path::Path;

use flexshape_camera::nalgebra::Point3;
use flexshape_rig::Volume;

use crate::bands::Band;
use crate::error::CarveError;

/// The occupied voxels of a volume, as ascending voxel indices `i + nx·(j + ny·k)`.
#[derive(Debug, Clone, PartialEq)]
pub struct Occupancy {
    /// The carved volume.
    pub volume: Volume,
    /// Occupied voxel indices, ascending.
    pub voxels: Vec<u32>,
}

impl Occupancy {
    /// Number of occupied voxels.
    pub fn len(&self) -> usize {
        self.voxels.len()
    }

    /// True when nothing is occupied.
    pub fn is_empty(&self) -> bool {
        self.voxels.is_empty()
    }

    /// `(i, j, k)` of a voxel index.
    pub fn ijk(&self, index: u32) -> [u32; 3] {
        let [nx, ny, _] = self.volume.dims;
        [index % nx, (index / nx) % ny, index / (nx * ny)]
    }

    /// Index of the voxel containing world point `p` (mm), if inside the volume.
    pub fn index_of(&self, p: &Point3<f64>) -> Option<u32> {
        if !self.volume.contains(p) {
            return None;
        }
        let v = &self.volume;
        let ijk: [u32; 3] = std::array::from_fn(|a| {
            (((p[a] - v.origin[a]) / v.voxel_size[a]).floor() as u32).min(v.dims[a] - 1)
        });
        Some(ijk[0] + v.dims[0] * (ijk[1] + v.dims[1] * ijk[2]))
    }

    /// True when the voxel containing `p` is occupied.
    pub fn contains_point(&self, p: &Point3<f64>) -> bool {
        self.index_of(p)
            .is_some_and(|i| self.voxels.binary_search(&i).is_ok())
    }

    /// These voxels without those of `other` (of the same volume).
    pub fn without(&self, other: &Occupancy) -> Occupancy {
        Occupancy {
            volume: self.volume,
            voxels: self
                .voxels
                .iter()
                .copied()
                .filter(|v| other.voxels.binary_search(v).is_err())
                .collect(),
        }
    }

    /// The connected parts of these voxels (26-neighbours) that hold a voxel of `seen` (of
    /// the same volume): a hull carved with a camera's hidden pixels taken as the object's
    /// keeps the parts that reach the hull every camera carved; a part the hidden pixels alone
    /// let stand, apart from it, is a ghost of the cameras that do see there.
    pub fn reaching(&self, seen: &Occupancy) -> Occupancy {
        let [nx, ny, nz] = self.volume.dims.map(i64::from);
        let mut kept = vec![false; self.voxels.len()];
        let mut stack: Vec<usize> = (0..self.voxels.len())
            .filter(|&k| seen.voxels.binary_search(&self.voxels[k]).is_ok())
            .collect();
        for &k in &stack {
            kept[k] = true;
        }
        while let Some(k) = stack.pop() {
            let [i, j, l] = self.ijk(self.voxels[k]).map(i64::from);
            for (di, dj, dl) in
                (-1..=1).flat_map(|a| (-1..=1).flat_map(move |b| (-1..=1).map(move |c| (a, b, c))))
            {
                let (a, b, c) = (i + di, j + dj, l + dl);
                if a < 0 || b < 0 || c < 0 || a >= nx || b >= ny || c >= nz {
                    continue;
                }
                let index = (a + nx * (b + ny * c)) as u32;
                if let Ok(n) = self.voxels.binary_search(&index)
                    && !kept[n]
                {
                    kept[n] = true;
                    stack.push(n);
                }
            }
        }
        Occupancy {
            volume: self.volume,
            voxels: self
                .voxels
                .iter()
                .zip(&kept)
                .filter(|&(_, &k)| k)
                .map(|(&v, _)| v)
                .collect(),
        }
    }

    /// Occupied volume, mm³.
    pub fn volume_mm3(&self) -> f64 {
        self.len() as f64 * self.volume.voxel_size.iter().product::<f64>()
    }

    /// The occupied voxels' centres, world mm, in index order.
    pub fn centres(&self) -> Vec<[f64; 3]> {
        self.voxels
            .iter()
            .map(|&v| {
                let [i, j, k] = self.ijk(v);
                let c = self.volume.voxel_centre(i, j, k);
                [c.x, c.y, c.z]
            })
            .collect()
    }

    /// The voxel centres as a point cloud, no voxel in a band.
    pub fn to_cloud(&self) -> PointCloud {
        let voxels: Vec<[u32; 3]> = self.voxels.iter().map(|&i| self.ijk(i)).collect();
        let points = voxels
            .iter()
            .map(|&[i, j, k]| {
                let c = self.volume.voxel_centre(i, j, k);
                [c.x as f32, c.y as f32, c.z as f32]
            })
            .collect();
        PointCloud {
            points,
            band: vec![0; voxels.len()],
            voxels,
        }
    }

    /// The point cloud with each voxel labelled by the band holding it (`bands` as
    /// [`crate::find_bands`] returned them for this occupancy).
    pub fn to_cloud_with_bands(&self, bands: &[Band]) -> PointCloud {
        let mut cloud = self.to_cloud();
        for (n, band) in bands.iter().enumerate() {
            let label = u16::try_from(n + 1).unwrap_or(u16::MAX);
            for v in &band.voxels {
                if let Ok(at) = self.voxels.binary_search(v) {
                    cloud.band[at] = label;
                }
            }
        }
        cloud
    }
}

/// Occupied voxel centres (world mm), their `(i, j, k)` and band labels.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct PointCloud {
    /// Voxel centres, world mm.
    pub points: Vec<[f32; 3]>,
    /// Voxel coordinates.
    pub voxels: Vec<[u32; 3]>,
    /// Per point: 0 outside every band, `n` in the `n`-th band (1-based, largest first).
    pub band: Vec<u16>,
}

/// How a PLY file stores its elements.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum PlyEncoding {
    /// `binary_little_endian 1.0`: a third of the size, written and read fastest.
    #[default]
    Binary,
    /// `ascii 1.0`: one line per element, for reading by eye or line-based tools.
    Ascii,
}

impl PlyEncoding {
    /// The header's `format` line.
    pub(crate) fn format_line(self) -> &'static str {
        match self {
            PlyEncoding::Binary => "format binary_little_endian 1.0",
            PlyEncoding::Ascii => "format ascii 1.0",
        }
    }
}

impl PointCloud {
    /// Writes a PLY file of the points (for MeshLab, CloudCompare, Open3D), whole or not at
    /// all: per vertex `x y z` (float, world mm), `red green blue` (uchar; band voxels
    /// 220 30 30, the rest 160 160 160, for viewers that colour by vertex) and `band` (ushort).
    pub fn write_ply(&self, path: &Path, encoding: PlyEncoding) -> Result<(), CarveError> {
        let mut out = format!(
            "ply\n{}\ncomment flexshape carved voxel centres, world frame, mm; band 0 = no band\nelement vertex {}\nproperty float x\nproperty float y\nproperty float z\nproperty uchar red\nproperty uchar green\nproperty uchar blue\nproperty ushort band\nend_header\n",
            encoding.format_line(),
            self.points.len()
        )
        .into_bytes();
        for (p, &b) in self.points.iter().zip(&self.band) {
            let rgb: [u8; 3] = if b == 0 { [160; 3] } else { [220, 30, 30] };
            match encoding {
                PlyEncoding::Binary => {
                    for v in p {
                        out.extend_from_slice(&v.to_le_bytes());
                    }
                    out.extend_from_slice(&rgb);
                    out.extend_from_slice(&b.to_le_bytes());
                }
                PlyEncoding::Ascii => out.extend_from_slice(
                    format!(
                        "{} {} {} {} {} {} {b}\n",
                        p[0], p[1], p[2], rgb[0], rgb[1], rgb[2]
                    )
                    .as_bytes(),
                ),
            }
        }
        write_whole(path, &out)
    }
}

/// Writes `bytes` to `path` whole or not at all: beside it first, then renamed into place (a
/// reader never sees a partial file, and an interrupted run leaves none).
pub(crate) fn write_whole(path: &Path, bytes: &[u8]) -> Result<(), CarveError> {
    let err = |source| CarveError::Write {
        path: path.display().to_string(),
        source,
    };
    let part = path.with_extension("ply.part");
    std::fs::write(&part, bytes).map_err(err)?;
    std::fs::rename(&part, path).map_err(err)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn occupancy(cells: &[[u32; 3]]) -> Occupancy {
        let volume = Volume::new([0.0; 3], [1.0; 3], [8, 8, 8]).unwrap();
        let mut voxels: Vec<u32> = cells.iter().map(|[i, j, k]| i + 8 * (j + 8 * k)).collect();
        voxels.sort_unstable();
        Occupancy { volume, voxels }
    }

    #[test]
    fn the_parts_reaching_what_every_camera_carved_are_kept_and_no_other() {
        // A rod along x (its middle a diagonal step, still 26-connected) and a blob apart.
        let hull = occupancy(&[
            [0, 0, 0],
            [1, 0, 0],
            [2, 1, 1],
            [3, 1, 1],
            [6, 6, 6],
            [6, 7, 6],
        ]);
        let seen = occupancy(&[[0, 0, 0]]);
        assert_eq!(
            hull.reaching(&seen),
            occupancy(&[[0, 0, 0], [1, 0, 0], [2, 1, 1], [3, 1, 1]])
        );
        assert!(hull.reaching(&occupancy(&[[5, 5, 5]])).is_empty());
        assert_eq!(hull.reaching(&hull), hull);
    }
}
