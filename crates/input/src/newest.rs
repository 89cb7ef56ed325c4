//! A source fed by its own thread — a rig that delivers whole frame sets on its own clock
//! (hardware-synchronised cameras, or the simulator in the live demo). Only the newest set is
//! kept; sets overwritten before tracking took them are counted as dropped.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Condvar, Mutex};

use crate::{FrameSet, FrameSource, InputError};

#[derive(Default)]
struct State {
    newest: Option<Result<FrameSet, InputError>>,
    /// Items produced so far.
    produced: u64,
    /// Set when the producer is done.
    ended: bool,
}

struct Shared {
    state: Mutex<State>,
    arrived: Condvar,
    stop: AtomicBool,
}

/// Newest-wins frames from a producer thread.
pub struct NewestSource {
    shared: Arc<Shared>,
    taken: u64,
    dropped: u64,
}

impl NewestSource {
    /// Runs `produce` on its own thread until it returns `None`, a frame ends the input, or
    /// the source is dropped.
    pub fn spawn(
        mut produce: impl FnMut() -> Option<Result<FrameSet, InputError>> + Send + 'static,
    ) -> Self {
        let shared = Arc::new(Shared {
            state: Mutex::new(State::default()),
            arrived: Condvar::new(),
            stop: AtomicBool::new(false),
        });
        let s = shared.clone();
        std::thread::spawn(move || {
            while !s.stop.load(Ordering::Relaxed) {
                let item = produce();
                let Ok(mut state) = s.state.lock() else {
                    return;
                };
                let last = match &item {
                    None => true,
                    Some(Err(e)) => e.ends_input(),
                    Some(Ok(_)) => false,
                };
                if item.is_some() {
                    state.newest = item;
                    state.produced += 1;
                }
                state.ended = last;
                drop(state);
                s.arrived.notify_all();
                if last {
                    return;
                }
            }
        });
        NewestSource {
            shared,
            taken: 0,
            dropped: 0,
        }
    }
}

impl FrameSource for NewestSource {
    fn next_frame(&mut self) -> Option<Result<FrameSet, InputError>> {
        let mut state = self.shared.state.lock().ok()?;
        loop {
            if state.produced > self.taken
                && let Some(item) = state.newest.take()
            {
                self.dropped += state.produced - self.taken - 1;
                self.taken = state.produced;
                return Some(item);
            }
            if state.ended {
                return None;
            }
            state = self.shared.arrived.wait(state).ok()?;
        }
    }

    fn is_live(&self) -> bool {
        true
    }

    fn dropped(&self) -> u64 {
        self.dropped
    }
}

impl Drop for NewestSource {
    fn drop(&mut self) {
        self.shared.stop.store(true, Ordering::Relaxed);
    }
}

#[cfg(test)]
mod tests {
    use std::time::Duration;

    use super::*;

    #[test]
    fn a_slow_taker_gets_the_newest_and_counts_the_rest() {
        let mut n = 0u64;
        let mut source = NewestSource::spawn(move || {
            std::thread::sleep(Duration::from_millis(5));
            n += 1;
            (n <= 40).then(|| Ok(FrameSet::new(n, Vec::new())))
        });
        let mut seen = Vec::new();
        while let Some(set) = source.next_frame() {
            seen.push(set.unwrap().frame);
            std::thread::sleep(Duration::from_millis(23));
        }
        assert!(seen.windows(2).all(|w| w[1] > w[0]), "{seen:?}");
        assert!(seen.len() < 20, "{seen:?}");
        assert_eq!(seen.len() as u64 + source.dropped(), 40, "{seen:?}");
        assert_eq!(*seen.last().unwrap(), 40, "the last frame is taken");
    }

    #[test]
    fn an_error_that_ends_the_input_is_handed_over_then_the_end() {
        let mut n = 0;
        let mut source = NewestSource::spawn(move || {
            n += 1;
            Some(if n < 3 {
                Ok(FrameSet::new(n, Vec::new()))
            } else {
                Err(InputError::Ended {
                    camera: "sim".into(),
                    frames: 2,
                })
            })
        });
        let mut last = None;
        while let Some(item) = source.next_frame() {
            last = Some(item);
        }
        assert!(matches!(last, Some(Err(InputError::Ended { .. }))));
    }
}
