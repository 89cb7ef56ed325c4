//! The loop as people read it: one row per frame, and the outcome.

use std::fmt;

use flexshape_model::{ManipulatorParams, Stiffness};
use serde::Serialize;

use crate::SteerStep;

impl SteerStep {
    /// The header of [`SteerStep::row`]'s table.
    pub fn table_header() -> String {
        format!(
            "{:>5} {:>6} {:>14} {:>10} {:>10} {:>10} {:>10}",
            "frame", "target", "status", "sensed mm", "true mm", "Kx used", "Kz used"
        )
    }

    /// The frame as a table row: target, status, sensed and true tip error (mm), the
    /// stiffnesses used.
    pub fn row(&self) -> String {
        format!(
            "{:>5} {:>6} {:>14} {:>10} {:>10.3} {:>10.1} {:>10.1}",
            self.frame,
            self.target_index,
            self.status,
            self.sensed_error_mm
                .map_or("—".into(), |e| format!("{e:.3}")),
            self.true_error_mm,
            self.stiffness[0],
            self.stiffness[1]
        )
    }
}

/// The loop's outcome: each target's final true tip error and the stiffnesses learnt.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SteerSummary {
    /// Frames run.
    pub frames: usize,
    /// Per target: the true tip's distance from it at its last frame, mm.
    pub final_true_error_mm: Vec<f64>,
    /// The largest of them, mm.
    pub worst_final_true_error_mm: f64,
    /// The simulated catheter's true `[Kx, Kz]`.
    pub true_stiffness: [f64; 2],
    /// `[Kx, Kz]` learnt online, once there was enough to learn them.
    pub learnt_stiffness: Option<[f64; 2]>,
    /// `[Kx, Kz]` of the parameter file the loop started from.
    #[serde(skip)]
    pub nominal_stiffness: [f64; 2],
}

impl SteerSummary {
    /// The outcome of `steps` towards `targets` targets.
    pub fn of(
        steps: &[SteerStep],
        targets: usize,
        learnt: Option<Stiffness>,
        truth: &ManipulatorParams,
        nominal: &ManipulatorParams,
    ) -> Self {
        let finals: Vec<f64> = (0..targets)
            .filter_map(|t| steps.iter().rfind(|s| s.target_index == t))
            .map(|s| s.true_error_mm)
            .collect();
        SteerSummary {
            frames: steps.len(),
            worst_final_true_error_mm: finals.iter().copied().fold(0.0, f64::max),
            final_true_error_mm: finals,
            true_stiffness: [truth.stiffness.kx, truth.stiffness.kz],
            learnt_stiffness: learnt.map(|k| [k.kx, k.kz]),
            nominal_stiffness: [nominal.stiffness.kx, nominal.stiffness.kz],
        }
    }
}

impl fmt::Display for SteerSummary {
    fn fmt(&self, f: &mut fmt::Formatter) -> fmt::Result {
        write!(
            f,
            "{} frames; tip at the end of each target within {:.3} mm of it (true tip); \
             Kx, Kz learnt online: {} (truth {:.1}, {:.1}; the file said {:.1}, {:.1})",
            self.frames,
            self.worst_final_true_error_mm,
            self.learnt_stiffness
                .map_or("not yet".into(), |k| format!("{:.1}, {:.1}", k[0], k[1])),
            self.true_stiffness[0],
            self.true_stiffness[1],
            self.nominal_stiffness[0],
            self.nominal_stiffness[1]
        )
    }
}
