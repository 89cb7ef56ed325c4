//! `flexshape bench --soak N`: the demo left running, as a lab leaves its bench instrument
//! running. The model sweeps the simulated catheter for `N` frames, every frame goes through
//! the whole chain as `flexshape demo` runs it, and the run is reported per window of frames:
//! the share of frames `ok`, frames `ok` yet off the simulator's truth, frames right by the
//! truth yet refused, what the run learned of its backdrops (backgrounds that followed the
//! backdrop, and those that took the captured one back), and the process's memory. A run that
//! poisons itself — a state it learned and cannot leave — shows as windows whose `ok` share
//! falls away from the first's.

use std::fmt;
use std::ops::ControlFlow;
use std::sync::atomic::AtomicBool;

use flexshape_model::{ManipulatorParams, Model};
use flexshape_record::TrackRecord;
use flexshape_sim::SimConfig;
use flexshape_track::Processed;
use serde::Serialize;

use crate::LabError;
use crate::demo::{Demo, RightBounds};

/// How long to run and how to report it.
#[derive(Debug, Clone, PartialEq)]
pub struct SoakSettings {
    /// Frames to run.
    pub frames: u64,
    /// Frames per reported window.
    pub window: u64,
    /// The simulated cameras' frame rate, frames per second: the sweep's command of frame `n`
    /// is its command at `n / fps` s (a lower rate plays the sweep faster).
    pub fps: f64,
    /// Frames tracked at once.
    pub threads: usize,
    /// How far from the truth a frame may be and still be right.
    pub right: RightBounds,
}

impl Default for SoakSettings {
    fn default() -> Self {
        SoakSettings {
            frames: 10_000,
            window: 1_000,
            fps: 12.0,
            threads: 1,
            right: RightBounds::default(),
        }
    }
}

/// One window of a soak run.
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct SoakWindow {
    /// The window's first frame.
    pub first_frame: u64,
    /// Frames in it.
    pub frames: u64,
    /// Frames whose status is `ok`.
    pub ok: u64,
    /// `ok` frames off the truth (centerline RMS or tip beyond
    /// [`SoakSettings::right`]), or without a shape to
    /// hold against it.
    pub ok_wrong: u64,
    /// Frames not `ok` whose shape is right by the truth.
    pub right_refused: u64,
    /// Frames not `ok` without a shape (`bad_silhouette`, `no_object`, errors).
    pub no_shape: u64,
    /// Frames whose backgrounds followed the backdrop (`background_updated`).
    pub background_updated: u64,
    /// Frames whose backgrounds took the captured one back (`background_restored`).
    pub background_restored: u64,
    /// The process's resident memory at the window's end, MB (where the system tells it).
    pub rss_mb: Option<f64>,
}

impl SoakWindow {
    /// The share of the window's frames that are `ok`, percent.
    pub fn ok_percent(&self) -> f64 {
        100.0 * self.ok as f64 / self.frames.max(1) as f64
    }

    fn add(&mut self, record: &TrackRecord, right: Option<bool>) {
        self.frames += 1;
        let ok = record.status == "ok";
        self.ok += u64::from(ok);
        self.ok_wrong += u64::from(ok && right != Some(true));
        self.right_refused += u64::from(!ok && right == Some(true));
        self.no_shape += u64::from(!ok && record.centerline.is_empty());
        self.background_updated += u64::from(!record.background_updated.is_empty());
        self.background_restored += u64::from(!record.background_restored.is_empty());
    }
}

/// A soak run, window by window.
#[derive(Debug, Clone, Default, Serialize)]
pub struct SoakReport {
    /// The windows in order (the last may be short).
    pub windows: Vec<SoakWindow>,
    /// Whether the run was stopped before its frames were done.
    pub stopped: bool,
}

impl SoakReport {
    /// Frames run.
    pub fn frames(&self) -> u64 {
        self.windows.iter().map(|w| w.frames).sum()
    }

    /// The largest difference of a whole window's `ok` share from the first window's,
    /// percentage points (0 with fewer than two whole windows).
    pub fn drift_points(&self) -> f64 {
        let Some(first) = self.windows.first() else {
            return 0.0;
        };
        self.windows
            .iter()
            .filter(|w| w.frames == first.frames)
            .map(|w| (w.ok_percent() - first.ok_percent()).abs())
            .fold(0.0, f64::max)
    }

    /// The resident memory's growth from the end of the first window to the end of the last,
    /// relative (where the system tells it).
    pub fn memory_growth(&self) -> Option<f64> {
        let first = self.windows.first()?.rss_mb?;
        let last = self.windows.last()?.rss_mb?;
        Some(last / first - 1.0)
    }

    /// Sum of a figure over every window.
    fn total(&self, f: impl Fn(&SoakWindow) -> u64) -> u64 {
        self.windows.iter().map(f).sum()
    }
}

/// The table's header (see [`SoakWindow`]'s row).
pub fn table_header() -> String {
    format!(
        "{:>8} {:>7} {:>7} {:>9} {:>8} {:>8} {:>8} {:>9} {:>8}",
        "frames", "ok %", "ok", "ok,wrong", "refused", "no shape", "bg upd", "bg restd", "RSS MB"
    )
}

impl fmt::Display for SoakWindow {
    /// One row of the table (see [`table_header`]).
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{:>8} {:>7.1} {:>7} {:>9} {:>8} {:>8} {:>8} {:>9} {:>8}",
            self.first_frame + self.frames,
            self.ok_percent(),
            self.ok,
            self.ok_wrong,
            self.right_refused,
            self.no_shape,
            self.background_updated,
            self.background_restored,
            self.rss_mb.map_or("-".into(), |m| format!("{m:.0}")),
        )
    }
}

impl fmt::Display for SoakReport {
    /// The summary: frames, `ok` share and its drift, the wrong and the refused, learned
    /// state, memory.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let frames = self.frames();
        let ok = self.total(|w| w.ok);
        write!(
            f,
            "{frames} frames{}: {ok} ok ({:.1} %), windows' ok share within {:.1} points of the first's; {} ok but off the truth, {} right but refused; backgrounds followed the backdrop on {} frames and took the captured one back on {}",
            if self.stopped { " (stopped)" } else { "" },
            100.0 * ok as f64 / frames.max(1) as f64,
            self.drift_points(),
            self.total(|w| w.ok_wrong),
            self.total(|w| w.right_refused),
            self.total(|w| w.background_updated),
            self.total(|w| w.background_restored),
        )?;
        match (
            self.windows.first().and_then(|w| w.rss_mb),
            self.windows.last().and_then(|w| w.rss_mb),
        ) {
            (Some(a), Some(b)) => write!(f, "; memory {a:.0} → {b:.0} MB"),
            _ => Ok(()),
        }
    }
}

/// Runs the demo on the rig of `config` for `settings.frames` frames (until `stop` is set),
/// handing each window to `window` as it ends.
pub fn soak(
    config: SimConfig,
    settings: &SoakSettings,
    stop: &AtomicBool,
    mut window: impl FnMut(&SoakWindow),
) -> Result<SoakReport, LabError> {
    if settings.frames == 0
        || settings.window == 0
        || !settings.fps.is_finite()
        || settings.fps <= 0.0
    {
        return Err(LabError::data(
            "soak",
            "needs at least one frame, a window of at least one frame and a positive frame rate",
        ));
    }
    let model = Model::new(ManipulatorParams::paper_like()).map_err(|source| LabError::Model {
        step: "the built-in manipulator model".into(),
        source,
    })?;
    let threads = settings.threads.max(1);
    let demo = Demo::new(config, model, None, threads)?;
    let mut source = demo.on_demand(Some(settings.frames), settings.fps);
    let mut report = SoakReport::default();
    let mut current = SoakWindow::default();
    let end = flexshape_track::run(
        &mut source,
        &demo.pipeline,
        threads,
        stop,
        |p: Processed| {
            let record = p.record();
            let right = demo.errors(&p).map(|e| e.within(settings.right));
            current.add(&record, right);
            if current.frames == settings.window {
                current.rss_mb = resident_mb();
                window(&current);
                let next = current.first_frame + current.frames;
                report.windows.push(std::mem::take(&mut current));
                current.first_frame = next;
            }
            ControlFlow::Continue(())
        },
    );
    if current.frames > 0 {
        current.rss_mb = resident_mb();
        window(&current);
        report.windows.push(current);
    }
    if let Some(e) = end.input_error {
        return Err(LabError::data("the simulated rig", e.to_string()));
    }
    report.stopped = end.stopped;
    Ok(report)
}

/// The process's resident memory, MB (Linux: `/proc/self/statm`, pages of 4 KiB).
fn resident_mb() -> Option<f64> {
    let statm = std::fs::read_to_string("/proc/self/statm").ok()?;
    let pages: f64 = statm.split_whitespace().nth(1)?.parse().ok()?;
    Some(pages * 4096.0 / 1e6)
}
