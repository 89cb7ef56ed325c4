//! A source fed by its own thread — a rig that delivers whole frame sets on its own clock
//! (hardware-synchronised cameras, or the simulator in the live demo). Only the newest set is
//! kept; sets overwritten before tracking took them are counted as dropped.

use std::sync::Arc;

use crate::latest::{Latest, Taker};
use crate::{FrameSet, FrameSource, InputError};

/// Newest-wins frames from a producer thread.
pub struct NewestSource {
    latest: Arc<Latest<Result<FrameSet, InputError>>>,
    taker: Taker,
}

impl NewestSource {
    /// Runs `produce` on its own thread until it returns `None`, a frame ends the input, or
    /// the source is dropped.
    pub fn spawn(
        mut produce: impl FnMut() -> Option<Result<FrameSet, InputError>> + Send + 'static,
    ) -> Self {
        let latest = Arc::new(Latest::new(1, 1));
        let shared = latest.clone();
        std::thread::spawn(move || {
            while !shared.stopped() {
                let Some(item) = produce() else {
                    return shared.end(0, Ok(()));
                };
                let last = matches!(&item, Err(e) if e.ends_input());
                shared.put(0, item);
                if last {
                    return shared.end(0, Ok(()));
                }
            }
        });
        NewestSource {
            latest,
            taker: Taker::new(1),
        }
    }
}

impl FrameSource for NewestSource {
    fn next_frame(&mut self) -> Option<Result<FrameSet, InputError>> {
        match self.taker.take(&self.latest)? {
            Ok(mut items) => items.pop(),
            Err(e) => Some(Err(e)),
        }
    }

    fn is_live(&self) -> bool {
        true
    }

    fn dropped(&self) -> u64 {
        self.taker.dropped()
    }
}

impl Drop for NewestSource {
    fn drop(&mut self) {
        self.latest.stop();
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
