//! The recording folder: flexshape's interchange format on disk (documented in
//! `docs/formats.md`; change it only additively).
//!
//! ```text
//! DIR/rig.toml                          rig file (cameras + volume), when written by flexshape
//! DIR/calibration/cam0.yml …            OpenCV FileStorage YAML, one per camera
//! DIR/background/cam0.png …             background image per camera (no object)
//! DIR/frames/cam0/000000.png …          one folder per camera, frames numbered from 000000
//! DIR/truth/000000.json …               ground truth (simulated recordings only)
//! DIR/truth/masks/cam0/000000.png       exact object mask per camera (simulated only)
//! DIR/truth/markers/cam0/000000.png     exact marker-band mask per camera (simulated only)
//! DIR/commands/000000.json …            commanded tendon displacements (model experiments)
//! ```

mod command;
mod error;
mod layout;
mod reader;
pub mod timestamps;
mod truth;
mod writer;

pub use command::{Command, PoseRole};
pub use error::RecordingError;
pub use layout::Layout;
pub use reader::RecordingReader;
pub use truth::{BendBase, RightBounds, Truth, TruthBand, TruthErrors, TruthSection};
pub use writer::RecordingWriter;
