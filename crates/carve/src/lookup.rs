//! Algorithm 1 (lookup table of every voxel's pixel in every camera) and Algorithm 2 (carving
//! with early exit).

use flexshape_camera::Camera;
use flexshape_rig::Volume;
use flexshape_silhouette::BitMask;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::cloud::Occupancy;
use crate::error::CarveError;
use crate::projector::VoxelProjector;

/// Table entry of a voxel a camera does not see (outside its image, behind it, or beyond its
/// lens model's valid radius).
const UNSEEN: u32 = u32::MAX;

/// Largest table the exact carver builds (bytes); larger volumes need coarser voxels.
pub const MAX_TABLE_BYTES: u64 = 4 << 30;

/// What a camera that does not see a voxel says about it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", tag = "rule")]
pub enum OutsideImage {
    /// The voxel is carved: the hull lies where every camera looks (the paper's rig sees the
    /// whole volume in every camera).
    #[default]
    Carve,
    /// The camera does not constrain the voxel; it is kept if at least `min_views` cameras see
    /// it and every camera that sees it sees it inside the silhouette.
    Ignore {
        /// Cameras that must see a voxel for it to be kept.
        min_views: usize,
    },
}

/// Every voxel's pixel in every camera, built once per rig and volume.
#[derive(Debug, Clone)]
pub struct LookupTable {
    volume: Volume,
    cameras: usize,
    sizes: Vec<(u32, u32)>,
    /// `table[voxel · cameras + c]`: bit address of the voxel centre's pixel in camera `c`'s
    /// mask ([`BitMask::bit_address`]), or `UNSEEN`.
    table: Vec<u32>,
}

impl LookupTable {
    /// Projects every voxel centre into every camera (Algorithm 1). Needs at least two
    /// cameras, every one of which must see some voxel.
    pub fn new(cameras: &[Camera], volume: &Volume) -> Result<Self, CarveError> {
        volume.validate()?;
        if cameras.len() < 2 {
            return Err(CarveError::TooFewCameras {
                cameras: cameras.len(),
            });
        }
        let nc = cameras.len();
        let bytes = volume.voxel_count() * nc as u64 * 4;
        if bytes > MAX_TABLE_BYTES {
            return Err(CarveError::TableTooLarge { bytes });
        }
        let [nx, ny, _] = volume.dims.map(|d| d as usize);
        let slice = nx * ny * nc;
        let projectors: Vec<VoxelProjector> = cameras.iter().map(VoxelProjector::new).collect();
        let mut table = vec![UNSEEN; volume.voxel_count() as usize * nc];
        table
            .par_chunks_mut(slice)
            .enumerate()
            .for_each(|(k, out)| {
                for j in 0..ny {
                    for i in 0..nx {
                        let centre = volume.voxel_centre(i as u32, j as u32, k as u32);
                        let v = (j * nx + i) * nc;
                        for (c, proj) in projectors.iter().enumerate() {
                            if let Some(a) = proj.bit_address([centre.x, centre.y, centre.z]) {
                                out[v + c] = a;
                            }
                        }
                    }
                }
            });
        for c in 0..nc {
            if !table.iter().skip(c).step_by(nc).any(|&a| a != UNSEEN) {
                return Err(CarveError::VolumeNotInView { camera: c });
            }
        }
        Ok(LookupTable {
            volume: *volume,
            cameras: nc,
            sizes: cameras
                .iter()
                .map(|c| (c.intrinsics.width, c.intrinsics.height))
                .collect(),
            table,
        })
    }

    /// The volume.
    pub fn volume(&self) -> &Volume {
        &self.volume
    }

    /// Memory held by the table, bytes (4 per voxel and camera).
    pub fn memory_bytes(&self) -> usize {
        self.table.len() * 4
    }

    /// The voxels whose centres every camera sees inside its mask (Algorithm 2), under `rule`
    /// for cameras that do not see a voxel.
    pub fn carve(&self, masks: &[&BitMask], rule: OutsideImage) -> Result<Occupancy, CarveError> {
        check_masks(masks, &self.sizes)?;
        let nc = self.cameras;
        let min_views = min_views(rule, nc)?;
        let carve_unseen = rule == OutsideImage::Carve;
        let words: Vec<&[u64]> = masks.iter().map(|m| m.words()).collect();
        let [nx, ny, _] = self.volume.dims.map(|d| d as usize);
        let slice = nx * ny;
        let voxels: Vec<u32> = self
            .table
            .par_chunks(slice * nc)
            .enumerate()
            .flat_map_iter(|(k, entries)| {
                let words = &words;
                entries
                    .chunks_exact(nc)
                    .enumerate()
                    .filter_map(move |(v, pixels)| {
                        let mut seen = 0;
                        for (c, &a) in pixels.iter().enumerate() {
                            if a == UNSEEN {
                                if carve_unseen {
                                    return None;
                                }
                                continue;
                            }
                            if words[c][(a >> 6) as usize] >> (a & 63) & 1 == 0 {
                                return None;
                            }
                            seen += 1;
                        }
                        (seen >= min_views).then_some((k * slice + v) as u32)
                    })
            })
            .collect();
        Ok(Occupancy {
            volume: self.volume,
            voxels,
        })
    }
}

/// Checks that there is one mask per camera, of that camera's image size.
pub(crate) fn check_masks(masks: &[&BitMask], sizes: &[(u32, u32)]) -> Result<(), CarveError> {
    if masks.len() != sizes.len() {
        return Err(CarveError::MaskCount {
            masks: masks.len(),
            cameras: sizes.len(),
        });
    }
    for (c, (m, &(w, h))) in masks.iter().zip(sizes).enumerate() {
        if (m.width(), m.height()) != (w as usize, h as usize) {
            return Err(CarveError::MaskSize {
                camera: c,
                width: m.width(),
                height: m.height(),
                expected_width: w,
                expected_height: h,
            });
        }
    }
    Ok(())
}

/// Cameras that must see a voxel under `rule`.
pub(crate) fn min_views(rule: OutsideImage, cameras: usize) -> Result<usize, CarveError> {
    match rule {
        OutsideImage::Carve => Ok(cameras),
        OutsideImage::Ignore { min_views } if min_views == 0 || min_views > cameras => {
            Err(CarveError::MinViews { min_views, cameras })
        }
        OutsideImage::Ignore { min_views } => Ok(min_views),
    }
}
