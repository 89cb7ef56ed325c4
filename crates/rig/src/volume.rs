//! The working volume that is carved: an axis-aligned box of voxels in world coordinates.

use flexshape_camera::nalgebra::Point3;
use serde::{Deserialize, Serialize};
use thiserror::Error;

/// Smallest and largest voxel edge, mm: a micrometre is finer than any camera resolves (the
/// stages count slices and cells by it: 1e-300 mm overflowed their indices), a metre coarser
/// than any instrument.
pub const VOXEL_MM: (f64, f64) = (0.001, 1000.0);

/// Largest number of voxels a volume may have (2³¹).
pub const MAX_VOXELS: u64 = 1 << 31;

/// An invalid volume description; `field` is `origin`, `voxel_size` or `dims`.
#[derive(Debug, Error, Clone, PartialEq)]
#[error("volume `{field}`: {problem}")]
pub struct VolumeError {
    /// Which part of the description is wrong.
    pub field: &'static str,
    /// What is wrong and what to do.
    pub problem: String,
}

/// A box of `dims[0] × dims[1] × dims[2]` voxels. Voxel `(i, j, k)` spans
/// `origin + [i, i+1) · voxel_size` (per axis); its centre, the point that is tested against
/// the silhouettes, is `origin + (i + ½) · voxel_size`. World frame, mm.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Volume {
    /// World position of the volume's minimum corner, mm.
    pub origin: [f64; 3],
    /// Voxel edge length along x, y, z, mm.
    pub voxel_size: [f64; 3],
    /// Number of voxels along x, y, z.
    pub dims: [u32; 3],
}

impl Default for Volume {
    /// The paper's volume: 256³ voxels of 1 mm centred on the world origin.
    fn default() -> Self {
        Volume {
            origin: [-128.0; 3],
            voxel_size: [1.0; 3],
            dims: [256; 3],
        }
    }
}

impl Volume {
    /// Validated constructor: finite origin, voxel edges within [`VOXEL_MM`], at least one voxel per
    /// axis and at most [`MAX_VOXELS`] in all.
    pub fn new(
        origin: [f64; 3],
        voxel_size: [f64; 3],
        dims: [u32; 3],
    ) -> Result<Self, VolumeError> {
        let v = Volume {
            origin,
            voxel_size,
            dims,
        };
        v.validate()?;
        Ok(v)
    }

    /// The volume spanning `min..max` (world mm) with cubic voxels of `voxel` mm; each axis gets
    /// `round((max − min) / voxel)` voxels (at least one), starting at `min`.
    pub fn from_bounds(min: [f64; 3], max: [f64; 3], voxel: f64) -> Result<Self, VolumeError> {
        if !(voxel.is_finite() && voxel > 0.0) {
            return Err(VolumeError {
                field: "voxel_size",
                problem: format!("{} mm is not a positive voxel size", crate::quoted(voxel)),
            });
        }
        let mut dims = [0u32; 3];
        for a in 0..3 {
            let extent = max[a] - min[a];
            if !(extent.is_finite() && extent > 0.0) {
                return Err(VolumeError {
                    field: "origin",
                    problem: format!(
                        "bounds on axis {} go from {} to {} mm; the maximum must exceed the minimum",
                        ["x", "y", "z"][a],
                        min[a],
                        max[a]
                    ),
                });
            }
            let n = (extent / voxel).round().max(1.0);
            if n > u32::MAX as f64 {
                return Err(Self::too_large(n));
            }
            dims[a] = n as u32;
        }
        Self::new(min, [voxel; 3], dims)
    }

    fn too_large(count: f64) -> VolumeError {
        VolumeError {
            field: "dims",
            problem: format!(
                "{count:.3e} voxels exceed the limit of 2^31; use larger voxels or a smaller box"
            ),
        }
    }

    /// Checks the invariants of [`Volume::new`].
    pub fn validate(&self) -> Result<(), VolumeError> {
        if let Some(o) = self.origin.iter().find(|o| !o.is_finite()) {
            return Err(VolumeError {
                field: "origin",
                problem: format!("{o} is not a finite coordinate in mm"),
            });
        }
        if let Some(s) = self
            .voxel_size
            .iter()
            .find(|s| !(s.is_finite() && **s > 0.0))
        {
            return Err(VolumeError {
                field: "voxel_size",
                problem: format!("{s} mm is not a positive voxel size"),
            });
        }
        if let Some(s) = self
            .voxel_size
            .iter()
            .find(|s| !(VOXEL_MM.0..=VOXEL_MM.1).contains(*s))
        {
            return Err(VolumeError {
                field: "voxel_size",
                problem: format!(
                    "{} mm is outside {}–{} mm: give each voxel edge in millimetres",
                    crate::quoted(*s),
                    VOXEL_MM.0,
                    VOXEL_MM.1
                ),
            });
        }
        if self.dims.contains(&0) {
            return Err(VolumeError {
                field: "dims",
                problem: "every axis needs at least one voxel".into(),
            });
        }
        let count = self.voxel_count();
        if count > MAX_VOXELS {
            return Err(Self::too_large(count as f64));
        }
        Ok(())
    }

    /// Total number of voxels (saturating at `u64::MAX`).
    pub fn voxel_count(&self) -> u64 {
        self.dims
            .iter()
            .fold(1u64, |n, &d| n.saturating_mul(d as u64))
    }

    /// Centre of voxel `(i, j, k)`, world mm.
    pub fn voxel_centre(&self, i: u32, j: u32, k: u32) -> Point3<f64> {
        let c = |a: usize, n: u32| self.origin[a] + (n as f64 + 0.5) * self.voxel_size[a];
        Point3::new(c(0, i), c(1, j), c(2, k))
    }

    /// Maximum corner, world mm.
    pub fn max_corner(&self) -> Point3<f64> {
        let m = |a: usize| self.origin[a] + self.dims[a] as f64 * self.voxel_size[a];
        Point3::new(m(0), m(1), m(2))
    }

    /// The eight corners of the box, world mm.
    pub fn corners(&self) -> [Point3<f64>; 8] {
        let lo = self.origin;
        let hi = self.max_corner();
        std::array::from_fn(|n| {
            Point3::new(
                if n & 1 == 0 { lo[0] } else { hi.x },
                if n & 2 == 0 { lo[1] } else { hi.y },
                if n & 4 == 0 { lo[2] } else { hi.z },
            )
        })
    }

    /// How far `p` (world mm) lies inside the box: its distance to the nearest face, mm,
    /// negative outside.
    pub fn depth(&self, p: &Point3<f64>) -> f64 {
        let hi = self.max_corner();
        (0..3)
            .map(|a| (p[a] - self.origin[a]).min(hi[a] - p[a]))
            .fold(f64::INFINITY, f64::min)
    }

    /// True when `p` (world mm) lies inside the box.
    pub fn contains(&self, p: &Point3<f64>) -> bool {
        let hi = self.max_corner();
        (0..3).all(|a| p[a] >= self.origin[a] && p[a] < hi[a])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn default_is_the_papers_256_cube_centred_on_the_origin() {
        let v = Volume::default();
        assert_eq!(v.voxel_count(), 1 << 24);
        assert_eq!(v.voxel_centre(0, 0, 0), Point3::new(-127.5, -127.5, -127.5));
        assert_eq!(v.max_corner(), Point3::new(128.0, 128.0, 128.0));
        assert!(v.contains(&Point3::origin()));
        // The nearest face decides; outside, negative.
        assert_eq!(v.depth(&Point3::new(100.0, -20.0, 0.0)), 28.0);
        assert_eq!(v.depth(&Point3::new(0.0, 0.0, -138.0)), -10.0);
    }

    #[test]
    fn rejects_absurd_volumes() {
        assert_eq!(
            Volume::new([0.0; 3], [1.0; 3], [2048, 2048, 1024])
                .unwrap_err()
                .field,
            "dims"
        );
        assert!(Volume::new([0.0; 3], [1.0; 3], [2048, 1024, 1024]).is_ok());
        assert_eq!(
            Volume::new([0.0; 3], [0.0, 1.0, 1.0], [1; 3])
                .unwrap_err()
                .field,
            "voxel_size"
        );
        assert_eq!(
            Volume::new([f64::NAN, 0.0, 0.0], [1.0; 3], [1; 3])
                .unwrap_err()
                .field,
            "origin"
        );
        assert_eq!(
            Volume::new([0.0; 3], [1.0; 3], [0, 1, 1])
                .unwrap_err()
                .field,
            "dims"
        );
        assert!(Volume::from_bounds([0.0; 3], [1e6; 3], 0.001).is_err());
        // Edges a stage cannot count slices by, or no camera resolves; the bounds themselves
        // are edges.
        for edge in [1e-300, 1e-9, 0.0009, 1000.1, 1e300] {
            let e = Volume::new([0.0; 3], [1.0, 1.0, edge], [1; 3]).unwrap_err();
            assert_eq!(e.field, "voxel_size", "{edge}");
            assert!(e.problem.contains("0.001–1000 mm"), "{edge}: {}", e.problem);
        }
        assert!(Volume::new([0.0; 3], [0.001, 1.0, 1000.0], [1; 3]).is_ok());
    }

    #[test]
    fn from_bounds_rounds_to_whole_voxels() {
        let v = Volume::from_bounds([-10.0, 0.0, 5.0], [10.0, 3.0, 6.0], 0.5).unwrap();
        assert_eq!(v.dims, [40, 6, 2]);
        assert_eq!(v.origin, [-10.0, 0.0, 5.0]);
    }
}
