//! The one channel of flexshape's live inputs: producer threads each keep their newest few
//! items in a slot; the taker waits until every slot holds an item it has not taken, then
//! takes one of each — the newest, or those nearest one instant ([`Taker::take_paired`]) —
//! and counts the ones passed over or overwritten as dropped.

use std::collections::VecDeque;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Condvar, Mutex};
use std::time::{Duration, Instant};

use crate::InputError;

/// One producer's newest items, oldest first.
struct Slot<T> {
    queue: VecDeque<T>,
    /// Items overwritten or passed over, never taken.
    discarded: u64,
    /// Set when the producer is done: `Ok` cleanly, or why it failed.
    ended: Option<Result<(), InputError>>,
}

/// Slots shared by the producers (one slot each) and the taker.
pub(crate) struct Latest<T> {
    slots: Mutex<Vec<Slot<T>>>,
    /// Items a slot keeps; a newer one overwrites the oldest.
    depth: usize,
    arrived: Condvar,
    stop: AtomicBool,
}

impl<T> Latest<T> {
    /// `producers` empty slots, each keeping its newest `depth` items (at least 1).
    pub(crate) fn new(producers: usize, depth: usize) -> Self {
        Latest {
            slots: Mutex::new(
                (0..producers)
                    .map(|_| Slot {
                        queue: VecDeque::new(),
                        discarded: 0,
                        ended: None,
                    })
                    .collect(),
            ),
            depth: depth.max(1),
            arrived: Condvar::new(),
            stop: AtomicBool::new(false),
        }
    }

    /// Producer `i`'s newest item, overwriting its oldest when the slot is full.
    pub(crate) fn put(&self, i: usize, item: T) {
        if let Ok(mut slots) = self.slots.lock() {
            let slot = &mut slots[i];
            slot.queue.push_back(item);
            if slot.queue.len() > self.depth {
                slot.queue.pop_front();
                slot.discarded += 1;
            }
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

/// Which items to take once every slot holds one.
enum Pick {
    /// The item at this place of each slot's queue (those before it are passed over).
    Items(Vec<usize>),
    /// No set: this slot's items have no partners and are discarded.
    Unpaired(usize),
}

/// The taker's side: what it missed.
pub(crate) struct Taker {
    /// Per slot: items passed over, unpaired or (as last seen) overwritten.
    dropped: Vec<u64>,
    overwritten: Vec<u64>,
    unpaired: u64,
    finished: bool,
    /// How long to wait for every slot, and the producers' names to say which did not fill.
    patience: Option<(Duration, Vec<String>)>,
}

impl Taker {
    /// A taker of `producers` slots.
    pub(crate) fn new(producers: usize) -> Self {
        Taker {
            dropped: vec![0; producers],
            overwritten: vec![0; producers],
            unpaired: 0,
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

    /// Waits until every slot holds an item not yet taken and takes the newest of each (in
    /// slot order); `None` once a slot ended with nothing new (after handing over its
    /// failure, if it failed).
    pub(crate) fn take<T>(&mut self, latest: &Latest<T>) -> Option<Result<Vec<T>, InputError>> {
        self.take_with(latest, |slots| {
            Pick::Items(slots.iter().map(|s| s.queue.len() - 1).collect())
        })
    }

    /// As [`Taker::take`], the items nearest one instant: the newest instant every slot has
    /// reached (the earliest of their newest items' `time`s), each slot's item nearest it.
    /// A set whose item is farther than `within(items)` seconds from that instant is not
    /// taken: the items up to the instant in the slot that set it have no partners, are
    /// discarded and counted ([`Taker::unpaired`]), and the taker waits for more.
    pub(crate) fn take_paired<T>(
        &mut self,
        latest: &Latest<T>,
        time: impl Fn(&T) -> f64,
        within: impl Fn(&[&T]) -> f64,
    ) -> Option<Result<Vec<T>, InputError>> {
        self.take_with(latest, |slots| {
            let queues: Vec<&VecDeque<T>> = slots.iter().map(|s| &s.queue).collect();
            let (slowest, instant) = queues
                .iter()
                .map(|q| time(&q[q.len() - 1]))
                .enumerate()
                .min_by(|a, b| a.1.total_cmp(&b.1))
                .unwrap_or((0, f64::INFINITY));
            let nearest: Vec<usize> = queues
                .iter()
                .map(|q| {
                    (0..q.len())
                        .min_by(|&a, &b| {
                            (time(&q[a]) - instant)
                                .abs()
                                .total_cmp(&(time(&q[b]) - instant).abs())
                        })
                        .unwrap_or(0)
                })
                .collect();
            let items: Vec<&T> = queues.iter().zip(&nearest).map(|(q, &j)| &q[j]).collect();
            let limit = within(&items);
            let apart = items
                .iter()
                .any(|item| (time(item) - instant).abs() > limit);
            if apart {
                Pick::Unpaired(slowest)
            } else {
                Pick::Items(nearest)
            }
        })
    }

    fn take_with<T>(
        &mut self,
        latest: &Latest<T>,
        mut pick: impl FnMut(&[Slot<T>]) -> Pick,
    ) -> Option<Result<Vec<T>, InputError>> {
        if self.finished {
            return None;
        }
        let Ok(mut slots) = latest.slots.lock() else {
            self.finished = true;
            return None;
        };
        let since = Instant::now();
        // The last slot whose items found no partners while waiting.
        let mut unpaired = None;
        loop {
            if slots.iter().all(|s| !s.queue.is_empty()) {
                match pick(&slots) {
                    Pick::Items(at) => {
                        let mut items = Vec::with_capacity(slots.len());
                        for (i, (slot, j)) in slots.iter_mut().zip(at).enumerate() {
                            let passed = slot.queue.drain(..j).count() as u64;
                            self.dropped[i] += passed;
                            self.overwritten[i] = slot.discarded;
                            if let Some(item) = slot.queue.pop_front() {
                                items.push(item);
                            }
                        }
                        return Some(Ok(items));
                    }
                    Pick::Unpaired(i) => {
                        let gone = slots[i].queue.drain(..).count();
                        self.dropped[i] += gone as u64;
                        self.unpaired += 1;
                        unpaired = Some(i);
                        continue;
                    }
                }
            }
            if let Some(i) =
                (0..slots.len()).find(|&i| slots[i].ended.is_some() && slots[i].queue.is_empty())
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
                    let silent = (0..slots.len()).find(|&i| slots[i].queue.is_empty());
                    if let (true, Some(i)) = (left.is_zero(), silent) {
                        self.finished = true;
                        let name =
                            |i: usize| names.get(i).cloned().unwrap_or_else(|| i.to_string());
                        // Cameras that deliver but never pair say so, not that one is silent.
                        return Some(Err(match unpaired {
                            Some(k) => InputError::Unpaired {
                                camera: name(k),
                                waited_s: patience.as_secs(),
                                unpaired: self.unpaired,
                            },
                            None => InputError::Silent {
                                camera: name(i),
                                waited_s: patience.as_secs(),
                            },
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
    }

    /// Items overwritten, passed over or unpaired before they were taken: the most of any
    /// slot.
    pub(crate) fn dropped(&self) -> u64 {
        self.dropped
            .iter()
            .zip(&self.overwritten)
            .map(|(a, b)| a + b)
            .max()
            .unwrap_or(0)
    }

    /// Sets not taken because one slot's item had no partners near its instant.
    pub(crate) fn unpaired(&self) -> u64 {
        self.unpaired
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A camera that sends nothing was waited for silently for ever: a patient taker names it.
    #[test]
    fn a_slot_that_stays_empty_is_named_once_patience_runs_out() {
        let latest = Latest::new(2, 1);
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

    /// Cameras paired by time: each slot's item nearest the newest instant all have reached,
    /// the older ones passed over; a camera whose frame near it was lost leaves the others'
    /// frame unpaired, counted, and the next instant pairs.
    #[test]
    fn items_are_paired_nearest_the_instant_every_slot_reached() {
        let latest = Latest::new(2, 4);
        let mut taker = Taker::new(2);
        let time = |t: &f64| *t;
        let within = |_: &[&f64]| 0.006;
        // cam0 at 0, 10, 20 ms; cam1 (phase 4 ms) at 4, 14 ms: the instant is 14 ms.
        for t in [0.000, 0.010, 0.020] {
            latest.put(0, t);
        }
        for t in [0.004, 0.014] {
            latest.put(1, t);
        }
        let set = taker.take_paired(&latest, time, within).unwrap().unwrap();
        assert_eq!(set, [0.010, 0.014]);
        assert_eq!(taker.dropped(), 1, "cam0's frame at 0 passed over");
        // cam1's frame at 24 ms lost: cam0's at 20 pairs with 34 no closer than 14 ms.
        latest.put(0, 0.030);
        latest.put(1, 0.034);
        let set = taker.take_paired(&latest, time, within).unwrap().unwrap();
        assert_eq!(set, [0.030, 0.034]);
        assert_eq!(
            taker.unpaired(),
            0,
            "20 was passed over, not unpaired: {set:?}"
        );
        // Only cam1's frame far ahead: cam0's newest has no partner.
        latest.put(0, 0.040);
        latest.put(1, 0.064);
        latest.put(0, 0.060);
        let set = taker.take_paired(&latest, time, within).unwrap().unwrap();
        assert_eq!(set, [0.060, 0.064]);
        assert_eq!(taker.unpaired(), 0);
        latest.put(0, 0.070);
        latest.put(1, 0.094);
        latest.put(0, 0.080);
        latest.put(0, 0.090);
        let set = taker.take_paired(&latest, time, within).unwrap().unwrap();
        assert_eq!(set, [0.090, 0.094]);
        // Frames whose partners never come: counted, and said once patience runs out.
        let names = vec!["cam0".to_string(), "cam1".to_string()];
        let mut taker = Taker::new(2).patient(Duration::from_millis(100), names);
        let latest = Latest::new(2, 4);
        let start = Instant::now();
        let feeder = std::thread::scope(|s| {
            s.spawn(|| {
                for k in 0..40 {
                    latest.put(0, k as f64 * 0.01);
                    latest.put(1, 100.0 + k as f64 * 0.01);
                    std::thread::sleep(Duration::from_millis(10));
                }
            });
            taker.take_paired(&latest, time, within)
        });
        let e = feeder.unwrap().unwrap_err().to_string();
        assert!(e.contains("could be paired") && e.contains("cam0"), "{e}");
        assert!(taker.unpaired() > 1);
        assert!(start.elapsed() >= Duration::from_millis(100));
    }
}
