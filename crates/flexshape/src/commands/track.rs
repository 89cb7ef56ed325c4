//! `flexshape track`: every frame of a recording, image folders, videos or live cameras through
//! the sensing chain, as JSON Lines (plus optional CSV rows, PLY clouds and the live viewer).
//!
//! Each record is written whole and flushed as soon as its frame is done; frames are processed
//! several at a time but written in input order. A frame that cannot be read or processed gets
//! a record with status `error` and the run goes on; Ctrl-C or a broken input stops taking
//! frames, the frames in flight are still written, and the last line is always the summary.

use std::fs::File;
use std::io::{BufWriter, Write};
use std::ops::ControlFlow;
use std::path::{Path, PathBuf};

use anyhow::{Context, bail};
use flexshape_input::FrameSource;
use flexshape_track::{Processed, RecordStatus, SummaryLine, Tally, TrackRecord, TrackSummary};
use indicatif::{ProgressBar, ProgressStyle};
use serde::Serialize;

use super::frames::{self, within};
use crate::cli::TrackArgs;
use crate::interrupt::Interrupt;

pub fn run(args: &TrackArgs) -> anyhow::Result<()> {
    let started = std::time::Instant::now();
    let stop = Interrupt::install();
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
    let model_frame = args
        .model_frame
        .as_deref()
        .map(super::model::load_frame)
        .transpose()?;
    let mut sinks = Sinks::open(args, &input.files)?;
    let mut viewer = super::viewer::start(&args.viewer, &pipeline)?;
    let bar = progress(input.source.as_ref());
    let startup_s = started.elapsed().as_secs_f64();
    let mut tally = Tally::new();
    let mut warned = std::collections::HashSet::new();
    let mut failure = None;
    let threads = args.threads.unwrap_or_else(super::cores);
    let end = flexshape_track::run(
        input.source.as_mut(),
        &pipeline,
        threads,
        stop.flag(),
        |p: Processed| {
            let mut record = TrackRecord::from_processed(&p);
            if let Some(f) = &model_frame {
                record = record.with_model_frame(f);
            }
            // Each warning once: one that holds for every frame would bury the rest.
            for w in &p.warnings {
                if warned.insert(w.clone()) {
                    bar.suspend(|| {
                        eprintln!(
                            "frame {:06}: {w} (said once; later frames may have it too)",
                            p.frame
                        )
                    });
                }
            }
            if record.status == RecordStatus::Error {
                let reason = record.reason.as_deref().unwrap_or("");
                bar.suspend(|| eprintln!("frame {:06}: {reason}", p.frame));
            }
            tally.add(&record);
            bar.inc(1);
            if let Err(e) = sinks.write(&record, &p) {
                failure = Some(e);
                return ControlFlow::Break(());
            }
            if let Some(v) = &mut viewer {
                v.publish(p, record, None);
            }
            ControlFlow::Continue(())
        },
    );
    bar.finish_and_clear();
    let summary = TrackSummary {
        startup_s: Some(startup_s),
        ..tally.summary(&end)
    };
    sinks.out.write(&SummaryLine {
        summary: summary.clone(),
    })?;
    if let Some(e) = failure {
        return Err(e);
    }
    eprintln!(
        "{} frames ({} ok, {} errors{}{}) in {:.2} s (after {:.2} s of start-up), {:.1} frames/s{}; ms per stage, median/p95: {}",
        summary.frames,
        summary.ok,
        summary.errors,
        if input.source.is_live() {
            format!(", {} dropped", summary.dropped)
        } else {
            String::new()
        },
        if end.stopped { ", stopped early" } else { "" },
        summary.seconds,
        startup_s,
        summary.fps,
        summary
            .latency_ms
            .as_ref()
            .map(|l| format!(
                ", latency {:.1} ms median / {:.1} ms p95",
                l.median_ms, l.p95_ms
            ))
            .unwrap_or_default(),
        summary
            .stages
            .iter()
            .map(|s| format!("{} {:.2}/{:.2}", s.stage, s.median_ms, s.p95_ms))
            .collect::<Vec<_>>()
            .join(", ")
    );
    if let Some(e) = end.input_error {
        bail!("the input broke after {} frames: {e}", summary.frames);
    }
    // An interrupted run, or one in which every frame failed, did not do what was asked.
    if stop.requested() {
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

/// Where records go: the JSON Lines stream, and optionally CSV rows and PLY clouds.
struct Sinks {
    out: Output,
    csv: Option<Output>,
    ply: Option<(PathBuf, flexshape_carve::PlyEncoding)>,
}

const CSV_HEADER: &str = "frame,image,status,tip_x,tip_y,tip_z,tip_dx,tip_dy,tip_dz,arc_length_mm,curvature_per_mm,bands,voxels,latency_ms,silhouettes_ms,carve_ms,bands_ms,shape_ms";

impl Sinks {
    /// Opens the outputs, refusing any that is (or lies in) one of `inputs`, and existing ones
    /// without `--overwrite`.
    fn open(args: &TrackArgs, inputs: &[PathBuf]) -> anyhow::Result<Self> {
        let outputs = [Some(&args.out), args.csv.as_ref(), args.ply.as_ref()];
        for path in outputs.into_iter().flatten() {
            if let Some(input) = inputs.iter().find(|i| within(path, i)) {
                bail!(
                    "{} is {} {}: write the output elsewhere",
                    path.display(),
                    if input.is_dir() {
                        "inside the input folder"
                    } else {
                        "the input"
                    },
                    input.display()
                );
            }
        }
        if args.csv.as_ref() == Some(&args.out) {
            if args.out == Path::new("-") {
                bail!(
                    "--csv - and --out - would both write to standard output: give one of them a file"
                );
            }
            bail!("--csv and --out are the same file {}", args.out.display());
        }
        let out = Output::open(&args.out, args.overwrite)?;
        let csv = match &args.csv {
            Some(path) => {
                let mut csv = Output::open(path, args.overwrite)?;
                csv.line(CSV_HEADER)?;
                Some(csv)
            }
            None => None,
        };
        if let Some(dir) = &args.ply {
            let clouds = std::fs::read_dir(dir).map_or(0, |entries| {
                entries
                    .filter_map(Result::ok)
                    .filter(|e| e.path().extension().is_some_and(|x| x == "ply"))
                    .count()
            });
            if clouds > 0 && !args.overwrite {
                bail!(
                    "{} already holds {clouds} PLY clouds: give --overwrite to replace them, or another --ply folder",
                    dir.display()
                );
            }
            std::fs::create_dir_all(dir)
                .with_context(|| format!("cannot create the PLY folder {}", dir.display()))?;
        }
        Ok(Sinks {
            out,
            csv,
            ply: args
                .ply
                .clone()
                .map(|dir| (dir, super::ply_encoding(args.ascii_ply))),
        })
    }

    fn write(&mut self, record: &TrackRecord, p: &Processed) -> anyhow::Result<()> {
        // The cloud first (written whole, then renamed into place), so that a record never
        // names a cloud that is not there.
        if let (Some((dir, encoding)), Ok(t)) = (&self.ply, &p.result) {
            let path = dir.join(format!("{:06}.ply", record.frame));
            t.occupancy
                .to_cloud_with_bands(&t.bands)
                .write_ply(&path, *encoding)
                .with_context(|| format!("cannot write {}", path.display()))?;
        }
        self.out.write(record)?;
        if let Some(csv) = &mut self.csv {
            csv.line(&csv_row(record))?;
        }
        Ok(())
    }
}

fn csv_row(r: &TrackRecord) -> String {
    let opt3 = |v: Option<[f64; 3]>| match v {
        Some([x, y, z]) => format!("{x:.4},{y:.4},{z:.4}"),
        None => ",,".into(),
    };
    let t = r.timings_ms;
    format!(
        "{},{},{},{},{},{:.4},{},{},{},{},{:.3},{:.3},{:.3},{:.3}",
        r.frame,
        r.image.as_deref().unwrap_or("").replace(',', ";"),
        r.status,
        opt3(r.tip),
        opt3(r.tip_direction),
        r.arc_length,
        r.arc_fit
            .as_ref()
            .map(|f| format!("{:.7}", f.curvature))
            .unwrap_or_default(),
        r.bands.len(),
        r.voxels,
        r.latency_ms.map(|l| format!("{l:.3}")).unwrap_or_default(),
        t.silhouettes,
        t.carve,
        t.bands,
        t.shape
    )
}

/// A line sink: a file or standard output, flushed after every line.
struct Output {
    name: String,
    sink: Box<dyn Write>,
}

impl Output {
    fn open(path: &Path, overwrite: bool) -> anyhow::Result<Self> {
        if path == Path::new("-") {
            return Ok(Output {
                name: "standard output".into(),
                sink: Box::new(std::io::stdout().lock()),
            });
        }
        if path.is_dir() {
            bail!("{} is a folder; give a file name", path.display());
        }
        // Without --overwrite the file must be new (created atomically, so two runs cannot both
        // take it); either way it is locked while written, so a second run on it stops.
        let file = if overwrite {
            File::options()
                .write(true)
                .create(true)
                .truncate(false)
                .open(path)
        } else {
            File::options().write(true).create_new(true).open(path)
        }
        .map_err(|e| match e.kind() {
            std::io::ErrorKind::AlreadyExists => anyhow::anyhow!(
                "{} already exists: give --overwrite to replace it, or another file",
                path.display()
            ),
            _ => anyhow::Error::new(e).context(format!("cannot create {}", path.display())),
        })?;
        if file.try_lock().is_err() {
            bail!(
                "{} is being written by another process (another `flexshape track`?): give another file",
                path.display()
            );
        }
        file.set_len(0)
            .with_context(|| format!("cannot empty {}", path.display()))?;
        Ok(Output {
            name: path.display().to_string(),
            sink: Box::new(BufWriter::new(file)),
        })
    }

    fn write(&mut self, record: &impl Serialize) -> anyhow::Result<()> {
        let line = serde_json::to_string(record).context("cannot encode a record")?;
        self.line(&line)
    }

    fn line(&mut self, line: &str) -> anyhow::Result<()> {
        self.sink
            .write_all(line.as_bytes())
            .and_then(|_| self.sink.write_all(b"\n"))
            .and_then(|_| self.sink.flush())
            .with_context(|| format!("cannot write to {}", self.name))
    }
}
