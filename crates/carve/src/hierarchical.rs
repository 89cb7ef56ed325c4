//! Hierarchical (octree) carving with conservative cell bounds and word-parallel mask tests.
//!
//! A cell is a box of voxels; its voxel centres span a world box whose perspective image in
//! normalized coordinates is exactly bounded by the projections of its 8 corners (all in front
//! of the camera). Lens distortion over that rectangle is enclosed by interval arithmetic on
//! OpenCV's polynomial, giving a pixel rectangle that holds every seen voxel centre's pixel.
//! Per camera: no mask pixel in the rectangle → the camera carves the whole cell (under
//! [`OutsideImage::Ignore`] only if it sees all of it); the camera sees the whole cell and the
//! rectangle is all mask → it keeps the whole cell. Cells no camera rejects and not all accept
//! are split; single voxels are decided by exactly the test of [`crate::LookupTable`], so the
//! result is identical to exact carving. Rectangle tests read the bit-packed mask directly, 64
//! pixels a word, stopping once the rectangle is known to be mixed: no per-frame summed-area
//! table is needed (building three would cost more than the whole carve).

use flexshape_camera::Camera;
use flexshape_camera::nalgebra::{Matrix3, Vector3};
use flexshape_rig::Volume;
use flexshape_silhouette::BitMask;

use crate::cloud::Occupancy;
use crate::error::CarveError;
use crate::interval::Interval;
use crate::lookup::{OutsideImage, check_masks, min_views, voxel_pixel};

/// Widening of every pixel bound, covering f64 rounding between this bound and the exact
/// projection (whose errors are ~1e-10 px).
const MARGIN_PX: f64 = 1e-6;

/// Carves without a lookup table: cost follows the object's surface, not the volume.
#[derive(Debug, Clone)]
pub struct HierarchicalCarver {
    volume: Volume,
    cameras: Vec<Camera>,
}

/// Rectangle queries straight on a bit-packed mask: a masked popcount per row, stopping as
/// soon as the answer is known (no per-frame table to build).
struct RectQuery<'a> {
    mask: &'a BitMask,
}

/// What a rectangle of a mask holds.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Fill {
    Empty,
    Full,
    Mixed,
}

impl RectQuery<'_> {
    /// Whether columns `x0..=x1`, rows `y0..=y1` are all unset, all set, or mixed.
    fn fill(&self, x0: usize, x1: usize, y0: usize, y1: usize) -> Fill {
        let (w0, w1) = (x0 / 64, x1 / 64);
        let word_mask = |w: usize| {
            let lo = if w == w0 { x0 % 64 } else { 0 };
            let hi = if w == w1 { x1 % 64 } else { 63 };
            (u64::MAX >> (63 - hi)) & (u64::MAX << lo)
        };
        let (mut any, mut all) = (false, true);
        for y in y0..=y1 {
            let row = self.mask.row(y);
            for (w, &word) in row.iter().enumerate().take(w1 + 1).skip(w0) {
                let m = word_mask(w);
                let bits = word & m;
                any |= bits != 0;
                all &= bits == m;
            }
            if any && !all {
                return Fill::Mixed;
            }
        }
        match (any, all) {
            (false, _) => Fill::Empty,
            (true, true) => Fill::Full,
            _ => Fill::Mixed,
        }
    }
}

/// What one camera says about a whole cell.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Verdict {
    Carve,
    Keep,
    Unsure,
}

impl HierarchicalCarver {
    /// A carver for these cameras and volume (at least two cameras).
    pub fn new(cameras: &[Camera], volume: &Volume) -> Result<Self, CarveError> {
        if cameras.len() < 2 {
            return Err(CarveError::TooFewCameras {
                cameras: cameras.len(),
            });
        }
        Ok(HierarchicalCarver {
            volume: *volume,
            cameras: cameras.to_vec(),
        })
    }

    /// The volume.
    pub fn volume(&self) -> &Volume {
        &self.volume
    }

    /// The occupied voxels, identical to [`crate::LookupTable::carve`] with the same masks and
    /// rule.
    pub fn carve(&self, masks: &[&BitMask], rule: OutsideImage) -> Result<Occupancy, CarveError> {
        let sizes: Vec<(u32, u32)> = self
            .cameras
            .iter()
            .map(|c| (c.intrinsics.width, c.intrinsics.height))
            .collect();
        check_masks(masks, &sizes)?;
        let min_views = min_views(rule, self.cameras.len())?;
        let queries: Vec<RectQuery> = masks.iter().map(|m| RectQuery { mask: m }).collect();
        let dims = self.volume.dims;
        let side = dims.iter().copied().max().unwrap_or(1).next_power_of_two();
        let mut voxels = Vec::new();
        let mut stack = vec![([0u32; 3], side)];
        while let Some((lo, size)) = stack.pop() {
            let hi: [u32; 3] = std::array::from_fn(|a| (lo[a] + size).min(dims[a]));
            if (0..3).any(|a| lo[a] >= hi[a]) {
                continue;
            }
            if size == 1 {
                if self.voxel_kept(lo, masks, rule, min_views) {
                    voxels.push(self.index(lo));
                }
                continue;
            }
            let mut all_keep = true;
            let mut carved = false;
            for (cam, query) in self.cameras.iter().zip(&queries) {
                match self.verdict(cam, query, lo, hi, rule) {
                    Verdict::Carve => {
                        carved = true;
                        break;
                    }
                    Verdict::Keep => {}
                    Verdict::Unsure => all_keep = false,
                }
            }
            if carved {
                continue;
            }
            if all_keep {
                for k in lo[2]..hi[2] {
                    for j in lo[1]..hi[1] {
                        for i in lo[0]..hi[0] {
                            voxels.push(self.index([i, j, k]));
                        }
                    }
                }
                continue;
            }
            let half = size / 2;
            for n in 0..8u32 {
                stack.push((
                    [
                        lo[0] + (n & 1) * half,
                        lo[1] + (n >> 1 & 1) * half,
                        lo[2] + (n >> 2) * half,
                    ],
                    half,
                ));
            }
        }
        voxels.sort_unstable();
        Ok(Occupancy {
            volume: self.volume,
            voxels,
        })
    }

    fn index(&self, [i, j, k]: [u32; 3]) -> u32 {
        let [nx, ny, _] = self.volume.dims;
        i + nx * (j + ny * k)
    }

    /// The exact per-voxel test, as the lookup table applies it.
    fn voxel_kept(
        &self,
        ijk: [u32; 3],
        masks: &[&BitMask],
        rule: OutsideImage,
        min_views: usize,
    ) -> bool {
        let centre = self.volume.voxel_centre(ijk[0], ijk[1], ijk[2]);
        let mut seen = 0;
        for (cam, m) in self.cameras.iter().zip(masks) {
            match voxel_pixel(cam, &centre, m.stride()) {
                None if rule == OutsideImage::Carve => return false,
                None => {}
                Some(a) => {
                    if m.words()[(a >> 6) as usize] >> (a & 63) & 1 == 0 {
                        return false;
                    }
                    seen += 1;
                }
            }
        }
        seen >= min_views
    }

    /// One camera's verdict on the voxels `lo..hi`.
    fn verdict(
        &self,
        cam: &Camera,
        query: &RectQuery,
        lo: [u32; 3],
        hi: [u32; 3],
        rule: OutsideImage,
    ) -> Verdict {
        let v = &self.volume;
        let first = v.voxel_centre(lo[0], lo[1], lo[2]);
        let last = v.voxel_centre(hi[0] - 1, hi[1] - 1, hi[2] - 1);
        let r: &Matrix3<f64> = cam.pose.rotation.matrix();
        let t = cam.pose.translation;
        let (mut x, mut y) = (
            Interval::new(f64::INFINITY, f64::NEG_INFINITY),
            Interval::new(f64::INFINITY, f64::NEG_INFINITY),
        );
        for n in 0..8 {
            let p = Vector3::new(
                if n & 1 == 0 { first.x } else { last.x },
                if n & 2 == 0 { first.y } else { last.y },
                if n & 4 == 0 { first.z } else { last.z },
            );
            let c = r * p + t;
            if c.z.is_nan() || c.z <= 0.0 {
                return Verdict::Unsure;
            }
            let (nx, ny) = (c.x / c.z, c.y / c.z);
            x = Interval::new(x.lo.min(nx), x.hi.max(nx));
            y = Interval::new(y.lo.min(ny), y.hi.max(ny));
        }
        let k = &cam.intrinsics;
        // The farthest point of a rectangle from the optical axis is a corner.
        let r_max = x.lo.abs().max(x.hi.abs()).hypot(y.lo.abs().max(y.hi.abs()));
        let all_valid = r_max <= k.valid_radius();
        let Some((xd, yd)) = distort_bounds(k.distortion, x, y) else {
            return Verdict::Unsure;
        };
        let u = Interval::new(
            k.fx * xd.lo + k.cx - MARGIN_PX,
            k.fx * xd.hi + k.cx + MARGIN_PX,
        );
        let vv = Interval::new(
            k.fy * yd.lo + k.cy - MARGIN_PX,
            k.fy * yd.hi + k.cy + MARGIN_PX,
        );
        let (w, h) = (k.width as f64, k.height as f64);
        let all_seen =
            all_valid && u.lo >= -0.5 && u.hi < w - 0.5 && vv.lo >= -0.5 && vv.hi < h - 0.5;
        // Pixels the seen centres can fall in (pixel = floor(coordinate + ½), clipped).
        let px0 = (u.lo + 0.5).floor().max(0.0);
        let px1 = (u.hi + 0.5).floor().min(w - 1.0);
        let py0 = (vv.lo + 0.5).floor().max(0.0);
        let py1 = (vv.hi + 0.5).floor().min(h - 1.0);
        let fill = if px0 > px1 || py0 > py1 || !px0.is_finite() || !py0.is_finite() {
            Fill::Empty
        } else {
            query.fill(px0 as usize, px1 as usize, py0 as usize, py1 as usize)
        };
        if fill == Fill::Empty && (rule == OutsideImage::Carve || all_seen) {
            return Verdict::Carve;
        }
        if all_seen && fill == Fill::Full {
            return Verdict::Keep;
        }
        Verdict::Unsure
    }
}

/// Encloses OpenCV's distorted normalized coordinates over the rectangle `x × y`; `None` when
/// the rational denominator may vanish there.
fn distort_bounds(
    d: flexshape_camera::Distortion,
    x: Interval,
    y: Interval,
) -> Option<(Interval, Interval)> {
    let (x2, y2) = (x.square(), y.square());
    let r2 = x2.add(y2);
    let r4 = r2.square();
    let r6 = r4.mul(r2);
    let [k1, k2, k3] = d.radial;
    let [k4, k5, k6] = d.rational;
    let [p1, p2] = d.tangential;
    let [s1, s2, s3, s4] = d.prism;
    let one = Interval::point(1.0);
    let num = one.add(r2.scale(k1)).add(r4.scale(k2)).add(r6.scale(k3));
    let den = one.add(r2.scale(k4)).add(r4.scale(k5)).add(r6.scale(k6));
    let g = num.div(den)?;
    let xy = x.mul(y);
    let xd = x
        .mul(g)
        .add(xy.scale(2.0 * p1))
        .add(r2.add(x2.scale(2.0)).scale(p2))
        .add(r2.scale(s1))
        .add(r4.scale(s2));
    let yd = y
        .mul(g)
        .add(r2.add(y2.scale(2.0)).scale(p1))
        .add(xy.scale(2.0 * p2))
        .add(r2.scale(s3))
        .add(r4.scale(s4));
    Some((xd, yd))
}
