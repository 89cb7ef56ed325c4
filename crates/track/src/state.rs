//! What a run learns as it goes and later frames read: each camera's backdrop (its background,
//! which follows a backdrop that changed since its capture, beside the captured one it is
//! taken back to where the frames show that again), each camera's usual silhouette share
//! (recent right frames'), and how many attempts of the bootstrap silhouettes failed in a row.
//! A frame reads one [`RunState`] and leaves a [`StateChange`]. Applied as frames end, the changes reach
//! whichever frames start next (live input); applied in input order and read as frame
//! `k − workers` left them, they give every frame of a recording the same state on every run
//! (see `runner`).

use std::collections::VecDeque;
use std::sync::{Arc, Mutex, MutexGuard};

use flexshape_silhouette::Silhouette;

use crate::backdrop::{BOOTSTRAP_ATTEMPTS, Backdrop};
use crate::usual::{LEARN_EVERY, LEARN_FRAMES, MIN_FRAMES, share};

/// The run's state as a frame reads it. Cheap to clone: the backdrops are shared.
#[derive(Debug, Clone)]
pub(crate) struct RunState {
    /// Each camera's backdrop, in the rig's order.
    pub backdrops: Vec<Arc<Backdrop>>,
    /// Each camera's backdrop as the run began (the captured background).
    pub captured: Vec<Arc<Backdrop>>,
    /// Each camera's silhouette shares of recent right frames, oldest first (at most
    /// [`LEARN_FRAMES`]; see [`crate::usual`]).
    learned: Vec<VecDeque<f64>>,
    /// Right frames whose shares were offered to `learned`.
    right_frames: u64,
    /// Attempts of the bootstrap silhouettes that located nothing, in a row.
    bootstrap_failed: usize,
}

/// What one frame changed of the run's state.
#[derive(Debug, Default)]
pub(crate) struct StateChange {
    /// Cameras whose backdrop the frame replaced, with the new one.
    backdrops: Vec<(usize, Arc<Backdrop>)>,
    /// The frame's silhouette shares, when it was right and they were to be learned.
    learned: Option<Vec<f64>>,
    /// What became of the bootstrap silhouettes' failures in a row.
    bootstrap: Option<Bootstrap>,
}

#[derive(Debug, Clone, Copy)]
enum Bootstrap {
    /// A right frame or a followed backdrop: attempts may be made again.
    Reset,
    /// An attempt located nothing.
    Failed,
}

impl RunState {
    pub fn new(backdrops: Vec<Backdrop>) -> Self {
        let backdrops: Vec<_> = backdrops.into_iter().map(Arc::new).collect();
        RunState {
            learned: vec![VecDeque::new(); backdrops.len()],
            captured: backdrops.clone(),
            backdrops,
            right_frames: 0,
            bootstrap_failed: 0,
        }
    }

    /// Camera `camera`'s usual share (the largest of its learned ones), once [`MIN_FRAMES`]
    /// are known.
    pub fn usual_share(&self, camera: usize) -> Option<f64> {
        let shares = self.learned.get(camera)?;
        (shares.len() >= MIN_FRAMES).then(|| shares.iter().copied().fold(0.0, f64::max))
    }

    /// Whether the bootstrap silhouettes may be tried.
    pub fn bootstrap_allows(&self) -> bool {
        self.bootstrap_failed < BOOTSTRAP_ATTEMPTS
    }

    /// The state with `change` made.
    pub fn apply(&mut self, change: &StateChange) {
        for (camera, backdrop) in &change.backdrops {
            if let Some(b) = self.backdrops.get_mut(*camera) {
                *b = Arc::clone(backdrop);
            }
        }
        if let Some(shares) = &change.learned {
            self.right_frames += 1;
            let filling = self.learned.iter().any(|l| l.len() < LEARN_FRAMES);
            if filling || self.right_frames.is_multiple_of(LEARN_EVERY) {
                for (learned, &s) in self.learned.iter_mut().zip(shares) {
                    if learned.len() == LEARN_FRAMES {
                        learned.pop_front();
                    }
                    learned.push_back(s);
                }
            }
        }
        match change.bootstrap {
            Some(Bootstrap::Reset) => self.bootstrap_failed = 0,
            Some(Bootstrap::Failed) => self.bootstrap_failed += 1,
            None => {}
        }
    }
}

/// One frame's view of the run's state: what it read, with its own changes made as it goes
/// (a frame that replaced a backdrop goes on with the new one), and those changes.
#[derive(Debug)]
pub(crate) struct Turn {
    pub state: RunState,
    pub change: StateChange,
}

impl Turn {
    pub fn new(state: RunState) -> Self {
        Turn {
            state,
            change: StateChange::default(),
        }
    }

    /// Puts `backdrop` in camera `camera`'s place.
    pub fn replace(&mut self, camera: usize, backdrop: Backdrop) {
        let backdrop = Arc::new(backdrop);
        self.change.backdrops.push((camera, Arc::clone(&backdrop)));
        if let Some(b) = self.state.backdrops.get_mut(camera) {
            *b = backdrop;
        }
    }

    /// Learns a right frame's silhouette shares.
    pub fn learn(&mut self, silhouettes: &[Silhouette]) {
        self.change.learned = Some(silhouettes.iter().map(share).collect());
    }

    /// A right frame or a followed backdrop: bootstrap attempts may be made again.
    pub fn bootstrap_reset(&mut self) {
        self.change.bootstrap = Some(Bootstrap::Reset);
        self.state.bootstrap_failed = 0;
    }

    /// A bootstrap attempt located nothing.
    pub fn bootstrap_failed(&mut self) {
        self.change.bootstrap = Some(Bootstrap::Failed);
        self.state.bootstrap_failed += 1;
    }
}

/// The state a pipeline keeps for callers that process frames one by one or as they come:
/// each frame reads the newest and its changes are made when it ends.
#[derive(Debug)]
pub(crate) struct Shared(Mutex<RunState>);

impl Clone for Shared {
    /// The current state; a later change to either copy leaves the other as it was.
    fn clone(&self) -> Self {
        Shared(Mutex::new(self.get()))
    }
}

impl Shared {
    pub fn new(state: RunState) -> Self {
        Shared(Mutex::new(state))
    }

    fn lock(&self) -> MutexGuard<'_, RunState> {
        // A worker that panicked while changing it left a whole state behind.
        self.0.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// The newest state.
    pub fn get(&self) -> RunState {
        self.lock().clone()
    }

    /// Makes a frame's changes.
    pub fn apply(&self, change: &StateChange) {
        self.lock().apply(change);
    }

    /// Replaces the state (a run that applies changes in input order keeps the newest here).
    pub fn set(&self, state: RunState) {
        *self.lock() = state;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Pipeline;
    use flexshape_silhouette::{BackgroundModel, BitMask, Silhouetter};
    use flexshape_sim::{SimConfig, Simulator};

    /// A run whose learned state was poisoned — one camera's background took in a patch of
    /// the tube's colour where no tube is (a ghost, as a tube taken for backdrop leaves), and
    /// every usual share is a hundredth of the tube's — recovers at once and for good: the
    /// first frame the ghost spoils takes the captured background back there and is `ok`,
    /// frames whose fitted tube explains every camera are `ok` though grown past the poisoned
    /// share, and they teach the usual share again. Before, every later frame was
    /// `bad_silhouette` ("… its usual share …") and nothing was learned again.
    #[test]
    fn a_poisoned_run_recovers() {
        let sim = Simulator::new(SimConfig::default()).unwrap();
        let captured = BackgroundModel::each(&sim.backgrounds()).unwrap();
        let pipeline = Pipeline::new(sim.rig(), &captured, &sim.rig().volume).unwrap();
        let poses = sim.sweep(30);
        let track = |n: usize| {
            let frame = sim.render(n as u64, &poses[n]).unwrap();
            let images: Vec<_> = frame.views.iter().map(|v| &v.image).collect();
            pipeline.process(&images).unwrap().record(n as u64)
        };
        for n in 0..6 {
            assert_eq!(track(n).status, "ok", "frame {n}");
        }
        let mut state = pipeline.run_state();
        let usual = state.usual_share(1).unwrap();
        // A 40 × 40 patch of the tube's dark blue, in a corner no pose reaches.
        let mut ghostly = sim.backgrounds()[1].clone();
        for y in 20..60 {
            for x in 20..60 {
                ghostly.put_pixel(x, y, image::Rgb([30, 40, 120]));
            }
        }
        let mut model = captured[1].clone();
        let (w, h) = ghostly.dimensions();
        assert!(
            model
                .absorb(&ghostly, &BitMask::new(w as usize, h as usize))
                .unwrap()
                >= 1600
        );
        let settings = state.backdrops[1].silhouetter.settings().clone();
        let silhouetter = Silhouetter::new(&model, settings).unwrap();
        state.backdrops[1] = Arc::new(Backdrop::new(model, silhouetter));
        for learned in &mut state.learned {
            *learned = vec![usual / 100.0; LEARN_FRAMES].into();
        }
        pipeline.set_run_state(state);

        let first = track(6);
        assert_eq!(first.status, "ok", "{:?}", first.reason);
        assert_eq!(first.background_restored.len(), 1, "{first:?}");
        assert_eq!(first.background_restored[0].camera, "cam1");
        assert!(first.background_restored[0].changed_px >= 1600);
        for n in 7..poses.len() {
            let r = track(n);
            assert_eq!(r.status, "ok", "frame {n}: {:?}", r.reason);
            assert!(r.background_restored.is_empty() && r.background_updated.is_empty());
        }
        let state = pipeline.run_state();
        assert!(
            Arc::ptr_eq(&state.backdrops[0], &state.captured[0])
                && state.backdrops[1].model.changed_from(&captured[1]).count() == 0
        );
        // Every poisoned share is gone from camera 1's memory of the usual, or soon will be.
        let relearned = state.usual_share(1).unwrap();
        assert!(relearned > usual / 2.0, "{relearned} against {usual}");
    }
}
