//! Fast motion filmed with the shutter open: the tip moving up to 15 mm between frames at
//! 10 Hz, the shutter open half the interval, so every moving edge is blurred along its path
//! (its ¼–¾ rise up to 2.5 px against 1.0 for a still one). The fit leans on the sharper
//! views; a camera whose outline is off only by what its blur allows is excused while two
//! others place the tube even with their own blur added. Every `ok` stays right, every
//! refusal names the blur, and a camera that is off for another reason still refuses.

use crate::common;

use common::*;
use flexshape_fit::STILL_RAMP_PX;
use flexshape_shape::Status;
use flexshape_sim::SimConfig;

/// Frames of the 10 Hz motion (every other of the first 20), the shutter open half the
/// interval, rendered at five instants while it is open.
const FRAMES: usize = 10;

/// `ok` frames and right-but-refused frames (centerline RMS ≤ 0.15 mm, tip ≤ 0.3 mm), asserting
/// every `ok` frame right and every `inconsistent` frame's reason naming the blur when a
/// camera's edges are blurred.
fn sweep(chain: &Chain, label: &str) -> (usize, usize) {
    let sim = &chain.sim;
    let (mut ok, mut refused) = (0, 0);
    let exposures = sim.motion_exposures(2 * FRAMES, 10.0, 0.5, 5);
    for (n, poses) in exposures.iter().enumerate().step_by(2) {
        let b = chain.run(sim.render_exposure(n as u64, poses).unwrap());
        let (rms, tip) = b.fitted_errors(sim);
        let right = rms <= 0.15 && tip <= 0.3;
        let label = format!("{label} frame {n:2}");
        if b.fitted.status == Status::Ok {
            ok += 1;
            assert!(right, "{label}: ok, rms {rms:.3} mm, tip {tip:.2} mm");
            continue;
        }
        refused += usize::from(right);
        let blurred = b
            .fit
            .iter()
            .flat_map(|f| &f.cameras)
            .any(|c| c.ramp_px > STILL_RAMP_PX);
        if let Status::Inconsistent { reason } = &b.fitted.status {
            assert!(
                !blurred || reason.contains("moved while the shutter was open"),
                "{label}: the reason does not name the blur: {reason}"
            );
        }
        println!(
            "{label}: {:?}, rms {rms:.3} mm, tip {tip:.2}",
            b.fitted.status
        );
    }
    println!("{label}: {ok} of {FRAMES} ok, {refused} refused but right");
    (ok, refused)
}

#[test]
fn blurred_views_leave_right_frames_ok() {
    let (mut ok, mut refused) = (0, 0);
    for seed in [1, 2, 3] {
        let chain = Chain::new(SimConfig {
            seed,
            ..SimConfig::default()
        });
        let (o, r) = sweep(&chain, &format!("seed {seed}"));
        ok += o;
        refused += r;
    }
    // Measured: 9 of 30 ok (4, 0, 5), 15 refused but right, every refusal naming the blur. Five
    // instants an exposure leave copies of the tip 5 px apart, as a flickering lamp would:
    // excusing a blurred camera whenever two others passed as measured gave 26 of 30 `ok` but
    // one 0.44 mm off at the tip, which the two cameras' own blur hid. 9 of 30 (9 refused but
    // right) before the fit weighted boundaries by their blur.
    assert!(ok >= 8, "only {ok} of 30 ok, {refused} refused but right");
}

/// One camera's pose turned by 0.2° (about 2 px at the tube) while the tube moves: its blur
/// must not excuse it.
#[test]
fn blur_does_not_excuse_a_miscalibrated_camera() {
    let chain = Chain::with_camera_turned(SimConfig::default(), 1, 0.2);
    let (ok, _) = sweep(&chain, "miscalibrated");
    assert!(ok <= 1, "{ok} of {FRAMES} ok with a camera 0.2° off");
}
