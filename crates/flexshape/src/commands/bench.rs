//! `flexshape bench`: per-stage figures of the sensing chain on the simulated rig, at 1 and 2
//! threads. Frames are rendered once and kept in memory; image decoding is measured apart.
//!
//! Latency: one frame at a time (cameras' silhouettes in parallel when there are threads).
//! Throughput: frames processed concurrently, one per thread.
//!
//! Two workloads: every frame through the whole chain from its hull (distinct poses from the
//! sweep), and tracking (a smooth motion filmed at `--rate`, each frame started from an
//! earlier one's shape as `flexshape track` does: with one frame per thread in flight, from
//! the frame `threads` back).

use std::time::Instant;

use anyhow::Context;
use flexshape_silhouette::BackgroundModel;
use flexshape_sim::Simulator;
use flexshape_track::{Pipeline, Recent, StageSummary, Start, quantile, stage_summaries};
use image::RgbImage;
use rayon::prelude::*;
use serde::Serialize;

use crate::cli::BenchArgs;

/// Figures at one thread count.
#[derive(Debug, Serialize)]
struct Figures {
    threads: usize,
    /// Per stage, median and 95th percentile ms, one frame at a time.
    stages: Vec<StageSummary>,
    /// Median ms of the whole chain, one frame at a time.
    frame_median_ms: f64,
    /// Frames per second with one frame per thread in flight.
    throughput_fps: f64,
    /// Tracking only: share of frames that started from an earlier frame (the rest were
    /// carved again).
    #[serde(skip_serializing_if = "Option::is_none")]
    followed: Option<f64>,
}

#[derive(Debug, Serialize)]
struct Report {
    cameras: usize,
    width: u32,
    height: u32,
    voxels: [u32; 3],
    voxel_mm: f64,
    frames: usize,
    rounds: usize,
    /// Median ms to decode one camera's PNG frame (not part of the figures above).
    png_decode_ms: f64,
    /// Every frame from its hull, at 1 and 2 threads.
    results: Vec<Figures>,
    /// Tracking frames of the smooth motion, at 1 and 2 threads (empty when the rig does not
    /// track: fewer than three cameras).
    tracking: Vec<Figures>,
    /// Frames of the motion and its rate, frames per second.
    track_frames: usize,
    rate_hz: f64,
}

pub fn run(args: &BenchArgs) -> anyhow::Result<()> {
    anyhow::ensure!(
        args.frames > 0 && args.rounds > 0 && args.track_frames > 1,
        "--frames and --rounds must be at least 1, --track-frames at least 2"
    );
    anyhow::ensure!(
        args.rate.is_finite() && args.rate > 0.0,
        "--rate must be a positive number of frames per second"
    );
    let sim =
        Simulator::new(super::sim_config(&args.sim)).context("cannot set up the simulated rig")?;
    let frames =
        render(&sim, &sim.sweep(args.frames)).context("cannot render the simulated frames")?;
    let backgrounds = BackgroundModel::each(&sim.backgrounds())?;
    let rig = sim.rig();
    let pipeline = Pipeline::new(rig, &backgrounds, &rig.volume)?;
    // Tracking is measured whatever the rig's default (it is off unless asked for).
    let following = pipeline.clone().following(true)?;
    let motion = if following.tracks() {
        render(&sim, &sim.motion(args.track_frames, args.rate))
            .context("cannot render the simulated motion")?
    } else {
        Vec::new()
    };
    let mut results = Vec::new();
    let mut tracking = Vec::new();
    for threads in [1, 2] {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .context("cannot start worker threads")?;
        results.push(pool.install(|| measure(&pipeline, &frames, args.rounds))?);
        if !motion.is_empty() {
            tracking.push(pool.install(|| measure(&following, &motion, args.rounds))?);
        }
    }
    let report = Report {
        cameras: frames[0].len(),
        width: frames[0][0].width(),
        height: frames[0][0].height(),
        voxels: rig.volume.dims,
        voxel_mm: rig.volume.voxel_size[0],
        frames: args.frames,
        rounds: args.rounds,
        png_decode_ms: png_decode_ms(&frames[0][0])?,
        results,
        tracking,
        track_frames: args.track_frames,
        rate_hz: args.rate,
    };
    if args.json {
        println!("{}", serde_json::to_string_pretty(&report)?);
    } else {
        print_table(&report);
    }
    Ok(())
}

/// Figures over `frames`: latency one frame at a time, throughput with one frame per thread in
/// flight (thread `k` takes frames `k`, `k + n`, …). A pipeline that tracks starts each frame
/// from the one before (for throughput, from its own previous one, `n` frames back, as the
/// runner's workers do); one that does not starts every frame from its hull.
fn measure(
    pipeline: &Pipeline,
    frames: &[Vec<RgbImage>],
    rounds: usize,
) -> anyhow::Result<Figures> {
    let refs: Vec<Vec<&RgbImage>> = frames.iter().map(|f| f.iter().collect()).collect();
    let mut timings = Vec::new();
    let mut totals = Vec::new();
    let mut followed = 0usize;
    for _ in 0..rounds {
        let mut recent = Recent::new(pipeline);
        for (seq, f) in refs.iter().enumerate() {
            let t = Instant::now();
            let prior = recent.for_frame(seq as u64);
            let tracked = pipeline.process_after(f, prior.as_deref())?;
            let elapsed = t.elapsed().as_secs_f64() * 1e3;
            recent.update(seq as u64, tracked.prior());
            // The first frame of a pass has nothing to start from.
            if tracked.start == Start::Previous {
                followed += 1;
            }
            totals.push(elapsed);
            timings.push(tracked.timings);
        }
    }
    let threads = rayon::current_num_threads();
    let start = Instant::now();
    for _ in 0..rounds {
        (0..threads)
            .into_par_iter()
            .map(|k| {
                let mut recent = Recent::new(pipeline);
                for (seq, f) in refs.iter().enumerate().skip(k).step_by(threads) {
                    let prior = recent.for_frame(seq as u64);
                    let tracked = pipeline.process_after(f, prior.as_deref())?;
                    recent.update(seq as u64, tracked.prior());
                }
                Ok(())
            })
            .collect::<anyhow::Result<Vec<()>>>()?;
    }
    let throughput_fps = (rounds * frames.len()) as f64 / start.elapsed().as_secs_f64();
    Ok(Figures {
        threads,
        stages: stage_summaries(&timings),
        frame_median_ms: quantile(&mut totals, 0.5),
        throughput_fps,
        followed: pipeline
            .tracks()
            .then(|| followed as f64 / (rounds * (frames.len() - 1).max(1)) as f64),
    })
}

/// Every camera's image of each pose, rendered.
fn render(
    sim: &Simulator,
    poses: &[flexshape_sim::CatheterPose],
) -> Result<Vec<Vec<RgbImage>>, flexshape_sim::SimError> {
    poses
        .iter()
        .enumerate()
        .map(|(i, pose)| {
            sim.render(i as u64, pose)
                .map(|f| f.views.into_iter().map(|v| v.image).collect())
        })
        .collect()
}

/// Median time to decode one frame stored as PNG, ms.
fn png_decode_ms(frame: &RgbImage) -> anyhow::Result<f64> {
    let mut png = Vec::new();
    frame.write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png)?;
    let mut t: Vec<f64> = (0..20)
        .map(|_| {
            let start = Instant::now();
            let img = image::load_from_memory_with_format(&png, image::ImageFormat::Png);
            let ms = start.elapsed().as_secs_f64() * 1e3;
            img.map(|_| ms)
        })
        .collect::<Result<_, _>>()?;
    Ok(quantile(&mut t, 0.5))
}

fn print_table(r: &Report) {
    println!(
        "flexshape bench: {} cameras at {}×{}, {}×{}×{} voxels of {} mm, {} frames × {} rounds (in memory)",
        r.cameras,
        r.width,
        r.height,
        r.voxels[0],
        r.voxels[1],
        r.voxels[2],
        r.voxel_mm,
        r.frames,
        r.rounds
    );
    print_figures("every frame from its hull", &r.results);
    if r.tracking.len() == 2 {
        print_figures(
            &format!(
                "tracking (`track --follow`): {} frames of smooth motion at {} Hz",
                r.track_frames, r.rate_hz
            ),
            &r.tracking,
        );
        println!(
            "frames that started from an earlier one: {:.0} % (1 thread), {:.0} % (2 threads; the rest were carved again)",
            100.0 * r.tracking[0].followed.unwrap_or(0.0),
            100.0 * r.tracking[1].followed.unwrap_or(0.0)
        );
    } else {
        println!("\ntracking: off (the rig needs two cameras or more, and the fit's `track` on)");
    }
    println!(
        "\nPNG decoding, not included above: {:.2} ms per camera frame",
        r.png_decode_ms
    );
}

fn print_figures(title: &str, results: &[Figures]) {
    println!(
        "\n{title}\n{:<22} {:>18} {:>18}",
        "stage (ms)", "1 thread med/p95", "2 threads med/p95"
    );
    let n = results[0].stages.len();
    for i in 0..n {
        let cell =
            |f: &Figures| format!("{:.2} / {:.2}", f.stages[i].median_ms, f.stages[i].p95_ms);
        println!(
            "{:<22} {:>18} {:>18}",
            results[0].stages[i].stage,
            cell(&results[0]),
            cell(&results[1])
        );
    }
    println!(
        "{:<22} {:>18.2} {:>18.2}",
        "whole frame (median)", results[0].frame_median_ms, results[1].frame_median_ms
    );
    println!(
        "{:<22} {:>18.0} {:>18.0}",
        "throughput (frames/s)", results[0].throughput_fps, results[1].throughput_fps
    );
}
