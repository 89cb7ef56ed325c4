//! Seeded pose sequences that sweep the workspace.

use std::f64::consts::{PI, TAU};

use rand::rngs::Xoshiro256PlusPlus;
use rand::{RngExt, SeedableRng};

use crate::catheter::{Catheter, CatheterPose};

/// Largest bend angle of the sweep, radians (170°).
pub const MAX_BEND_ANGLE: f64 = 170.0 * PI / 180.0;
/// Largest insertion of the sweep, mm.
pub const MAX_INSERTION: f64 = 30.0;

/// `frames` constant-curvature poses covering the workspace: bend angle κ·L up to 170° with
/// its area-uniform spread (√ of a low-discrepancy sequence), bending plane turning by the
/// golden angle each frame, insertion 0–30 mm, and compression ε0 ∈ [0, 1 %], ε1 ∈ [0, 3 %].
/// The seed shifts the sequences and jitters every pose, so different seeds give different
/// sweeps of the same coverage.
pub fn sweep(catheter: &Catheter, seed: u64, frames: usize) -> Vec<CatheterPose> {
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(seed ^ 0x5EED_5EED);
    let golden = (5f64.sqrt() - 1.0) / 2.0;
    let offsets: [f64; 3] = [rng.random(), rng.random(), rng.random()];
    (0..frames)
        .map(|i| {
            let i = i as f64;
            let frac = |x: f64| x - x.floor();
            let u = frac(offsets[0] + i * 0.754_877_666); // plastic-number sequence
            let angle = MAX_BEND_ANGLE * (u.sqrt() * 0.97 + 0.03 * rng.random::<f64>());
            let phi = TAU * frac(offsets[1] + i * golden) + rng.random_range(-0.05..0.05);
            let insertion = MAX_INSERTION * frac(offsets[2] + i * 2f64.sqrt());
            let eps = [0.01 * rng.random::<f64>(), 0.03 * rng.random::<f64>()];
            let arc = catheter.bend_length * (1.0 - eps[1]);
            let kappa = angle / arc;
            CatheterPose::arc(
                catheter,
                [kappa * phi.cos(), kappa * phi.sin()],
                eps,
                insertion,
            )
        })
        .collect()
}
