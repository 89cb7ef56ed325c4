//! `flexshape track`: every frame of a recording, image folders, videos or live cameras through
//! the sensing chain, as JSON Lines (plus optional CSV rows, PLY clouds, MCAP, the live viewer,
//! a live Foxglove connection and live ROS 2 topics).
//!
//! Each record is written whole and flushed as soon as its frame is done; frames are processed
//! several at a time but written in input order. A frame that cannot be read or processed gets
//! a record with status `error` and the run goes on; Ctrl-C or a broken input stops taking
//! frames, the frames in flight are still written, and the last line is always the summary.

use std::collections::HashSet;
use std::ops::ControlFlow;

use anyhow::{Context, bail};
use flexshape_input::FrameSource;
use flexshape_mcap::{McapOptions, McapSink};
use flexshape_record::{ModelFrame, RecordStatus, SummaryLine, TrackSummary, TruthTally};
use flexshape_track::output::{SinkSpec, Sinks};
use flexshape_track::{Input, Pipeline, Processed, Tally};
use indicatif::{ProgressBar, ProgressStyle};

use super::frames;
use super::live::LiveOutputs;
use crate::cli::TrackArgs;
use crate::interrupt::Interrupt;

pub fn run(args: &TrackArgs) -> anyhow::Result<()> {
    let started = std::time::Instant::now();
    let stop = Interrupt::install();
    let (mut input, pipeline) = open(args)?;
    let spec = SinkSpec {
        out: args.out.clone(),
        csv: args.csv.clone(),
        ply: args.ply.clone(),
        ply_encoding: super::ply_encoding(args.ascii_ply),
        mcap: args.mcap.clone(),
        overwrite: args.overwrite,
    };
    // What can be refused first, the outputs last.
    let model_frame = args
        .model_frame
        .as_deref()
        .map(super::model::load_frame)
        .transpose()?;
    let viewer = super::viewer::start(&args.viewer, &pipeline)?;
    let live = LiveOutputs::start(&args.live, args.viewer.allow_remote, &input.rig)?;
    let sinks = Sinks::open(&spec, &input.files)?;
    let mut frames = Frames {
        model_frame,
        sinks,
        mcap: open_mcap(args, &input)?,
        live,
        viewer,
        bar: progress(input.source.as_ref()),
        tally: Tally::new(),
        truth: args
            .frames
            .recording
            .as_deref()
            .and_then(|dir| TruthTally::open(dir, pipeline.volume())),
        warned: HashSet::new(),
        failure: None,
    };
    let startup_s = started.elapsed().as_secs_f64();
    let threads = args.threads.unwrap_or_else(super::cores);
    let end = flexshape_track::run(
        input.source.as_mut(),
        &pipeline,
        threads,
        stop.flag(),
        |p: Processed| frames.take(p),
    );
    frames.bar.finish_and_clear();
    let summary = TrackSummary {
        startup_s: Some(startup_s),
        refined_rig: input.rig.refined.clone(),
        truth: frames.truth.as_ref().map(TruthTally::check),
        ..frames.tally.summary(&end)
    };
    frames.sinks.finish(&SummaryLine {
        summary: summary.clone(),
    })?;
    if let Some(mcap) = frames.mcap.take() {
        mcap.finish()?;
    }
    frames.live.finish();
    if let Some(e) = frames.failure {
        return Err(e);
    }
    eprintln!("{}", summary.line(input.source.is_live(), end.stopped));
    if let Some(truth) = &summary.truth {
        eprintln!("{}", truth.line());
    }
    let interrupted = stop.requested();
    super::viewer::linger(frames.viewer.as_ref(), &args.viewer, &stop);
    if let Some(e) = end.input_error {
        bail!("the input broke after {} frames: {e}", summary.frames);
    }
    // An interrupted run, or one in which every frame failed, did not do what was asked.
    if interrupted {
        bail!(
            "interrupted after {} frames (every record written is whole, the summary says `stopped`)",
            summary.frames
        );
    }
    if summary.frames > 0 && summary.errors == summary.frames {
        bail!(
            "every one of the {} frames failed (see the records' `reason`)",
            summary.frames
        );
    }
    Ok(())
}

/// The input the arguments name and the chain that tracks it.
fn open(args: &TrackArgs) -> anyhow::Result<(Input, Pipeline)> {
    let mut input = frames::open_input(&args.frames)?;
    let volume = frames::volume(&input.rig.volume, &args.frames)?;
    frames::warn_unseen(&input.rig, &volume);
    input.files.extend(args.model_frame.clone());
    let pipeline = input
        .pipeline(&volume)
        .and_then(|p| super::with_method(p, args.method))
        .and_then(|p| {
            let follow = (args.follow || p.fit_settings().track) && args.ply.is_none();
            p.following(follow)
        })
        .with_context(|| format!("cannot set up tracking for {}", input.rig_name))?;
    Ok((input, pipeline))
}

/// The MCAP file `--mcap` asks for ([`Sinks::open`] refused what it must not replace).
fn open_mcap(args: &TrackArgs, input: &Input) -> anyhow::Result<Option<McapSink>> {
    let Some(path) = &args.mcap else {
        return Ok(None);
    };
    let options = McapOptions {
        images: args.mcap_images.map(Into::into).unwrap_or_default(),
        compression: args.mcap_compression.into(),
        overwrite: args.overwrite,
    };
    Ok(Some(McapSink::create(path, &input.rig, options)?))
}

/// What happens to each tracked frame, in input order.
struct Frames {
    model_frame: Option<ModelFrame>,
    sinks: Sinks,
    mcap: Option<McapSink>,
    /// `--foxglove` and `--ros2`.
    live: LiveOutputs,
    viewer: Option<super::viewer::Live>,
    bar: ProgressBar,
    tally: Tally,
    /// A simulated recording's records against its truth (`None` for any other input, or
    /// once a truth file could not be read, which is said).
    truth: Option<TruthTally>,
    /// Warnings said so far (each is said once).
    warned: HashSet<String>,
    /// Why writing failed, which stops the run.
    failure: Option<anyhow::Error>,
}

impl Frames {
    /// Records the frame: warnings and errors said, the record written, the viewer fed.
    fn take(&mut self, p: Processed) -> ControlFlow<()> {
        let mut record = p.record();
        if let Some(f) = &self.model_frame {
            record = record.with_model_frame(f);
        }
        // Each warning once: one that holds for every frame would bury the rest.
        for w in &p.warnings {
            if self.warned.insert(w.clone()) {
                self.bar.suspend(|| {
                    eprintln!(
                        "frame {:06}: {w} (said once; later frames may have it too)",
                        p.frame
                    )
                });
            }
        }
        if record.status == RecordStatus::Error {
            let reason = record.reason.as_deref().unwrap_or("");
            self.bar
                .suspend(|| eprintln!("frame {:06}: {reason}", p.frame));
        }
        self.tally.add(&record);
        if let Some(Err(e)) = self.truth.as_mut().map(|t| t.add(&record)) {
            self.bar.suspend(|| {
                eprintln!(
                    "frame {:06}: {e}; the records are not held against the truth",
                    p.frame
                )
            });
            self.truth = None;
        }
        self.bar.inc(1);
        if let Err(e) = self.sinks.write(&record, &p) {
            self.failure = Some(anyhow::Error::new(e));
            return ControlFlow::Break(());
        }
        if let Some(Err(e)) = self.mcap.as_mut().map(|m| m.write(&record, &p)) {
            self.failure = Some(anyhow::Error::new(e));
            return ControlFlow::Break(());
        }
        self.live.publish(&record, &p);
        if let Some(v) = &mut self.viewer {
            v.publish(p, record, None);
        }
        ControlFlow::Continue(())
    }
}

fn progress(source: &dyn FrameSource) -> ProgressBar {
    let (bar, template) = match source.len_hint() {
        Some(n) => (
            ProgressBar::new(n as u64),
            "tracking [{bar:40}] {pos}/{len} frames, {per_sec}, eta {eta}",
        ),
        None => (
            ProgressBar::new_spinner(),
            "tracking {spinner} {pos} frames, {per_sec}",
        ),
    };
    bar.with_style(
        ProgressStyle::with_template(template)
            .unwrap_or_else(|_| ProgressStyle::default_bar())
            .progress_chars("=> "),
    )
}
