//! The simulated rig: a deterministic, seeded stand-in for real cameras looking at a catheter,
//! with exact ground truth. Used by the tests of every stage, by `flexshape simulate` and
//! `flexshape demo`, and by users planning a rig.
//!
//! - [`SimRigConfig`]: cameras around the working cube (default: three near-orthogonal
//!   640×480 cameras about 600 mm away, with realistic distortion).
//! - [`Catheter`] and [`CatheterPose`]: a tube (radius 3 mm) with a straight proximal section
//!   and a 160 mm bending section of constant-curvature pieces, red bands at both ends of the
//!   bending section.
//! - [`Renderer`]: per-pixel ray casting with supersampled edges, Lambert + highlight shading,
//!   a bright textured backdrop, optional soft shadows and Gaussian noise.
//! - [`BoardRenderer`]: chessboards seen through a camera, for testing calibration.
//! - [`Simulator`]: all of it together, producing [`SimFrame`]s (images + exact masks + truth)
//!   and writing recordings.
//!
//! World frame: mm, right-handed, z up; the default volume is the 256 mm cube centred on the
//! origin.
//!
//! ```
//! use flexshape_sim::{CatheterPose, SimConfig, Simulator};
//!
//! let sim = Simulator::new(SimConfig::default())?;
//! // The bending section curved 1/200 mm about its x axis, uncompressed, not inserted.
//! let pose = CatheterPose::arc(&sim.config().catheter, [0.005, 0.0], [0.0, 0.0], 0.0);
//! let frame = sim.render(0, &pose)?;
//! assert_eq!(frame.views.len(), sim.rig().cameras.len());
//! // Exact masks beside the images, and the truth: centerline, tip, bands (world mm).
//! let covered = frame.views[0].mask.pixels().filter(|p| p.0[0] == 255).count();
//! assert!(covered > 1000, "{covered} tube pixels");
//! println!("tip at {:?} mm", frame.truth.tip);
//! # Ok::<(), flexshape_sim::SimError>(())
//! ```

mod catheter;
mod chessboard;
mod clocks;
mod drawn;
mod error;
mod render;
mod rig;
mod scene;
mod sequence;
mod simulator;

pub use catheter::{Catheter, CatheterPose, CatheterState, RENDER_STEP, TRUTH_STEP};
pub use chessboard::{
    BoardRenderer, CalibrationView, PrintedBoard, PrintedMarkers, PrintedPattern, calibration_views,
};
pub use clocks::FreeRunning;
pub use drawn::drawn_mask;
pub use error::SimError;
pub use render::{Plate, PlatePattern, RenderSettings, Renderer, View};
pub use rig::SimRigConfig;
pub use scene::{
    Albedo, BAND_ALBEDO, BODY_ALBEDO, Gloss, Material, OCCLUDER_ALBEDO, Occluder, Scene, Tube,
};
pub use sequence::{MAX_BEND_ANGLE, MAX_INSERTION, motion, motion_at, sweep};
pub use simulator::{SimConfig, SimFrame, Simulator};
