//! Silhouettes: per camera, the object mask and the marker-band mask of a frame, from a
//! background model (paper, Section II-A).
//!
//! Pipeline ([`Silhouetter::process`]): classify every pixel against the [`BackgroundModel`]
//! ([`Classifier`]: the paper's green matting, or colour subtraction with shadow rejection) into
//! bit-packed masks ([`BitMask`]), close small holes, keep the object's connected components
//! ([`KeepComponents`]), then find the marker tape inside the object ([`MarkerSettings`]).
//! Masks keep their boundary at half contrast; a consumer that wants a margin dilates its own
//! copy ([`BitMask::dilate`]). Pixel (0, 0) is the top-left pixel.

mod background;
mod bitmask;
mod classify;
pub mod components;
mod error;
mod markers;
mod shade;
mod silhouetter;

pub use background::{BackgroundModel, CHANGED_LEVELS, CHANGED_SPREADS, DEFAULT_SPREAD};
pub use bitmask::BitMask;
pub use classify::{Classifier, ColourShadow, Difference, GreenMatte, Region};
pub use components::KeepComponents;
pub use error::SilhouetteError;
pub use markers::MarkerSettings;
pub use silhouetter::{
    GROWTH_FLOOR, MASK_LEVEL, Silhouette, SilhouetteSettings, SilhouetteStatus, Silhouetter,
    debug_image,
};
