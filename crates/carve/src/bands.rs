//! Marker bands in 3-D: occupied voxels whose pixels are marker pixels, grouped into bands.

use flexshape_camera::Camera;
use flexshape_silhouette::BitMask;
use serde::{Deserialize, Serialize};

use crate::cloud::Occupancy;
use crate::error::CarveError;
use crate::lookup::check_masks;
use crate::projector::VoxelProjector;

/// When an occupied voxel is a band voxel, and which groups count as bands.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct BandRule {
    /// A voxel is a band voxel when its pixel is a marker pixel in at least this many cameras
    /// (cameras that do not see it do not count). Two keeps one camera's stray marker pixel,
    /// or a voxel lying on a camera's ray through the band, from making a band alone.
    pub min_views: usize,
    /// 26-connected groups of band voxels smaller than this are dropped as specks.
    pub min_voxels: usize,
}

impl Default for BandRule {
    fn default() -> Self {
        BandRule {
            min_views: 2,
            min_voxels: 8,
        }
    }
}

/// One marker band found in the carved volume.
#[derive(Debug, Clone, PartialEq)]
pub struct Band {
    /// Mean of its voxel centres, world mm.
    pub centroid: [f64; 3],
    /// Its voxels (indices into the volume, ascending).
    pub voxels: Vec<u32>,
}

/// The bands of an occupancy, largest first, given one marker mask per camera.
pub fn find_bands(
    occupancy: &Occupancy,
    cameras: &[Camera],
    markers: &[&BitMask],
    rule: &BandRule,
) -> Result<Vec<Band>, CarveError> {
    let sizes: Vec<(u32, u32)> = cameras
        .iter()
        .map(|c| (c.intrinsics.width, c.intrinsics.height))
        .collect();
    check_masks(markers, &sizes)?;
    if rule.min_views == 0 || rule.min_views > cameras.len() {
        return Err(CarveError::MinViews {
            min_views: rule.min_views,
            cameras: cameras.len(),
        });
    }
    let projectors: Vec<VoxelProjector> = cameras.iter().map(VoxelProjector::new).collect();
    let band_voxels: Vec<u32> = occupancy
        .voxels
        .iter()
        .copied()
        .filter(|&v| {
            let [i, j, k] = occupancy.ijk(v);
            let centre = occupancy.volume.voxel_centre(i, j, k);
            let hits = projectors
                .iter()
                .zip(markers)
                .filter(|(proj, m)| {
                    proj.bit_address([centre.x, centre.y, centre.z])
                        .is_some_and(|a| m.words()[(a >> 6) as usize] >> (a & 63) & 1 == 1)
                })
                .count();
            hits >= rule.min_views
        })
        .collect();
    let mut bands: Vec<Band> = components(occupancy, &band_voxels)
        .into_iter()
        .filter(|c| c.len() >= rule.min_voxels)
        .map(|voxels| {
            let mut sum = [0.0; 3];
            for &v in &voxels {
                let [i, j, k] = occupancy.ijk(v);
                let c = occupancy.volume.voxel_centre(i, j, k);
                for a in 0..3 {
                    sum[a] += c[a];
                }
            }
            let n = voxels.len() as f64;
            Band {
                centroid: sum.map(|s| s / n),
                voxels,
            }
        })
        .collect();
    bands.sort_by_key(|b| std::cmp::Reverse(b.voxels.len()));
    Ok(bands)
}

/// 26-connected components of a sorted set of voxel indices.
fn components(occupancy: &Occupancy, voxels: &[u32]) -> Vec<Vec<u32>> {
    let dims = occupancy.volume.dims.map(|d| d as i64);
    let mut seen = vec![false; voxels.len()];
    let mut out = Vec::new();
    for start in 0..voxels.len() {
        if seen[start] {
            continue;
        }
        seen[start] = true;
        let mut stack = vec![start];
        let mut group = Vec::new();
        while let Some(n) = stack.pop() {
            group.push(voxels[n]);
            let [i, j, k] = occupancy.ijk(voxels[n]).map(|c| c as i64);
            for dz in -1..=1 {
                for dy in -1..=1 {
                    for dx in -1..=1 {
                        let (x, y, z) = (i + dx, j + dy, k + dz);
                        if x < 0 || y < 0 || z < 0 || x >= dims[0] || y >= dims[1] || z >= dims[2] {
                            continue;
                        }
                        let idx = (x + dims[0] * (y + dims[1] * z)) as u32;
                        if let Ok(m) = voxels.binary_search(&idx)
                            && !seen[m]
                        {
                            seen[m] = true;
                            stack.push(m);
                        }
                    }
                }
            }
        }
        group.sort_unstable();
        out.push(group);
    }
    out
}
