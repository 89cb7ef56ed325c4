//! `flexshape track`: every frame of a recording through the sensing chain, as JSON Lines.
//!
//! Each record is written whole and flushed before the next frame is read. A frame that cannot
//! be read or processed gets a record with status `error` and the run goes on; Ctrl-C stops
//! after the current frame. The last line is always the summary.

use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::Path;
use std::time::Instant;

use anyhow::{Context, bail};
use flexshape_recording::RecordingReader;
use flexshape_rig::Volume;
use flexshape_silhouette::BackgroundModel;
use flexshape_track::{Pipeline, SummaryLine, TrackRecord, TrackSummary};
use indicatif::{ProgressBar, ProgressStyle};
use serde::Serialize;

use crate::cli::TrackArgs;
use crate::interrupt::Interrupt;

pub fn run(args: &TrackArgs) -> anyhow::Result<()> {
    let stop = Interrupt::install();
    let rec = RecordingReader::open(&args.recording)
        .with_context(|| format!("cannot open the recording {}", args.recording.display()))?;
    let rig = rec.rig();
    let volume = volume(&rig.volume, args)?;
    let backgrounds = rig
        .cameras
        .iter()
        .map(|cam| {
            let path = rec.layout().background(&cam.name);
            BackgroundModel::load(&path).with_context(|| {
                format!(
                    "camera {}: tracking needs its background image {} (make one with `flexshape background`)",
                    cam.name,
                    path.display()
                )
            })
        })
        .collect::<anyhow::Result<Vec<_>>>()?;
    let pipeline = Pipeline::new(rig, &backgrounds, &volume).with_context(|| {
        format!(
            "cannot set up tracking for {}",
            rec.layout().rig().display()
        )
    })?;
    let mut out = Output::open(&args.out)?;
    let frames = rec.frames().to_vec();
    let bar = ProgressBar::new(frames.len() as u64).with_style(
        ProgressStyle::with_template(
            "tracking [{bar:40}] {pos}/{len} frames, {per_sec}, eta {eta}",
        )
        .unwrap_or_else(|_| ProgressStyle::default_bar())
        .progress_chars("=> "),
    );
    let start = Instant::now();
    let (mut timings, mut ok, mut errors, mut stopped) = (Vec::new(), 0, 0, false);
    for &frame in &frames {
        if stop.requested() {
            stopped = true;
            break;
        }
        let images: Result<Vec<_>, _> = (0..rig.cameras.len())
            .map(|cam| rec.read_frame(cam, frame))
            .collect();
        let record = match images {
            Err(e) => TrackRecord::error(frame, format!("cannot read the frame: {e}")),
            Ok(images) => match pipeline.process(&images.iter().collect::<Vec<_>>()) {
                Ok(t) => {
                    timings.push(t.timings);
                    TrackRecord::from_tracked(frame, &t)
                }
                Err(e) => TrackRecord::error(frame, e.to_string()),
            },
        };
        let record = match rec.read_command(frame) {
            Ok(command) => record.with_command(command),
            Err(e) => {
                bar.suspend(|| eprintln!("frame {frame:06}: {e}; its command is left out"));
                record
            }
        };
        match record.status.as_str() {
            "ok" => ok += 1,
            "error" => {
                errors += 1;
                bar.suspend(|| {
                    eprintln!(
                        "frame {frame:06}: {}",
                        record.reason.as_deref().unwrap_or("")
                    )
                });
            }
            _ => {}
        }
        out.write(&record)?;
        bar.inc(1);
    }
    bar.finish_and_clear();
    let summary = TrackSummary::new(&timings, ok, errors, stopped, start.elapsed().as_secs_f64());
    out.write(&SummaryLine {
        summary: summary.clone(),
    })?;
    eprintln!(
        "{} frames ({} ok, {} errors{}) in {:.2} s, {:.1} frames/s; median ms: {}",
        summary.frames,
        summary.ok,
        summary.errors,
        if stopped { ", stopped early" } else { "" },
        summary.seconds,
        summary.fps,
        summary
            .stages
            .iter()
            .map(|s| format!("{} {:.2}", s.stage, s.median_ms))
            .collect::<Vec<_>>()
            .join(", ")
    );
    Ok(())
}

/// The volume to carve: the rig's, or the one given on the command line.
fn volume(rig: &Volume, args: &TrackArgs) -> anyhow::Result<Volume> {
    let (min, max) = match args.volume {
        Some(b) => ([b[0], b[1], b[2]], [b[3], b[4], b[5]]),
        None if args.voxel.is_none() => return Ok(*rig),
        None => {
            let m = rig.max_corner();
            (rig.origin, [m.x, m.y, m.z])
        }
    };
    let voxel = args.voxel.unwrap_or(rig.voxel_size[0]);
    Volume::from_bounds(min, max, voxel).context("invalid --volume / --voxel")
}

/// The JSON Lines sink: a file or standard output, flushed after every record.
struct Output {
    name: String,
    sink: Box<dyn Write>,
}

impl Output {
    fn open(path: &Path) -> anyhow::Result<Self> {
        if path == Path::new("-") {
            return Ok(Output {
                name: "standard output".into(),
                sink: Box::new(std::io::stdout().lock()),
            });
        }
        if path.is_dir() {
            bail!("--out {} is a folder; give a file name", path.display());
        }
        let file =
            File::create(path).with_context(|| format!("cannot create {}", path.display()))?;
        Ok(Output {
            name: path.display().to_string(),
            sink: Box::new(BufWriter::new(file)),
        })
    }

    fn write(&mut self, record: &impl Serialize) -> anyhow::Result<()> {
        let mut line = serde_json::to_string(record).context("cannot encode a record")?;
        line.push('\n');
        self.sink
            .write_all(line.as_bytes())
            .and_then(|_| self.sink.flush())
            .with_context(|| format!("cannot write to {}", self.name))
    }
}
