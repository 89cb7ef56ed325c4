//! Frames in flight: workers take frame sets from a [`FrameSource`], decode them and run the
//! [`Pipeline`]; the caller's sink gets the results in input order. Queues are bounded: no
//! more than `window` frames are taken ahead of the last one handed to the sink, so a slow
//! sink slows the input instead of filling memory. Offline input is processed whole; live
//! input always yields its newest frames (the source drops and counts the rest).
//!
//! Tracking: a frame starts from the newest earlier frame whose shape was right (at most
//! [`MAX_PRIOR_AGE`] frames back), see [`Pipeline::process_after`]. Offline, with `n`
//! workers, frame `k` starts from what frames `0..=k − n` left, in input order (it waits for
//! them if it must): their shapes, and the run's state their changes made in input order
//! (backgrounds that followed the backdrop, the usual silhouette shares, the bootstrap
//! budget). So a recording gives the same records on every run with the same number of
//! workers, tracked or not. Live, frame `k` starts from whichever earlier frame finished
//! last, and its changes are made when it ends: waiting would add latency, and live frames
//! are not repeatable anyway.

use std::collections::{BTreeMap, VecDeque};
use std::ops::ControlFlow;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc;
use std::sync::{Arc, Condvar, Mutex};
use std::time::{Duration, Instant, SystemTime};

use flexshape_input::{CaptureTime, FrameSet, FrameSource, InputError, unix_seconds};
use flexshape_recording::{Command, Truth};
use image::RgbImage;

use crate::instants::CameraTimes;
use crate::state::{RunState, StateChange, Turn};
use crate::{Pipeline, Prior, Tracked};

/// One frame set after the chain, in input order.
#[derive(Debug)]
pub struct Processed {
    /// Frame number (the input's).
    pub frame: u64,
    /// The input's name of the frame, if any.
    pub name: Option<String>,
    /// Commanded tendon displacements, if the input has them.
    pub command: Option<Command>,
    /// Ground truth, if the input has it.
    pub truth: Option<Truth>,
    /// Problems that did not stop the frame.
    pub warnings: Vec<String>,
    /// The decoded images, one per camera (empty when they could not be read).
    pub images: Vec<RgbImage>,
    /// What the chain gave, or why the frame failed.
    pub result: Result<Tracked, String>,
    /// When the frame was captured (live) or read (offline).
    pub captured: Instant,
    /// From capture or reading to the end of the chain, ms.
    pub latency_ms: f64,
    /// Frame sets the (live) source had dropped when this one was taken.
    pub dropped: u64,
    /// When the frame was captured, where the input knows it.
    pub capture_time: Option<CaptureTime>,
    /// Each camera's own capture time, rig order, where the input knows them
    /// ([`FrameSet::camera_times`]).
    pub camera_times: Option<Vec<f64>>,
    /// The wall clock when the chain finished the frame, seconds since the Unix epoch.
    pub processed_s: Option<f64>,
}

impl Processed {
    /// One frame set (e.g. the one a replay seeks to) through `pipeline`, from `prior` when
    /// there is one, as [`run`] processes each.
    pub fn of(pipeline: &Pipeline, set: FrameSet, prior: Option<&Prior>) -> Self {
        process(pipeline, set, 0, prior, None).0
    }

    /// What a later frame may start from ([`Tracked::prior`]), at this frame's capture time.
    pub fn prior(&self) -> Option<Prior> {
        let tracked = self.result.as_ref().ok()?;
        tracked.prior_at(self.capture_time.map(|c| c.seconds))
    }

    /// A frame the source could not read (numbered by its place in the input), and why.
    pub fn unreadable(seq: u64, reason: String, dropped: u64) -> Self {
        Processed {
            frame: seq,
            name: None,
            command: None,
            truth: None,
            warnings: Vec::new(),
            images: Vec::new(),
            result: Err(reason),
            captured: Instant::now(),
            latency_ms: 0.0,
            dropped,
            capture_time: None,
            camera_times: None,
            processed_s: unix_seconds(SystemTime::now()),
        }
    }
}

/// How a run ended.
#[derive(Debug, Default)]
pub struct RunEnd {
    /// Frame sets handed to the sink.
    pub frames: u64,
    /// Frame sets the live source dropped.
    pub dropped: u64,
    /// Frame sets the live source could not pair by capture time.
    pub unpaired: u64,
    /// True when stopped by the flag or the sink before the input ended.
    pub stopped: bool,
    /// The error that ended the input early, if any.
    pub input_error: Option<InputError>,
}

/// Frame-taking state shared by the workers.
struct Window {
    taken: u64,
    handed: u64,
    closed: bool,
    /// Offline: frames whose outcome is in [`Window::after`], in input order.
    ordered: u64,
    /// Offline: what later frames start from once frame `k`'s outcome is in (the frames
    /// before it included), for the frames still to start: the shapes and the run's state.
    after: BTreeMap<u64, (Recent, RunState)>,
}

/// How many frames back a prior may be to start a frame from: beyond, the tube may have moved
/// farther than the fit searches.
pub const MAX_PRIOR_AGE: u64 = 4;

/// The newest frames processed and what later frames may start from when tracking: the
/// newest right shape, carried on as it moved since an earlier right one when both are recent
/// ([`Prior::predicted`]). The earlier one is the newest at least as many frames before it as
/// the frame to start is after it, so a move is never extrapolated past the span it was
/// measured over when a long enough one is at hand (the fits' own scatter would be amplified).
/// Frames are counted in input order (`seq`).
#[derive(Debug, Clone)]
pub struct Recent {
    /// The newest frame whose outcome is in.
    seq: Option<u64>,
    /// The right shapes since the last frame that was not right, oldest first, each with its
    /// frame; none older than [`MAX_PRIOR_AGE`] frames before the newest.
    right: VecDeque<(u64, Arc<Prior>)>,
    /// The largest move a prediction may give a point, mm.
    limit_mm: f64,
}

impl Recent {
    /// Nothing processed yet; predictions move no point more than the pipeline's fit lets a
    /// followed tip move (`track_max_move_mm`).
    pub fn new(pipeline: &Pipeline) -> Self {
        Recent {
            seq: None,
            right: VecDeque::new(),
            limit_mm: pipeline.fit_settings().track_max_move_mm,
        }
    }

    /// What frame `seq` may start from, if a recent enough frame left a right shape.
    pub fn for_frame(&self, seq: u64) -> Option<Arc<Prior>> {
        let (s1, p1) = self.right.back()?;
        if !(*s1 < seq && seq - s1 <= MAX_PRIOR_AGE) {
            return None;
        }
        let ahead = seq - s1;
        let earlier = self.right.iter().rev().skip(1);
        let chosen = earlier
            .clone()
            .find(|(s0, _)| s1 - s0 >= ahead)
            .or_else(|| earlier.last());
        // The limit is a move per frame: a start `ahead` frames on may move a point that many
        // times as far (two workers start each frame from the one two back; at 60 frames/s
        // with the limit unscaled, nearly every prediction was refused and 2 threads ran at
        // 40 % of 1 thread's speed). Slides along the tube are told from motion by the limit
        // of one frame's move (scaled too, they carried slides on as motion: 5 % slower).
        let limit = self.limit_mm * ahead as f64;
        let predicted = chosen.and_then(|(s0, p0)| {
            p1.predicted(p0, ahead as f64 / (s1 - s0) as f64, self.limit_mm, limit)
        });
        // The motion that carries the tube to cameras that captured apart: over the longest
        // time at hand, which the shapes' own errors enter the least.
        let predicted = match (predicted, self.right.front()) {
            (Some(p), Some((s0, oldest))) if *s0 < *s1 => Some(p1.moving_since(oldest, p)),
            (p, _) => p,
        };
        Some(predicted.map_or_else(|| p1.clone(), Arc::new))
    }

    /// Records frame `seq`'s outcome (its right shape, if any), unless a later frame's is
    /// already in.
    pub fn update(&mut self, seq: u64, prior: Option<Prior>) {
        if self.seq.is_some_and(|s| seq <= s) {
            return;
        }
        self.seq = Some(seq);
        match prior {
            Some(p) => {
                self.right.push_back((seq, Arc::new(p)));
                while self
                    .right
                    .front()
                    .is_some_and(|(s0, _)| seq - s0 > MAX_PRIOR_AGE)
                {
                    self.right.pop_front();
                }
            }
            None => self.right.clear(),
        }
    }
}

/// The source and what it said last, behind one lock.
struct Puller<'a, S: ?Sized> {
    source: &'a mut S,
    ended: bool,
    error: Option<InputError>,
}

/// Runs every frame of `source` through `pipeline` on `workers` threads (at least 1), handing
/// each result to `sink` in input order. Stops taking frames when `stop` is set (frames
/// already taken still reach the sink, so nothing processed is lost) or when the sink breaks
/// (it is handed nothing more).
pub fn run<S: FrameSource + ?Sized>(
    source: &mut S,
    pipeline: &Pipeline,
    workers: usize,
    stop: &AtomicBool,
    mut sink: impl FnMut(Processed) -> ControlFlow<()>,
) -> RunEnd {
    let workers = workers.max(1);
    let window_len = (2 * workers) as u64;
    // Offline, frames start from earlier ones in a fixed order (see the module's comment).
    let ordered = !source.is_live();
    let initial = pipeline.run_state();
    let window = Mutex::new(Window {
        taken: 0,
        handed: 0,
        closed: false,
        ordered: 0,
        after: BTreeMap::new(),
    });
    let moved = Condvar::new();
    let puller = Mutex::new(Puller {
        source,
        ended: false,
        error: None,
    });
    let (tx, rx) = mpsc::channel::<(u64, Processed, Option<StateChange>)>();
    let latest = Mutex::new(Recent::new(pipeline));
    let mut end = RunEnd::default();
    std::thread::scope(|scope| {
        for _ in 0..workers {
            let tx = tx.clone();
            let (window, moved, puller, latest, initial) =
                (&window, &moved, &puller, &latest, &initial);
            scope.spawn(move || {
                let _closes = ClosesOnPanic { window, moved };
                while let Some((seq, set, dropped)) = take(window, moved, puller, stop, window_len)
                {
                    let (prior, state) = if ordered {
                        let Some(start) =
                            start_in_order(window, moved, seq, workers as u64, initial)
                        else {
                            return;
                        };
                        (start.0, Some(start.1))
                    } else {
                        (latest.lock().ok().and_then(|l| l.for_frame(seq)), None)
                    };
                    let (processed, change) = match set {
                        Ok(set) => process(pipeline, set, dropped, prior.as_deref(), state),
                        Err(reason) => (Processed::unreadable(seq, reason, dropped), None),
                    };
                    if !ordered && let Ok(mut l) = latest.lock() {
                        l.update(seq, processed.prior());
                    }
                    if tx.send((seq, processed, change)).is_err() {
                        return;
                    }
                }
            });
        }
        drop(tx);
        // A sink that panics ends the workers too (they may wait for frames to be handed).
        let _closes = ClosesOnPanic {
            window: &window,
            moved: &moved,
        };
        let mut pending = BTreeMap::new();
        let mut next = 0u64;
        let mut in_order = Recent::new(pipeline);
        let mut state = initial.clone();
        // A sink that said stop sees nothing more: leaving the loop drops the receiver, and
        // the workers' next sends end them.
        'handing: for (seq, processed, change) in rx {
            pending.insert(seq, (processed, change));
            while let Some((p, change)) = pending.remove(&next) {
                if ordered {
                    // Before the sink, so that a frame waiting for this one starts meanwhile.
                    in_order.update(next, p.prior());
                    if let Some(change) = &change {
                        state.apply(change);
                        pipeline.set_run_state(state.clone());
                    }
                    let Ok(mut w) = window.lock() else { return };
                    w.after.insert(next, (in_order.clone(), state.clone()));
                    w.ordered = next + 1;
                    // Frames still to start come after this one and need frame
                    // `their number − workers` at the earliest.
                    let keep = (next + 1).saturating_sub(workers as u64);
                    w.after = w.after.split_off(&keep);
                    drop(w);
                    moved.notify_all();
                }
                next += 1;
                end.frames += 1;
                let flow = sink(p);
                let Ok(mut w) = window.lock() else { return };
                w.handed = next;
                w.closed |= flow.is_break();
                drop(w);
                moved.notify_all();
                if flow.is_break() {
                    end.stopped = true;
                    break 'handing;
                }
            }
        }
    });
    if let Ok(p) = puller.into_inner() {
        end.dropped = p.source.dropped();
        end.unpaired = p.source.unpaired();
        end.input_error = p.error;
        end.stopped |= !p.ended && end.input_error.is_none();
    }
    end
}

/// Closes the window when a worker or the sink panics, so that the workers (which may wait
/// for a frame's outcome or for room in the window) end and the panic reaches the caller
/// instead of a hang.
struct ClosesOnPanic<'a> {
    window: &'a Mutex<Window>,
    moved: &'a Condvar,
}

impl Drop for ClosesOnPanic<'_> {
    fn drop(&mut self) {
        if std::thread::panicking() {
            let mut w = self.window.lock().unwrap_or_else(|e| e.into_inner());
            w.closed = true;
            drop(w);
            self.moved.notify_all();
        }
    }
}

/// Takes the next frame set when the window allows; `None` when the run is over.
fn take<S: FrameSource + ?Sized>(
    window: &Mutex<Window>,
    moved: &Condvar,
    puller: &Mutex<Puller<'_, S>>,
    stop: &AtomicBool,
    window_len: u64,
) -> Option<(u64, Result<FrameSet, String>, u64)> {
    {
        let mut w = window.lock().ok()?;
        while w.taken >= w.handed + window_len && !w.closed && !stop.load(Ordering::SeqCst) {
            // A stop is a flag, not a notification: look again now and then.
            w = moved.wait_timeout(w, Duration::from_millis(50)).ok()?.0;
        }
        if w.closed || stop.load(Ordering::SeqCst) {
            return None;
        }
    }
    let mut p = puller.lock().ok()?;
    if p.ended || p.error.is_some() {
        return None;
    }
    let next = p.source.next_frame();
    let mut w = window.lock().ok()?;
    let seq = w.taken;
    match next {
        None => {
            p.ended = true;
            None
        }
        Some(Err(e)) if e.ends_input() => {
            p.error = Some(e);
            None
        }
        Some(result) => {
            w.taken += 1;
            let set = result.map_err(|e| format!("cannot read the frame: {e}"));
            Some((seq, set, p.source.dropped()))
        }
    }
}

/// What frames start from offline: a prior shape, if any, and the run's state.
type Start = (Option<Arc<Prior>>, RunState);

/// Offline: what frame `seq` starts from, once the outcome of frame `seq − workers` (and of
/// every frame before it) is in (the first frames: the run's `initial` state); `None` when
/// the sink stopped the run first.
fn start_in_order(
    window: &Mutex<Window>,
    moved: &Condvar,
    seq: u64,
    workers: u64,
    initial: &RunState,
) -> Option<Start> {
    let Some(before) = seq.checked_sub(workers) else {
        return Some((None, initial.clone()));
    };
    let mut w = window.lock().ok()?;
    // Frames up to `before` were taken earlier and are being processed, so this ends; a stop
    // flag does not end it (what was taken still reaches the sink).
    while w.ordered <= before && !w.closed {
        w = moved.wait_timeout(w, Duration::from_millis(50)).ok()?.0;
    }
    if w.closed {
        return None;
    }
    // Kept for every frame still to start (see the pruning in `run`).
    Some(w.after.get(&before).map_or_else(
        || (None, initial.clone()),
        |(recent, state)| (recent.for_frame(seq), state.clone()),
    ))
}

/// Decodes one frame set and runs the chain on it, from `prior` if there is one, and its
/// change of the run's state: read from `state` and returned when there is one, else made
/// in the pipeline's own as the frame ends.
fn process(
    pipeline: &Pipeline,
    set: FrameSet,
    dropped: u64,
    prior: Option<&Prior>,
    state: Option<RunState>,
) -> (Processed, Option<StateChange>) {
    let mut change = None;
    // Cameras that captured at different instants are each held to the tube where it was.
    let times = CameraTimes::of(
        set.capture_time.map(|c| c.seconds),
        set.camera_times.as_deref(),
    );
    let mut warnings = set.warnings;
    let images = pipeline.load(set.images);
    let (images, result) = match images {
        Ok((images, notes)) => {
            warnings.extend(notes);
            let refs: Vec<&RgbImage> = images.iter().collect();
            let result = match state {
                Some(state) => {
                    let mut turn = Turn::new(state);
                    let result = pipeline.process_after_in(&refs, prior, times.as_ref(), &mut turn);
                    change = result.is_ok().then_some(turn.change);
                    result
                }
                None => pipeline.process_after_at(&refs, prior, times.as_ref()),
            }
            .map_err(|e| e.to_string());
            (images, result)
        }
        Err(e) => (Vec::new(), Err(e)),
    };
    let processed = Processed {
        frame: set.frame,
        name: set.name,
        command: set.command,
        truth: set.truth,
        warnings,
        images,
        result,
        captured: set.captured,
        latency_ms: set.captured.elapsed().as_secs_f64() * 1e3,
        dropped,
        capture_time: set.capture_time,
        camera_times: set.camera_times,
        processed_s: unix_seconds(SystemTime::now()),
    };
    (processed, change)
}
