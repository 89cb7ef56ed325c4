//! Feeds frames from your own camera driver, one image per camera at a time, and follows the
//! tube from frame to frame. The "driver" here is the simulated rig filmed at 120 Hz; replace
//! `grab` with your cameras' (RGB images of the calibrated sizes, in the rig's camera order).
//!
//! ```text
//! cargo run --release -p flexshape-track --example own_camera
//! ```

use flexshape_silhouette::BackgroundModel;
use flexshape_sim::{SimConfig, Simulator};
use flexshape_track::{Pipeline, Recent};
use image::RgbImage;

fn main() {
    if let Err(e) = track() {
        eprintln!("error: {e}");
        std::process::exit(1);
    }
}

fn track() -> Result<(), Box<dyn std::error::Error>> {
    // Your rig (flexshape_rig::Rig::load("rig.toml")) and one background model per camera
    // (BackgroundModel::load("bg/cam0.png"), ...): here the simulator's.
    let sim = Simulator::new(SimConfig::default())?;
    let rig = sim.rig().clone();
    let backgrounds = BackgroundModel::each(&sim.backgrounds())?;
    // Each frame starts from the newest right shape: no carving while it follows.
    let pipeline = Pipeline::new(&rig, &backgrounds, &rig.volume)?.following(true)?;
    let poses = sim.motion(20, 120.0);
    let grab = |n: usize| -> Result<Vec<RgbImage>, Box<dyn std::error::Error>> {
        let frame = sim.render(n as u64, &poses[n])?;
        Ok(frame.views.into_iter().map(|v| v.image).collect())
    };
    // The newest right shapes, from which the next frame starts.
    let mut recent = Recent::new(&pipeline);
    for n in 0..poses.len() {
        let images = grab(n)?;
        let refs: Vec<&RgbImage> = images.iter().collect();
        let prior = recent.for_frame(n as u64);
        let tracked = pipeline.process_after(&refs, prior.as_deref())?;
        recent.update(n as u64, tracked.prior());
        let record = tracked.record(n as u64);
        println!(
            "frame {n}: {} (from {}) tip {:?} mm, {:.2} ms",
            record.status,
            record.start.as_ref().map_or("-", |s| s.as_str()),
            record.tip.map(|t| t.map(|v| (v * 100.0).round() / 100.0)),
            tracked.timings.total()
        );
    }
    Ok(())
}
