//! Silhouettes: per camera, the object mask and the marker-band mask of a frame, from a
//! background model (paper, Section II-A).
//!
//! Pipeline ([`Silhouetter::process`]): classify every pixel against the [`BackgroundModel`]
//! ([`Classifier`]: the paper's green matting, or colour subtraction with shadow rejection) into
//! bit-packed masks ([`BitMask`]), close small holes, keep the object's connected components
//! ([`KeepComponents`]), fill the holes it encloses that are thinner than it is wide (a silvery
//! tube's highlight), then find the marker tape inside the object ([`MarkerSettings`]).
//! Masks keep their boundary at half contrast; a consumer that wants a margin dilates its own
//! copy ([`BitMask::dilate`]). Pixel (0, 0) is the top-left pixel.
//!
//! ```
//! use flexshape_silhouette::{BackgroundModel, BitMask, SilhouetteSettings, Silhouetter};
//! use flexshape_sim::{CatheterPose, SimConfig, Simulator};
//!
//! // A simulated camera's empty scene as the background, then a frame with the catheter.
//! let sim = Simulator::new(SimConfig::default())?;
//! let background = BackgroundModel::from_frames(&sim.backgrounds()[..1])?;
//! let pose = CatheterPose::arc(&sim.config().catheter, [0.004, 0.0], [0.0, 0.0], 0.0);
//! let frame = sim.render(0, &pose)?;
//! let silhouetter = Silhouetter::new(&background, SilhouetteSettings::default())?;
//! let silhouette = silhouetter.process(&frame.views[0].image)?;
//! // Against the simulator's exact mask: the same pixels to within a few per cent.
//! let truth = BitMask::from_gray(&frame.views[0].mask).count() as f64;
//! assert!((silhouette.object.count() as f64 / truth - 1.0).abs() < 0.05);
//! assert!(silhouette.markers.count() > 0, "the red bands are found");
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

mod background;
mod bitmask;
mod classify;
pub mod components;
mod error;
mod holes;
mod markers;
mod shade;
mod silhouetter;
mod trial;

pub use background::{BackgroundModel, CHANGED_LEVELS, CHANGED_SPREADS, DEFAULT_SPREAD};
pub use bitmask::BitMask;
pub use classify::{Area, Classifier, ColourShadow, Difference, GreenMatte, Region, Rows};
pub use components::KeepComponents;
pub use error::SilhouetteError;
pub use markers::MarkerSettings;
pub use silhouetter::{
    GROWTH_FLOOR, MASK_LEVEL, Silhouette, SilhouetteSettings, SilhouetteStatus, Silhouetter,
    debug_image,
};
pub use trial::{ClassifierTrial, suggest_classifier, try_classifiers};
