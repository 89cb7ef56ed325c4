//! Voxels a shadow carved: a sharp shadow on the backdrop is foreground to a silhouette that
//! cannot tell it from a grey object by its edge, and where its rays meet another camera's rays
//! through the object, the hull holds voxels no object fills (a second object, a branch, a
//! ghost beside the tube). Such a voxel is held by shadow-coloured pixels in one camera and by
//! the object's own colour in another; the object itself is held alike in every camera — by
//! its colour, or (a grey object) by shadow-coloured pixels throughout.

use flexshape_silhouette::BitMask;

use crate::cloud::Occupancy;
use crate::error::CarveError;
use crate::hierarchical::HierarchicalCarver;
use crate::lookup::OutsideImage;

/// How far (pixels) a voxel's pixel may lie from pixels of a kind and still count as held by
/// them: a voxel at the object's edge in the image lands on either side of it.
const EDGE_PX: usize = 1;

/// The voxels of `hull` (carved by `carver` from `objects` under `rule`) that some camera holds
/// only by shadow-coloured pixels (`shadow_like`, a subset of each object) while another holds
/// them only by the object's colour — the rest of its object; each within a pixel.
/// Empty when no camera's object holds a shadow-coloured pixel (nothing is a shadow), or some
/// camera's object holds nothing else (shadow-coloured throughout, or empty: colour tells
/// nothing there).
pub fn shadow_carved(
    carver: &HierarchicalCarver,
    hull: &Occupancy,
    objects: &[&BitMask],
    shadow_like: &[&BitMask],
    rule: OutsideImage,
) -> Result<Occupancy, CarveError> {
    let shades: Vec<BitMask> = objects
        .iter()
        .zip(shadow_like)
        .map(|(o, s)| o.and(s))
        .collect();
    let coloured: Vec<BitMask> = objects
        .iter()
        .zip(&shades)
        .map(|(o, s)| o.and_not(s))
        .collect();
    if shades.iter().all(|s| s.count() == 0) || coloured.iter().any(|c| c.count() == 0) {
        return Ok(Occupancy {
            volume: hull.volume,
            voxels: Vec::new(),
        });
    }
    let grown =
        |masks: &[BitMask]| -> Vec<BitMask> { masks.iter().map(|m| m.dilate(EDGE_PX)).collect() };
    let (coloured, shades) = (grown(&coloured), grown(&shades));
    let by_colour = carver.carve(&coloured.iter().collect::<Vec<_>>(), rule)?;
    let by_shade = carver.carve(&shades.iter().collect::<Vec<_>>(), rule)?;
    Ok(hull.without(&by_colour).without(&by_shade))
}

#[cfg(test)]
mod tests {
    use super::*;
    use flexshape_sim::{CatheterPose, SimConfig, Simulator};
    use image::GrayImage;

    /// `mask` moved `dx` pixels right.
    fn shifted(mask: &GrayImage, dx: u32) -> BitMask {
        let (w, h) = mask.dimensions();
        BitMask::from_gray(&GrayImage::from_fn(w, h, |x, y| {
            if x >= dx {
                *mask.get_pixel(x - dx, y)
            } else {
                image::Luma([0])
            }
        }))
    }

    #[test]
    fn a_shadow_beside_the_tube_in_one_camera_is_dropped_and_nothing_else() {
        let sim = Simulator::new(SimConfig::default()).unwrap();
        let pose = CatheterPose::arc(&sim.config().catheter, [0.006, -0.002], [0.0, 0.0], 0.0);
        let frame = sim.render(0, &pose).unwrap();
        // Two cameras: with a third, the other two seldom agree anywhere but on the tube.
        let tubes: Vec<BitMask> = frame.views[..2]
            .iter()
            .map(|v| BitMask::from_gray(&v.mask))
            .collect();
        let carver = HierarchicalCarver::new(&sim.cameras()[..2], &sim.rig().volume).unwrap();
        let rule = OutsideImage::Carve;
        let clean = carver
            .carve(&tubes.iter().collect::<Vec<_>>(), rule)
            .unwrap();
        // Camera 0 also sees the tube's "shadow": its image moved 40 px, shadow-coloured.
        let shadow = shifted(&frame.views[0].mask, 40).and_not(&tubes[0]);
        let mut objects = tubes.clone();
        objects[0] = tubes[0].or(&shadow);
        let none = BitMask::new(shadow.width(), shadow.height());
        let shadow_like = [&shadow, &none];
        let objects: Vec<&BitMask> = objects.iter().collect();
        let hull = carver.carve(&objects, rule).unwrap();
        let dropped = shadow_carved(&carver, &hull, &objects, &shadow_like, rule).unwrap();
        assert!(
            hull.len() > clean.len() && !dropped.is_empty(),
            "{} {}",
            hull.len(),
            dropped.len()
        );
        assert_eq!(hull.without(&dropped), clean);

        // A grey object: shadow-coloured in every camera, held alike; nothing dropped.
        let tube_refs: Vec<&BitMask> = tubes.iter().collect();
        let grey = shadow_carved(&carver, &clean, &tube_refs, &tube_refs, rule).unwrap();
        assert!(grey.is_empty());
        // No shadow-coloured pixel anywhere: nothing dropped.
        let nothing = shadow_carved(&carver, &clean, &tube_refs, &[&none, &none], rule).unwrap();
        assert!(nothing.is_empty());
        // A camera whose object is shadow-coloured throughout: colour tells nothing there.
        let all_shade = [&tubes[0], &none];
        let told = shadow_carved(&carver, &clean, &tube_refs, &all_shade, rule).unwrap();
        assert!(told.is_empty());
    }
}
