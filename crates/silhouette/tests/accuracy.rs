//! Silhouettes against the simulator's exact masks (default scene, noise σ = 2).

use flexshape_silhouette::{BackgroundModel, BitMask, Classifier, SilhouetteSettings, Silhouetter};
use flexshape_sim::{SimConfig, Simulator};

/// Per camera and frame: object IoU, and marker (true positives, found, truth) counts.
struct Score {
    iou: Vec<f64>,
    marker_tp: usize,
    marker_found: usize,
    marker_truth: usize,
}

fn score(shadows: bool, classifier: Classifier, frames: usize) -> Score {
    let mut config = SimConfig::default();
    config.render.shadows = shadows;
    score_scene(config, classifier, frames)
}

fn score_scene(config: SimConfig, classifier: Classifier, frames: usize) -> Score {
    let sim = Simulator::new(config).unwrap();
    let backgrounds = sim.backgrounds();
    let silhouetters: Vec<Silhouetter> = backgrounds
        .iter()
        .map(|bg| {
            let model = BackgroundModel::from_frames(std::slice::from_ref(bg)).unwrap();
            Silhouetter::new(
                &model,
                SilhouetteSettings {
                    classifier: classifier.clone(),
                    ..SilhouetteSettings::default()
                },
            )
            .unwrap()
        })
        .collect();
    let mut s = Score {
        iou: Vec::new(),
        marker_tp: 0,
        marker_found: 0,
        marker_truth: 0,
    };
    for (i, pose) in sim.sweep(frames).iter().enumerate() {
        let f = sim.render(i as u64, pose).unwrap();
        for (view, sil) in f.views.iter().zip(&silhouetters) {
            let out = sil.process(&view.image).unwrap();
            let truth = BitMask::from_gray(&view.mask);
            s.iou.push(out.object.iou(&truth));
            let truth_markers = BitMask::from_gray(&view.markers);
            s.marker_tp += out.markers.and(&truth_markers).count();
            s.marker_found += out.markers.count();
            s.marker_truth += truth_markers.count();
        }
    }
    s
}

fn report(name: &str, s: &Score) -> (f64, f64, f64, f64) {
    let min = s.iou.iter().copied().fold(1.0, f64::min);
    let mean = s.iou.iter().sum::<f64>() / s.iou.len() as f64;
    let recall = s.marker_tp as f64 / s.marker_truth as f64;
    let precision = s.marker_tp as f64 / s.marker_found as f64;
    println!(
        "{name}: object IoU min {min:.4} mean {mean:.4}; markers recall {recall:.3} precision {precision:.3} ({} truth px)",
        s.marker_truth
    );
    (min, mean, recall, precision)
}

#[test]
fn default_scene_both_classifiers() {
    for (name, c) in [
        ("colour+shadow", Classifier::colour_shadow()),
        ("green matte", Classifier::green_matte()),
    ] {
        let s = score(false, c, 12);
        let (min, _, recall, precision) = report(name, &s);
        assert!(min >= 0.95, "{name}: object IoU {min:.4} < 0.95");
        assert!(
            recall >= 0.9 && precision >= 0.95,
            "{name}: markers recall {recall:.3}, precision {precision:.3}"
        );
    }
}

#[test]
fn shadows_are_rejected_by_colour_but_not_by_green_matting() {
    let colour = score(true, Classifier::colour_shadow(), 12);
    let (min, _, recall, precision) = report("shadows, colour+shadow", &colour);
    assert!(
        min >= 0.93,
        "shadow-rejecting classifier: IoU {min:.4} < 0.93"
    );
    assert!(
        recall >= 0.9 && precision >= 0.95,
        "markers recall {recall:.3}, precision {precision:.3}"
    );
    let green = score(true, Classifier::green_matte(), 12);
    let (gmin, gmean, _, _) = report("shadows, green matte", &green);
    assert!(
        gmin < 0.93 && gmean < min,
        "green matting should fail on shadows (min {gmin:.4}, mean {gmean:.4})"
    );
}

/// A silvery tube (dark grey, a strong highlight) on the green cloth: the highlight is
/// colourless where the cloth is green, lighter in red and blue and darker in green — no mix
/// of cloth and body — and the silhouette must take it in, whether it runs down the tube's
/// middle (a slit) or along its edge (a notch).
#[test]
fn a_silvery_tube_on_green_cloth_is_whole() {
    let mut worst: f64 = 1.0;
    for seed in 1..=3 {
        let mut config = SimConfig {
            catheter: flexshape_sim::Catheter::silvery(),
            seed,
            ..SimConfig::default()
        };
        config.render.seed = seed;
        let s = score_scene(config, Classifier::colour_shadow(), 10);
        worst = worst.min(report(&format!("silvery, seed {seed}"), &s).0);
    }
    // Measured: 0.931 at worst (0.834 with the highlight left out, means 0.974 and 0.965).
    assert!(worst >= 0.90, "object IoU {worst:.4} < 0.90");
}

/// The same silvery tube thin (1.2 mm radius, 3–4 px wide): no pixel is wholly covered, the
/// strict test passes only in specks, and the silhouette is followed along the loose pixels
/// near the backdrop. A soft shadow's core, as dark and as thin, is not followed: with the
/// lamp's shadows on the cloth the thick tube's silhouettes stay as they were.
#[test]
fn a_thin_silvery_tube_is_followed_along_its_loose_pixels() {
    let silvery = |seed: u64, radius: f64, shadows: bool| {
        let mut config = SimConfig {
            catheter: flexshape_sim::Catheter {
                radius,
                ..flexshape_sim::Catheter::silvery()
            },
            seed,
            ..SimConfig::default()
        };
        config.render.shadows = shadows;
        config.render.seed = seed;
        score_scene(config, Classifier::colour_shadow(), 6)
    };
    let (mut thin, mut shadowed) = (1.0f64, 1.0f64);
    for seed in 1..=3 {
        thin = thin.min(
            report(
                &format!("thin silvery, seed {seed}"),
                &silvery(seed, 1.2, false),
            )
            .0,
        );
        shadowed = shadowed.min(
            report(
                &format!("silvery, shadows, seed {seed}"),
                &silvery(seed, 3.0, true),
            )
            .0,
        );
    }
    // Measured: thin 0.89 at worst (0.33 before it was followed); the shadowed thick tube
    // 0.95 (0.84 before: a highlight's notch; following every loose pixel, near the backdrop
    // or not, took in a shadow's core: 0.78).
    assert!(thin >= 0.85, "thin: object IoU {thin:.4} < 0.85");
    assert!(
        shadowed >= 0.93,
        "shadowed: object IoU {shadowed:.4} < 0.93"
    );
}

/// Classifying only a region: inside it, exactly the whole frame's silhouette; outside it,
/// nothing.
#[test]
fn a_region_gives_the_same_pixels_inside_and_none_outside() {
    use flexshape_silhouette::Region;
    let sim = Simulator::new(SimConfig::default()).unwrap();
    let bg = &sim.backgrounds()[0];
    let model = BackgroundModel::from_frames(std::slice::from_ref(bg)).unwrap();
    let s = Silhouetter::new(&model, SilhouetteSettings::default()).unwrap();
    let frame = &sim.render(0, &sim.sweep(1)[0]).unwrap().views[0].image;
    let whole = s.process(frame).unwrap();
    // The object's bounding box, grown by 8 pixels (the closing and the colour test's
    // neighbourhood reach a pixel or two).
    let (w, h) = (whole.object.width(), whole.object.height());
    let (mut x0, mut y0, mut x1, mut y1) = (w, h, 0, 0);
    for y in 0..h {
        for x in 0..w {
            if whole.object.get(x, y) {
                (x0, y0, x1, y1) = (x0.min(x), y0.min(y), x1.max(x + 1), y1.max(y + 1));
            }
        }
    }
    assert!(x0 < x1, "the frame shows the tube");
    let around = Region {
        x0: x0.saturating_sub(8),
        y0: y0.saturating_sub(8),
        x1: x1 + 8,
        y1: y1 + 8,
    };
    let within = s.process_within(frame, &around).unwrap();
    assert_eq!(within.object, whole.object);
    assert_eq!(within.markers, whole.markers);
    // Row by row: each row's own extent of the object, grown by 8 pixels each way (and the
    // rows within 8 of the object's).
    let extent = |y: usize| {
        let xs = (0..w).filter(|&x| whole.object.get(x, y));
        xs.clone().min().zip(xs.max())
    };
    let rows = flexshape_silhouette::Rows {
        y0: around.y0,
        columns: (around.y0..(y1 + 8).min(h))
            .map(|y| {
                let near = y.saturating_sub(8)..(y + 9).min(h);
                let (lo, hi) = near
                    .filter_map(extent)
                    .fold((w, 0), |(lo, hi), (a, b)| (lo.min(a), hi.max(b + 1)));
                lo.saturating_sub(8)..(hi + 8).min(w)
            })
            .collect(),
    };
    let covered: usize = rows.columns.iter().map(|c| c.len()).sum();
    assert!(covered < (around.x1 - around.x0) * (around.y1 - around.y0));
    let by_rows = s.process_within(frame, &rows).unwrap();
    assert_eq!(by_rows.object, whole.object);
    assert_eq!(by_rows.markers, whole.markers);
    // Rows that miss part of the tube leave that part out, and only that part.
    let mut half = rows.clone();
    for c in &mut half.columns[..rows.columns.len() / 2] {
        *c = 0..0;
    }
    let cut = s.process_within(frame, &half).unwrap();
    assert!(cut.object.count() > 0 && cut.object.count() < whole.object.count());
    // A region away from the tube: nothing.
    let away = if x0 > 40 {
        Region {
            x0: 0,
            y0: 0,
            x1: x0 / 2,
            y1: h,
        }
    } else {
        Region {
            x0: (x1 + w) / 2,
            y0: 0,
            x1: w,
            y1: h,
        }
    };
    assert_eq!(s.process_within(frame, &away).unwrap().object.count(), 0);
}
