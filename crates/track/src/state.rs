//! What a run learns as it goes and later frames read: each camera's backdrop (its background,
//! which follows a backdrop that changed since its capture), each camera's usual silhouette
//! share, and how many attempts of the bootstrap silhouettes failed in a row. A frame reads
//! one [`RunState`] and leaves a [`StateChange`]. Applied as frames end, the changes reach
//! whichever frames start next (live input); applied in input order and read as frame
//! `k − workers` left them, they give every frame of a recording the same state on every run
//! (see `runner`).

use std::sync::{Arc, Mutex, MutexGuard};

use flexshape_silhouette::Silhouette;

use crate::backdrop::{BOOTSTRAP_ATTEMPTS, Backdrop};
use crate::usual::{LEARN_FRAMES, MIN_FRAMES, share};

/// The run's state as a frame reads it. Cheap to clone: the backdrops are shared.
#[derive(Debug, Clone)]
pub(crate) struct RunState {
    /// Each camera's backdrop, in the rig's order.
    pub backdrops: Vec<Arc<Backdrop>>,
    /// Each camera's silhouette shares of the run's first right frames (at most
    /// [`LEARN_FRAMES`]).
    learned: Vec<Vec<f64>>,
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
        RunState {
            learned: vec![Vec::new(); backdrops.len()],
            backdrops: backdrops.into_iter().map(Arc::new).collect(),
            bootstrap_failed: 0,
        }
    }

    /// Camera `camera`'s usual share (the median of its learned ones), once [`MIN_FRAMES`]
    /// are known.
    pub fn usual_share(&self, camera: usize) -> Option<f64> {
        let mut shares = self.learned.get(camera)?.clone();
        if shares.len() < MIN_FRAMES {
            return None;
        }
        shares.sort_by(f64::total_cmp);
        Some(shares[shares.len() / 2])
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
            for (learned, &s) in self.learned.iter_mut().zip(shares) {
                if learned.len() < LEARN_FRAMES {
                    learned.push(s);
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
