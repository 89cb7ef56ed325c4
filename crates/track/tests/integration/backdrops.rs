//! Backdrops and tubes we did not choose: a light grey tube over white paper, under a lamp that
//! casts its soft shadow on the paper (the tube darkens the paper without changing its
//! chromaticity, as its shadow does; the colour classifier tells them apart by the tube's sharp
//! outline); a silvery one; cloth whose folds moved after the background was captured. Every
//! frame the chain calls `ok` must be right.

use crate::common;

use flexshape_shape::Status;
use flexshape_sim::{Catheter, CatheterPose, RenderSettings, SimConfig, Simulator};
use flexshape_track::Pipeline;
use image::RgbImage;
use nalgebra::Point3;

/// The grey-tube scene: body reflectance 0.5 (grey), paper 0.9, shadows.
fn grey_on_white() -> SimConfig {
    let defaults = SimConfig::default();
    SimConfig {
        render: RenderSettings {
            shadows: true,
            backdrop_albedo: [0.9, 0.9, 0.9],
            ..defaults.render
        },
        catheter: Catheter {
            albedo: [0.5, 0.5, 0.5],
            ..defaults.catheter
        },
        ..defaults
    }
}

#[test]
fn a_grey_tube_on_white_paper_is_not_a_shadow() {
    let (sim, pipeline) = common::chain_of(grey_on_white());
    // The same chain without the outline test: shadow-like regions never count.
    let without = with_silhouette(
        &sim,
        toml::toml! { classifier = { kind = "colour_shadow", edge = 0.0 } },
    );
    let poses = sim.sweep(10);
    let (ok, _) = run(&sim, &pipeline, &poses);
    let (ok_without, _) = run(&sim, &without, &poses);
    println!("{ok} of 10 ok ({ok_without} without the outline test)");
    // Measured: 10 and 8 (8 and 6 before a tube across a lamp's long soft shadow was told
    // from it by the stretch of its own sharp outline; all right: the shadow carved no
    // second object there). A frame
    // whose silhouettes lost the paper-grey tube's proximal part, fitted with a cap 2.2 mm
    // RMS off the truth, was `ok` without the outline test until the check looked beyond the
    // cap (`goes_on`); since the fit is lengthened along what the images show there, it is
    // `ok` and right. Without the outline test 3 were `ok` until the silhouettes followed the
    // tube along its loose pixels tinted beyond the noise (the lamp's shadow keeps the
    // paper's chromaticity; the shaded tube does not, by a little).
    assert!(ok >= 9 && ok_without < ok, "{ok} / {ok_without}");
}

#[test]
fn a_background_that_follows_the_backdrop_never_takes_the_tubes_shadow() {
    // A lit grey tube (0.6) on white paper, the lamp's shadow moving with it over ten poses
    // far apart. A frame whose grey tube the silhouettes partly lose is not right, and its
    // background follows; the tube's shadow on the paper is light, not backdrop: taken into
    // the background it stayed where the tube had left, and later frames lost the tube over
    // it. Measured: 4 of 10 ok when the shadows were taken in, 7 as captured, 7 followed
    // without them. Since a tube across its long soft shadow is told from it by its own
    // sharp outline (`shade`), all 10 are right and none follows: this guards the sequence;
    // what a followed background leaves out is `Silhouetter::shadowed`'s own test.
    let config = SimConfig {
        catheter: Catheter {
            albedo: [0.6, 0.6, 0.6],
            ..Catheter::default()
        },
        seed: 3,
        render: RenderSettings {
            seed: 3,
            ..grey_on_white().render
        },
        ..grey_on_white()
    };
    let (sim, pipeline) = common::chain_of(config);
    let poses = sim.sweep(10);
    let (ok, updated) = run(&sim, &pipeline, &poses);
    let (ok_fixed, _) = run(&sim, &without_adapting(&sim), &poses);
    println!("{ok} of 10 ok, updated at {updated:?} ({ok_fixed} as captured)");
    assert!(ok >= ok_fixed && ok >= 9, "{ok} / {ok_fixed}");
}

/// A silvery tube (grey, with a strong sharp highlight where it reflects the lamp) over the
/// same white paper: the highlight is brighter than the paper and colourless, the body darker
/// and colourless, its shadow beside it. Every frame the chain calls `ok` must be right.
#[test]
fn a_silvery_tube_on_white_paper_is_right_or_says_so() {
    let grey = grey_on_white();
    let (sim, pipeline) = common::chain_of(SimConfig {
        catheter: Catheter {
            gloss: flexshape_sim::Gloss {
                strength: 1.0,
                shininess: 20.0,
            },
            ..grey.catheter
        },
        ..grey
    });
    let (ok, _) = run(&sim, &pipeline, &sim.sweep(10));
    println!("{ok} of 10 ok");
    assert!(ok >= 4, "{ok}");
}

/// A silvery tube (a darker grey, 0.35, with a highlight of strength 0.9) on white paper
/// without a lamp's shadow: where the highlight matches the paper, the silhouettes have slits
/// along the tube, and the hull carved from them is a hollow tube whose cross-sections fall
/// into pieces (`ambiguous`, no shape). Filled as holes thinner than the tube, they give the
/// shape.
#[test]
fn a_silvery_tubes_highlight_does_not_hollow_it_out() {
    let defaults = SimConfig::default();
    let (sim, pipeline) = common::chain_of(SimConfig {
        render: RenderSettings {
            backdrop_albedo: [0.9, 0.9, 0.9],
            seed: 1,
            ..defaults.render
        },
        catheter: Catheter::silvery(),
        seed: 1,
        ..defaults
    });
    let slit = with_silhouette(&sim, toml::toml! { fill_holes = false });
    let poses = sim.sweep(10);
    let (ok, _) = run(&sim, &pipeline, &poses);
    let (ok_slit, _) = run(&sim, &slit, &poses);
    println!("{ok} of 10 ok ({ok_slit} with the highlight's slits left open)");
    // Measured: 10 and 8 (frames 3 and 8 `ambiguous`). Frame 6's tip band is read against
    // the dark body beside it, not the whole body's mean with the highlight in it (which read
    // the dark body as half tape: `bands_missing`).
    assert!(ok >= 10 && ok_slit <= 8, "{ok} / {ok_slit}");
}

/// A thin silvery tube (1.2 mm radius, grey 0.35 with a highlight of 0.9) on white paper at
/// 640×480, 3–4 px wide: where its highlight or its grey matches the paper, a camera's
/// silhouette loses a stretch of it, and the hull carved falls into pieces that lie end to end
/// (`ambiguous`, "two separate objects", no shape). Chained across their gaps, the tube is
/// fitted from the pieces and kept where every camera's image shows its boundaries across
/// each gap. Measured (3 seeds × 4 frames): 12 of 12 `ok`, every one right by the third
/// wave's bounds (7 when this test was written; 2 before chaining). A tube with 8 mm taken
/// out of every image (two tubes end to end, a real gap) is refused on every frame.
#[test]
fn a_thin_tube_in_pieces_is_chained_across_the_gaps_its_images_show() {
    let ok: usize = [1, 2, 3]
        .map(|seed| {
            oks(
                thin_silvery_on_white(seed),
                4,
                &format!("seed {seed}"),
                true,
            )
        })
        .iter()
        .sum();
    println!("{ok} of 12 ok");
    assert!(ok >= 7, "{ok} of 12");

    // A real gap: 8 mm of a tube taken out of every camera's image, two tubes end to end. The
    // hull's two pieces chain, and the tube fitted through them explains every image (it was
    // `ok` on frame 1 before its outline across the gap was asked for); no image shows it
    // there.
    let (sim, pipeline) = common::chain_of(SimConfig::default());
    let backgrounds = sim.backgrounds();
    let mut unshown = 0;
    for (i, pose) in sim.sweep(4).iter().enumerate() {
        let frame = sim.render(i as u64, pose).unwrap();
        let line: Vec<Point3<f64>> = frame.truth.centerline.iter().map(|&p| p.into()).collect();
        let images: Vec<RgbImage> = frame
            .views
            .iter()
            .zip(&sim.rig().cameras)
            .zip(&backgrounds)
            .map(|((v, cam), bg)| erased(&v.image, bg, &cam.camera, &line, 185.0..193.0))
            .collect();
        let t = pipeline
            .process(&images.iter().collect::<Vec<_>>())
            .unwrap();
        println!("a real gap, frame {i}: {:?}", t.shape.status);
        assert_ne!(t.shape.status, Status::Ok, "frame {i}");
        unshown += usize::from(matches!(&t.shape.status,
            Status::Ambiguous { reason } if reason.contains("do not show its outline there")));
    }
    assert!(unshown >= 1, "{unshown}");
}

/// The thin silvery tube over a white plate printed with black dots 6–7 px across (issue 45,
/// thin tubes over clutter): grey on grey, the tube darkens the plate without changing its
/// chromaticity, as a shadow does, and where it crosses a dot it is lighter than the backdrop.
/// Its silhouette was taken for shadow along most of its length — read one pixel in from its
/// outline, its step in brightness reached its lit middle, not its dark limb — and the hull
/// carved two objects; fitted, its sides read outward of the tube by 0.3 px (its glossy rim,
/// darker than any pixel reads, is finer than a pixel) and every frame was refused. Every
/// `ok` must be right; a camera whose calibration is 1.5 px off is never `ok`. Measured
/// (3 seeds × 4 frames): 8 of 12 `ok` (none before), the rest `ambiguous`, two objects
/// carved where a stretch of the tube's silhouette is still lost in one camera.
#[test]
fn a_thin_tube_over_a_dotted_plate_is_right_or_says_so() {
    let over_dots = |seed: u64, error_px: f64| {
        let mut config = thin_silvery_on_white(seed);
        config.render.plate = Some(flexshape_sim::Plate::new(flexshape_sim::PlatePattern::Dots));
        config.rig.calibration_error_px = error_px;
        config.rig.miscalibrated = vec![0];
        config
    };
    let (mut ok, mut ok_off) = (0, 0);
    for seed in [1, 2, 3] {
        ok += oks(over_dots(seed, 0.0), 4, &format!("seed {seed}"), true);
        let off = format!("seed {seed}, a camera 1.5 px off");
        ok_off += oks(over_dots(seed, 1.5), 4, &off, false);
    }
    println!("{ok} of 12 ok; {ok_off} ok with a camera 1.5 px off");
    assert!(ok >= 6 && ok_off == 0, "{ok} of 12; {ok_off}");
}

/// The thin silvery tube over the dotted plate, frame 7 of seeds 2 and 3: the hull falls into
/// two pieces 5 mm apart where the tube crosses dots of its own grey in two cameras, whose
/// samples there show it neither way; the third camera finds its outline all across the gap
/// (4 of 4 samples). Chained through it, the tube is `ok` and right: where it lies along that
/// camera's rays the pieces on either side hold, and the fit's 1-σ there says so. (Asked of
/// two cameras, both frames were `ambiguous`: "two separate objects".) A real gap, which
/// every camera that sees it shows as backdrop, is refused in
/// `a_thin_tube_in_pieces_is_chained_across_the_gaps_its_images_show`.
#[test]
fn a_gap_one_camera_shows_and_the_others_cannot_is_chained() {
    for seed in [2, 3] {
        let mut config = thin_silvery_on_white(seed);
        config.render.plate = Some(flexshape_sim::Plate::new(flexshape_sim::PlatePattern::Dots));
        let (sim, pipeline) = common::chain_of(config);
        let pose = &sim.sweep(10)[7];
        let frame = sim.render(7, pose).unwrap();
        let images: Vec<_> = frame.views.iter().map(|v| &v.image).collect();
        let t = pipeline.process(&images).unwrap();
        let e = common::errors(&frame.truth, &sim, &t.shape);
        println!("seed {seed}, frame 7: {:?}, {e:?}", t.shape.status);
        assert_eq!(t.shape.status, Status::Ok, "seed {seed}");
        assert!(e.unwrap().within(Default::default()), "seed {seed}: {e:?}");
    }
}

/// How many of `frames` poses of `config`'s sweep the whole chain calls `ok` (`what` names
/// them in the log); with `right`, each `ok` must be right by the truth.
fn oks(config: SimConfig, frames: usize, what: &str, right: bool) -> usize {
    let (sim, pipeline) = common::chain_of(config);
    let mut ok = 0;
    for (i, pose) in sim.sweep(frames).iter().enumerate() {
        let frame = sim.render(i as u64, pose).unwrap();
        let images: Vec<_> = frame.views.iter().map(|v| &v.image).collect();
        let t = pipeline.process(&images).unwrap();
        println!("{what}, frame {i}: {:?}", t.shape.status);
        if t.shape.status != Status::Ok {
            continue;
        }
        ok += 1;
        if right {
            let e = common::errors(&frame.truth, &sim, &t.shape).unwrap();
            assert!(
                e.within(Default::default()),
                "{what}, frame {i}: ok, {:.3} mm RMS, tip {:.2} mm",
                e.centerline_rms,
                e.tip
            );
        }
    }
    ok
}

/// The thin silvery tube on white paper of seed `seed`, no lamp.
fn thin_silvery_on_white(seed: u64) -> SimConfig {
    let defaults = SimConfig::default();
    SimConfig {
        render: RenderSettings {
            backdrop_albedo: [0.9, 0.9, 0.9],
            seed,
            ..defaults.render
        },
        catheter: Catheter {
            radius: 1.2,
            ..Catheter::silvery()
        },
        seed,
        ..defaults
    }
}

/// `image` with the tube along `line` (world mm, proximal first) between `arc` mm along it
/// replaced by the background `bg`, 8 px round each point.
fn erased(
    image: &RgbImage,
    bg: &RgbImage,
    cam: &flexshape_camera::Camera,
    line: &[Point3<f64>],
    arc: std::ops::Range<f64>,
) -> RgbImage {
    let mut out = image.clone();
    let (w, h) = (image.width() as i64, image.height() as i64);
    let mut s = 0.0;
    for pair in line.windows(2) {
        s += (pair[1] - pair[0]).norm();
        if !arc.contains(&s) {
            continue;
        }
        let c = cam.project(&pair[1]).unwrap().pixel;
        let (cx, cy) = (c.x.round() as i64, c.y.round() as i64);
        for y in (cy - 8).max(0)..(cy + 9).min(h) {
            for x in (cx - 8).max(0)..(cx + 9).min(w) {
                if (x - cx).pow(2) + (y - cy).pow(2) <= 64 {
                    out.put_pixel(x as u32, y as u32, *bg.get_pixel(x as u32, y as u32));
                }
            }
        }
    }
    out
}

/// The chain for `sim` with `[processing.silhouette]` replaced by `table`.
fn with_silhouette(sim: &Simulator, table: toml::Table) -> Pipeline {
    let mut rig = sim.rig().clone();
    rig.processing.insert("silhouette".into(), table.into());
    let backgrounds: Vec<_> =
        flexshape_silhouette::BackgroundModel::each(&sim.backgrounds()).unwrap();
    Pipeline::new(&rig, &backgrounds, &rig.volume).unwrap()
}

/// The chain for `sim` with its backgrounds as captured, never following the backdrop.
fn without_adapting(sim: &Simulator) -> Pipeline {
    with_silhouette(sim, toml::toml! { adapt = false })
}

/// The frames of `poses` through `pipeline` (the whole chain each): the `ok` count, each `ok`
/// frame checked against truth (within 0.1 mm RMS and 0.4 mm at the tip), and the frames whose
/// background was updated.
fn run(sim: &Simulator, pipeline: &Pipeline, poses: &[CatheterPose]) -> (usize, Vec<usize>) {
    let (mut ok, mut updated) = (0, Vec::new());
    for (i, pose) in poses.iter().enumerate() {
        let frame = sim.render(i as u64, pose).unwrap();
        let images: Vec<_> = frame.views.iter().map(|v| &v.image).collect();
        let t = pipeline.process(&images).unwrap();
        let record = t.record(i as u64);
        let changes: Vec<_> = record
            .background_updated
            .iter()
            .map(|u| (u.camera.as_str(), u.changed_px))
            .collect();
        println!(
            "frame {i}: {} {:?}, updated {changes:?}",
            record.status, record.reason
        );
        if !changes.is_empty() {
            updated.push(i);
        }
        if record.status == "ok" {
            ok += 1;
            let e = common::errors(&frame.truth, sim, &t.shape).unwrap();
            let (rms, tip) = (e.centerline_rms, e.tip);
            println!("  {rms:.3} mm RMS, tip {tip:.2} mm");
            assert!(rms < 0.1 && tip < 0.4, "frame {i}: {rms} mm, tip {tip} mm");
        }
    }
    (ok, updated)
}

#[test]
fn folds_that_moved_since_the_background_was_captured_are_followed() {
    // Folds where they were at the capture: nothing to follow, no background changes.
    let (sim, pipeline) = common::chain_of(common::folds_moved(0.0));
    let (ok, updated) = run(&sim, &pipeline, &sim.sweep(3));
    assert!(
        ok == 3 && updated.is_empty(),
        "{ok}, updated at {updated:?}"
    );
    // Folds slid 20 mm; poses far apart (every frame through the whole chain). Measured: as
    // captured, no frame is ok (the old valleys break the hull); followed, all six within
    // 0.042 mm. (At 10 mm the boundaries, read by hue, already explain every frame as captured.)
    let (sim, pipeline) = common::chain_of(common::folds_moved(20.0));
    let (ok, updated) = run(&sim, &pipeline, &sim.sweep(6));
    let (ok_fixed, _) = run(&sim, &without_adapting(&sim), &sim.sweep(6));
    println!("20 mm: {ok} of 6 ok, updated at {updated:?} ({ok_fixed} as captured)");
    assert!(
        ok == 6 && !updated.is_empty() && ok_fixed <= 3,
        "{ok} / {ok_fixed}"
    );
    // Slid half their spacing (the old valleys bright stripes over a third of every image),
    // filmed at 120 Hz: the first frame's fit finds the tube, the backgrounds follow.
    let (sim, pipeline) = common::chain_of(common::folds_moved(35.0));
    let (ok, updated) = run(&sim, &pipeline, &sim.motion(8, 120.0));
    let (ok_fixed, _) = run(&sim, &without_adapting(&sim), &sim.motion(3, 120.0));
    println!("35 mm: {ok} of 8 ok, updated at {updated:?} ({ok_fixed} of 3 as captured)");
    assert!(
        ok == 8 && updated.first() == Some(&0) && ok_fixed == 0,
        "{ok} / {ok_fixed}"
    );
}
