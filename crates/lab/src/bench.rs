//! `flexshape bench`: per-stage figures of the sensing chain on the simulated rig, at 1 and 2
//! threads. Frames are rendered once and kept in memory; image decoding is measured apart.
//!
//! Latency: one frame at a time (cameras' silhouettes in parallel when there are threads).
//! Throughput: frames processed concurrently, one per thread.
//!
//! Two workloads: every frame through the whole chain from its hull (distinct poses from the
//! sweep), and tracking (a smooth motion filmed at `rate_hz`, played back and forth as one
//! continuous run, each frame started from an earlier one's shape as `flexshape track` does:
//! with one frame per thread in flight, from the frame `threads` back). Each workload's
//! records are also held against the simulator's truth, one frame at a time and as the
//! throughput run makes them (its lanes start from frames further back), so that a setting
//! that buys speed shows what it costs in accuracy.

use std::fmt::Write as _;
use std::time::Instant;

use flexshape_record::{StageSummary, Start, quantile, stage_summaries};
use flexshape_recording::Truth;
use flexshape_sim::{SimConfig, Simulator};
use flexshape_track::{Pipeline, Recent, TrackError, Tracked};
use image::RgbImage;
use rayon::prelude::*;
use serde::Serialize;

use crate::LabError;
use crate::demo::{DemoFigures, RightBounds, ShapeErrors};

/// What to measure.
#[derive(Debug, Clone, PartialEq)]
pub struct BenchSettings {
    /// Distinct frames of the sweep (each processed `rounds` times).
    pub frames: usize,
    /// Passes over the frames per thread count.
    pub rounds: usize,
    /// Frames of the smooth motion the tracking figures are measured on.
    pub track_frames: usize,
    /// Its frame rate, frames per second.
    pub rate_hz: f64,
}

impl Default for BenchSettings {
    fn default() -> Self {
        Self {
            frames: 10,
            rounds: 5,
            track_frames: 60,
            rate_hz: 120.0,
        }
    }
}

/// Renders the rig of `config` and measures the chain on it at 1 and 2 threads.
pub fn bench(config: SimConfig, settings: &BenchSettings) -> Result<BenchReport, LabError> {
    let s = settings;
    if s.frames == 0 || s.rounds == 0 || s.track_frames < 2 {
        return Err(LabError::data(
            "bench",
            "frames and rounds must be at least 1, track frames at least 2",
        ));
    }
    if !(s.rate_hz.is_finite() && s.rate_hz > 0.0) {
        return Err(LabError::data(
            "bench",
            "the rate must be a positive number of frames per second",
        ));
    }
    let sim = Simulator::new(config).map_err(LabError::simulator)?;
    let frames = render(&sim, &sim.sweep(s.frames)).map_err(LabError::simulator)?;
    let rig = sim.rig();
    let pipeline = crate::simulate::chain(&sim)?;
    // Tracking is measured whatever the rig's default (it is off unless asked for).
    let following = pipeline.clone().following(true)?;
    let motion = if following.tracks() {
        render(&sim, &sim.motion(s.track_frames, s.rate_hz)).map_err(LabError::simulator)?
    } else {
        Vec::new()
    };
    let mut results = Vec::new();
    let mut tracking = Vec::new();
    for threads in [1, 2] {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .map_err(|e| LabError::data("bench", format!("cannot start worker threads: {e}")))?;
        results.push(pool.install(|| measure(&pipeline, &frames, s.rounds))?);
        if !motion.is_empty() {
            tracking.push(pool.install(|| measure(&following, &motion, s.rounds))?);
        }
    }
    Ok(BenchReport {
        cameras: frames[0].0.len(),
        width: frames[0].0[0].width(),
        height: frames[0].0[0].height(),
        voxels: rig.volume.dims,
        voxel_mm: rig.volume.voxel_size[0],
        frames: s.frames,
        rounds: s.rounds,
        png_decode_ms: png_decode_ms(&frames[0].0[0])
            .map_err(|e| LabError::data("bench", format!("cannot encode a PNG: {e}")))?,
        results,
        tracking,
        track_frames: s.track_frames,
        rate_hz: s.rate_hz,
    })
}

/// Figures at one thread count.
#[derive(Debug, Clone, Serialize)]
pub struct Figures {
    /// Threads.
    pub threads: usize,
    /// Per stage, median and 95th percentile ms, one frame at a time.
    pub stages: Vec<StageSummary>,
    /// Median ms of the whole chain, one frame at a time.
    pub frame_median_ms: f64,
    /// Frames per second with one frame per thread in flight (the median of three runs).
    pub throughput_fps: f64,
    /// Tracking only: share of frames that started from an earlier frame (the rest were
    /// carved again), the run's first frame, which has none, left out.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub followed: Option<f64>,
    /// The records of the first pass (one frame at a time) against the simulator's truth.
    pub accuracy: Accuracy,
    /// The records of the throughput run (`threads` lanes, each frame started from the one
    /// `threads` back), every step of it, against the simulator's truth.
    pub throughput_accuracy: Accuracy,
}

/// A workload's records against the simulator's truth, mm: over the frames whose status says
/// the shape is right (`ok`, `bands_missing`, `leaves_volume`).
#[derive(Debug, Clone, Serialize)]
pub struct Accuracy {
    /// Frames measured.
    pub frames: usize,
    /// Of which right and held against the truth (a true centerline in the volume).
    pub right: usize,
    /// Centerline RMS distance from the truth: median and worst over the right frames.
    pub centerline_rms_mm: [f64; 2],
    /// Tip distance from the true tip: median and worst.
    pub tip_mm: [f64; 2],
    /// Worst distance of a true band centre from the nearest one found.
    pub band_mm: f64,
    /// Frames whose status says the shape is right but the truth does not (centerline RMS
    /// beyond 0.15 mm or tip beyond 0.3 mm, [`RightBounds`]).
    pub right_said_wrong: usize,
    /// Frames whose status refuses a shape the truth says is right.
    pub right_refused: usize,
}

impl Accuracy {
    fn of(figures: &DemoFigures, frames: usize) -> Self {
        let pair = |v: &[f64]| [DemoFigures::median(v), DemoFigures::worst(v)];
        Accuracy {
            frames,
            right: figures.rms.len(),
            centerline_rms_mm: pair(&figures.rms),
            tip_mm: pair(&figures.tip),
            band_mm: figures.band,
            right_said_wrong: figures.right_said_wrong,
            right_refused: figures.right_refused,
        }
    }
}

/// What `flexshape bench` measured (ms, frames per second).
#[derive(Debug, Clone, Serialize)]
pub struct BenchReport {
    /// Cameras of the simulated rig.
    pub cameras: usize,
    /// Image width, px.
    pub width: u32,
    /// Image height, px.
    pub height: u32,
    /// Voxels along x, y, z.
    pub voxels: [u32; 3],
    /// Voxel edge, mm.
    pub voxel_mm: f64,
    /// Distinct frames (sweep poses).
    pub frames: usize,
    /// Passes over them per thread count.
    pub rounds: usize,
    /// Median ms to decode one camera's PNG frame (not part of the figures above).
    pub png_decode_ms: f64,
    /// Every frame from its hull, at 1 and 2 threads.
    pub results: Vec<Figures>,
    /// Tracking frames of the smooth motion, at 1 and 2 threads (empty when the rig does not
    /// track: fewer than three cameras).
    pub tracking: Vec<Figures>,
    /// Frames of the motion and its rate, frames per second.
    pub track_frames: usize,
    /// See `track_frames`.
    pub rate_hz: f64,
}

/// Times the throughput run is made; the median is reported. One run of the tracking workload
/// lasts a fifth of a second, and on a shared 2-core VM two threads' figure varied by ±7 % from
/// one run to the next.
const THROUGHPUT_PASSES: usize = 3;

/// Figures over `rounds` passes of `frames`: latency one frame at a time, throughput with one
/// frame per thread in flight (thread `k` takes steps `k`, `k + n`, …; the median of
/// [`THROUGHPUT_PASSES`] runs). A pipeline that tracks plays the frames back and forth
/// (0 … last … 0 …: a motion that reverses, never a jump) as one continuous run, each frame
/// started from the one before (for throughput, from its own previous one, `n` steps back, as
/// the runner's workers do): only a run's first frames start from their hulls, as in a
/// recording. One that does not starts every frame from its hull.
fn measure(pipeline: &Pipeline, frames: &Frames, rounds: usize) -> Result<Figures, LabError> {
    let refs: Vec<Vec<&RgbImage>> = frames.iter().map(|f| f.0.iter().collect()).collect();
    let steps = rounds * refs.len();
    // Frames from their hulls are independent: each is shown `rounds` times, in turn.
    let tracks = pipeline.tracks();
    let shown = |step: usize| {
        if tracks {
            back_and_forth(step, refs.len())
        } else {
            step % refs.len()
        }
    };
    let mut timings = Vec::new();
    let mut totals = Vec::new();
    let mut followed = 0usize;
    let mut errors = DemoFigures::default();
    let mut recent = Recent::new(pipeline);
    for step in 0..steps {
        let k = shown(step);
        let t = Instant::now();
        let prior = recent.for_frame(step as u64);
        let tracked = pipeline.process_after(&refs[k], prior.as_deref())?;
        let elapsed = t.elapsed().as_secs_f64() * 1e3;
        recent.update(step as u64, tracked.prior());
        if step < refs.len() {
            let e = ShapeErrors::of(pipeline, &frames[k].1, &tracked);
            errors.judge(
                tracked.shape.status.is_right(),
                e.as_ref(),
                RightBounds::default(),
            );
        }
        if tracked.start == Start::Previous {
            followed += 1;
        }
        totals.push(elapsed);
        timings.push(tracked.timings);
    }
    let threads = rayon::current_num_threads();
    let mut passes = Vec::with_capacity(THROUGHPUT_PASSES);
    for _ in 0..THROUGHPUT_PASSES {
        let start = Instant::now();
        lanes(pipeline, &refs, steps, threads, &shown, |_, _| ())?;
        passes.push(steps as f64 / start.elapsed().as_secs_f64());
    }
    // Once more, untimed, with every record held against the truth: lanes start from
    // frames further back, so their records differ from one frame at a time.
    let mut in_lanes = DemoFigures::default();
    let checked = lanes(pipeline, &refs, steps, threads, &shown, |step, tracked| {
        let e = ShapeErrors::of(pipeline, &frames[shown(step)].1, tracked);
        (tracked.shape.status.is_right(), e)
    })?;
    for (said_right, e) in &checked {
        in_lanes.judge(*said_right, e.as_ref(), RightBounds::default());
    }
    let throughput_fps = quantile(&mut passes, 0.5);
    Ok(Figures {
        threads,
        stages: stage_summaries(&timings),
        frame_median_ms: quantile(&mut totals, 0.5),
        throughput_fps,
        // The run's first frame has nothing to start from.
        followed: tracks.then(|| followed as f64 / (steps - 1).max(1) as f64),
        accuracy: Accuracy::of(&errors, frames.len()),
        throughput_accuracy: Accuracy::of(&in_lanes, steps),
    })
}

/// Runs the tracking or hull workload as the throughput figure does: `threads` lanes, lane
/// `k` taking steps `k`, `k + threads`, … each started from its own previous frame. Returns
/// what `check` made of every step's record, lane by lane.
fn lanes<T: Send>(
    pipeline: &Pipeline,
    refs: &[Vec<&RgbImage>],
    steps: usize,
    threads: usize,
    shown: &(impl Fn(usize) -> usize + Sync),
    check: impl Fn(usize, &Tracked) -> T + Sync,
) -> Result<Vec<T>, TrackError> {
    let per_lane = (0..threads)
        .into_par_iter()
        .map(|first| {
            let mut recent = Recent::new(pipeline);
            let mut checked = Vec::new();
            for step in (first..steps).step_by(threads) {
                let prior = recent.for_frame(step as u64);
                let tracked = pipeline.process_after(&refs[shown(step)], prior.as_deref())?;
                checked.push(check(step, &tracked));
                recent.update(step as u64, tracked.prior());
            }
            Ok(checked)
        })
        .collect::<Result<Vec<Vec<T>>, TrackError>>()?;
    Ok(per_lane.into_iter().flatten().collect())
}

/// The frame shown at step `step` of a run back and forth over `n` frames: 0, 1, …, n − 1,
/// n − 2, …, 1, 0, 1, … (the tracking workload's order: a motion that reverses, never jumps).
///
/// ```
/// use flexshape_lab::bench::back_and_forth;
/// let shown: Vec<usize> = (0..8).map(|s| back_and_forth(s, 4)).collect();
/// assert_eq!(shown, [0, 1, 2, 3, 2, 1, 0, 1]);
/// assert_eq!(back_and_forth(5, 1), 0);
/// ```
pub fn back_and_forth(step: usize, n: usize) -> usize {
    if n < 2 {
        return 0;
    }
    let period = 2 * (n - 1);
    let k = step % period;
    if k < n { k } else { period - k }
}

/// Frames in memory: every camera's image of one pose, and the truth.
type Frames = Vec<(Vec<RgbImage>, Truth)>;

/// Every camera's image of each pose, rendered, with the pose's truth.
fn render(
    sim: &Simulator,
    poses: &[flexshape_sim::CatheterPose],
) -> Result<Frames, flexshape_sim::SimError> {
    poses
        .iter()
        .enumerate()
        .map(|(i, pose)| {
            sim.render(i as u64, pose)
                .map(|f| (f.views.into_iter().map(|v| v.image).collect(), f.truth))
        })
        .collect()
}

/// Median time to decode one frame stored as PNG, ms.
fn png_decode_ms(frame: &RgbImage) -> Result<f64, image::ImageError> {
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

impl BenchReport {
    /// The report as `flexshape bench` prints it: per stage median and 95th percentile at 1
    /// and 2 threads, whole frame and throughput, for both workloads.
    pub fn table(&self) -> String {
        let mut out = String::new();
        let r = self;
        _ = writeln!(
            out,
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
        figures_table(&mut out, "every frame from its hull", &r.results);
        if r.tracking.len() == 2 {
            figures_table(
                &mut out,
                &format!(
                    "tracking (`track --follow`): {} frames of smooth motion at {} Hz, {} passes back and forth in one run",
                    r.track_frames, r.rate_hz, r.rounds
                ),
                &r.tracking,
            );
            _ = writeln!(
                out,
                "frames that started from an earlier one: {:.1} % (1 thread), {:.1} % (2 threads; the rest were carved again)",
                100.0 * r.tracking[0].followed.unwrap_or(0.0),
                100.0 * r.tracking[1].followed.unwrap_or(0.0)
            );
        } else {
            _ = writeln!(
                out,
                "\ntracking: off (the rig needs two cameras or more, and the fit's `track` on)"
            );
        }
        _ = writeln!(
            out,
            "\nPNG decoding, not included above: {:.2} ms per camera frame",
            r.png_decode_ms
        );
        out
    }
}

fn figures_table(out: &mut String, title: &str, results: &[Figures]) {
    _ = writeln!(
        out,
        "\n{title}\n{:<22} {:>18} {:>18}",
        "stage (ms)", "1 thread med/p95", "2 threads med/p95"
    );
    let n = results[0].stages.len();
    for i in 0..n {
        let cell =
            |f: &Figures| format!("{:.2} / {:.2}", f.stages[i].median_ms, f.stages[i].p95_ms);
        _ = writeln!(
            out,
            "{:<22} {:>18} {:>18}",
            results[0].stages[i].stage,
            cell(&results[0]),
            cell(&results[1])
        );
    }
    _ = writeln!(
        out,
        "{:<22} {:>18.2} {:>18.2}",
        "whole frame (median)", results[0].frame_median_ms, results[1].frame_median_ms
    );
    _ = writeln!(
        out,
        "{:<22} {:>18.0} {:>18.0}",
        "throughput (frames/s)", results[0].throughput_fps, results[1].throughput_fps
    );
    _ = writeln!(
        out,
        "against truth (1 thread): {}",
        accuracy_line(&results[0].accuracy)
    );
    for f in results {
        _ = writeln!(
            out,
            "against truth, throughput run ({} thread{}, every frame): {}",
            f.threads,
            if f.threads == 1 { "" } else { "s" },
            accuracy_line(&f.throughput_accuracy)
        );
    }
}

/// Frames right and their errors from the truth, as the table prints them.
fn accuracy_line(a: &Accuracy) -> String {
    format!(
        "{} of {} frames right; {} said right but off the truth, {} right but refused; centerline rms median {:.3} mm, worst {:.3}; tip median {:.3} mm, worst {:.3}; band worst {:.3} mm",
        a.right,
        a.frames,
        a.right_said_wrong,
        a.right_refused,
        a.centerline_rms_mm[0],
        a.centerline_rms_mm[1],
        a.tip_mm[0],
        a.tip_mm[1],
        a.band_mm
    )
}
