//! Cameras that are not triggered together: each films at the rig's frame rate from its own
//! phase, every frame a little early or late, as free-running USB and network cameras do.

use rand::rngs::Xoshiro256PlusPlus;
use rand::{RngExt, SeedableRng};

/// When each camera of a free-running rig captures its frames.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct FreeRunning {
    /// Per camera, rig order: how long after each frame's instant (`n / rate`) it captures,
    /// seconds (may be negative; a camera without an entry captures at the instant).
    pub phases_s: Vec<f64>,
    /// Every capture is moreover early or late by up to this, seconds, uniformly and
    /// independently (0: none).
    pub jitter_s: f64,
}

impl FreeRunning {
    /// When camera `camera` captures its frame `frame` of a film at `rate_hz`, seconds from
    /// the film's start: the frame's instant, the camera's phase and its seeded jitter.
    pub fn capture_time(&self, seed: u64, camera: usize, frame: u64, rate_hz: f64) -> f64 {
        let phase = self.phases_s.get(camera).copied().unwrap_or(0.0);
        let jitter = if self.jitter_s > 0.0 {
            let key = seed
                ^ 0x0C10_C450
                ^ (camera as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15)
                ^ frame.wrapping_mul(0xC2B2_AE3D_27D4_EB4F);
            let mut rng = Xoshiro256PlusPlus::seed_from_u64(key);
            rng.random_range(-self.jitter_s..=self.jitter_s)
        } else {
            0.0
        };
        frame as f64 / rate_hz.max(1e-9) + phase + jitter
    }

    /// The largest spread between two cameras' captures of one frame this can give, seconds:
    /// the phases' range and twice the jitter.
    pub fn widest_spread_s(&self, cameras: usize) -> f64 {
        let phase = |k: usize| self.phases_s.get(k).copied().unwrap_or(0.0);
        let (lo, hi) = (0..cameras).fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), k| {
            (lo.min(phase(k)), hi.max(phase(k)))
        });
        if cameras == 0 {
            0.0
        } else {
            hi - lo + 2.0 * self.jitter_s
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_camera_keeps_its_phase_and_its_jitter_stays_within_bounds() {
        let clocks = FreeRunning {
            phases_s: vec![0.0, 0.010, -0.004],
            jitter_s: 0.002,
        };
        let mut seen_late = false;
        for frame in 0..200 {
            for (k, phase) in [0.0, 0.010, -0.004].iter().enumerate() {
                let t = clocks.capture_time(7, k, frame, 30.0);
                let off = t - frame as f64 / 30.0 - phase;
                assert!(
                    off.abs() <= 0.002 + 1e-12,
                    "camera {k} frame {frame}: {off}"
                );
                seen_late |= off > 0.0015;
            }
        }
        assert!(
            seen_late,
            "the jitter never reached near its bound in 600 captures"
        );
        // Seeded: the same capture again, another seed elsewhere.
        assert_eq!(
            clocks.capture_time(7, 1, 5, 30.0),
            clocks.capture_time(7, 1, 5, 30.0)
        );
        assert_ne!(
            clocks.capture_time(7, 1, 5, 30.0),
            clocks.capture_time(8, 1, 5, 30.0)
        );
        assert!((clocks.widest_spread_s(3) - 0.018).abs() < 1e-12);
        let together = FreeRunning::default();
        assert_eq!(together.capture_time(1, 2, 3, 10.0), 0.3);
    }
}
