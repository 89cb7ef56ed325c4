//! Scenes built to break assumptions: soft shadows on the backdrops, occluders hiding parts of
//! the views, a strongly distorting lens, backdrops of the tube's hue or printed under it. Every `ok` frame must still be right.

use crate::common;

use common::*;
use flexshape_shape::{ShapeEstimator, ShapeSettings, Status};
use flexshape_silhouette::Silhouette;
use flexshape_sim::{Plate, PlatePattern, RenderSettings, SimConfig, SimFrame, SimRigConfig};
use nalgebra::Point3;

#[test]
fn shadows_occluders_and_strong_distortion_never_give_a_wrong_ok() {
    let config = SimConfig {
        rig: SimRigConfig {
            // A wide-angle lens: 6 % barrel distortion at the image corners.
            distortion: [-0.32, 0.14, 0.0008, -0.0005, -0.03],
            ..SimRigConfig::default()
        },
        render: RenderSettings {
            shadows: true,
            ..RenderSettings::default()
        },
        occluders: 2,
        seed: 5,
        ..SimConfig::default()
    };
    let chain = Chain::new(config);
    let sim = &chain.sim;
    let mut ok = 0;
    for (n, pose) in sim.sweep(12).iter().enumerate() {
        let b = chain.run(sim.render(n as u64, pose).unwrap());
        let (rms, tip) = b.fitted_errors(sim);
        println!(
            "frame {n:2}: {:?}, rms {rms:.3} mm (hull {:.3}), tip {tip:.2} mm",
            b.fitted.status,
            centerline_rms(&b.frame.truth, sim, &b.hull.points)
        );
        if let Status::Inconsistent { reason } = &b.fitted.status {
            // The tube is darker than this backdrop: no word of a lighter one.
            assert!(!reason.contains("lighter than the backdrop"), "{reason}");
        }
        if b.fitted.status == Status::Ok {
            ok += 1;
            assert!(rms <= 0.12, "frame {n}: ok with rms {rms:.3} mm");
            assert!(tip <= 0.3, "frame {n}: ok with the tip {tip:.2} mm off");
        }
    }
    // Measured: 9 of 12 ok (rms 0.029–0.077 mm, tips ≤ 0.19 mm); an occluder cutting the hull
    // short gives `inconsistent`, one splitting it `ambiguous`, and one frame whose top view
    // has a shadow along the tube fails the p90 check (0.35 px) though it is 0.07 mm right.
    println!("{ok} of 12 ok");
    assert!(ok >= 6, "only {ok} of 12 ok");
}

/// A tip pointing at a camera lies, in its image, just beside the outline of the tube behind
/// it (seed 15's motion, frame 38, camera cam0). Where the two parts' edges are less than a
/// pixel apart they merge in the image, and the boundary found for the near part's outline
/// was the pair's: residuals grew along it to 0.95 px, the outline's p90 reached 0.28 px and
/// the right shape (0.08 mm RMS) was `inconsistent`. Outline points with another part's edge
/// that close beside them are left out, as those with it farther out always were.
#[test]
fn a_part_just_beside_another_outline_does_not_move_it() {
    let chain = Chain::new(SimConfig {
        seed: 15,
        ..SimConfig::default()
    });
    let sim = &chain.sim;
    let pose = &sim.motion(60, 120.0)[38];
    let b = chain.run(sim.render(38, pose).unwrap());
    let fit = b.fit.as_ref().unwrap();
    let rms = centerline_rms(&b.frame.truth, sim, &b.fitted.points);
    for c in &fit.cameras {
        println!(
            "{}: {}/{} found, residual {:.3} px, p90 {:.3} px",
            c.camera, c.found, c.samples, c.residual_px, c.p90_px
        );
    }
    println!("{:?}, rms {rms:.3} mm", b.fitted.status);
    assert_eq!(b.fitted.status, Status::Ok);
    // Measured: cam0 0.074 px RMS (0.209 before), p90 at most 0.15 px in every camera; the
    // centerline 0.045 mm RMS (0.079).
    for c in &fit.cameras {
        assert!(c.residual_px < 0.1, "{}: {:.3} px", c.camera, c.residual_px);
        assert!(c.p90_px < 0.2, "{}: p90 {:.3} px", c.camera, c.p90_px);
    }
    assert!(rms < 0.06, "rms {rms:.3} mm");
}

/// A lit tube darkens toward its outline, and against a near-black backdrop its limbs fade
/// into it: read against the colour inside the outline, every boundary of the blue tube was
/// found 0.6–0.9 px inside the true one, the fitted radius shrank to 2.1 mm for 3 and the
/// centerline was 0.40 mm RMS off (every frame `inconsistent`). Read by hue, the shape is
/// right; the outline stays noisier than on a light backdrop, and every `ok` frame is right.
#[test]
fn a_tube_whose_limbs_fade_into_a_dark_backdrop_is_placed_by_its_hue() {
    let chain = Chain::new(SimConfig {
        render: RenderSettings {
            backdrop_albedo: [0.1, 0.1, 0.1],
            ..RenderSettings::default()
        },
        ..SimConfig::default()
    });
    let sim = &chain.sim;
    let mut errors = Vec::new();
    for (n, pose) in sim.sweep(6).iter().enumerate() {
        let b = chain.run(sim.render(n as u64, pose).unwrap());
        let (rms, tip) = b.fitted_errors(sim);
        println!(
            "frame {n}: {:?}, rms {rms:.3} mm, tip {tip:.2} mm",
            b.fitted.status
        );
        // A frame that is not `ok` says why its outline is faint.
        if let Status::Inconsistent { reason } = &b.fitted.status {
            assert!(
                reason.contains("lighter than the backdrop along"),
                "{reason}"
            );
        }
        if b.fitted.status == Status::Ok {
            assert!(
                rms <= 0.12 && tip <= 0.3,
                "frame {n}: ok with rms {rms:.3}, tip {tip:.2}"
            );
        }
        errors.push(rms);
    }
    // Measured: median 0.045 mm, worst 0.049; 3 of 6 ok, the rest a p90 of 0.26–0.28 px.
    let (median, worst) = (median(&errors), errors.iter().copied().fold(0.0, f64::max));
    assert!(
        median <= 0.06 && worst <= 0.1,
        "median {median:.3} mm, worst {worst:.3}"
    );
}

/// A blue tube on a lighter cloth of nearly its hue (7° apart): where the lit tube is as
/// bright as the cloth the silhouette leaves it out — a stripe down its middle, or all of it
/// but a dark limb — while the boundary search, reading the colour along whole lines, still
/// finds both sides. Across 3 seeds every `ok` is right; a camera turned by 0.2° is still
/// refused on every frame.
#[test]
fn a_tube_on_a_backdrop_of_its_hue_is_placed_by_its_outline() {
    let scene = |seed: u64| cloth_of_its_hue(seed, RenderSettings::default().noise_sigma);
    let (mut tally, mut completed) = (Tally::default(), 0);
    for seed in [1, 2, 3] {
        let chain = Chain::new(scene(seed));
        let sim = &chain.sim;
        for (n, pose) in sim.sweep(8).iter().enumerate() {
            let b = chain.run(sim.render(n as u64, pose).unwrap());
            let (rms, tip) = b.fitted_errors(sim);
            let right = rms <= 0.15 && tip <= 0.3;
            let fit = b.fit.as_ref();
            let iou: Vec<_> = fit
                .map(|f| f.cameras.iter().map(|c| (c.iou, c.iou_outlined)).collect())
                .unwrap_or_default();
            println!(
                "seed {seed} frame {n}: {:?}, rms {rms:.3} mm, tip {tip:.2} mm, IoU {iou:.2?}",
                b.fitted.status
            );
            completed += usize::from(iou.iter().any(|(_, o)| o.is_some()));
            let which = format!("seed {seed} frame {n}: rms {rms:.3} mm, tip {tip:.2} mm");
            tally.add(&b.fitted.status, right, &which);
        }
    }
    let Tally {
        ok,
        right_refused: refused,
    } = tally;
    println!("{ok} of 24 ok, {refused} right but refused, {completed} with a silhouette completed");
    // Measured: 21 of 24 ok, 1 right but refused (the outline's 90th percentile 0.28 px),
    // the tips 0.12–0.22 mm off; 13 frames had a camera's silhouette missing part of the
    // tube the outline found (IoU 0.64–0.74, 0.97–0.98 completed). Before, read against the
    // colour inside, the boundary lay 0.2 px outside the dark rim (the radius 5 % large, the
    // tips 0.22–0.36 mm short) and an `ok` frame's tip was off by more than 0.3 mm; those
    // silhouettes failed the IoU limit of 0.75. Since the silhouettes take in the lit tube's
    // pixels of the tube's hue at the cloth's brightness beside its strict ones, 4 frames
    // still need a camera's silhouette completed (IoU 0.71–0.73, then 0.97–0.98). Since an
    // end the images show going on is lengthened along them (a proximal shaft one camera's
    // silhouette lost stopped the hull short), 23 of 24 are ok, 6 completed. Since the
    // silhouettes follow the tube along its loose pixels tinted beyond the noise, none needs
    // completing (IoU 0.78–0.98), still 23 of 24 `ok`; `check`'s unit tests hold the
    // completion to its definition.
    assert!(
        ok >= 22 && refused <= 2,
        "{ok} ok, {refused} right but refused"
    );

    never_ok_with_a_camera_turned(scene(1), 8);
}

/// A dark tube (albedo 0.08) over a white plate printed with black dots 8 mm across at a 20 mm
/// pitch (6–7 px wide, about as wide as the tube): where a dot lies behind the tube's outline
/// the tube differs from it by less than the least contrast a boundary is read at, so those
/// outline samples are unseen, neither found nor missed; beside a dot's edge the coverage is
/// read pixel by pixel against each pixel's backdrop. Measured: 18 of 18 `ok` (0.040–0.054
/// mm RMS, tips ≤ 0.10 mm), 2,034 outline samples unseen. Without unseen samples the boundary
/// search found the dots' edges behind the tube: 1 of 18 `ok`, 17 right but refused. A
/// camera turned by 0.2° is still refused on every frame.
#[test]
fn a_dark_tube_over_a_printed_dot_plate_is_placed_where_the_plate_shows_it() {
    let scene = |seed: u64| SimConfig {
        render: RenderSettings {
            plate: Some(Plate::new(PlatePattern::Dots)),
            ..RenderSettings::default()
        },
        catheter: flexshape_sim::Catheter {
            albedo: [0.08, 0.08, 0.09],
            ..Default::default()
        },
        seed,
        ..SimConfig::default()
    };
    let (mut tally, mut unseen) = (Tally::default(), 0);
    for seed in [1, 2, 3] {
        let chain = Chain::new(scene(seed));
        let sim = &chain.sim;
        for (n, pose) in sim.sweep(6).iter().enumerate() {
            let b = chain.run(sim.render(n as u64, pose).unwrap());
            let (rms, tip) = b.fitted_errors(sim);
            let right = rms <= 0.15 && tip <= 0.3;
            unseen += b
                .fit
                .iter()
                .flat_map(|f| &f.cameras)
                .map(|c| c.unseen)
                .sum::<usize>();
            let which = format!("seed {seed} frame {n}: rms {rms:.3} mm, tip {tip:.2} mm");
            println!("{which}: {:?}", b.fitted.status);
            tally.add(&b.fitted.status, right, &which);
        }
    }
    let Tally { ok, right_refused } = tally;
    println!("{ok} of 18 ok, {right_refused} right but refused, {unseen} outline samples unseen");
    assert!(
        ok >= 16 && right_refused <= 2,
        "{ok} ok, {right_refused} right but refused"
    );
    assert!(unseen > 0);

    never_ok_with_a_camera_turned(scene(1), 6);
}

/// The default dark-blue tube over a chessboard plate (20 mm squares). Over a black square
/// the tube's limb fades into it: the backdrop loses only 6–15 grey levels across the tube's
/// hue there, against about 150 over a white square, and its boundaries scatter three times
/// as far (0.2 px against 0.07). Each boundary's residual is held to its own scatter, from
/// the floor and the noise over its contrast, both read from the outline. Measured: 15 of 18
/// `ok` (0.045–0.069 mm RMS, tips ≤ 0.16 mm), the boundaries' scatter 0.04–0.45 px; the 3
/// right but refused have a free end whose outline a printed edge pulls 3 px off at several
/// samples. With one scatter for the whole outline (the median's), 5 of 30 frames tracked
/// were `ok` (25 of 30 now), the rest right but refused, a tenth of the outline 0.31–0.46 px
/// off against limits of 0.28–0.34. A camera turned by 0.2° is still refused on every frame
/// (15–41 % of an outline beyond its limits, or its free end 0.70 px off).
#[test]
fn a_tube_over_a_chessboard_is_held_to_each_boundarys_own_scatter() {
    let scene = |seed: u64| SimConfig {
        render: RenderSettings {
            plate: Some(Plate::new(PlatePattern::Chessboard)),
            ..RenderSettings::default()
        },
        seed,
        ..SimConfig::default()
    };
    let mut tally = Tally::default();
    let mut range = [f64::INFINITY, 0.0f64];
    for seed in [1, 2, 3] {
        let chain = Chain::new(scene(seed));
        let sim = &chain.sim;
        for (n, pose) in sim.sweep(6).iter().enumerate() {
            let b = chain.run(sim.render(n as u64, pose).unwrap());
            let (rms, tip) = b.fitted_errors(sim);
            let right = rms <= 0.15 && tip <= 0.3;
            for c in b.fit.iter().flat_map(|f| &f.cameras) {
                range = [
                    range[0].min(c.noise_range_px[0]),
                    range[1].max(c.noise_range_px[1]),
                ];
            }
            let which = format!("seed {seed} frame {n}: rms {rms:.3} mm, tip {tip:.2} mm");
            println!("{which}: {:?}", b.fitted.status);
            tally.add(&b.fitted.status, right, &which);
        }
    }
    let Tally { ok, right_refused } = tally;
    println!(
        "{ok} of 18 ok, {right_refused} right but refused; boundaries' scatter {:.2}–{:.2} px",
        range[0], range[1]
    );
    assert!(
        ok >= 14 && right_refused <= 4,
        "{ok} ok, {right_refused} right but refused"
    );
    // The faint boundaries were told from the clear ones.
    assert!(range[1] > 2.0 * range[0], "{range:?}");

    never_ok_with_a_camera_turned(scene(1), 6);
}

/// A thin silvery tube (1.2 mm radius, 3–4 px wide at 640×480; grey 0.35 with a strong
/// highlight) on the green cloth, three cameras. No pixel of it is wholly covered: half
/// covered, it is as dark as a shadow and reaches the strict test only in specks, so the
/// silhouettes followed it only as far as the specks did (IoU 0.33 at worst) and carved two
/// objects; and its boundaries, projected on the colour read inside (its highlight or its far
/// rim), were read up to half a pixel off. Followed along its loose pixels near the backdrop,
/// and unmixed by hue (grey keeps its hue in its highlight): measured 12 of 12 `ok`
/// (0.027–0.040 mm RMS, tips ≤ 0.12 mm); before, 0 of 30 tracked frames were `ok`, half
/// without a shape. A camera turned by 0.2° is still refused on every frame.
#[test]
fn a_thin_silvery_tube_is_followed_whole_and_read_through_its_highlight() {
    let scene = |seed: u64| SimConfig {
        catheter: flexshape_sim::Catheter {
            radius: 1.2,
            ..flexshape_sim::Catheter::silvery()
        },
        seed,
        ..SimConfig::default()
    };
    let tally = four_frames_of_three_seeds(scene, |chain, frame| chain.run(frame));
    let Tally { ok, right_refused } = tally;
    println!("{ok} of 12 ok, {right_refused} right but refused");
    assert!(
        ok >= 11 && right_refused <= 1,
        "{ok} ok, {right_refused} right but refused"
    );

    never_ok_with_a_camera_turned(scene(1), 4);
}

/// A concentric-tube robot as a lab films it (issue 45's real footage, simulated): a dark outer
/// tube (3 mm radius, albedo 0.08) around a thin silvery inner one (1.2 mm, its last 70 mm),
/// crossing a white plate printed with black dots on cloth whose folds slid 8 mm after the
/// backgrounds were taken, two 1280×720 cameras 90° apart. Measured (3 seeds × 4 frames): 8
/// of 12 `ok`, every one right (0.017–0.048 mm RMS); 2 right but refused (the cameras pin a
/// stretch along their epipolar plane down only to 0.16 mm; the tip along a camera's line of
/// sight), 2 refused and off (the tip hidden in a view; a stretch in the epipolar plane).
/// Tracked by `flexshape track`, 3 seeds × 10 frames: 25 of 30 `ok`, 0 before outline samples
/// against the dots could be unseen. (A camera turned by a fraction of a degree is not a test
/// here: two cameras explain their images with the shape displaced, README "Positions are as
/// good as the calibration"; the three-camera scenes refuse it.)
#[test]
fn a_concentric_tube_robot_over_a_dot_plate_is_found_by_two_cameras() {
    let scene = concentric_tube_robot;
    let tally = four_frames_of_three_seeds(scene, |chain, frame| chain.run_two_views(frame).0);
    let Tally { ok, right_refused } = tally;
    println!("{ok} of 12 ok, {right_refused} right but refused");
    assert!(
        ok >= 7 && right_refused <= 3,
        "{ok} ok, {right_refused} right but refused"
    );
}

/// The concentric-tube robot of [`a_concentric_tube_robot_over_a_dot_plate_is_found_by_two_cameras`].
fn concentric_tube_robot(seed: u64) -> SimConfig {
    SimConfig {
        rig: SimRigConfig {
            cameras: 2,
            width: 1280,
            height: 720,
            focal: 1600.0,
            ..SimRigConfig::default()
        },
        render: RenderSettings {
            plate: Some(Plate::new(PlatePattern::Dots)),
            fold_depth: 0.3,
            fold_shift_mm: 8.0,
            ..RenderSettings::default()
        },
        catheter: flexshape_sim::Catheter {
            radius: 1.2,
            radius_steps: vec![flexshape_curve::RadiusStep {
                from_tip_mm: 70.0,
                radius_mm: 3.0,
            }],
            outer: Some(flexshape_sim::Material {
                albedo: [0.08, 0.08, 0.09],
                gloss: flexshape_sim::Gloss {
                    strength: 0.3,
                    shininess: 30.0,
                },
            }),
            ..flexshape_sim::Catheter::silvery()
        },
        seed,
        ..SimConfig::default()
    }
}

/// Where two cameras pin a stretch of the tube down only loosely, the fit's own 1-σ across the
/// tube says how loosely, and a frame is `ambiguous` only when that is looser than the
/// 0.15 mm an `ok` claims. Measured on the concentric-tube robot, 3 seeds × 10 frames: the
/// ok frames' σ 0.022–0.101 mm, their centerlines 0.016–0.048 mm RMS from the truth. Seed 1
/// frame 9 (σ up to 0.101 mm, 0.039 mm RMS) is `ok` (a limit of 0.1 mm refused it though
/// right); seed 1 frame 1 (0.159 mm at 154 mm along it) says the cameras do not pin it down
/// (though it lies only 0.093 mm RMS off: a limit on σ also refuses some right shapes).
#[test]
fn two_cameras_vouch_for_a_shape_as_far_as_they_pin_it_down() {
    let limit = flexshape_fit::FitSettings::default().max_sigma_mm;
    for (seed, frame, pinned) in [(1, 9, true), (1, 1, false)] {
        let chain = Chain::new(concentric_tube_robot(seed));
        let sim = &chain.sim;
        let pose = &sim.sweep(10)[frame];
        let b = chain
            .run_two_views(sim.render(frame as u64, pose).unwrap())
            .0;
        let (rms, tip) = b.fitted_errors(sim);
        let sigma = b.fitted.sigma.iter().copied().fold(0.0, f64::max);
        println!(
            "seed {seed} frame {frame}: σ max {sigma:.3} mm, rms {rms:.3} mm, tip {tip:.2} mm: {:?}",
            b.fitted.status
        );
        if pinned {
            assert!(
                sigma > 0.1 && sigma <= limit,
                "seed {seed} frame {frame}: σ {sigma:.3}"
            );
            assert!(rms <= 0.15 && tip <= 0.3, "seed {seed} frame {frame}");
            assert_eq!(b.fitted.status, Status::Ok, "seed {seed} frame {frame}");
        } else {
            assert!(sigma > limit, "seed {seed} frame {frame}: σ {sigma:.3}");
            assert!(
                matches!(&b.fitted.status, Status::Ambiguous { reason } if reason.contains("pin the centerline")),
                "seed {seed} frame {frame}: {:?}",
                b.fitted.status
            );
        }
    }
}

/// The same cloth filmed with sensor noise of σ 6 grey levels (three times the default): each
/// boundary's place scatters by 0.05–0.1 px, which the outline's own residual differences
/// show, and the residual limits widen by it. Every `ok` is right, and a camera turned by 0.2°
/// is still refused on every frame: its error is smooth along the outline and does not count
/// as noise, and its outline lies off the image's as a whole (`max_shift_px`).
#[test]
fn noise_widens_the_outline_limits_by_the_scatter_it_gives() {
    let scene = |seed: u64| cloth_of_its_hue(seed, 6.0);
    let (mut tally, mut noise) = (Tally::default(), Vec::new());
    for seed in [1, 2, 3] {
        let chain = Chain::new(scene(seed));
        let sim = &chain.sim;
        for (n, pose) in sim.sweep(4).iter().enumerate() {
            let b = chain.run(sim.render(n as u64, pose).unwrap());
            let (rms, tip) = b.fitted_errors(sim);
            let right = rms <= 0.15 && tip <= 0.3;
            if let Some(fit) = &b.fit {
                noise.extend(fit.cameras.iter().map(|c| c.noise_px));
            }
            println!(
                "seed {seed} frame {n}: {:?}, rms {rms:.3} mm, tip {tip:.2} mm",
                b.fitted.status
            );
            let which = format!("seed {seed} frame {n}: rms {rms:.3} mm, tip {tip:.2} mm");
            tally.add(&b.fitted.status, right, &which);
        }
    }
    let Tally { ok, right_refused } = tally;
    noise.sort_by(f64::total_cmp);
    println!(
        "{ok} of 12 ok, {right_refused} right but refused; boundary noise {:.3}–{:.3} px",
        noise[0],
        noise[noise.len() - 1]
    );
    // Measured: 12 of 12 ok (0.042–0.061 mm RMS), boundary noise 0.078–0.152 px. (At σ 6 the
    // outline's 90th percentile reaches 0.25–0.30 px on right fits: on three such recordings
    // of 10 frames, 12 were ok before the limits widened, 28 after.) The turned camera's wrong fits (1.3–1.7 mm RMS) reach 90th
    // percentiles of 0.31 px against a widened limit of 0.30 in one frame; their outlines lie
    // 1.3–2.2 px off the images' as a whole.
    assert!(
        ok >= 10 && right_refused <= 2,
        "{ok} ok, {right_refused} right but refused"
    );

    let chain = Chain::with_camera_turned(scene(1), 1, 0.2);
    let sim = &chain.sim;
    let mut fitted = 0;
    for (n, pose) in sim.sweep(4).iter().enumerate() {
        let b = chain.run(sim.render(n as u64, pose).unwrap());
        let (rms, tip) = b.fitted_errors(sim);
        let shift = b
            .fit
            .iter()
            .flat_map(|f| &f.cameras)
            .map(|c| c.shift_px[0].hypot(c.shift_px[1]));
        let shift = shift.fold(0.0, f64::max);
        println!(
            "turned camera, frame {n}: {:?}, rms {rms:.3} mm, tip {tip:.2} mm, largest shift {shift:.2} px",
            b.fitted.status
        );
        assert_ne!(b.fitted.status, Status::Ok, "frame {n}");
        // However wide the noise made the residual limits, the outline's shift alone refuses
        // a fit: noise scatters boundaries, it does not move a whole outline. (A frame whose
        // hull the turned camera cuts in two is refused before a fit.)
        if b.fit.is_some() {
            fitted += 1;
            assert!(
                shift > chain.fitter.settings().max_shift_px,
                "frame {n}: {shift}"
            );
        }
    }
    assert!(fitted >= 2, "{fitted} of 4 fitted");
}

/// The same cloth, where the silhouettes lost the tube's proximal 60 mm in every camera (as
/// sensor noise makes them lose a lit stretch as bright as the cloth), on a rig without bands
/// (a lost band would say so by itself): the fit from what is left caps the tube there, a
/// shape that explains every silhouette, but the images still show the tube's two sides
/// going on from that cap. The end is lengthened along them to the volume's boundary and the
/// tube fitted again: every `ok` is right. With the whole silhouettes no end of a right fit is
/// taken for one that goes on. Measured: 5 of 6 `ok` (0.04–0.05 mm RMS, tips 0.15–0.22 mm
/// off), lengthened in 3–4 rounds; the sixth cut fit, 28 mm off, is refused (65 silhouette
/// pixels beyond it). Before the lengthening no frame was `ok` (two cameras saw the cut fit
/// going on in 5 of 6), and before the probe frame 0 was `ok` 26.7 mm RMS off.
#[test]
fn a_tube_its_silhouettes_cut_short_is_lengthened_along_the_images() {
    let chain = cut_chain();
    let sim = &chain.sim;
    let volume = &sim.rig().volume;
    let (mut ok, mut lengthened) = (0, 0);
    for (n, pose) in sim.sweep(6).iter().enumerate() {
        let frame = sim.render(n as u64, pose).unwrap();
        let whole = chain.run(frame.clone());
        let fit = whole
            .fit
            .as_ref()
            .expect("a fit from the whole silhouettes");
        for c in &fit.cameras {
            assert_eq!(c.goes_on, [false, false], "frame {n}, camera {}", c.camera);
        }
        // The tube up to 60 mm into the volume (and outside it, towards its base).
        let line = truth_line(&frame);
        let entry = line.iter().position(|p| volume.contains(p)).unwrap();
        let end = entry + within_mm(line[entry..].iter(), 60.0);
        let sil = cut_out(&chain, &frame, &line[..=end]);
        let cut = chain.run_with(frame, sil, |_| {});
        let (rms, tip) = cut.fitted_errors(sim);
        println!(
            "frame {n}: {:?}, rms {rms:.2} mm, tip {tip:.2} mm",
            cut.fitted.status
        );
        if cut.fitted.status == Status::Ok {
            ok += 1;
            assert!(
                rms <= 0.15 && tip <= 0.3,
                "frame {n}: ok at {rms:.2} mm, tip {tip:.2}"
            );
        }
        let open = cut.fit.as_ref().is_some_and(|f| !f.tube.capped[0]);
        lengthened += usize::from(open);
    }
    println!("{ok} of 6 ok, {lengthened} with the proximal end lengthened to the boundary");
    assert!(
        ok >= 5 && lengthened >= 5,
        "{ok} ok, {lengthened} lengthened"
    );
}

/// The same, with the tube's last 25 mm and its tip cut out of every silhouette: the tip is
/// walked on along what the images show, capped where they stop showing it (to within
/// 1.25 mm) and fitted again, its cap's outline placing it. Every `ok` is right.
/// Measured: 5 of 6 `ok` (0.03–0.05 mm RMS, tips 0.12–0.33 mm off, all short along the
/// tube); the sixth cut splits the hull in two (`ambiguous`). Walking 4 mm short of where the
/// images stopped showing the tube, and only while they showed it going on straight, gave 2.
/// The walk's start leaves the fitted tip shorter than a fit from the whole silhouettes does
/// (frame 5: 0.33 mm against 0.14, since the silhouettes' sharp regions gained the tube's
/// limb pixels on this cloth of its hue; 0.14–0.21 before): a tip that starts short settles
/// short, within the cap's limits — held here to 0.35 mm.
#[test]
fn a_tip_its_silhouettes_lost_is_found_along_the_images() {
    let chain = cut_chain();
    let sim = &chain.sim;
    let (mut ok, mut right) = (0, 0);
    for (n, pose) in sim.sweep(6).iter().enumerate() {
        let frame = sim.render(n as u64, pose).unwrap();
        let line = truth_line(&frame);
        let from = line.len() - 1 - within_mm(line.iter().rev(), 25.0);
        let sil = cut_out(&chain, &frame, &line[from..]);
        let cut = chain.run_with(frame, sil, |_| {});
        let (rms, tip) = cut.fitted_errors(sim);
        println!(
            "frame {n}: {:?}, rms {rms:.2} mm, tip {tip:.2} mm",
            cut.fitted.status
        );
        right += usize::from(rms <= 0.15 && tip <= 0.3);
        if cut.fitted.status == Status::Ok {
            ok += 1;
            assert!(
                rms <= 0.15 && tip <= 0.35,
                "frame {n}: ok at {rms:.2} mm, tip {tip:.2}"
            );
        }
    }
    println!("{ok} of 6 ok, {right} right");
    assert!(ok >= 4, "{ok} ok, {right} right");
}

/// A blue tube on a lighter cloth of nearly its hue (7° apart), sensor noise `noise_sigma`
/// grey levels.
fn cloth_of_its_hue(seed: u64, noise_sigma: f64) -> SimConfig {
    SimConfig {
        render: RenderSettings {
            backdrop_albedo: [0.22, 0.28, 0.45],
            noise_sigma,
            ..RenderSettings::default()
        },
        seed,
        ..SimConfig::default()
    }
}

/// Four frames of the sweep of `scene` at seeds 1–3, each through `run`, tallied: right when
/// within 0.15 mm RMS and its tip within 0.3 mm of the truth.
fn four_frames_of_three_seeds(
    scene: impl Fn(u64) -> SimConfig,
    run: impl Fn(&Chain, SimFrame) -> Both,
) -> Tally {
    let mut tally = Tally::default();
    for seed in [1, 2, 3] {
        let chain = Chain::new(scene(seed));
        let sim = &chain.sim;
        for (n, pose) in sim.sweep(4).iter().enumerate() {
            let b = run(&chain, sim.render(n as u64, pose).unwrap());
            let (rms, tip) = b.fitted_errors(sim);
            let right = rms <= 0.15 && tip <= 0.3;
            let which = format!("seed {seed} frame {n}: rms {rms:.3} mm, tip {tip:.2} mm");
            println!("{which}: {:?}", b.fitted.status);
            tally.add(&b.fitted.status, right, &which);
        }
    }
    tally
}

/// `frames` frames of `scene` with camera 1 turned by 0.2° (its calibration off by about
/// 3 px): none may be `ok`.
fn never_ok_with_a_camera_turned(scene: SimConfig, frames: usize) {
    let chain = Chain::with_camera_turned(scene, 1, 0.2);
    let sim = &chain.sim;
    for (n, pose) in sim.sweep(frames).iter().enumerate() {
        let b = chain.run(sim.render(n as u64, pose).unwrap());
        println!("turned camera, frame {n}: {:?}", b.fitted.status);
        assert_ne!(b.fitted.status, Status::Ok, "frame {n}");
    }
}

/// Frames `ok` (each asserted right) and frames right but refused.
#[derive(Default)]
struct Tally {
    ok: usize,
    right_refused: usize,
}

impl Tally {
    /// Counts a frame of `status`, right or not by the truth; `which` names it.
    fn add(&mut self, status: &Status, right: bool, which: &str) {
        if *status == Status::Ok {
            self.ok += 1;
            assert!(right, "{which}: ok but off the truth");
        } else {
            self.right_refused += usize::from(right);
        }
    }
}

/// The chain of the cut-silhouette tests: the blue tube on cloth of its hue, no bands to
/// count (a lost band would say so by itself), the base's place telling the tube's direction.
fn cut_chain() -> Chain {
    let mut chain = Chain::new(cloth_of_its_hue(2, RenderSettings::default().noise_sigma));
    chain.estimator = ShapeEstimator::new(ShapeSettings {
        expected_bands: 0,
        tip_band: false,
        sections: Vec::new(),
        proximal_hint: Some([0.0, 0.0, -128.0]),
        ..chain.estimator.settings().clone()
    })
    .unwrap();
    chain
}

/// The frame's true centerline, proximal end first, world mm.
fn truth_line(frame: &SimFrame) -> Vec<Point3<f64>> {
    frame
        .truth
        .centerline
        .iter()
        .map(|p| Point3::from(*p))
        .collect()
}

/// How many steps along `points` stay within `mm` of arc from the first.
fn within_mm<'a>(points: impl Iterator<Item = &'a Point3<f64>>, mm: f64) -> usize {
    let points: Vec<_> = points.collect();
    let mut arc = 0.0;
    points
        .windows(2)
        .take_while(|w| {
            arc += (w[1] - w[0]).norm();
            arc < mm
        })
        .count()
}

/// The frame's silhouettes with the tube along `line` cut out of every camera's, 12 px round
/// each point (the tube is about 6 px wide).
fn cut_out(chain: &Chain, frame: &SimFrame, line: &[Point3<f64>]) -> Vec<Silhouette> {
    let mut sil = chain.silhouettes(frame);
    for (s, cam) in sil.iter_mut().zip(&chain.cameras) {
        let (w, h) = (s.object.width() as i64, s.object.height() as i64);
        for p in line {
            let c = cam.project(p).unwrap().pixel;
            let (cx, cy) = (c.x.round() as i64, c.y.round() as i64);
            for y in (cy - 12).max(0)..(cy + 13).min(h) {
                for x in (cx - 12).max(0)..(cx + 13).min(w) {
                    if (x - cx).pow(2) + (y - cy).pow(2) <= 144 {
                        s.object.set(x as usize, y as usize, false);
                    }
                }
            }
        }
    }
    sil
}
