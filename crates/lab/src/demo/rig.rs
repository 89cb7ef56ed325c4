//! The simulated rig as a frame source: the model's command at each frame's time, rendered
//! (and written).

use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::{Duration, Instant};

use flexshape_input::{CaptureTime, FrameImage, FrameSet, FrameSource, InputError, NewestSource};
use flexshape_model::{Model, Sweep};
use flexshape_recording::{Command, PoseRole, RecordingWriter};
use flexshape_sim::{CatheterPose, Simulator};

/// The simulated rig filming the model-driven catheter.
pub struct DemoRig {
    pub(super) sim: Simulator,
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

impl DemoRig {
    pub(super) fn new(
        sim: Simulator,
        model: Model,
        sweep: Sweep,
        writer: Option<RecordingWriter>,
        threads: usize,
    ) -> Result<Self, rayon::ThreadPoolBuildError> {
        Ok(DemoRig {
            sim,
            model,
            sweep,
            writer,
            pool: rayon::ThreadPoolBuilder::new()
                .num_threads(threads.max(1))
                .thread_name(|i| format!("render-{i}"))
                .build()?,
            render_us: AtomicU64::new(0),
            rendered: AtomicU64::new(0),
        })
    }

    /// Frame `n` at `fps`: the model's command at that time, rendered (and written).
    pub fn frame(&self, n: u64, fps: f64) -> Result<FrameSet, InputError> {
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

    /// Mean time to render one frame set so far, ms.
    pub fn render_ms(&self) -> f64 {
        self.render_us.load(Ordering::Relaxed) as f64
            / 1e3
            / self.rendered.load(Ordering::Relaxed).max(1) as f64
    }
}

/// Headless input: each frame rendered when tracking asks for it.
pub struct OnDemand {
    rig: Arc<DemoRig>,
    next: u64,
    frames: Option<u64>,
    fps: f64,
}

impl OnDemand {
    pub(super) fn new(rig: Arc<DemoRig>, frames: Option<u64>, fps: f64) -> Self {
        OnDemand {
            rig,
            next: 0,
            frames,
            fps,
        }
    }
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
pub(super) fn live_source(rig: Arc<DemoRig>, frames: Option<u64>, fps: f64) -> NewestSource {
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
