//! Marker bands found in the carved volume against the simulator's band centres.

use crate::common;

use flexshape_camera::nalgebra::Point3;
use flexshape_carve::{BandRule, HierarchicalCarver, OutsideImage, find_bands};
use flexshape_sim::{SimConfig, Simulator};

#[test]
fn band_centroids_are_within_a_millimetre_of_the_true_band_centres() {
    let sim = Simulator::new(SimConfig::default()).unwrap();
    let cameras = sim.cameras();
    let carver = HierarchicalCarver::new(&cameras, &sim.rig().volume).unwrap();
    let silhouetters = common::silhouetters(&sim);
    // Worst distance for the band at the bending base and for the band ending at the tip.
    let (mut worst_base, mut worst_tip): (f64, f64) = (0.0, 0.0);
    for (n, pose) in sim.sweep(8).iter().enumerate() {
        let f = sim.render(n as u64, pose).unwrap();
        let sil: Vec<_> = silhouetters
            .iter()
            .zip(&f.views)
            .map(|(s, v)| s.process(&v.image).unwrap())
            .collect();
        let objects: Vec<_> = sil.iter().map(|s| &s.object).collect();
        let markers: Vec<_> = sil.iter().map(|s| &s.markers).collect();
        let occ = carver.carve(&objects, OutsideImage::Carve).unwrap();
        // Both rules find both bands; the simple rule's centroids lie on the tube's axis (the
        // visibility rule labels the visible surface only, so its centroids sit off the axis
        // toward the cameras: the shape stage places those bands along the curve instead).
        let visible = find_bands(&occ, &cameras, &markers, &BandRule::default()).unwrap();
        let simple = BandRule {
            visibility: false,
            min_views: 2,
            ..BandRule::default()
        };
        let bands = find_bands(&occ, &cameras, &markers, &simple).unwrap();
        assert_eq!(visible.len(), bands.len(), "frame {n}");
        // The cloud labels exactly the band voxels, each with its band.
        let cloud = occ.to_cloud_with_bands(&bands);
        for (n, band) in bands.iter().enumerate() {
            let labelled = cloud.band.iter().filter(|&&b| b as usize == n + 1).count();
            assert_eq!(labelled, band.voxels.len());
        }
        let unlabelled = cloud.band.iter().filter(|&&b| b == 0).count();
        assert_eq!(
            unlabelled + bands.iter().map(|b| b.voxels.len()).sum::<usize>(),
            occ.len()
        );
        let inside: Vec<_> = f
            .truth
            .bands
            .iter()
            .filter(|b| sim.rig().volume.contains(&Point3::from(b.position)))
            .collect();
        assert_eq!(
            bands.len(),
            inside.len(),
            "frame {n}: {} bands found, {} in the volume",
            bands.len(),
            inside.len()
        );
        for truth in inside {
            let t = Point3::from(truth.position);
            let d = bands
                .iter()
                .map(|b| (Point3::from(b.centroid) - t).norm())
                .fold(f64::INFINITY, f64::min);
            println!(
                "frame {n}: band at arc {:.1} mm found {d:.2} mm away",
                truth.arc_length
            );
            if Some(truth.arc_length) == f.truth.bend_start_arc_length {
                worst_base = worst_base.max(d);
            } else {
                worst_tip = worst_tip.max(d);
            }
        }
    }
    assert!(
        worst_base < 1.0,
        "bending-base band centroid {worst_base:.2} mm from the true centre"
    );
    // The band that ends at the tip is pulled tipward: the visual hull reaches past the tube's
    // end where no camera bounds it, and those voxels project onto band pixels (the marked tip,
    // or the band itself in cameras looking from behind). Issue 4's 1 mm target for this band
    // is open.
    assert!(
        worst_tip < 2.0,
        "tip band centroid {worst_tip:.2} mm from the true centre"
    );
}
