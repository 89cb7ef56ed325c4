//! `flexshape bench`: per-stage figures of the sensing chain on the simulated rig, at 1 and 2
//! threads. Frames are rendered once and kept in memory; image decoding is measured apart.
//!
//! Latency: one frame at a time (cameras' silhouettes in parallel when there are threads).
//! Throughput: frames processed concurrently, one per thread.

use std::time::Instant;

use anyhow::Context;
use flexshape_silhouette::BackgroundModel;
use flexshape_sim::Simulator;
use flexshape_track::{Pipeline, StageSummary, quantile, stage_summaries};
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
    results: Vec<Figures>,
}

pub fn run(args: &BenchArgs) -> anyhow::Result<()> {
    anyhow::ensure!(
        args.frames > 0 && args.rounds > 0,
        "--frames and --rounds must be at least 1"
    );
    let sim =
        Simulator::new(super::sim_config(&args.sim)).context("cannot set up the simulated rig")?;
    let frames: Vec<Vec<RgbImage>> = sim
        .sweep(args.frames)
        .iter()
        .enumerate()
        .map(|(i, pose)| {
            sim.render(i as u64, pose)
                .map(|f| f.views.into_iter().map(|v| v.image).collect())
        })
        .collect::<Result<_, _>>()
        .context("cannot render the simulated frames")?;
    let backgrounds = sim
        .backgrounds()
        .iter()
        .map(|b| BackgroundModel::from_frames(std::slice::from_ref(b)))
        .collect::<Result<Vec<_>, _>>()?;
    let rig = sim.rig();
    let pipeline = Pipeline::new(rig, &backgrounds, &rig.volume)?;
    let mut results = Vec::new();
    for threads in [1, 2] {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .context("cannot start worker threads")?;
        results.push(pool.install(|| measure(&pipeline, &frames, args.rounds))?);
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
    };
    if args.json {
        println!("{}", serde_json::to_string_pretty(&report)?);
    } else {
        print_table(&report);
    }
    Ok(())
}

fn measure(
    pipeline: &Pipeline,
    frames: &[Vec<RgbImage>],
    rounds: usize,
) -> anyhow::Result<Figures> {
    let refs: Vec<Vec<&RgbImage>> = frames.iter().map(|f| f.iter().collect()).collect();
    // One frame at a time.
    let mut timings = Vec::new();
    let mut totals = Vec::new();
    for _ in 0..rounds {
        for f in &refs {
            let t = Instant::now();
            let tracked = pipeline.process(f)?;
            totals.push(t.elapsed().as_secs_f64() * 1e3);
            timings.push(tracked.timings);
        }
    }
    // Frames in flight, one per thread.
    let start = Instant::now();
    for _ in 0..rounds {
        refs.par_iter()
            .map(|f| pipeline.process(f).map(|_| ()))
            .collect::<Result<Vec<()>, _>>()?;
    }
    let throughput_fps = (rounds * frames.len()) as f64 / start.elapsed().as_secs_f64();
    let stages = stage_summaries(&timings);
    Ok(Figures {
        threads: rayon::current_num_threads(),
        stages,
        frame_median_ms: quantile(&mut totals, 0.5),
        throughput_fps,
    })
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
    println!(
        "\n{:<22} {:>18} {:>18}",
        "stage (ms)", "1 thread med/p95", "2 threads med/p95"
    );
    let n = r.results[0].stages.len();
    for i in 0..n {
        let cell =
            |f: &Figures| format!("{:.2} / {:.2}", f.stages[i].median_ms, f.stages[i].p95_ms);
        println!(
            "{:<22} {:>18} {:>18}",
            r.results[0].stages[i].stage,
            cell(&r.results[0]),
            cell(&r.results[1])
        );
    }
    println!(
        "{:<22} {:>18.2} {:>18.2}",
        "whole frame (median)", r.results[0].frame_median_ms, r.results[1].frame_median_ms
    );
    println!(
        "{:<22} {:>18.0} {:>18.0}",
        "throughput (frames/s)", r.results[0].throughput_fps, r.results[1].throughput_fps
    );
    println!(
        "\nPNG decoding, not included above: {:.2} ms per camera frame",
        r.png_decode_ms
    );
}
