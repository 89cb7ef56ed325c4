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
use flexshape_lab::demo::{Demo, DemoFigures};
use flexshape_mcap::{Compression, ImageFormat, McapOptions, McapSink};
use flexshape_model::{ManipulatorParams, Model};
use flexshape_track::{Processed, Tally};

use super::live::LiveOutputs;
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
    println!("{}", demo.introduction(setup.elapsed()));
    let viewer = viewer(args, &demo)?;
    let live = LiveOutputs::start(&args.live, args.allow_remote, demo.simulator().rig())?;
    let mut source = source(args, &demo);
    let mut frames = Frames {
        demo: &demo,
        mcap: mcap(args, &demo)?,
        live,
        failure: None,
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
    if let Some(e) = frames.failure.take() {
        return Err(e).context("cannot write the MCAP file");
    }
    if let Some(mcap) = frames.mcap.take() {
        mcap.finish()?;
    }
    frames.live.finish();
    if let Some(e) = end.input_error {
        return Err(e).context("the simulated rig stopped");
    }
    if summary.frames == 0 {
        return Ok(());
    }
    let figures = &frames.figures;
    println!("\n{}", figures.truth_line(&summary));
    println!(
        "{}",
        demo.speed_line(&summary, figures, threads, args.no_viewer)
    );
    if let Some(dir) = &args.out {
        println!("wrote {} frames to {}", summary.frames, dir.display());
    }
    Ok(())
}

/// The simulated cameras: rendered as tracking takes them when headless (after the table's
/// header), else live at `--fps`.
fn source(args: &DemoArgs, demo: &Demo) -> Box<dyn FrameSource> {
    if args.no_viewer {
        println!("{}", flexshape_lab::demo::table_header());
        Box::new(demo.on_demand(args.frames, args.fps))
    } else {
        println!(
            "live: simulated cameras at {} frames/s; open the viewer's address above; Ctrl-C stops",
            args.fps
        );
        Box::new(demo.live(args.frames, args.fps))
    }
}

/// The MCAP file `--mcap` asks for, with every camera's images.
fn mcap(args: &DemoArgs, demo: &Demo) -> anyhow::Result<Option<McapSink>> {
    let Some(path) = &args.mcap else {
        return Ok(None);
    };
    let options = McapOptions {
        images: ImageFormat::Raw,
        compression: Compression::Zstd,
        overwrite: true,
    };
    Ok(Some(McapSink::create(
        path,
        demo.simulator().rig(),
        options,
    )?))
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
    /// The MCAP file (`--mcap`), and why writing it failed (which stops the run).
    mcap: Option<McapSink>,
    /// `--foxglove` and `--ros2`.
    live: LiveOutputs,
    failure: Option<flexshape_mcap::McapError>,
    headless: bool,
    viewer: Option<super::viewer::Live>,
    tally: Tally,
    figures: DemoFigures,
    last_status: Instant,
}

impl Frames<'_> {
    fn take(&mut self, p: Processed) -> ControlFlow<()> {
        let record = p.record().with_model_frame(&self.demo.model_frame);
        self.tally.add(&record);
        let errors = self.demo.errors(&p);
        if let Some(e) = &errors {
            self.figures.add(e);
        }
        if let Ok(t) = &p.result {
            self.figures.chain_ms.push(t.timings.total());
        }
        if self.headless {
            println!("{}", self.demo.table_row(&p, &record, errors.as_ref()));
        } else if self.last_status.elapsed() > Duration::from_secs(2) {
            self.last_status = Instant::now();
            let line = self.figures.status_line(&p, &self.tally, errors.as_ref());
            println!("{line}");
        }
        if let Some(Err(e)) = self.mcap.as_mut().map(|m| m.write(&record, &p)) {
            self.failure = Some(e);
            return ControlFlow::Break(());
        }
        self.live.publish(&record, &p);
        if let Some(v) = &mut self.viewer {
            let truth = errors.as_ref().map(|e| (e.centerline_rms, e.tip));
            v.publish(p, record, truth);
        }
        ControlFlow::Continue(())
    }
}
