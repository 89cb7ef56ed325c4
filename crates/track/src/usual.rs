//! Each camera's usual silhouette: the share of its image the object covered in the run's
//! first right frames. A frame whose silhouette covers many times that share (the light
//! changed, a hand entered the view) is implausible even below `max_foreground`.

use flexshape_silhouette::Silhouette;

/// Right frames whose shares are learned.
pub(crate) const LEARN_FRAMES: usize = 10;
/// Right frames needed before a usual share is known.
pub(crate) const MIN_FRAMES: usize = 5;

/// The share of its image a silhouette covers.
pub(crate) fn share(s: &Silhouette) -> f64 {
    let mask = &s.object;
    s.object.count() as f64 / (mask.width() as f64 * mask.height() as f64).max(1.0)
}
