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
use std::time::{Duration, Instant};

use anyhow::Context;
use flexshape_input::FrameSource;
use flexshape_lab::demo::{Demo, DemoFigures, ShapeErrors};
use flexshape_model::{ManipulatorParams, Model};
use flexshape_sim::Simulator;
use flexshape_track::{Processed, Tally, TrackRecord};

use crate::cli::DemoArgs;
use crate::interrupt::Interrupt;

/// Where the viewer goes when no address is given.
const DEFAULT_VIEWER: &str = "127.0.0.1:8080";

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
    let demo = Demo::new(
        super::sim_config(&args.sim),
        model,
        args.out.as_deref(),
        super::cores(),
    )
    .context("cannot set up the demo")?;
    introduce(demo.simulator(), setup);
    let viewer = viewer(args, &demo)?;
    let mut source: Box<dyn FrameSource> = if args.no_viewer {
        println!("{}", table_header());
        Box::new(demo.on_demand(args.frames, args.fps))
    } else {
        println!(
            "live: simulated cameras at {} frames/s; open the viewer's address above; Ctrl-C stops",
            args.fps
        );
        Box::new(demo.live(args.frames, args.fps))
    };
    let mut frames = Frames {
        demo: &demo,
        headless: args.no_viewer,
        viewer,
        tally: Tally::new(),
        figures: DemoFigures::default(),
        last_status: Instant::now(),
    };
    // Headless, frames are rendered on demand: one worker keeps rendering and tracking apart,
    // so the chain's figures are its own.
    let threads = args
        .threads
        .unwrap_or(if args.no_viewer { 1 } else { super::cores() });
    let end = flexshape_track::run(
        source.as_mut(),
        &demo.pipeline,
        threads,
        stop.flag(),
        |p: Processed| frames.take(p),
    );
    let summary = frames.tally.summary(&end);
    if let Some(e) = end.input_error {
        return Err(e).context("the simulated rig stopped");
    }
    if summary.frames == 0 {
        return Ok(());
    }
    let figures = &frames.figures;
    println!("\n{}", truth_line(&summary, figures));
    println!(
        "{}",
        speed_line(&summary, figures, threads, args.no_viewer, &demo)
    );
    if let Some(dir) = &args.out {
        println!("wrote {} frames to {}", summary.frames, dir.display());
    }
    Ok(())
}

/// The viewer, unless headless: at the address given, or the default one (any free port
/// when that is taken).
fn viewer(args: &DemoArgs, demo: &Demo) -> anyhow::Result<Option<super::viewer::Live>> {
    if args.no_viewer {
        return Ok(None);
    }
    let addr = args.viewer.as_deref().unwrap_or(DEFAULT_VIEWER);
    let started = super::viewer::start_at(addr, args.allow_remote, &demo.pipeline);
    Ok(Some(match started {
        Err(e) if args.viewer.is_none() => {
            eprintln!("{e:#}; using a free port instead");
            super::viewer::start_at("127.0.0.1:0", false, &demo.pipeline)?
        }
        other => other?,
    }))
}

/// What happens to each tracked frame: measured against truth, printed (a table row
/// headless, a status line every 2 s live) and shown.
struct Frames<'a> {
    demo: &'a Demo,
    headless: bool,
    viewer: Option<super::viewer::Live>,
    tally: Tally,
    figures: DemoFigures,
    last_status: Instant,
}

impl Frames<'_> {
    fn take(&mut self, p: Processed) -> ControlFlow<()> {
        let record = TrackRecord::from_processed(&p).with_model_frame(&self.demo.model_frame);
        self.tally.add(&record);
        let errors = self.demo.errors(&p);
        if let Some(e) = &errors {
            self.figures.add(e);
        }
        if let Ok(t) = &p.result {
            self.figures.chain_ms.push(t.timings.total());
        }
        if self.headless {
            let bend_length = self.demo.simulator().config().catheter.bend_length;
            println!("{}", table_row(&p, &record, errors.as_ref(), bend_length));
        } else if self.last_status.elapsed() > Duration::from_secs(2) {
            self.last_status = Instant::now();
            println!(
                "frame {:>6}: {:.1} frames/s tracked, {} dropped, latency {:.1} ms; centerline rms {:.3} mm (worst so far {:.3}), tip {:.2} mm",
                p.frame,
                self.tally.frames() as f64 / self.tally.seconds(),
                p.dropped,
                p.latency_ms,
                errors.as_ref().map_or(f64::NAN, |e| e.centerline_rms),
                DemoFigures::worst(&self.figures.rms),
                errors.as_ref().map_or(f64::NAN, |e| e.tip),
            );
        }
        if let Some(v) = &mut self.viewer {
            let truth = errors.as_ref().map(|e| (e.centerline_rms, e.tip));
            v.publish(p, record, truth);
        }
        ControlFlow::Continue(())
    }
}

/// The run against truth: centerline, tip, bands, curvature, hull coverage.
fn truth_line(summary: &flexshape_track::TrackSummary, figures: &DemoFigures) -> String {
    format!(
        "{} frames, {} ok; against truth over {} frames: centerline rms median {:.3} mm, worst {:.3} mm; tip median {:.2} mm, worst {:.2} mm; band centre worst {:.2} mm; arc-fit curvature worst {:.2} %; the carved hull holds ≥ {:.1} % of the true centerline",
        summary.frames,
        summary.ok,
        figures.rms.len(),
        DemoFigures::median(&figures.rms),
        DemoFigures::worst(&figures.rms),
        DemoFigures::median(&figures.tip),
        DemoFigures::worst(&figures.tip),
        figures.band,
        figures.curvature * 100.0,
        figures.cover.unwrap_or(0.0) * 100.0,
    )
}

/// The run's speed: the chain per frame and per stage, and what the workers kept up with.
fn speed_line(
    summary: &flexshape_track::TrackSummary,
    figures: &DemoFigures,
    threads: usize,
    headless: bool,
    demo: &Demo,
) -> String {
    let chain = DemoFigures::median(&figures.chain_ms);
    format!(
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
        if headless {
            format!(
                " while rendering the simulated cameras ({:.1} ms per frame) on the same cores",
                demo.rig.render_ms()
            )
        } else {
            " (sharing the cores with the simulated cameras' rendering)".to_string()
        },
        match (&summary.latency_ms, headless) {
            (Some(l), false) => format!(
                "; latency {:.1} ms median, {:.1} ms p95; {} frames dropped",
                l.median_ms, l.p95_ms, summary.dropped
            ),
            _ => String::new(),
        }
    )
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
