//! The records of a tracking run, apart from the engine that makes them: what
//! `flexshape track` writes as JSON Lines ([`TrackRecord`] per frame, then one
//! [`SummaryLine`]), what the MCAP file and live connections carry, and what `validate`,
//! `model fit`, the viewer and the Python package read back ([`read_records`]). World frame
//! of the rig, mm, radians, seconds.
//!
//! The fields `docs/formats.md` documents are a stable contract, changed only additively;
//! [`json_lines_schema`] is their JSON Schema. Numbers are written to the precision that
//! matters (positions to 0.1 µm, unit vectors to 1e-7, durations to a microsecond).

mod against_truth;
mod camera_clocks;
mod hull;
mod precision;
mod read;
mod record;
mod schema;
mod status;
mod strings;
mod summary;
mod timings;

use std::path::PathBuf;

use thiserror::Error;

pub use against_truth::{TruthCheck, TruthTally};
pub use camera_clocks::{CameraClock, ClockTally};
pub use hull::HullRecord;
pub use read::{TrackLine, parse_line, read_records};
pub use record::{
    BackgroundUpdate, ModelFrame, TrackArcFit, TrackBand, TrackCompression, TrackRecord,
};
pub use schema::{json_lines_schema, record_schema};
pub use status::{RecordStatus, STATUSES};
pub use strings::{CapturedFrom, Method, Start};
pub use summary::{StageSummary, SummaryLine, TrackSummary, quantile, stage_summaries};
pub use timings::StageTimings;

/// Why records could not be read.
#[derive(Debug, Error)]
pub enum RecordError {
    /// A JSON Lines file of tracking records.
    #[error("{}{}: {problem}", path.display(), line.map(|l| format!(" line {l}")).unwrap_or_default())]
    Records {
        /// The file.
        path: PathBuf,
        /// The line (from 1), if the problem is on one.
        line: Option<usize>,
        /// What is wrong.
        problem: String,
    },
}
