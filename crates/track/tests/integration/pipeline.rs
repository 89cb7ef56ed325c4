//! One simulated frame through the pipeline, and its record against truth.

use crate::common;

use flexshape_track::TrackError;

#[test]
fn a_frame_becomes_a_record_in_world_coordinates() {
    let (sim, pipeline) = common::simulated_chain();
    let frame = sim.render(2, &sim.sweep(3)[2]).unwrap();
    let images: Vec<_> = frame.views.iter().map(|v| &v.image).collect();
    let tracked = pipeline.process(&images).unwrap();
    let record = tracked.record(7);
    assert_eq!((record.frame, record.status.as_str()), (7, "ok"));
    assert_eq!(record.voxels, tracked.occupancy.len());
    assert_eq!(record.centerline.len(), record.curvature.len());
    // The arc fit's bend direction is a unit vector across the tangent, and points where the
    // simulated section bends.
    let fit = record.arc_fit.unwrap();
    let dot = |a: [f64; 3], b: [f64; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    assert!((dot(fit.bend_direction, fit.bend_direction) - 1.0).abs() < 1e-9);
    assert!(dot(fit.bend_direction, fit.base_tangent).abs() < 1e-9);
    let [kx, kz] = frame.truth.kappa.unwrap();
    let r = frame.truth.bend_base.unwrap().rotation;
    let local = [-kz, 0.0, kx].map(|v| v / kx.hypot(kz));
    let truth: [f64; 3] = std::array::from_fn(|i| dot(r[i], local));
    let angle = dot(truth, fit.bend_direction)
        .clamp(-1.0, 1.0)
        .acos()
        .to_degrees();
    assert!(angle < 1.0, "bend direction {angle:.2}° from truth");
    // One image short is an error, not a panic.
    assert!(matches!(
        pipeline.process(&images[..2]),
        Err(TrackError::CameraCount {
            found: 2,
            expected: 3,
            ..
        })
    ));
}

/// Lights turned down after the background was captured: the classifier takes most of a
/// camera's image for the object. The frame says so (`bad_silhouette`, naming the camera and
/// the share) instead of carving nonsense; the other cameras' frames are not blamed.
#[test]
fn a_silhouette_covering_most_of_the_image_is_bad_not_carved() {
    let (sim, pipeline) = common::simulated_chain();
    let frame = sim.render(0, &sim.sweep(1)[0]).unwrap();
    let mut dark = frame.views[1].image.clone();
    for p in dark.pixels_mut() {
        p.0 = p.0.map(|v| v / 5);
    }
    let images = vec![&frame.views[0].image, &dark, &frame.views[2].image];
    let t = pipeline.process(&images).unwrap();
    let record = t.record(0);
    assert_eq!(record.status, "bad_silhouette");
    let reason = record.reason.unwrap();
    assert!(
        reason.starts_with("camera cam1:") && reason.contains("% of the image"),
        "{reason}"
    );
    assert!(t.occupancy.is_empty() && t.fit.is_none() && record.centerline.is_empty());
    // The undarkened frame is fine.
    let images: Vec<_> = frame.views.iter().map(|v| &v.image).collect();
    assert_eq!(pipeline.process(&images).unwrap().record(0).status, "ok");
}

/// After a few right frames the chain knows how much of each image the tube covers; a frame
/// whose silhouette in one camera covers many times that (a stripe of the backdrop darkened:
/// a shadow of something new, light changed), though far below `max_foreground`, is
/// `bad_silhouette`, naming the camera, the share and its usual one. A chain that has seen no
/// right frame yet cannot say so.
#[test]
fn a_silhouette_far_larger_than_usual_is_bad() {
    let (sim, pipeline) = common::simulated_chain();
    let poses = sim.sweep(8);
    let last = sim.render(7, &poses[7]).unwrap();
    let mut dark = last.views[1].image.clone();
    for y in 200..260 {
        for x in 0..dark.width() {
            let p = dark.get_pixel_mut(x, y);
            p.0 = p.0.map(|v| v / 5);
        }
    }
    let images = vec![&last.views[0].image, &dark, &last.views[2].image];
    let fresh = pipeline.clone().process(&images).unwrap().record(7);
    assert!(
        !fresh.reason.clone().unwrap_or_default().contains("usual"),
        "{fresh:?}"
    );
    for (i, pose) in poses.iter().enumerate().take(6) {
        let frame = sim.render(i as u64, pose).unwrap();
        let images: Vec<_> = frame.views.iter().map(|v| &v.image).collect();
        let t = pipeline.process(&images).unwrap();
        assert_eq!(t.record(i as u64).status, "ok");
    }
    let t = pipeline.process(&images).unwrap();
    let record = t.record(7);
    assert_eq!(record.status, "bad_silhouette");
    let reason = record.reason.unwrap();
    println!("{reason}");
    assert!(
        reason.starts_with("camera cam1:") && reason.contains("its usual"),
        "{reason}"
    );
    // The same frame undarkened is fine.
    let images: Vec<_> = last.views.iter().map(|v| &v.image).collect();
    assert_eq!(pipeline.process(&images).unwrap().record(7).status, "ok");
}

/// Lights down over the middle of every camera's view, each silhouette under
/// `max_foreground`: the hull carved from them fills a large part of the volume, which no
/// tube does. The frame says so (`bad_silhouette`) instead of fitting a tube into it.
#[test]
fn a_hull_filling_much_of_the_volume_is_bad_not_fitted() {
    let (sim, pipeline) = common::simulated_chain();
    let frame = sim.render(0, &sim.sweep(1)[0]).unwrap();
    let dark: Vec<_> = frame
        .views
        .iter()
        .map(|v| {
            let mut img = v.image.clone();
            let (w, h) = img.dimensions();
            for (x, y, p) in img.enumerate_pixels_mut() {
                if x > w / 5 && x < 4 * w / 5 && y > h / 5 && y < 17 * h / 20 {
                    p.0 = p.0.map(|v| v / 5);
                }
            }
            img
        })
        .collect();
    let images: Vec<_> = dark.iter().collect();
    let t = pipeline.process(&images).unwrap();
    let record = t.record(0);
    let share = t.occupancy.len() as f64 / 256f64.powi(3);
    println!("hull {share:.3} of the volume: {:?}", record.reason);
    assert_eq!(record.status, "bad_silhouette");
    let reason = record.reason.unwrap();
    assert!(reason.contains("of the working volume"), "{reason}");
    assert!(share > flexshape_track::MAX_HULL_SHARE);
    assert!(t.fit.is_none() && record.centerline.is_empty());
}
