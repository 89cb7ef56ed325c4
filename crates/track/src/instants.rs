//! When a frame's cameras captured: together (hardware-triggered, or nothing said), or apart
//! (free-running cameras), and what the fit did about it.

use flexshape_fit::{AcrossTime, Motion};

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

    /// The first and last capture apart, seconds.
    pub fn spread_s(&self) -> f64 {
        let lo = self.cameras_s.iter().copied().fold(f64::INFINITY, f64::min);
        let hi = self
            .cameras_s
            .iter()
            .copied()
            .fold(f64::NEG_INFINITY, f64::max);
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

    /// Why a shape fitted to cameras that captured apart, with no motion known, is not `ok`.
    pub(crate) fn unknown_motion(&self) -> String {
        let (first, last) = self
            .cameras_s
            .iter()
            .map(|t| t - self.at_s)
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), d| {
                (lo.min(d), hi.max(d))
            });
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
    /// capture; the shape is the tube at the frame's instant.
    Carried {
        /// The farthest the tube was carried for a camera, mm.
        shift_mm: f64,
        /// How far from the frame's instant the shape may still be, seconds: the motion was
        /// measured from shapes that were themselves that uncertain (0: from shapes at one
        /// instant each).
        lag_s: f64,
    },
    /// Apart, and what carries the tube is not known well enough: the shape may be the
    /// tube's at any instant within `lag_s` of the frame's (status `ambiguous`). It serves
    /// the next frame as a start and to measure the motion, which makes the lag shrink.
    Unknown {
        /// Seconds.
        lag_s: f64,
    },
}

impl Instants {
    /// How far from its frame's instant the shape may be, seconds.
    pub fn lag_s(&self) -> f64 {
        match *self {
            Instants::Together => 0.0,
            Instants::Carried { lag_s, .. } | Instants::Unknown { lag_s } => lag_s,
        }
    }
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
        let reason = apart.unknown_motion();
        assert!(reason.contains("-2.0 to +4.0 ms"), "{reason}");
        assert!(CameraTimes::of(None, Some(&[1.0])).is_none());
        assert!(CameraTimes::of(Some(1.0), Some(&[f64::NAN])).is_none());
    }
}
