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
            bent(catheter, angle, phi, eps, insertion)
        })
        .collect()
}

/// `frames` poses of a smooth motion filmed at `rate_hz` frames per second, as a tracker sees
/// it: the bend angle swings between 5° and 150° and back every 6 s, the bending plane turns
/// once every 9 s, the insertion runs 0–30 mm and back every 7 s (at 30 Hz the tip moves up
/// to about 5 mm between frames, at 120 Hz about 1 mm), compression following the bend. The
/// seed sets the phases. Frame `i` is [`motion_at`] `i / rate_hz` seconds.
pub fn motion(catheter: &Catheter, seed: u64, frames: usize, rate_hz: f64) -> Vec<CatheterPose> {
    (0..frames)
        .map(|i| motion_at(catheter, seed, i as f64 / rate_hz.max(1e-9)))
        .collect()
}

/// The pose of [`motion`] at `t` seconds from its start (any instant, e.g. while a shutter is
/// open).
pub fn motion_at(catheter: &Catheter, seed: u64, t: f64) -> CatheterPose {
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(seed ^ 0x00F0_1100);
    let phase: [f64; 3] = [
        rng.random_range(0.0..TAU),
        rng.random_range(0.0..TAU),
        rng.random_range(0.0..TAU),
    ];
    let (low, high) = (5f64.to_radians(), 150f64.to_radians());
    let swing = 0.5 - 0.5 * (TAU * t / 6.0 + phase[0]).cos();
    let angle = low + (high - low) * swing;
    let phi = TAU * t / 9.0 + phase[1];
    let insertion = MAX_INSERTION * (0.5 - 0.5 * (TAU * t / 7.0 + phase[2]).cos());
    bent(
        catheter,
        angle,
        phi,
        [0.01 * swing, 0.03 * swing],
        insertion,
    )
}

/// The constant-curvature pose of bend angle `angle` (radians, over the compressed bending
/// section) in the plane at `phi`, with compressions `eps` and `insertion` mm.
fn bent(catheter: &Catheter, angle: f64, phi: f64, eps: [f64; 2], insertion: f64) -> CatheterPose {
    let kappa = angle / (catheter.bend_length * (1.0 - eps[1]));
    CatheterPose::arc(
        catheter,
        [kappa * phi.cos(), kappa * phi.sin()],
        eps,
        insertion,
    )
}
