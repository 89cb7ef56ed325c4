//! A simulated recording's records held against its truth (`truth/NNNNNN.json`) as they are
//! written: how many frames a status vouched for and the truth bears out, which it vouched
//! for wrongly, and which it refused although their shape is right. What a lab planning its
//! rig on the simulator asks of a run, and what every change to a check is judged by.

use std::path::Path;

use flexshape_recording::{Layout, RecordingError, RightBounds, Truth};
use flexshape_rig::Volume;
use serde::{Deserialize, Serialize};

use crate::{TrackRecord, quantile};

/// A run's records against the truth ([`TruthTally`]); the summary's `truth` (additive).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
pub struct TruthCheck {
    /// A shape is right when its centerline lies within this RMS distance of the true one
    /// (over the true samples inside the volume), mm.
    pub rms_bound_mm: f64,
    /// … and its tip within this distance of the true tip, mm.
    pub tip_bound_mm: f64,
    /// Frames with a truth file.
    pub frames: usize,
    /// Frames whose status vouches for the shape (`ok`, `bands_missing`, `leaves_volume`) and
    /// whose shape is right.
    pub vouched_right: usize,
    /// Frames whose status vouches for a shape that is not right (or that carries none).
    pub vouched_but_off: Vec<u64>,
    /// Frames refused (any other status) whose shape is right.
    pub refused_but_right: Vec<u64>,
    /// Median centerline RMS over the frames vouched for and right, mm.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub centerline_rms_median_mm: Option<f64>,
    /// Median tip error over the same frames, mm.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tip_median_mm: Option<f64>,
}

impl TruthCheck {
    /// The check in one line.
    pub fn line(&self) -> String {
        // `what` with the frames listed (the first dozen), or `none` when there are none.
        let listed = |list: &[u64], none: &str, what: &str, after: &str| {
            if list.is_empty() {
                return none.to_string();
            }
            let shown: Vec<String> = list.iter().take(12).map(|f| f.to_string()).collect();
            let more = match list.len() - shown.len() {
                0 => String::new(),
                n => format!(" and {n} more"),
            };
            format!(
                "{} {what} (frames {}{more}{after})",
                list.len(),
                shown.join(", ")
            )
        };
        let medians = match (self.centerline_rms_median_mm, self.tip_median_mm) {
            (Some(rms), Some(tip)) => {
                format!(" (median centerline RMS {rms:.3} mm, tip {tip:.3} mm)")
            }
            _ => String::new(),
        };
        let off = listed(
            &self.vouched_but_off,
            "none vouched for but off it",
            "VOUCHED FOR BUT OFF IT",
            "",
        );
        let refused = listed(
            &self.refused_but_right,
            "none refused though right",
            "refused though right",
            "; their records say why",
        );
        format!(
            "against the recording's truth (right: centerline within {:.2} mm RMS, tip within {:.2} mm): {} of {} frames vouched for and right{medians}; {off}; {refused}",
            self.rms_bound_mm, self.tip_bound_mm, self.vouched_right, self.frames
        )
    }
}

/// Records held against a recording's truth one by one ([`TruthCheck`]).
#[derive(Debug, Clone)]
pub struct TruthTally {
    layout: Layout,
    volume: Volume,
    bounds: RightBounds,
    frames: usize,
    vouched_right: usize,
    vouched_but_off: Vec<u64>,
    refused_but_right: Vec<u64>,
    rms: Vec<f64>,
    tip: Vec<f64>,
}

impl TruthTally {
    /// A tally for the recording at `dir`, whose shapes are reported within `volume` (world
    /// mm): `None` when it holds no `truth/` folder (a recording not simulated).
    pub fn open(dir: &Path, volume: &Volume) -> Option<Self> {
        let layout = Layout::new(dir);
        layout.truth(0).parent()?.is_dir().then(|| TruthTally {
            layout,
            volume: *volume,
            bounds: RightBounds::default(),
            frames: 0,
            vouched_right: 0,
            vouched_but_off: Vec::new(),
            refused_but_right: Vec::new(),
            rms: Vec::new(),
            tip: Vec::new(),
        })
    }

    /// Holds `record` against its frame's truth; a frame without a truth file is not counted.
    /// A truth file that cannot be read is an error naming it.
    pub fn add(&mut self, record: &TrackRecord) -> Result<(), RecordingError> {
        let Some(truth) = Truth::read(&self.layout, record.frame)? else {
            return Ok(());
        };
        self.frames += 1;
        let errors = record
            .tip
            .and_then(|tip| truth.errors(&record.centerline, tip, |p| self.volume.contains(p)));
        let right = errors.filter(|e| e.within(self.bounds));
        match (record.status.vouches_for_shape(), right) {
            (true, Some(e)) => {
                self.vouched_right += 1;
                self.rms.push(e.centerline_rms);
                self.tip.push(e.tip);
            }
            (true, None) => self.vouched_but_off.push(record.frame),
            (false, Some(_)) => self.refused_but_right.push(record.frame),
            (false, None) => {}
        }
        Ok(())
    }

    /// The records so far against the truth.
    pub fn check(&self) -> TruthCheck {
        let median = |v: &[f64]| (!v.is_empty()).then(|| quantile(&mut v.to_vec(), 0.5));
        TruthCheck {
            rms_bound_mm: self.bounds.rms_mm,
            tip_bound_mm: self.bounds.tip_mm,
            frames: self.frames,
            vouched_right: self.vouched_right,
            vouched_but_off: self.vouched_but_off.clone(),
            refused_but_right: self.refused_but_right.clone(),
            centerline_rms_median_mm: median(&self.rms),
            tip_median_mm: median(&self.tip),
        }
    }
}
