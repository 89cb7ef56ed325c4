//! Each camera's usual silhouette: the share of its image the object covered in the run's
//! first right frames. A frame whose silhouette covers many times that share (the light
//! changed, a hand entered the view) is implausible even below `max_foreground`.

use std::sync::Mutex;

use flexshape_silhouette::Silhouette;

/// Right frames whose shares are learned.
const LEARN_FRAMES: usize = 10;
/// Right frames needed before a usual share is known.
const MIN_FRAMES: usize = 5;

/// The shares learned so far, per camera (frames from any worker, in the order they end).
#[derive(Debug, Default)]
pub(crate) struct UsualShares {
    learned: Mutex<Vec<Vec<f64>>>,
}

impl Clone for UsualShares {
    fn clone(&self) -> Self {
        UsualShares {
            learned: Mutex::new(self.lock().clone()),
        }
    }
}

impl UsualShares {
    fn lock(&self) -> std::sync::MutexGuard<'_, Vec<Vec<f64>>> {
        // A worker that panicked while holding it left whole vectors behind.
        self.learned.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Learns a right frame's silhouettes, until [`LEARN_FRAMES`] are known.
    pub fn learn(&self, silhouettes: &[Silhouette]) {
        let mut learned = self.lock();
        learned.resize_with(silhouettes.len(), Vec::new);
        for (shares, s) in learned.iter_mut().zip(silhouettes) {
            if shares.len() < LEARN_FRAMES {
                shares.push(share(s));
            }
        }
    }

    /// Camera `camera`'s usual share (the median of its learned ones), once
    /// [`MIN_FRAMES`] are known.
    pub fn of(&self, camera: usize) -> Option<f64> {
        let learned = self.lock();
        let mut shares = learned.get(camera)?.clone();
        if shares.len() < MIN_FRAMES {
            return None;
        }
        shares.sort_by(f64::total_cmp);
        Some(shares[shares.len() / 2])
    }
}

/// The share of its image a silhouette covers.
pub(crate) fn share(s: &Silhouette) -> f64 {
    let mask = &s.object;
    s.object.count() as f64 / (mask.width() as f64 * mask.height() as f64).max(1.0)
}
