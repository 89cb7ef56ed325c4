//! The run's summary: the last line of `flexshape track`'s output, and the one line a person
//! reads at the end of a run (with the advice a run's records call for, once).

use serde::{Deserialize, Serialize};

use crate::record::is_zero;
use crate::{CameraClock, StageTimings};

/// Median and 95th percentile of one stage's time, ms.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
pub struct StageSummary {
    /// Stage name.
    pub stage: String,
    /// Median, ms.
    pub median_ms: f64,
    /// 95th percentile, ms.
    pub p95_ms: f64,
}

/// The last line of a run: `{"summary": {…}}`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
pub struct TrackSummary {
    /// Frames read.
    pub frames: usize,
    /// Frames with status `ok`.
    pub ok: usize,
    /// Frames with status `error`.
    pub errors: usize,
    /// Whether the run was stopped early (Ctrl-C or a structural input error).
    pub stopped: bool,
    /// Wall-clock seconds.
    pub seconds: f64,
    /// Frames per second, wall clock (including reading and decoding images).
    pub fps: f64,
    /// Per-stage times.
    pub stages: Vec<StageSummary>,
    /// Frame sets a live input dropped because newer ones arrived first.
    #[serde(default)]
    pub dropped: u64,
    /// Frame sets live cameras could not pair: one camera had no frame within the pairing
    /// tolerance of the others' capture instant (its frame near it lost), so the others'
    /// frames were not tracked (additive).
    #[serde(default, skip_serializing_if = "is_zero")]
    pub unpaired: u64,
    /// From capture or reading to the end of the chain.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub latency_ms: Option<StageSummary>,
    /// The input error that ended the stream early, if any.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub input_error: Option<String>,
    /// Seconds from the command's start to its first frame asked for — reading the rig and
    /// backgrounds, setting up carving and the outputs — not counted in `seconds` (additive).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub startup_s: Option<f64>,
    /// Frames `ambiguous` only because nothing told the proximal end from the tip (additive;
    /// absent: none); the summary line then says once which setting decides it.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub direction_guessed: usize,
    /// Frames whose hull held a sharp shadow's voxels, dropped before the shape was found
    /// (`shadow_voxels` in their records; additive; absent: none); the summary line then says
    /// once what makes such shadows.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub shadow_frames: usize,
    /// The rig's `[refined]` table, when `flexshape rig refine` made it (additive): which
    /// cameras moved, and how far the world frame may have moved with them; the summary line
    /// then says so when that is not 0.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub refined_rig: Option<flexshape_rig::Refined>,
    /// Frames whose capture time is only their image file's modification time (nothing else
    /// gave one; additive; absent: none): the summary line says so once.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub file_time_frames: usize,
    /// Each camera's clock, rig order, where the input gave every camera's own capture time
    /// (additive; absent otherwise): its frame rate and its captures' offset from the frames'
    /// instants; the summary line says how far apart they captured.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub camera_clocks: Vec<CameraClock>,
    /// Frames `ambiguous` because the tube's motion between their cameras' captures was not
    /// known well enough (`lag_ms` in their records; additive; absent: none); beyond a few the
    /// summary line suggests triggering the cameras together.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub between_captures: usize,
    /// A simulated recording's records held against its truth (additive; absent for any
    /// other input): frames vouched for and right, vouched for but off, refused though right.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub truth: Option<crate::TruthCheck>,
}

/// The summary as its own line.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
pub struct SummaryLine {
    /// The summary.
    pub summary: TrackSummary,
}

/// Median and 95th percentile of each stage over per-frame timings.
pub fn stage_summaries(records: &[StageTimings]) -> Vec<StageSummary> {
    StageTimings::default()
        .stages()
        .iter()
        .enumerate()
        .map(|(i, (name, _))| {
            let mut t: Vec<f64> = records.iter().map(|r| r.stages()[i].1).collect();
            StageSummary {
                stage: (*name).into(),
                median_ms: quantile(&mut t, 0.5),
                p95_ms: quantile(&mut t, 0.95),
            }
        })
        .collect()
}

/// The `q`-quantile (nearest rank) of `values`, which it sorts; 0 when empty.
pub fn quantile(values: &mut [f64], q: f64) -> f64 {
    values.sort_by(f64::total_cmp);
    values
        .get(((values.len().max(1) - 1) as f64 * q).round() as usize)
        .copied()
        .unwrap_or(0.0)
}

impl TrackSummary {
    /// The run in one line: frames (with those dropped, for a `live` source), speed, latency
    /// and per-stage times.
    pub fn line(&self, live: bool, stopped: bool) -> String {
        let summary = self;
        let startup_s = self.startup_s.unwrap_or(0.0);
        format!(
            "{} frames ({} ok, {} errors{}{}) in {:.2} s (after {:.2} s of start-up), {:.1} frames/s{}; ms per stage, median/p95: {}",
            summary.frames,
            summary.ok,
            summary.errors,
            if live && summary.unpaired > 0 {
                format!(
                    ", {} dropped, {} sets unpaired",
                    summary.dropped, summary.unpaired
                )
            } else if live {
                format!(", {} dropped", summary.dropped)
            } else {
                String::new()
            },
            if stopped { ", stopped early" } else { "" },
            summary.seconds,
            startup_s,
            summary.fps,
            summary
                .latency_ms
                .as_ref()
                .map(|l| format!(
                    ", latency {:.1} ms median / {:.1} ms p95",
                    l.median_ms, l.p95_ms
                ))
                .unwrap_or_default(),
            summary
                .stages
                .iter()
                .map(|s| format!("{} {:.2}/{:.2}", s.stage, s.median_ms, s.p95_ms))
                .collect::<Vec<_>>()
                .join(", ")
        ) + &self.direction_advice()
            + &self.shadow_advice()
            + &self.refined_advice()
            + &self.file_time_advice()
            + &crate::camera_clocks::advice(&self.camera_clocks, self.between_captures, self.frames)
    }

    /// Once per run, on a refined rig whose refinement could not tell which cameras moved:
    /// how far the world frame may have gone with them.
    fn refined_advice(&self) -> String {
        match &self.refined_rig {
            Some(r) if r.world_open_mm > 0.0 => format!(
                "
the rig was refined ({} moved), and the images could not tell which cameras had been knocked: positions may be off by up to {:.2} mm in the world frame the calibration gave (shapes are not); refine with --hold NAME naming a camera known to be right, or register to your robot",
                r.moved.join(", "),
                r.world_open_mm
            ),
            _ => String::new(),
        }
    }

    /// Once per run whose capture times are only the image files' modification times.
    fn file_time_advice(&self) -> String {
        match self.file_time_frames {
            0 => String::new(),
            n => format!(
                "\n{n} of {} frames' capture times (captured_s) are their image files' modification times, which copying changes: write the real ones to timestamps.csv (docs/formats.md)",
                self.frames
            ),
        }
    }

    /// Once per run, when hulls held a sharp shadow's voxels: what throws such shadows.
    fn shadow_advice(&self) -> String {
        match self.shadow_frames {
            0 => String::new(),
            n => format!(
                "\n{n} of {} frames' hulls held a sharp shadow of the tube (dropped, see shadow_voxels): a small lamp near a camera casts it on a backdrop close behind the volume; a larger or more distant lamp, or the backdrop farther back, softens it out of the silhouettes",
                self.frames
            ),
        }
    }

    /// Once per run, when frames were `ambiguous` for want of a cue to the tube's direction:
    /// which setting decides it.
    fn direction_advice(&self) -> String {
        match self.direction_guessed {
            0 => String::new(),
            n => format!(
                "\n{n} of {} frames are ambiguous only because nothing tells the tube's tip from its proximal end (neither end leaves the volume or a camera's view): {}",
                self.frames,
                flexshape_shape::DIRECTION_SETTINGS
            ),
        }
    }
}
