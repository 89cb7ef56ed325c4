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
//! - [`shadow_carved`]: the voxels a sharp shadow on the backdrop carved (shadow-coloured
//!   pixels in one camera, the object's colour in another).
//! - [`Occupancy`] and [`PointCloud`]: the result, with PLY export.
//!
//! World frame and millimetres throughout; voxel `(i, j, k)` has index `i + nx·(j + ny·k)`.
//!
//! ```
//! use flexshape_carve::{HierarchicalCarver, OutsideImage};
//! use flexshape_silhouette::BitMask;
//! use flexshape_sim::{CatheterPose, SimConfig, Simulator};
//!
//! // The simulator's exact masks of a bent catheter, carved in its rig's 256 mm cube.
//! let sim = Simulator::new(SimConfig::default())?;
//! let pose = CatheterPose::arc(&sim.config().catheter, [0.006, -0.002], [0.0, 0.0], 0.0);
//! let frame = sim.render(0, &pose)?;
//! let masks: Vec<BitMask> = frame.views.iter().map(|v| BitMask::from_gray(&v.mask)).collect();
//! let carver = HierarchicalCarver::new(&sim.cameras(), &sim.rig().volume)?;
//! let hull = carver.carve(&masks.iter().collect::<Vec<_>>(), OutsideImage::Carve)?;
//! // The visual hull holds the true centerline wherever it is in the volume.
//! let volume = &sim.rig().volume;
//! let inside = frame.truth.centerline.iter().map(|p| flexshape_camera::nalgebra::Point3::from(*p));
//! let inside = inside.filter(|p| volume.contains(p));
//! assert!(inside.clone().count() > 100 && inside.clone().all(|p| hull.contains_point(&p)));
//! println!("{} voxels, {:.0} mm³", hull.len(), hull.volume_mm3());
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

mod bands;
mod cloud;
mod error;
mod hierarchical;
mod interval;
mod lookup;
mod projector;
mod shadows;
mod surface;

pub use bands::{Band, BandRule, find_bands};
pub use cloud::{Occupancy, PlyEncoding, PointCloud};
pub use error::CarveError;
pub use hierarchical::HierarchicalCarver;
pub use lookup::{LookupTable, OutsideImage};
pub use shadows::shadow_carved;
pub use surface::SurfaceMesh;
