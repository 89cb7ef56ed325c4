//! `flexshape demo`: the whole system on the built-in simulated rig.
//!
//! The tendon-driven model sweeps the simulated catheter through its workspace (the bending
//! plane turning while the bend swings from straight to the maximum); three simulated cameras
//! film it; every frame goes through the sensing chain — silhouettes → voxel carving → marker
//! bands → shape — exactly as `flexshape track` runs it, and is measured against the
//! simulator's ground truth. By default the cameras run live at `--fps` and the viewer shows
//! it all until Ctrl-C; `--no-viewer` renders frames as fast as tracking takes them and
//! prints one row per frame.

use std::ops::ControlFlow;
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::{Duration, Instant};

use anyhow::Context;
use flexshape_camera::nalgebra::Point3;
use flexshape_curve::Polyline;
use flexshape_input::{CaptureTime, FrameImage, FrameSet, FrameSource, InputError, NewestSource};
use flexshape_model::{ManipulatorParams, Model, Sweep};
use flexshape_recording::{Command, PoseRole, RecordingWriter, Truth};
use flexshape_silhouette::BackgroundModel;
use flexshape_sim::{CatheterPose, Simulator};
use flexshape_track::{ModelFrame, Pipeline, Processed, Tally, TrackRecord, Tracked, quantile};

use crate::cli::DemoArgs;
use crate::interrupt::Interrupt;

/// Where the viewer goes when no address is given.
const DEFAULT_VIEWER: &str = "127.0.0.1:8080";

/// The simulated rig filming the model-driven catheter.
struct Rig {
    sim: Simulator,
    model: Model,
    sweep: Sweep,
    writer: Option<RecordingWriter>,
    /// Rendering runs in its own thread pool so that tracking's parallel work never queues
    /// behind it (the cores are shared fairly instead).
    pool: rayon::ThreadPool,
    /// Total rendering time, µs, and frames rendered.
    render_us: AtomicU64,
    rendered: AtomicU64,
}

impl Rig {
    /// Frame `n` at `fps`: the model's command at that time, rendered (and written).
    fn frame(&self, n: u64, fps: f64) -> Result<FrameSet, InputError> {
        let failed = |message: String| InputError::Producer {
            producer: format!("the simulated rig, frame {n}"),
            message,
        };
        let command = self
            .sweep
            .command(&self.model, n as f64 / fps)
            .map_err(|e| failed(format!("the model has no command: {e}")))?;
        let q = command.q;
        let pose = CatheterPose::arc(&self.sim.config().catheter, [q[0], q[1]], [q[2], q[3]], 0.0);
        let started = Instant::now();
        let rendered = self
            .pool
            .install(|| self.sim.render(n, &pose))
            .map_err(|e| failed(e.to_string()))?;
        self.render_us
            .fetch_add(started.elapsed().as_micros() as u64, Ordering::Relaxed);
        self.rendered.fetch_add(1, Ordering::Relaxed);
        let command = Command {
            frame: n,
            tendon_displacements: command.y.iter().copied().collect(),
            role: PoseRole::Pose,
        };
        if let Some(w) = &self.writer {
            self.sim
                .write_frame(w, &rendered, Some(&command))
                .map_err(|e| failed(format!("cannot write the recording: {e}")))?;
        }
        let images = rendered
            .views
            .into_iter()
            .map(|v| FrameImage::Decoded(v.image))
            .collect();
        let mut set = FrameSet::new(n, images);
        set.capture_time = CaptureTime::of_instant(set.captured);
        set.truth = Some(rendered.truth);
        set.command = Some(command);
        Ok(set)
    }
}

/// Headless input: each frame rendered when tracking asks for it.
struct OnDemand {
    rig: Arc<Rig>,
    next: u64,
    frames: Option<u64>,
    fps: f64,
}

impl FrameSource for OnDemand {
    fn next_frame(&mut self) -> Option<Result<FrameSet, InputError>> {
        if self.frames.is_some_and(|n| self.next >= n) {
            return None;
        }
        self.next += 1;
        Some(self.rig.frame(self.next - 1, self.fps))
    }

    fn len_hint(&self) -> Option<usize> {
        self.frames.map(|n| n as usize)
    }
}

/// Live input: the simulated cameras render on their own clock at `fps`; tracking takes the
/// newest frame (the rest are dropped and counted).
fn live_source(rig: Arc<Rig>, frames: Option<u64>, fps: f64) -> NewestSource {
    let start = Instant::now();
    let mut n = 0u64;
    NewestSource::spawn(move || {
        if frames.is_some_and(|f| n >= f) {
            return None;
        }
        let due = start + Duration::from_secs_f64(n as f64 / fps);
        if let Some(wait) = due.checked_duration_since(Instant::now()) {
            std::thread::sleep(wait);
        }
        n += 1;
        Some(rig.frame(n - 1, fps))
    })
}

/// A shape against the simulator's truth, mm (curvature relative).
struct ShapeErrors {
    /// RMS distance from the true centerline samples in the volume to the estimated curve.
    centerline_rms: f64,
    tip: f64,
    /// Worst distance from a true band centre to the nearest estimated one.
    band: f64,
    /// Estimated and true curvature of the bending section, 1/mm.
    curvature: Option<(f64, f64)>,
    /// Share of the true centerline samples in the volume that lie in occupied voxels.
    hull_covers: f64,
}

/// The tracked shape's errors against truth (`None` without a shape).
fn shape_errors(pipeline: &Pipeline, truth: &Truth, t: &Tracked) -> Option<ShapeErrors> {
    let shape = &t.shape;
    let volume = pipeline.volume();
    let inside: Vec<Point3<f64>> = truth
        .centerline
        .iter()
        .map(|p| Point3::from(*p))
        .filter(|p| volume.contains(p))
        .collect();
    if shape.points.len() < 2 || inside.is_empty() {
        return None;
    }
    let curve = Polyline::new(shape.points.iter().map(|&p| Point3::from(p)).collect()).ok()?;
    let sum2: f64 = inside.iter().map(|p| curve.closest(p).1.powi(2)).sum();
    let band = truth
        .bands
        .iter()
        .map(|b| Point3::from(b.position))
        .filter(|p| inside.iter().any(|q| (q - p).norm() < 1.0))
        .map(|p| {
            shape
                .bands
                .iter()
                .map(|b| (Point3::from(b.position) - p).norm())
                .fold(f64::INFINITY, f64::min)
        })
        .fold(0.0, f64::max);
    let curvature = match (truth.kappa, &shape.arc_fit) {
        (Some([kx, kz]), Some(fit)) => Some((fit.curvature, kx.hypot(kz))),
        _ => None,
    };
    let covered = inside
        .iter()
        .filter(|p| t.occupancy.contains_point(p))
        .count();
    Some(ShapeErrors {
        centerline_rms: (sum2 / inside.len() as f64).sqrt(),
        tip: (Point3::from(shape.tip) - Point3::from(truth.tip)).norm(),
        band,
        curvature,
        hull_covers: covered as f64 / inside.len() as f64,
    })
}

/// Figures over the frames so far.
#[derive(Default)]
struct Figures {
    rms: Vec<f64>,
    tip: Vec<f64>,
    band: f64,
    curvature: f64,
    cover: Option<f64>,
    chain_ms: Vec<f64>,
}

impl Figures {
    fn add(&mut self, e: &ShapeErrors) {
        self.rms.push(e.centerline_rms);
        self.tip.push(e.tip);
        self.band = self.band.max(e.band);
        self.cover = Some(self.cover.map_or(e.hull_covers, |c| c.min(e.hull_covers)));
        if let Some((fit, truth)) = e.curvature
            && truth >= 1.0 / 200.0
        {
            self.curvature = self.curvature.max((fit / truth - 1.0).abs());
        }
    }

    fn worst(v: &[f64]) -> f64 {
        v.iter().copied().fold(0.0, f64::max)
    }

    fn median(v: &[f64]) -> f64 {
        quantile(&mut v.to_vec(), 0.5)
    }
}

pub fn run(args: &DemoArgs) -> anyhow::Result<()> {
    let stop = Interrupt::install();
    let setup = Instant::now();
    let model = match &args.model {
        Some(path) => super::model::load(path)?,
        None => Model::new(ManipulatorParams::paper_like())
            .context("the built-in manipulator model is invalid")?,
    };
    anyhow::ensure!(
        args.fps.is_finite() && args.fps > 0.0,
        "--fps must be a positive number of frames per second"
    );
    let mut config = super::sim_config(&args.sim);
    config.catheter = flexshape_steer::catheter_for(&config.catheter, model.params());
    let sim = Simulator::new(config).context("cannot set up the simulated rig")?;
    let backgrounds = sim
        .backgrounds()
        .iter()
        .map(|bg| BackgroundModel::from_frames(std::slice::from_ref(bg)))
        .collect::<Result<Vec<_>, _>>()
        .context("cannot model the simulated backgrounds")?;
    // The simulated rig's `[processing.shape]` describes its catheter (bands, sections).
    let pipeline = Pipeline::new(sim.rig(), &backgrounds, &sim.rig().volume)
        .context("cannot set up the sensing chain")?;
    let writer = match &args.out {
        Some(dir) => Some(
            sim.create_recording(dir, false)
                .with_context(|| format!("cannot write the recording to {}", dir.display()))?,
        ),
        None => None,
    };
    introduce(&sim, setup);
    let mut viewer = if args.no_viewer {
        None
    } else {
        let addr = args.viewer.as_deref().unwrap_or(DEFAULT_VIEWER);
        let started = super::viewer::start_at(addr, args.allow_remote, &pipeline);
        Some(match started {
            // The default port may be taken: any free one will do.
            Err(e) if args.viewer.is_none() => {
                eprintln!("{e:#}; using a free port instead");
                super::viewer::start_at("127.0.0.1:0", false, &pipeline)?
            }
            other => other?,
        })
    };
    let rig = Arc::new(Rig {
        sim,
        model,
        sweep: Sweep::default(),
        writer,
        pool: rayon::ThreadPoolBuilder::new()
            .num_threads(super::cores())
            .thread_name(|i| format!("render-{i}"))
            .build()
            .context("cannot start the simulator's threads")?,
        render_us: AtomicU64::new(0),
        rendered: AtomicU64::new(0),
    });
    let mut source: Box<dyn FrameSource> = if args.no_viewer {
        println!("{}", table_header());
        Box::new(OnDemand {
            rig: rig.clone(),
            next: 0,
            frames: args.frames,
            fps: args.fps,
        })
    } else {
        println!(
            "live: simulated cameras at {} frames/s; open the viewer's address above; Ctrl-C stops",
            args.fps
        );
        Box::new(live_source(rig.clone(), args.frames, args.fps))
    };
    // The simulator built the catheter in the model's frame: its κx, κz are known exactly, so
    // the records (and the viewer) carry them as a registered rig would.
    let m = rig.sim.config().catheter.base.rotation.into_inner();
    let model_frame = ModelFrame {
        rotation: std::array::from_fn(|r| std::array::from_fn(|c| m[(r, c)])),
        reference_base: None,
        residual_deg: [0.0, 0.0],
    };
    let mut tally = Tally::new();
    let mut figures = Figures::default();
    let mut last_status = Instant::now();
    // Headless, frames are rendered on demand: one worker keeps rendering and tracking apart,
    // so the chain's figures are its own.
    let threads = args
        .threads
        .unwrap_or(if args.no_viewer { 1 } else { super::cores() });
    let end = flexshape_track::run(
        source.as_mut(),
        &pipeline,
        threads,
        stop.flag(),
        |p: Processed| {
            let record = TrackRecord::from_processed(&p).with_model_frame(&model_frame);
            tally.add(&record);
            let errors = match (&p.truth, &p.result) {
                (Some(truth), Ok(t)) => shape_errors(&pipeline, truth, t),
                _ => None,
            };
            if let Some(e) = &errors {
                figures.add(e);
            }
            if let Ok(t) = &p.result {
                figures.chain_ms.push(t.timings.total());
            }
            if args.no_viewer {
                let bend_length = rig.sim.config().catheter.bend_length;
                println!("{}", table_row(&p, &record, errors.as_ref(), bend_length));
            } else if last_status.elapsed() > Duration::from_secs(2) {
                last_status = Instant::now();
                println!(
                    "frame {:>6}: {:.1} frames/s tracked, {} dropped, latency {:.1} ms; centerline rms {:.3} mm (worst so far {:.3}), tip {:.2} mm",
                    p.frame,
                    tally.frames() as f64 / tally.seconds(),
                    p.dropped,
                    p.latency_ms,
                    errors.as_ref().map_or(f64::NAN, |e| e.centerline_rms),
                    Figures::worst(&figures.rms),
                    errors.as_ref().map_or(f64::NAN, |e| e.tip),
                );
            }
            if let Some(v) = &mut viewer {
                let truth = errors.as_ref().map(|e| (e.centerline_rms, e.tip));
                v.publish(p, record, truth);
            }
            ControlFlow::Continue(())
        },
    );
    let summary = tally.summary(&end);
    if let Some(e) = end.input_error {
        return Err(e).context("the simulated rig stopped");
    }
    if summary.frames == 0 {
        return Ok(());
    }
    let n = figures.rms.len();
    println!(
        "\n{} frames, {} ok; against truth over {n} frames: centerline rms median {:.3} mm, worst {:.3} mm; tip median {:.2} mm, worst {:.2} mm; band centre worst {:.2} mm; arc-fit curvature worst {:.2} %; the carved hull holds ≥ {:.1} % of the true centerline",
        summary.frames,
        summary.ok,
        Figures::median(&figures.rms),
        Figures::worst(&figures.rms),
        Figures::median(&figures.tip),
        Figures::worst(&figures.tip),
        figures.band,
        figures.curvature * 100.0,
        figures.cover.unwrap_or(0.0) * 100.0,
    );
    let chain = Figures::median(&figures.chain_ms);
    println!(
        "speed: the chain takes {chain:.2} ms per frame (median; {}), {:.0} frames/s per worker; {threads} worker{} tracked {:.1} frames/s{}{}",
        summary
            .stages
            .iter()
            .map(|s| format!("{} {:.2}", s.stage, s.median_ms))
            .collect::<Vec<_>>()
            .join(", "),
        1e3 / chain.max(1e-9),
        if threads == 1 { "" } else { "s" },
        summary.fps,
        if args.no_viewer {
            format!(
                " while rendering the simulated cameras ({:.1} ms per frame) on the same cores",
                rig.render_us.load(Ordering::Relaxed) as f64
                    / 1e3
                    / rig.rendered.load(Ordering::Relaxed).max(1) as f64
            )
        } else {
            " (sharing the cores with the simulated cameras' rendering)".to_string()
        },
        match (&summary.latency_ms, args.no_viewer) {
            (Some(l), false) => format!(
                "; latency {:.1} ms median, {:.1} ms p95; {} frames dropped",
                l.median_ms, l.p95_ms, summary.dropped
            ),
            _ => String::new(),
        }
    );
    if let Some(dir) = &args.out {
        println!("wrote {} frames to {}", summary.frames, dir.display());
    }
    Ok(())
}

fn introduce(sim: &Simulator, setup: Instant) {
    let c = sim.config();
    let v = &sim.rig().volume;
    println!(
        "flexshape demo: simulated rig of {} cameras at {}×{}, volume {}×{}×{} voxels of {} mm; catheter r = {} mm with a {} mm bending section, driven by the tendon model",
        c.rig.cameras,
        c.rig.width,
        c.rig.height,
        v.dims[0],
        v.dims[1],
        v.dims[2],
        v.voxel_size[0],
        c.catheter.radius,
        c.catheter.bend_length
    );
    println!(
        "stages: model → simulator → silhouettes → voxel carving → marker bands → hull shape → tube fitted to every camera's outline and checked against the images (centerline, tip, bands, arc fit); errors against the simulator's truth"
    );
    println!("set up in {:.0} ms\n", setup.elapsed().as_secs_f64() * 1e3);
}

fn table_header() -> String {
    format!(
        "{:>5} {:>6} {:>7}  {:>6} {:>6} {:>5}  {:>7} {:>6} {:>7} {:>13}  {:>6} {:>6} {:>6} {:>6} {:>6}",
        "frame",
        "bend°",
        "plane°",
        "voxels",
        "hull⊇",
        "bands",
        "rms mm",
        "tip mm",
        "band mm",
        "κ fit/true 1/m",
        "sil ms",
        "carve",
        "bands",
        "shape",
        "fit",
    )
}

fn table_row(
    p: &Processed,
    record: &TrackRecord,
    errors: Option<&ShapeErrors>,
    bend_length: f64,
) -> String {
    let (bend, plane) = match &p.truth {
        Some(t) => {
            let [kx, kz] = t.kappa.unwrap_or([0.0, 0.0]);
            let [_, e1] = t.eps.unwrap_or([0.0, 0.0]);
            (
                (kx.hypot(kz) * bend_length * (1.0 - e1)).to_degrees(),
                kz.atan2(kx).to_degrees(),
            )
        }
        None => (f64::NAN, f64::NAN),
    };
    let measured = match errors {
        Some(e) => format!(
            "{:>5.1}% {:>5}  {:>7.3} {:>6.2} {:>7.2} {:>13}",
            e.hull_covers * 100.0,
            record.bands.len(),
            e.centerline_rms,
            e.tip,
            e.band,
            e.curvature
                .map(|(fit, t)| format!("{:.2}/{:.2}", fit * 1e3, t * 1e3))
                .unwrap_or_else(|| "-".into())
        ),
        None => format!(
            "{:>44}",
            format!(
                "{}{}",
                record.status,
                record
                    .reason
                    .as_deref()
                    .map(|r| format!(": {r}"))
                    .unwrap_or_default()
            )
        ),
    };
    let t = record.timings_ms;
    format!(
        "{:>5} {bend:>6.1} {plane:>7.1}  {:>6} {measured}  {:>6.2} {:>6.2} {:>6.2} {:>6.2} {:>6.2}{}",
        record.frame,
        record.voxels,
        t.silhouettes,
        t.carve,
        t.bands,
        t.shape,
        t.fit,
        match (errors, record.status.as_str()) {
            (Some(_), "ok") | (None, _) => String::new(),
            (Some(_), status) => format!("  {status}: {}", record.reason.as_deref().unwrap_or("")),
        }
    )
}
