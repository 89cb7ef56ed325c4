//! Marker bands in 3-D: occupied voxels whose pixels are marker pixels, grouped into bands.

use flexshape_camera::Camera;
use flexshape_silhouette::BitMask;
use serde::{Deserialize, Serialize};

use crate::cloud::Occupancy;
use crate::error::CarveError;
use crate::lookup::check_masks;
use crate::projector::VoxelProjector;

/// When an occupied voxel is a band voxel, and which groups count as bands.
///
/// A camera's pixel shows the surface nearest to it, not the voxel: a voxel deep in the hull,
/// or on its far side, takes the colour of whatever lies in front of it. With `visibility`
/// each voxel is judged only by the cameras that see it on the hull's surface (a z-buffer of
/// the occupied voxels per camera), so the band is the patch of surface that looks like tape.
/// Without it (the simple rule), every camera that projects the voxel onto a marker pixel
/// counts, which shifts a band toward the cameras' side by up to a tube radius times the
/// tangent of the viewing elevation.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct BandRule {
    /// Judge voxels only by the cameras that see them (see above).
    pub visibility: bool,
    /// With `visibility`: a band voxel is a marker pixel in every camera that sees it, and in
    /// at least this many. Without: in at least this many of all cameras (two keeps one
    /// camera's stray pixel, or a voxel on a camera's ray through the band, out).
    pub min_views: usize,
    /// 26-connected groups of band voxels smaller than this are dropped as specks.
    pub min_voxels: usize,
}

impl Default for BandRule {
    fn default() -> Self {
        BandRule {
            visibility: true,
            min_views: 1,
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
    let centres = occupancy.centres();
    // Per camera and voxel: not seen, seen on a marker pixel, or seen elsewhere.
    let verdicts: Vec<Vec<Seen>> = projectors
        .iter()
        .zip(markers)
        .map(|(proj, m)| {
            let pixels: Vec<Option<u32>> = centres.iter().map(|&c| proj.bit_address(c)).collect();
            let visible = rule
                .visibility
                .then(|| visible_voxels(proj, &centres, &pixels, &occupancy.volume));
            pixels
                .iter()
                .enumerate()
                .map(|(n, &p)| match p {
                    Some(_) if visible.as_ref().is_some_and(|v| !v[n]) => Seen::No,
                    Some(a) if m.words()[(a >> 6) as usize] >> (a & 63) & 1 == 1 => Seen::Marker,
                    Some(_) => Seen::Other,
                    None => Seen::No,
                })
                .collect()
        })
        .collect();
    let band_voxels: Vec<u32> = occupancy
        .voxels
        .iter()
        .enumerate()
        .filter(|&(n, _)| {
            let hits = verdicts.iter().filter(|v| v[n] == Seen::Marker).count();
            let others = verdicts.iter().filter(|v| v[n] == Seen::Other).count();
            hits >= rule.min_views && (!rule.visibility || others == 0)
        })
        .map(|(_, &v)| v)
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

/// What one camera says about one voxel.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Seen {
    No,
    Marker,
    Other,
}

/// Which voxels (in `centres`' order) the camera sees on the surface: each voxel's depth is
/// splatted over its footprint into a z-buffer; a voxel is visible when it lies within a voxel
/// diagonal of the nearest depth at its pixel.
fn visible_voxels(
    proj: &VoxelProjector,
    centres: &[[f64; 3]],
    addresses: &[Option<u32>],
    volume: &flexshape_rig::Volume,
) -> Vec<bool> {
    let edge = volume.voxel_size.iter().copied().fold(0.0, f64::max);
    let diagonal = volume.voxel_size.iter().map(|s| s * s).sum::<f64>().sqrt();
    let focal = proj.fx.max(proj.fy);
    let row = proj.row_bits();
    // Pixel, depth and footprint half-width (whole pixels) of each seen voxel.
    let pixels: Vec<Option<(usize, usize, f64, usize)>> = centres
        .iter()
        .zip(addresses)
        .map(|(&c, &a)| {
            let a = a? as usize;
            let z = proj.to_camera(c)[2];
            Some((
                a % row,
                a / row,
                z,
                (0.5 * edge * focal / z).ceil() as usize,
            ))
        })
        .collect();
    // The z-buffer covers only the voxels' footprints.
    let (mut x0, mut y0, mut x1, mut y1) = (usize::MAX, usize::MAX, 0, 0);
    for &(x, y, _, r) in pixels.iter().flatten() {
        (x0, y0) = (x0.min(x.saturating_sub(r)), y0.min(y.saturating_sub(r)));
        (x1, y1) = (x1.max(x + r), y1.max(y + r));
    }
    if x0 > x1 {
        return vec![false; centres.len()];
    }
    let w = x1 - x0 + 1;
    let mut zbuf = vec![f64::INFINITY; w * (y1 - y0 + 1)];
    for &(x, y, z, r) in pixels.iter().flatten() {
        for yy in y - r.min(y)..=y + r {
            let line = &mut zbuf[(yy - y0) * w..(yy - y0 + 1) * w];
            for d in &mut line[x - r.min(x) - x0..=x + r - x0] {
                *d = d.min(z);
            }
        }
    }
    pixels
        .iter()
        .map(|p| p.is_some_and(|(x, y, z, _)| z <= zbuf[(y - y0) * w + x - x0] + diagonal))
        .collect()
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
