//! When a frame's cameras captured: together (hardware-triggered, or nothing said), or apart
//! (free-running cameras), and what the fit did about it: the motion that carries the tube to
//! each camera's capture, measured between shapes, with how far it may be off
//! (`MotionEstimate`), and whether the shape so fitted is at one instant or may lie between
//! them (`judge_instant`).

use flexshape_fit::{AcrossTime, Motion, Tube};
use flexshape_shape::{ShapeRecord, Status};

use crate::pipeline::{Prior, Tracked};

/// Spreads below this are taken as cameras captured together, seconds: a clock's rounding,
/// far below any exposure.
const TOGETHER_S: f64 = 1e-6;

/// When a frame's cameras captured it.
#[derive(Debug, Clone, PartialEq)]
pub struct CameraTimes {
    /// The instant the frame's shape refers to, seconds (the frame's capture time).
    pub at_s: f64,
    /// Each camera's capture, rig order, seconds in the same time base.
    pub cameras_s: Vec<f64>,
}

impl CameraTimes {
    /// From a frame's instant and its cameras' captures, when both are known and finite.
    pub fn of(at_s: Option<f64>, cameras_s: Option<&[f64]>) -> Option<CameraTimes> {
        let (at_s, cameras_s) = (at_s?, cameras_s?);
        (at_s.is_finite() && !cameras_s.is_empty() && cameras_s.iter().all(|t| t.is_finite())).then(
            || CameraTimes {
                at_s,
                cameras_s: cameras_s.to_vec(),
            },
        )
    }

    /// The first and the last capture, seconds.
    fn first_and_last(&self) -> (f64, f64) {
        self.cameras_s
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &t| {
                (lo.min(t), hi.max(t))
            })
    }

    /// The first and last capture apart, seconds.
    pub fn spread_s(&self) -> f64 {
        let (lo, hi) = self.first_and_last();
        (hi - lo).max(0.0)
    }

    /// Whether any camera captured away from the frame's instant.
    pub(crate) fn apart(&self) -> bool {
        self.cameras_s
            .iter()
            .any(|t| (t - self.at_s).abs() > TOGETHER_S)
    }

    /// The fit across time that carries the tube by `motion` to each camera's capture, or
    /// `None` when the cameras captured at the instant.
    pub(crate) fn across(&self, motion: &Motion) -> Option<AcrossTime> {
        self.apart().then(|| AcrossTime {
            motion: motion.clone(),
            offsets_s: self.cameras_s.iter().map(|t| t - self.at_s).collect(),
        })
    }

    /// The farthest any camera captured from the frame's instant, seconds.
    pub(crate) fn widest_offset_s(&self) -> f64 {
        self.cameras_s
            .iter()
            .map(|t| (t - self.at_s).abs())
            .fold(0.0, f64::max)
    }

    /// The middle of the captures less the frame's instant, and half their spread, seconds:
    /// where a shape fitted to them as they are lies in time, and how far from there.
    pub(crate) fn between_captures(&self) -> (f64, f64) {
        let (lo, hi) = self.first_and_last();
        ((lo + hi) / 2.0 - self.at_s, self.spread_s() / 2.0)
    }

    /// Why a shape fitted to cameras that captured apart, with no motion known, is not `ok`.
    pub(crate) fn unknown_motion(&self) -> String {
        let (lo, hi) = self.first_and_last();
        let (first, last) = (lo - self.at_s, hi - self.at_s);
        format!(
            "the cameras captured from {:+.1} to {:+.1} ms of the frame's instant and no earlier frame tells how the tube moved meanwhile: the shape lies somewhere between where it was at those captures (the next frame measures the motion from this one); trigger the cameras together to fit every frame at once",
            first * 1e3,
            last * 1e3
        )
    }
}

/// How a frame's cameras' capture instants entered its fit.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub enum Instants {
    /// Together, or the input did not say: every camera saw the same tube.
    #[default]
    Together,
    /// Apart, each camera held to the tube carried by its recent motion to that camera's
    /// capture; the shape is the tube at the frame's instant (what its motion's doubt leaves
    /// is within the fit's own 1-σ, or with it within `max_sigma_mm`, so later frames take it
    /// as at one instant).
    Carried {
        /// The farthest the tube was carried for a camera, mm.
        shift_mm: f64,
    },
    /// Apart, and what carries the tube is not known well enough: the shape may be the
    /// tube's at any instant within `lag_s` of the frame's instant moved by `centre_s`
    /// (status `ambiguous`). It serves the next frame as a start and to measure the motion,
    /// which makes the lag shrink.
    Unknown {
        /// Seconds.
        lag_s: f64,
        /// The middle of the instants the shape may be at, less the frame's instant, seconds:
        /// a shape fitted to the captures as they are lies between the first and the last of
        /// them, half their spread from its middle; one carried to the frame's instant, 0.
        centre_s: f64,
    },
}

impl Instants {
    /// How far from the middle of the instants it may be at the shape may be, seconds.
    pub fn lag_s(&self) -> f64 {
        match *self {
            Instants::Together | Instants::Carried { .. } => 0.0,
            Instants::Unknown { lag_s, .. } => lag_s,
        }
    }

    /// The middle of the instants the shape may be at, less its frame's instant, seconds.
    pub fn centre_s(&self) -> f64 {
        match *self {
            Instants::Together | Instants::Carried { .. } => 0.0,
            Instants::Unknown { centre_s, .. } => centre_s,
        }
    }
}

/// A motion measured between two shapes, and how far it may be from the velocity at another
/// instant.
#[derive(Debug, Clone)]
pub(crate) struct MotionEstimate {
    pub motion: Motion,
    /// The share of the speed it may be off by: the two shapes' lags over the time between.
    pub lag_share: f64,
    /// The instant its velocity is the tube's (the middle of the time it was measured over),
    /// seconds.
    pub mid_s: f64,
    /// How fast the velocity changes, mm/s²: its difference from a motion measured over
    /// another time, less what the shapes' own scatter gives the two, over the time between
    /// their middles; 0 when there was none to compare.
    pub accel_mm_s2: f64,
    /// The scatter the two shapes' own uncertainty gives it, mm/s: their largest 1-σ across
    /// the tube, summed, over the time between them.
    pub noise_mm_s: f64,
}

impl MotionEstimate {
    /// The motion from `earlier` to `tube`, a shape at `at_s` that may lie `lag_s` from it.
    /// `sigma_mm`: `tube`'s largest 1-σ across itself.
    pub(crate) fn between(
        earlier: &Prior,
        tube: &Tube,
        at_s: f64,
        lag_s: f64,
        sigma_mm: f64,
    ) -> Option<Self> {
        let dt = at_s - earlier.at_s()?;
        Some(MotionEstimate {
            motion: Motion::between(earlier.fitted(), tube, dt)?,
            lag_share: (lag_s + earlier.lag_s()) / dt,
            mid_s: at_s - dt / 2.0,
            accel_mm_s2: 0.0,
            noise_mm_s: (sigma_mm + earlier.sigma_mm()) / dt,
        })
    }

    /// Measures how far this motion may be from the velocity at another instant by its
    /// difference from `other`, measured over another time: beyond what the shapes' scatter
    /// gives the two, the difference is the tube's acceleration. (Beyond twice that, a 30 Hz
    /// motion whose tip moved up to 5 mm a frame hid its acceleration in the scatter: 12 of 60
    /// frames `ok` and up to 0.8 mm off on one thread; now none.)
    pub(crate) fn compared_with(mut self, other: &MotionEstimate) -> Self {
        let difference = self.motion.largest_difference(&other.motion);
        // The shapes' lags are not taken off: at 30 Hz, the tip moving up to 5 mm a frame,
        // what they may explain hid real acceleration and 7 of 180 frames said `ok` while up to
        // 0.4 mm off (it gained 3-15 right frames of 240 at 120 Hz while the motion was first
        // measured).
        let scatter = self.noise_mm_s + other.noise_mm_s;
        let apart = (self.mid_s - other.mid_s).abs();
        if apart > 0.0 {
            self.accel_mm_s2 = (difference - scatter).max(0.0) / apart;
        }
        self
    }

    /// How far the tube carried by this motion over `offset_s` may be from where it was, mm.
    /// For a frame at `at_s` whose camera captured `offset_s` from it: the velocity may be
    /// off by its lag share of the speed, and by the acceleration over the time from its
    /// middle to the capture.
    pub(crate) fn doubt_mm(&self, at_s: f64, offset_s: f64) -> f64 {
        let stale = (at_s - self.mid_s).abs() + offset_s.abs();
        (self.lag_share * self.motion.fastest_across() + self.accel_mm_s2 * stale) * offset_s.abs()
    }
}

/// A shape fitted across time (`across`) whose carried tubes may be up to `off_mm` from
/// where the tube was at its cameras' captures (the motion's doubt times the farthest offset):
/// the shape may be that far from the tube at its instant. Within the fit's own 1-σ across
/// the tube, the images' uncertainty dominates and a right shape stays right; so it does
/// while that 1-σ and the doubt together stay within `loosest_mm`, the loosest a shape may be
/// pinned down and still be vouched for (`max_sigma_mm`, the accuracy an `ok` claims). Then
/// the shape is the tube at the frame's instant for what follows ([`Instants::Carried`]);
/// beyond it the frame is `ambiguous`, saying by how much ([`Instants::Unknown`], its lag the
/// fastest point's time to move that far), and the next frame measures the motion again
/// from it.
pub(crate) fn judge_instant(
    tracked: &mut Tracked,
    across: &AcrossTime,
    off_mm: f64,
    loosest_mm: f64,
) {
    let lag_s = off_mm / across.motion.fastest_across().max(1e-9);
    let sigma = largest_sigma(&tracked.shape);
    let pinned = off_mm <= sigma || sigma + off_mm <= loosest_mm;
    if tracked.shape.status.is_right() && !pinned {
        tracked.shape.status = Status::Ambiguous {
            reason: format!(
                "the cameras captured apart, and the motion that carries the tube between their captures was measured from a shape that lay between its own cameras' captures: this one may be {off_mm:.2} mm from the tube at the frame's instant, beyond the fit's own {sigma:.2} mm and, with it, beyond {loosest_mm:.2} mm (the next frames measure the motion again from it); trigger the cameras together to fit every frame at once"
            ),
        };
        tracked.instants = Instants::Unknown {
            lag_s,
            centre_s: 0.0,
        };
    } else {
        // Within the images' own uncertainty: a shape at one instant for what follows.
        tracked.instants = Instants::Carried {
            shift_mm: across.largest_shift_mm(),
        };
    }
}

/// A shape's largest 1-σ across the tube, mm (0 for the hull's, which has none).
pub(crate) fn largest_sigma(shape: &ShapeRecord) -> f64 {
    shape.sigma.iter().copied().fold(0.0, f64::max)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn captures_within_a_microsecond_are_together() {
        let together = CameraTimes::of(Some(2.0), Some(&[2.0, 2.0 + 5e-7, 2.0 - 5e-7])).unwrap();
        assert!(!together.apart());
        let apart = CameraTimes::of(Some(2.0), Some(&[2.0, 2.004, 1.998])).unwrap();
        assert!(apart.apart());
        assert!((apart.spread_s() - 0.006).abs() < 1e-12);
        // A shape fitted to them as they are: between -2 and +4 ms, so 1 ms ± 3 ms.
        let (centre, lag) = apart.between_captures();
        assert!((centre - 0.001).abs() < 1e-12 && (lag - 0.003).abs() < 1e-12);
        let reason = apart.unknown_motion();
        assert!(reason.contains("-2.0 to +4.0 ms"), "{reason}");
        assert!(CameraTimes::of(None, Some(&[1.0])).is_none());
        assert!(CameraTimes::of(Some(1.0), Some(&[f64::NAN])).is_none());
    }
}
