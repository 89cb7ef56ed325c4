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
use flexshape_rig::Volume;
use flexshape_silhouette::BitMask;
use rayon::prelude::*;

use crate::cloud::Occupancy;
use crate::error::CarveError;
use crate::interval::Interval;
use crate::lookup::{OutsideImage, check_masks, min_views};
use crate::projector::VoxelProjector;

/// Widening of every pixel bound, covering f64 rounding between this bound and the exact
/// projection (whose errors are ~1e-10 px).
const MARGIN_PX: f64 = 1e-6;

/// Smallest corner depth (mm) for which a cell counts as in front of the camera.
const MIN_DEPTH: f64 = 1e-9;

/// Carves without a lookup table: cost follows the object's surface, not the volume.
#[derive(Debug, Clone)]
pub struct HierarchicalCarver {
    volume: Volume,
    cameras: Vec<Camera>,
    projectors: Vec<VoxelProjector>,
}

/// Rectangle queries straight on a bit-packed mask: a masked popcount per row, stopping as
/// soon as the answer is known (no per-frame table to build).
struct RectQuery<'a> {
    mask: &'a BitMask,
}

/// One frame's masks as the carver reads them, and the rule for unseen voxels.
struct FrameMasks<'a> {
    queries: Vec<RectQuery<'a>>,
    words: Vec<&'a [u64]>,
    rule: OutsideImage,
    min_views: usize,
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
        volume.validate()?;
        if cameras.len() < 2 {
            return Err(CarveError::TooFewCameras {
                cameras: cameras.len(),
            });
        }
        Ok(HierarchicalCarver {
            volume: *volume,
            cameras: cameras.to_vec(),
            projectors: cameras.iter().map(VoxelProjector::new).collect(),
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
        let frame = FrameMasks {
            queries: masks.iter().map(|m| RectQuery { mask: m }).collect(),
            words: masks.iter().map(|m| m.words()).collect(),
            rule,
            min_views,
        };
        let dims = self.volume.dims;
        let side = dims.iter().copied().max().unwrap_or(1).next_power_of_two();
        // With more than one thread, the top two levels in one pass and the cells below them
        // in parallel (on one thread the split measurably costs, ~20 %).
        let split = if side >= 16 && rayon::current_num_threads() > 1 {
            side / 4
        } else {
            0
        };
        let mut voxels = Vec::new();
        let mut deferred = Vec::new();
        self.descend(&frame, ([0; 3], side), split, &mut voxels, &mut deferred);
        let parts: Vec<Vec<u32>> = deferred
            .into_par_iter()
            .map(|cell| {
                let mut part = Vec::new();
                self.descend(&frame, cell, 0, &mut part, &mut Vec::new());
                part
            })
            .collect();
        voxels.extend(parts.into_iter().flatten());
        voxels.sort_unstable();
        Ok(Occupancy {
            volume: self.volume,
            voxels,
        })
    }

    /// Carves the cell `(lo, size)` into `voxels`, except that cells of size `defer` are
    /// left in `deferred` instead of being split.
    fn descend(
        &self,
        frame: &FrameMasks,
        root: ([u32; 3], u32),
        defer: u32,
        voxels: &mut Vec<u32>,
        deferred: &mut Vec<([u32; 3], u32)>,
    ) {
        // Cameras in the order they are asked; the last one to carve goes first, since
        // neighbouring cells tend to be carved by the same camera.
        let mut order: Vec<usize> = (0..self.cameras.len()).collect();
        let dims = self.volume.dims;
        let mut stack = vec![root];
        while let Some((lo, size)) = stack.pop() {
            let hi: [u32; 3] = std::array::from_fn(|a| (lo[a] + size).min(dims[a]));
            if (0..3).any(|a| lo[a] >= hi[a]) {
                continue;
            }
            if size == defer {
                deferred.push((lo, size));
                continue;
            }
            let mut all_keep = true;
            let mut carved = false;
            for n in 0..order.len() {
                let c = order[n];
                match self.verdict(&self.projectors[c], &frame.queries[c], lo, hi, frame.rule) {
                    Verdict::Carve => {
                        order[..=n].rotate_right(1);
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
            if size <= 2 {
                self.carve_block(lo, hi, frame, &mut order, voxels);
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
    }

    fn index(&self, [i, j, k]: [u32; 3]) -> u32 {
        let [nx, ny, _] = self.volume.dims;
        i + nx * (j + ny * k)
    }

    /// Decides the (at most 2×2×2) voxels `lo..hi` one by one with the lookup table's exact
    /// test, one camera at a time over the whole block so the projections run branch-free.
    fn carve_block(
        &self,
        lo: [u32; 3],
        hi: [u32; 3],
        frame: &FrameMasks,
        order: &mut [usize],
        out: &mut Vec<u32>,
    ) {
        let mut centres = [[0.0; 3]; 8];
        let mut index = [0u32; 8];
        let mut n = 0;
        for k in lo[2]..hi[2] {
            for j in lo[1]..hi[1] {
                for i in lo[0]..hi[0] {
                    let c = self.volume.voxel_centre(i, j, k);
                    centres[n] = [c.x, c.y, c.z];
                    index[n] = self.index([i, j, k]);
                    n += 1;
                }
            }
        }
        let carve_unseen = frame.rule == OutsideImage::Carve;
        let mut alive = [true; 8];
        let mut seen = [0usize; 8];
        for at in 0..order.len() {
            let c = order[at];
            let (proj, w) = (&self.projectors[c], frame.words[c]);
            let mut any = false;
            for v in 0..n {
                let (s, a) = proj.address(centres[v]);
                let inside = w[(a >> 6) as usize] >> (a & 63) & 1 == 1;
                alive[v] &= if s { inside } else { !carve_unseen };
                seen[v] += s as usize;
                any |= alive[v];
            }
            if !any {
                order[..=at].rotate_right(1);
                return;
            }
        }
        for v in 0..n {
            if alive[v] && seen[v] >= frame.min_views {
                out.push(index[v]);
            }
        }
    }

    /// One camera's verdict on the voxels `lo..hi`.
    fn verdict(
        &self,
        cam: &VoxelProjector,
        query: &RectQuery,
        lo: [u32; 3],
        hi: [u32; 3],
        rule: OutsideImage,
    ) -> Verdict {
        let v = &self.volume;
        let first = v.voxel_centre(lo[0], lo[1], lo[2]);
        let last = v.voxel_centre(hi[0] - 1, hi[1] - 1, hi[2] - 1);
        let c0 = cam.to_camera([first.x, first.y, first.z]);
        let span = [last.x - first.x, last.y - first.y, last.z - first.z];
        // Camera-frame edge vectors of the box: column a of R times the box's extent along a.
        let edge: [[f64; 3]; 3] =
            std::array::from_fn(|a| std::array::from_fn(|i| cam.r[i][a] * span[a]));
        let (mut x, mut y) = (
            Interval::new(f64::INFINITY, f64::NEG_INFINITY),
            Interval::new(f64::INFINITY, f64::NEG_INFINITY),
        );
        for n in 0..8 {
            let mut c = c0;
            for (a, e) in edge.iter().enumerate() {
                if n >> a & 1 == 1 {
                    c = [c[0] + e[0], c[1] + e[1], c[2] + e[2]];
                }
            }
            // The voxels' own depths may differ from these by rounding: keep clear of zero.
            if c[2].is_nan() || c[2] <= MIN_DEPTH {
                return Verdict::Unsure;
            }
            let (nx, ny) = (c[0] / c[2], c[1] / c[2]);
            x = Interval::new(x.lo.min(nx), x.hi.max(nx));
            y = Interval::new(y.lo.min(ny), y.hi.max(ny));
        }
        // The farthest point of a rectangle from the optical axis is a corner.
        let r2_max = x.lo.abs().max(x.hi.abs()).powi(2) + y.lo.abs().max(y.hi.abs()).powi(2);
        let all_valid = r2_max * (1.0 + 1e-9) <= cam.valid_r2;
        let Some((xd, yd)) = distort_bounds(&cam.distortion, x, y) else {
            return Verdict::Unsure;
        };
        // Pixel coordinates + ½, so that a centre's pixel index is the floor.
        let u = Interval::new(
            cam.fx * xd.lo + cam.cx + 0.5 - MARGIN_PX,
            cam.fx * xd.hi + cam.cx + 0.5 + MARGIN_PX,
        );
        let vv = Interval::new(
            cam.fy * yd.lo + cam.cy + 0.5 - MARGIN_PX,
            cam.fy * yd.hi + cam.cy + 0.5 + MARGIN_PX,
        );
        if [u.lo, u.hi, vv.lo, vv.hi].iter().any(|a| a.is_nan()) {
            return Verdict::Unsure;
        }
        let (w, h) = (cam.width, cam.height);
        let all_seen = all_valid && u.lo >= 0.0 && u.hi < w && vv.lo >= 0.0 && vv.hi < h;
        // Pixels the seen centres can fall in, clipped to the image.
        let fill = if u.hi >= 0.0 && vv.hi >= 0.0 && u.lo < w && vv.lo < h {
            let clip = |a: f64, n: f64| a.clamp(0.0, n - 1.0) as usize;
            query.fill(clip(u.lo, w), clip(u.hi, w), clip(vv.lo, h), clip(vv.hi, h))
        } else {
            Fill::Empty
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
    d: &flexshape_camera::Distortion,
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
