//! What a run saw of its cameras' clocks: each camera's frame rate and its capture's offset
//! from the frame's instant, measured from the records' capture times, for the summary — so a
//! lab sees whether its cameras are triggered together and at what rate they really run, and
//! is told to trigger them together when the motion between their captures is not known
//! well enough to fit across time.

use serde::{Deserialize, Serialize};

use crate::quantile;

/// One camera's clock as a run measured it (rig order in the summary).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
pub struct CameraClock {
    /// Frames per second: one over the median time between its consecutive captures (absent
    /// before two frames).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rate_hz: Option<f64>,
    /// Median time from the frame's instant (`captured_s`) to this camera's capture, ms.
    pub offset_ms: f64,
    /// The largest such time either way, ms.
    pub widest_ms: f64,
}

/// The share of frames `ambiguous` between their cameras' captures beyond which the summary
/// suggests triggering the cameras together: the first frames of a run, and of every start
/// after a gap, measure the motion, so a few are always there.
const ADVISE_SHARE: f64 = 0.05;

/// Collects each camera's capture times from the records of a run.
#[derive(Debug, Clone, Default)]
pub struct ClockTally {
    /// Per camera, rig order.
    cameras: Vec<CameraTally>,
    /// Frames ambiguous because the motion between their cameras' captures was not known.
    between: usize,
}

/// One camera's captures so far.
#[derive(Debug, Clone, Default)]
struct CameraTally {
    /// Offsets from the frames' instants, s.
    offsets: Vec<f64>,
    /// Times between consecutive captures, s.
    intervals: Vec<f64>,
    /// The last capture, s.
    last: Option<f64>,
}

impl ClockTally {
    /// Counts one frame: its instant, its cameras' captures (rig order) and whether its shape
    /// may lie between them (`lag_ms`).
    pub fn add(&mut self, at_s: Option<f64>, cameras_s: &[f64], between: bool) {
        self.between += usize::from(between);
        let Some(at) = at_s.filter(|t| t.is_finite()) else {
            return;
        };
        if cameras_s.is_empty() || cameras_s.iter().any(|t| !t.is_finite()) {
            return;
        }
        if self.cameras.len() < cameras_s.len() {
            self.cameras.resize(cameras_s.len(), CameraTally::default());
        }
        for (camera, &t) in self.cameras.iter_mut().zip(cameras_s) {
            camera.offsets.push(t - at);
            if let Some(last) = camera.last
                && t > last
            {
                camera.intervals.push(t - last);
            }
            camera.last = Some(t);
        }
    }

    /// Each camera's clock (rig order), empty when the input gave no camera's own times.
    pub fn clocks(&self) -> Vec<CameraClock> {
        self.cameras
            .iter()
            .map(|c| {
                let mut intervals = c.intervals.clone();
                let rate_hz = (!intervals.is_empty()).then(|| 1.0 / quantile(&mut intervals, 0.5));
                let widest = c.offsets.iter().fold(0.0f64, |w, o| w.max(o.abs()));
                CameraClock {
                    rate_hz,
                    offset_ms: quantile(&mut c.offsets.clone(), 0.5) * 1e3,
                    widest_ms: widest * 1e3,
                }
            })
            .collect()
    }

    /// Frames ambiguous because the motion between their cameras' captures was not known.
    pub fn between(&self) -> usize {
        self.between
    }
}

/// Once per run whose cameras captured apart: how far apart and at what rates, and — when more
/// than a few frames were `ambiguous` between their captures — that a trigger fixes it.
pub(crate) fn advice(clocks: &[CameraClock], between: usize, frames: usize) -> String {
    let widest = clocks.iter().fold(0.0f64, |w, c| w.max(c.widest_ms));
    if widest < 1e-3 {
        return String::new();
    }
    let rates: Vec<String> = clocks
        .iter()
        .map(|c| c.rate_hz.map_or("?".into(), |r| format!("{r:.1}")))
        .collect();
    let offsets: Vec<String> = clocks
        .iter()
        .map(|c| format!("{:+.1}", c.offset_ms))
        .collect();
    let mut said = format!(
        "\nthe cameras captured apart (rig order: {} frames/s; median {} ms from each frame's instant, up to {widest:.1} ms): each camera was fitted at its own capture",
        rates.join(", "),
        offsets.join(" / ")
    );
    if between as f64 > ADVISE_SHARE * frames as f64 {
        said += &format!(
            "; {between} of {frames} frames are ambiguous because the tube's motion between the captures was not known well enough (lag_ms): trigger the cameras together (a hardware trigger line), or film faster"
        );
    }
    said
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rates_and_offsets_are_measured_and_a_trigger_suggested_when_frames_wait_on_the_motion() {
        let mut tally = ClockTally::default();
        for n in 0..30 {
            let at = n as f64 / 30.0;
            // cam1 8 ms late, cam2 15 ms late with 1 ms of jitter.
            let jitter = if n % 2 == 0 { 0.001 } else { -0.001 };
            tally.add(Some(at), &[at, at + 0.008, at + 0.015 + jitter], n < 5);
        }
        let clocks = tally.clocks();
        assert_eq!(clocks.len(), 3);
        for c in &clocks {
            let rate = c.rate_hz.unwrap();
            assert!((rate - 30.0).abs() < 2.5, "{c:?}");
        }
        assert!((clocks[1].offset_ms - 8.0).abs() < 1e-6);
        assert!((clocks[2].widest_ms - 16.0).abs() < 1e-6, "{:?}", clocks[2]);
        let said = advice(&clocks, tally.between(), 30);
        assert!(
            said.contains("captured apart") && said.contains("+8.0"),
            "{said}"
        );
        assert!(
            said.contains("5 of 30 frames") && said.contains("trigger"),
            "{said}"
        );
        // A run with few such frames is not told to change its rig.
        assert!(!advice(&clocks, 1, 30).contains("trigger"));
        // Cameras captured together: nothing to say.
        let mut together = ClockTally::default();
        together.add(Some(1.0), &[1.0, 1.0], false);
        assert_eq!(advice(&together.clocks(), 0, 1), "");
        // No camera times: no clocks.
        let mut none = ClockTally::default();
        none.add(Some(1.0), &[], false);
        assert!(none.clocks().is_empty());
    }
}
