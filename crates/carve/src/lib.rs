//! Voxel carving (paper, Section II-B): the voxels of a working volume whose centres project
//! inside every camera's silhouette — the visual hull — as a point cloud.
//!
//! - [`LookupTable`] and [`LookupTable::carve`]: the paper's Algorithms 1 and 2, every voxel's
//!   pixel in every camera precomputed once per rig (with lens distortion), then a per-frame
//!   scan with early exit. The correctness oracle and the baseline.
//! - [`HierarchicalCarver`]: the fast path, octree cells bounded conservatively in every
//!   camera (interval arithmetic through the lens model) and tested on the bit-packed masks;
//!   identical results to the lookup table at a cost that follows the object's surface.
//! - [`OutsideImage`]: what a camera that does not see a voxel says about it.
//! - [`find_bands`]: marker-band voxels (marker pixels in the cameras that see them on the
//!   hull's surface) grouped into bands with their centroids.
//! - [`Occupancy`] and [`PointCloud`]: the result, with PLY export.
//!
//! World frame and millimetres throughout; voxel `(i, j, k)` has index `i + nx·(j + ny·k)`.

mod bands;
mod cloud;
mod error;
mod hierarchical;
mod interval;
mod lookup;
mod projector;
mod surface;

pub use bands::{Band, BandRule, find_bands};
pub use cloud::{Occupancy, PlyEncoding, PointCloud};
pub use error::CarveError;
pub use hierarchical::HierarchicalCarver;
pub use lookup::{LookupTable, OutsideImage};
pub use surface::SurfaceMesh;
