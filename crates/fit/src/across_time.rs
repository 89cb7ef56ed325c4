//! A fit across time: cameras that are not triggered together see a moving tube at their own
//! instants, so each camera's outline is compared with the tube where it was when that camera
//! captured — the shape carried by its recent motion — and the fitted shape is the tube at
//! one instant.
//!
//! The motion is a velocity along the tube (mm/s at each fraction of its parameter), read
//! from two earlier right shapes; each camera's tube is the fitted one with every control
//! point moved by the velocity at its place times the camera's time from the instant. The
//! moves are fixed while the tube is fitted, so every camera's Jacobian in the control points
//! is the one it has without them.

use nalgebra::{DVector, Vector3};

use crate::tube::Tube;

/// Samples of the velocity along the tube's parameter (0 to 1): a smooth motion's field
/// varies over tens of millimetres, and 64 intervals place it every few.
const SAMPLES: usize = 65;

/// How a tube moved: its velocity at evenly spaced fractions of its parameter, world frame,
/// mm per second.
#[derive(Debug, Clone, PartialEq)]
pub struct Motion {
    velocity: Vec<Vector3<f64>>,
    /// The later tube's unit tangent at each sample: what moves along the tube is mostly a
    /// matter of where two fits put their parameters, which the images hardly see.
    tangent: Vec<Vector3<f64>>,
}

impl Motion {
    /// The motion from `earlier` to `later`, `dt_s` seconds apart: the two curves' points at
    /// the same fraction of their parameter paired (the fit keeps control points about evenly
    /// spread, so that is about the same fraction of their length). `None` for tubes whose ends
    /// differ (capped against open), or a time that is not positive.
    pub fn between(earlier: &Tube, later: &Tube, dt_s: f64) -> Option<Motion> {
        if earlier.capped != later.capped || !(dt_s > 0.0 && dt_s.is_finite()) {
            return None;
        }
        let (velocity, tangent) = (0..SAMPLES)
            .map(|i| {
                let u = i as f64 / (SAMPLES - 1) as f64;
                let (p, t) = later.frame(u);
                ((p - earlier.frame(u).0) / dt_s, t)
            })
            .unzip();
        Some(Motion { velocity, tangent })
    }

    /// The velocity at the fraction `u` (0–1) of the tube's parameter, mm/s, linear between
    /// the samples.
    pub fn at(&self, u: f64) -> Vector3<f64> {
        let x = u.clamp(0.0, 1.0) * (SAMPLES - 1) as f64;
        let i = (x.floor() as usize).min(SAMPLES - 2);
        let f = x - i as f64;
        self.velocity[i] * (1.0 - f) + self.velocity[i + 1] * f
    }

    /// The largest difference between this motion's velocity and `other`'s at one fraction of
    /// the tube, mm/s: two estimates over different times differ by the tube's acceleration
    /// between them and by the shapes' own scatter, which is how far either may be from the
    /// velocity at another instant.
    /// Across the tube only (see [`Motion::fastest_across`]).
    pub fn largest_difference(&self, other: &Motion) -> f64 {
        self.velocity
            .iter()
            .zip(&other.velocity)
            .zip(&self.tangent)
            .map(|((a, b), t)| across(a - b, t))
            .fold(0.0, f64::max)
    }

    /// The fastest any point of the tube moves across it, mm/s: motion along the tube moves
    /// its outline only at the ends, and between two fits it is mostly where each put its
    /// parameters.
    pub fn fastest_across(&self) -> f64 {
        self.velocity
            .iter()
            .zip(&self.tangent)
            .map(|(v, t)| across(*v, t))
            .fold(0.0, f64::max)
    }

    /// The fastest any point of the tube moves, mm/s.
    pub fn fastest(&self) -> f64 {
        self.velocity.iter().map(|v| v.norm()).fold(0.0, f64::max)
    }
}

/// A frame whose cameras captured at different instants, and the tube's motion about then.
#[derive(Debug, Clone, PartialEq)]
pub struct AcrossTime {
    /// The tube's recent motion.
    pub motion: Motion,
    /// Per camera, rig order: its capture time less the instant the fitted shape refers to,
    /// seconds.
    pub offsets_s: Vec<f64>,
}

impl AcrossTime {
    /// `tube` as each camera (rig order) saw it: every control point moved by the motion at
    /// its Greville abscissa (the parameter it pulls the curve toward most) times the camera's
    /// offset. A camera without an offset sees the tube as it is.
    pub(crate) fn seen(&self, tube: &Tube, cameras: usize) -> Vec<Tube> {
        let n = tube.centerline.control().len();
        // Each control point's velocity, the same for every camera.
        let velocity: Vec<Vector3<f64>> =
            greville(n).into_iter().map(|u| self.motion.at(u)).collect();
        (0..cameras)
            .map(|k| {
                let dt = self.offsets_s.get(k).copied().unwrap_or(0.0);
                let mut seen = tube.clone();
                if dt != 0.0 {
                    let mut step = DVector::zeros(3 * n);
                    for (j, v) in velocity.iter().enumerate() {
                        step.fixed_rows_mut::<3>(3 * j).copy_from(&(v * dt));
                    }
                    seen.centerline.displace(&step);
                }
                seen
            })
            .collect()
    }

    /// The farthest any camera saw the tube from where it is at the instant, mm: the fastest
    /// point's speed times the largest offset.
    pub fn largest_shift_mm(&self) -> f64 {
        let dt = self.offsets_s.iter().map(|t| t.abs()).fold(0.0, f64::max);
        self.motion.fastest() * dt
    }
}

/// The part of `v` across the unit tangent `t`, its length.
fn across(v: Vector3<f64>, t: &Vector3<f64>) -> f64 {
    (v - t * v.dot(t)).norm()
}

/// The Greville abscissae of a clamped uniform cubic B-spline's `n` control points: the
/// average of the three inner knots each spans, over `n − 3` equal spans of `[0, 1]`.
fn greville(n: usize) -> Vec<f64> {
    let spans = n.saturating_sub(3).max(1) as f64;
    let knot = |i: usize| ((i as f64 - 3.0) / spans).clamp(0.0, 1.0);
    (0..n)
        .map(|j| (knot(j + 1) + knot(j + 2) + knot(j + 3)) / 3.0)
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn straight(offset: Vector3<f64>) -> Tube {
        let points: Vec<[f64; 3]> = (0..=100)
            .map(|i| [offset.x + i as f64, offset.y, offset.z])
            .collect();
        Tube::through(&points, 2.0, [false, true], 10.0, 0.0).unwrap()
    }

    #[test]
    fn greville_abscissae_run_from_end_to_end_in_order() {
        let g = greville(8);
        assert_eq!(g.len(), 8);
        assert!(g[0].abs() < 1e-12 && (g[7] - 1.0).abs() < 1e-12);
        assert!(g.windows(2).all(|w| w[1] > w[0]), "{g:?}");
    }

    #[test]
    fn each_camera_sees_the_tube_carried_by_its_own_offset() {
        // A tube translating at 100 mm/s across itself.
        let earlier = straight(Vector3::zeros());
        let later = straight(Vector3::new(0.0, 1.0, 0.0));
        let motion = Motion::between(&earlier, &later, 0.01).unwrap();
        assert!(
            (motion.fastest() - 100.0).abs() < 1e-6,
            "{}",
            motion.fastest()
        );
        let across = AcrossTime {
            motion,
            offsets_s: vec![0.0, 0.004, -0.002],
        };
        assert!((across.largest_shift_mm() - 0.4).abs() < 1e-9);
        let seen = across.seen(&later, 3);
        for (tube, dy) in seen.iter().zip([0.0, 0.4, -0.2]) {
            for i in 0..=10 {
                let u = i as f64 / 10.0;
                let d = tube.frame(u).0 - later.frame(u).0;
                assert!(
                    (d - Vector3::new(0.0, dy, 0.0)).norm() < 1e-9,
                    "u {u}: {d:?}"
                );
            }
        }
        // Ends that differ pair up no motion.
        let mut capped = later.clone();
        capped.capped = [true, true];
        assert!(Motion::between(&earlier, &capped, 0.01).is_none());
        assert!(Motion::between(&earlier, &later, 0.0).is_none());
    }
}
