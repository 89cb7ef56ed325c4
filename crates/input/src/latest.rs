//! The one newest-wins channel of flexshape's live inputs: producer threads each keep only
//! their newest item in a slot; the taker waits until every slot holds an item newer than the
//! last it took, takes the newest of each, and counts the ones overwritten as dropped.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Condvar, Mutex};
use std::time::{Duration, Instant};

use crate::InputError;

/// One producer's newest item.
struct Slot<T> {
    item: Option<T>,
    /// Items received so far.
    received: u64,
    /// Set when the producer is done: `Ok` cleanly, or why it failed.
    ended: Option<Result<(), InputError>>,
}

impl<T> Slot<T> {
    /// Whether it holds an item the taker has not taken (`taken` items taken so far).
    fn has_new(&self, taken: u64) -> bool {
        self.received > taken && self.item.is_some()
    }
}

/// Slots shared by the producers (one slot each) and the taker.
pub(crate) struct Latest<T> {
    slots: Mutex<Vec<Slot<T>>>,
    arrived: Condvar,
    stop: AtomicBool,
}

impl<T> Latest<T> {
    /// `producers` empty slots.
    pub(crate) fn new(producers: usize) -> Self {
        Latest {
            slots: Mutex::new(
                (0..producers)
                    .map(|_| Slot {
                        item: None,
                        received: 0,
                        ended: None,
                    })
                    .collect(),
            ),
            arrived: Condvar::new(),
            stop: AtomicBool::new(false),
        }
    }

    /// Producer `i`'s newest item, replacing the one not taken.
    pub(crate) fn put(&self, i: usize, item: T) {
        if let Ok(mut slots) = self.slots.lock() {
            slots[i].item = Some(item);
            slots[i].received += 1;
        }
        self.arrived.notify_all();
    }

    /// Producer `i` is done: `Ok` cleanly, or why it failed.
    pub(crate) fn end(&self, i: usize, why: Result<(), InputError>) {
        if let Ok(mut slots) = self.slots.lock() {
            slots[i].ended = Some(why);
        }
        self.arrived.notify_all();
    }

    /// Whether the taker has gone: producers stop.
    pub(crate) fn stopped(&self) -> bool {
        self.stop.load(Ordering::Relaxed)
    }

    /// Tells the producers to stop.
    pub(crate) fn stop(&self) {
        self.stop.store(true, Ordering::Relaxed);
    }
}

/// The taker's side: what it took last from each slot, and what it missed.
pub(crate) struct Taker {
    taken: Vec<u64>,
    dropped: Vec<u64>,
    finished: bool,
    /// How long to wait for every slot, and the producers' names to say which did not fill.
    patience: Option<(Duration, Vec<String>)>,
}

impl Taker {
    /// A taker of `producers` slots.
    pub(crate) fn new(producers: usize) -> Self {
        Taker {
            taken: vec![0; producers],
            dropped: vec![0; producers],
            finished: false,
            patience: None,
        }
    }

    /// The same, ending with [`InputError::Silent`] (naming the producer by `names`) when a
    /// slot stays without a new item for `patience`.
    pub(crate) fn patient(self, patience: Duration, names: Vec<String>) -> Self {
        Taker {
            patience: Some((patience, names)),
            ..self
        }
    }

    /// Waits until every slot holds an item newer than the last taken and takes the newest of
    /// each (in slot order); `None` once a slot ended with nothing new (after handing over
    /// its failure, if it failed).
    pub(crate) fn take<T>(&mut self, latest: &Latest<T>) -> Option<Result<Vec<T>, InputError>> {
        if self.finished {
            return None;
        }
        let Ok(mut slots) = latest.slots.lock() else {
            self.finished = true;
            return None;
        };
        let since = Instant::now();
        loop {
            let fresh = slots.iter().zip(&self.taken).all(|(s, &t)| s.has_new(t));
            if fresh {
                break;
            }
            if let Some(i) = (0..slots.len())
                .find(|&i| slots[i].ended.is_some() && slots[i].received == self.taken[i])
            {
                self.finished = true;
                return match slots[i].ended.take() {
                    Some(Err(e)) => Some(Err(e)),
                    _ => None,
                };
            }
            let waited = match &self.patience {
                None => latest.arrived.wait(slots).map_err(|_| ()),
                Some((patience, names)) => {
                    let left = patience.saturating_sub(since.elapsed());
                    let silent = (0..slots.len()).find(|&i| !slots[i].has_new(self.taken[i]));
                    if let (true, Some(i)) = (left.is_zero(), silent) {
                        self.finished = true;
                        return Some(Err(InputError::Silent {
                            camera: names.get(i).cloned().unwrap_or_else(|| i.to_string()),
                            waited_s: patience.as_secs(),
                        }));
                    }
                    latest
                        .arrived
                        .wait_timeout(slots, left)
                        .map(|(s, _)| s)
                        .map_err(|_| ())
                }
            };
            slots = match waited {
                Ok(s) => s,
                Err(_) => {
                    self.finished = true;
                    return None;
                }
            };
        }
        let mut items = Vec::with_capacity(slots.len());
        for (i, slot) in slots.iter_mut().enumerate() {
            if let Some(item) = slot.item.take() {
                self.dropped[i] += slot.received - self.taken[i] - 1;
                self.taken[i] = slot.received;
                items.push(item);
            }
        }
        Some(Ok(items))
    }

    /// Items overwritten before they were taken: the most of any slot.
    pub(crate) fn dropped(&self) -> u64 {
        self.dropped.iter().copied().max().unwrap_or(0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A camera that sends nothing was waited for silently for ever: a patient taker names it.
    #[test]
    fn a_slot_that_stays_empty_is_named_once_patience_runs_out() {
        let latest = Latest::new(2);
        let names = vec!["cam0".to_string(), "cam1".to_string()];
        let mut taker = Taker::new(2).patient(Duration::from_millis(200), names);
        latest.put(0, 1);
        latest.put(1, 1);
        assert_eq!(taker.take(&latest).unwrap().unwrap(), [1, 1]);
        // Only cam0 goes on.
        let start = Instant::now();
        latest.put(0, 2);
        let e = taker.take(&latest).unwrap().unwrap_err().to_string();
        assert!(e.contains("camera `cam1` sent no new frame"), "{e}");
        let waited = start.elapsed();
        assert!(
            waited >= Duration::from_millis(200) && waited < Duration::from_secs(2),
            "{waited:?}"
        );
        assert!(taker.take(&latest).is_none(), "the source has ended");
    }
}
