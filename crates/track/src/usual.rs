//! Each camera's usual silhouette: the most of its image the object covered in the run's
//! recent right frames, learned across a spread of poses (the first right frames, then every
//! [`LEARN_EVERY`]th, the oldest forgotten). A frame whose silhouette covers many times that
//! share (the light changed, a hand entered the view) is implausible even below
//! `max_foreground` — unless the tube fitted to it explains every camera, which makes its
//! share the tube's (and learned).

use flexshape_silhouette::Silhouette;

/// Right frames' shares kept per camera.
pub(crate) const LEARN_FRAMES: usize = 16;
/// Once [`LEARN_FRAMES`] are kept, one right frame in this many replaces the oldest: the
/// shares span the last few hundred right frames' poses, not the first few.
pub(crate) const LEARN_EVERY: u64 = 8;
/// Right frames needed before a usual share is known.
pub(crate) const MIN_FRAMES: usize = 5;

/// The share of its image a silhouette covers.
pub(crate) fn share(s: &Silhouette) -> f64 {
    let mask = &s.object;
    s.object.count() as f64 / (mask.width() as f64 * mask.height() as f64).max(1.0)
}
