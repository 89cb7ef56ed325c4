//! The simulator against its own ground truth.

use flexshape_camera::nalgebra::{Point2, Point3, Vector3};
use flexshape_sim::{CatheterPose, SimConfig, SimFrame, Simulator, TRUTH_STEP};

fn sim(config: SimConfig) -> Simulator {
    Simulator::new(config).expect("default simulator builds")
}

fn frames(sim: &Simulator, n: usize) -> Vec<SimFrame> {
    sim.sweep(n)
        .iter()
        .enumerate()
        .map(|(i, p)| sim.render(i as u64, p).expect("renders"))
        .collect()
}

#[test]
fn centerline_projects_inside_the_mask_in_every_camera() {
    let sim = sim(SimConfig::default());
    for f in frames(&sim, 6) {
        for (c, (cam, view)) in sim.rig().cameras.iter().zip(&f.views).enumerate() {
            let (mut inside, mut total) = (0, 0);
            for p in &f.truth.centerline {
                let Ok(proj) = cam.camera.project(&Point3::from(*p)) else {
                    continue;
                };
                let Some((u, v)) = cam.camera.intrinsics.pixel_index(proj.pixel) else {
                    continue;
                };
                total += 1;
                inside += (view.mask.get_pixel(u, v)[0] == 255) as usize;
            }
            assert!(
                total > 200,
                "frame {} cam {c}: only {total} samples in view",
                f.truth.frame
            );
            let ratio = inside as f64 / total as f64;
            assert!(
                ratio > 0.99,
                "frame {} cam {c}: {:.2} % inside",
                f.truth.frame,
                ratio * 100.0
            );
        }
    }
}

/// Bilinear sample of the coverage image.
fn coverage_at(cov: &[f32], w: usize, h: usize, x: f64, y: f64) -> f64 {
    if x < 0.0 || y < 0.0 || x >= (w - 1) as f64 || y >= (h - 1) as f64 {
        return 0.0;
    }
    let (i, j) = (x.floor() as usize, y.floor() as usize);
    let (fx, fy) = (x - i as f64, y - j as f64);
    let at = |i: usize, j: usize| cov[j * w + i] as f64;
    let top = at(i, j) * (1.0 - fx) + at(i + 1, j) * fx;
    let bottom = at(i, j + 1) * (1.0 - fx) + at(i + 1, j + 1) * fx;
    top * (1.0 - fy) + bottom * fy
}

#[test]
fn rendered_tube_width_matches_two_r_f_over_depth() {
    let sim = sim(SimConfig::default());
    let r = sim.config().catheter.radius;
    let mut checked = 0;
    for f in frames(&sim, 3) {
        let line = &f.truth.centerline;
        // Straight proximal section, well inside the images of the side cameras.
        let bend_start = f.truth.bend_start_arc_length.unwrap();
        for k in [0.45, 0.6, 0.75, 0.9] {
            let i = (bend_start * k / TRUTH_STEP) as usize;
            let p = Point3::from(line[i]);
            let t = (Point3::from(line[i + 4]) - Point3::from(line[i - 4])).normalize();
            for (c, cam) in sim.rig().cameras.iter().enumerate().take(2) {
                let camera = &cam.camera;
                let proj = camera.project(&p).unwrap();
                if !camera.intrinsics.contains(proj.pixel) {
                    continue;
                }
                let q = camera.project(&(p + t)).unwrap().pixel;
                let along = (q - proj.pixel).normalize();
                let across = Vector3::new(-along.y, along.x, 0.0);
                let view = &f.views[c];
                let (w, h) = (view.mask.width() as usize, view.mask.height() as usize);
                let step = 0.05;
                let width: f64 = (-400..=400)
                    .map(|n| {
                        let s = n as f64 * step;
                        coverage_at(
                            &view.coverage,
                            w,
                            h,
                            proj.pixel.x + across.x * s,
                            proj.pixel.y + across.y * s,
                        ) * step
                    })
                    .sum();
                let simple = 2.0 * r * camera.intrinsics.fx / proj.depth;
                // The same with the lens's local magnification, for a tighter check.
                let (_, jac) = camera.project_with_jacobian(&p).unwrap();
                let view_dir = (p - camera.centre()).normalize();
                let normal = t.cross(&view_dir).normalize();
                let g = jac * normal;
                let exact = 2.0 * r * Point2::new(g.x, g.y).coords.dot(&across.xy()).abs();
                assert!(
                    (width / simple - 1.0).abs() < 0.05,
                    "cam {c}: {width:.3} px vs 2rf/z {simple:.3}"
                );
                assert!(
                    (width / exact - 1.0).abs() < 0.02,
                    "cam {c}: {width:.3} px vs lens-exact {exact:.3}"
                );
                checked += 1;
            }
        }
    }
    assert!(checked >= 12, "only {checked} width checks ran");
}

#[test]
fn same_seed_gives_byte_identical_images_and_another_seed_does_not() {
    let pose = |s: &Simulator| s.sweep(3)[2].clone();
    let a = sim(SimConfig::default());
    let b = sim(SimConfig::default());
    let fa = a.render(2, &pose(&a)).unwrap();
    let fb = b.render(2, &pose(&b)).unwrap();
    for (va, vb) in fa.views.iter().zip(&fb.views) {
        assert!(
            va.image.as_raw() == vb.image.as_raw(),
            "same seed, different images"
        );
        assert!(va.mask.as_raw() == vb.mask.as_raw());
    }
    assert_eq!(fa.truth, fb.truth);
    let mut other = SimConfig::default();
    other.render.seed = 2;
    let c = sim(other);
    let fc = c.render(2, &pose(&a)).unwrap();
    assert!(fc.views[0].image.as_raw() != fa.views[0].image.as_raw());
    assert!(
        fc.views[0].mask.as_raw() == fa.views[0].mask.as_raw(),
        "noise must not move the object"
    );
}

/// True when the surface point seen on the sight line from `eye` to the centerline point
/// `point` (arc length `s`) may not belong to the 5 mm band there: the line meets the tube
/// r·cot(θ) along the axis from `point` (θ: angle to the tangent), which must stay within the
/// band's half-width, and no other part of the tube may pass in front within one radius.
fn hidden_by_tube(
    truth: &flexshape_recording::Truth,
    eye: Point3<f64>,
    point: Point3<f64>,
    s: f64,
) -> bool {
    let ray = point - eye;
    let len = ray.norm();
    let dir = ray / len;
    let i = ((s / TRUTH_STEP) as usize).clamp(1, truth.centerline.len() - 2);
    let tangent =
        (Point3::from(truth.centerline[i + 1]) - Point3::from(truth.centerline[i - 1])).normalize();
    let cos = tangent.dot(&dir).abs();
    let cot = cos / (1.0 - cos * cos).sqrt().max(1e-9);
    if truth.radius * cot > 2.0 {
        return true;
    }
    truth.centerline.iter().enumerate().any(|(i, q)| {
        let q = Point3::from(*q);
        let along = (q - eye).dot(&dir);
        let off = ((q - eye) - dir * along).norm();
        (i as f64 * TRUTH_STEP - s).abs() > 8.0
            && along < len - truth.radius
            && off < truth.radius + 0.5
    })
}

#[test]
fn band_centres_land_on_marker_pixels() {
    let sim = sim(SimConfig::default());
    let (mut hits, mut total, mut hidden) = (0, 0, 0);
    for f in frames(&sim, 10) {
        assert_eq!(f.truth.bands.len(), 2);
        for (cam, view) in sim.rig().cameras.iter().zip(&f.views) {
            for band in &f.truth.bands {
                let centre = Point3::from(band.position);
                let Ok(p) = cam.camera.project(&centre) else {
                    continue;
                };
                let Some((u, v)) = cam.camera.intrinsics.pixel_index(p.pixel) else {
                    continue;
                };
                if hidden_by_tube(&f.truth, cam.camera.centre(), centre, band.arc_length) {
                    hidden += 1;
                    continue;
                }
                total += 1;
                hits += (view.markers.get_pixel(u, v)[0] == 255) as usize;
            }
        }
        // Marker pixels are object pixels.
        for view in &f.views {
            assert!(
                view.markers
                    .pixels()
                    .zip(view.mask.pixels())
                    .all(|(m, o)| m[0] == 0 || o[0] == 255)
            );
        }
    }
    assert!(
        total >= 30,
        "only {total} visible band centres ({hidden} hidden)"
    );
    assert_eq!(
        hits, total,
        "{hits}/{total} visible band centres on marker pixels"
    );
}

#[test]
fn truth_is_consistent_with_the_pose() {
    let sim = sim(SimConfig::default());
    let catheter = &sim.config().catheter;
    let pose = CatheterPose::arc(catheter, [0.01, -0.004], [0.005, 0.02], 12.0);
    let f = sim.render(0, &pose).unwrap();
    let t = &f.truth;
    assert_eq!(t.kappa, Some([0.01, -0.004]));
    assert_eq!(t.eps, Some([0.005, 0.02]));
    let pts: Vec<Point3<f64>> = t.centerline.iter().map(|p| Point3::from(*p)).collect();
    assert!(pts.windows(2).all(|w| (w[1] - w[0]).norm() <= 0.5 + 1e-9));
    let length: f64 = pts.windows(2).map(|w| (w[1] - w[0]).norm()).sum();
    let expect = catheter.proximal_length * (1.0 - 0.005) + catheter.bend_length * (1.0 - 0.02);
    assert!((length - expect).abs() < 1e-3, "{length} vs {expect}");
    assert_eq!(*pts.last().unwrap(), Point3::from(t.tip));
    assert!((Vector3::from(t.tip_direction).norm() - 1.0).abs() < 1e-12);
    // Bands: proximal at the bending base, distal ending at the tip; compressed spacing.
    let [b0, b1] = [&t.bands[0], &t.bands[1]];
    let start = t.bend_start_arc_length.unwrap();
    assert!((b0.arc_length - start).abs() < 1e-9);
    let spacing = (catheter.bend_length - catheter.band_width / 2.0) * (1.0 - 0.02);
    assert!((b1.arc_length - b0.arc_length - spacing).abs() < 1e-9);
    assert!((b1.width - catheter.band_width * 0.98).abs() < 1e-9);
    // The tip of a constant-curvature arc: chord = 2 sin(θ/2)/κ.
    let k = 0.01f64.hypot(0.004);
    let arc = catheter.bend_length * 0.98;
    let base = Point3::from(t.bend_base.as_ref().unwrap().origin);
    let chord = (Point3::from(t.tip) - base).norm();
    assert!((chord - 2.0 * (k * arc / 2.0).sin() / k).abs() < 1e-6);
    // Two pieces: the tip is the first arc's tip frame composed with the second arc.
    let two =
        CatheterPose::two_section(catheter, [0.012, 0.0], [0.0, -0.02], 70.0, [0.0, 0.01], 5.0);
    let f = sim.render(1, &two).unwrap();
    assert_eq!(f.truth.kappa, None);
    assert_eq!(f.truth.sections.len(), 3);
    let base = f.truth.bend_base.as_ref().unwrap();
    let r = flexshape_camera::nalgebra::Matrix3::from_fn(|i, j| base.rotation[i][j]);
    let first = flexshape_curve::Section {
        length: 70.0,
        kappa: [0.012, 0.0],
        strain: 0.01,
    }
    .local_frame(70.0 * 0.99);
    let second = flexshape_curve::Section {
        length: 90.0,
        kappa: [0.0, -0.02],
        strain: 0.01,
    }
    .local_frame(90.0 * 0.99);
    let tip_local = first.compose(&second).position;
    let tip = Point3::from(base.origin) + r * tip_local.coords;
    assert!((tip - Point3::from(f.truth.tip)).norm() < 1e-9);
    // A free-form bend has no single κ.
    let smooth = CatheterPose::smooth(
        catheter,
        |s| [0.01 * (s / 40.0).sin(), 0.005],
        [0.0, 0.0],
        0.0,
    );
    let f = sim.render(1, &smooth).unwrap();
    assert_eq!(f.truth.kappa, None);
    assert_eq!(f.truth.eps, None);
}

#[test]
fn shadows_darken_the_backdrop_without_changing_its_colour_or_the_mask() {
    let mut plain = SimConfig::default();
    plain.render.noise_sigma = 0.0;
    let mut shadowed = plain.clone();
    shadowed.render.shadows = true;
    let (a, b) = (sim(plain), sim(shadowed));
    let pose = a.sweep(1)[0].clone();
    let (fa, fb) = (a.render(0, &pose).unwrap(), b.render(0, &pose).unwrap());
    for (va, vb) in fa.views.iter().zip(&fb.views) {
        assert!(va.mask.as_raw() == vb.mask.as_raw());
        let mut dark = 0;
        for ((pa, pb), m) in va
            .image
            .pixels()
            .zip(vb.image.pixels())
            .zip(va.mask.pixels())
        {
            if m[0] != 0 || pa[1] < 100 {
                continue;
            }
            let ratio = pb[1] as f64 / pa[1] as f64;
            if ratio < 0.8 {
                dark += 1;
                // Same chromaticity: every channel scaled alike (to 8-bit rounding).
                for c in [0, 2] {
                    let rc = pb[c] as f64 / pa[c] as f64;
                    assert!(
                        (rc - ratio).abs() < 0.03,
                        "channel {c}: {rc:.3} vs green {ratio:.3}"
                    );
                }
            }
        }
        assert!(dark > 500, "shadow too small: {dark} pixels darker by 20 %");
    }
}

#[test]
fn occluders_hide_the_catheter_and_are_not_in_the_mask() {
    let plain = sim(SimConfig::default());
    let occluded = sim(SimConfig {
        occluders: 3,
        ..SimConfig::default()
    });
    let mut hidden = 0;
    for (i, pose) in plain.sweep(4).iter().enumerate() {
        let (fa, fb) = (
            plain.render(i as u64, pose).unwrap(),
            occluded.render(i as u64, pose).unwrap(),
        );
        for (va, vb) in fa.views.iter().zip(&fb.views) {
            for (ma, mb) in va.mask.pixels().zip(vb.mask.pixels()) {
                assert!(
                    mb[0] == 0 || ma[0] == 255,
                    "occluders cannot add object pixels"
                );
                hidden += (ma[0] == 255 && mb[0] == 0) as usize;
            }
        }
    }
    assert!(
        hidden > 100,
        "occluders hid only {hidden} object pixels over 4 frames"
    );
}

#[test]
fn bad_settings_are_errors_naming_the_setting() {
    let mut c = SimConfig::default();
    c.rig.cameras = 0;
    assert!(
        Simulator::new(c)
            .err()
            .unwrap()
            .to_string()
            .contains("cameras")
    );
    let mut c = SimConfig::default();
    c.render.supersampling = 0;
    assert!(
        Simulator::new(c)
            .err()
            .unwrap()
            .to_string()
            .contains("supersampling")
    );
    let mut c = SimConfig::default();
    c.rig.distortion = [-0.9, 0.0, 0.0, 0.0, 0.0];
    let err = Simulator::new(c).err().unwrap().to_string();
    assert!(err.contains("distortion"), "{err}");
    let mut c = SimConfig::default();
    c.render.plate = Some(flexshape_sim::Plate {
        pitch_mm: 0.0,
        ..flexshape_sim::Plate::new(flexshape_sim::PlatePattern::Dots)
    });
    let err = Simulator::new(c).err().unwrap().to_string();
    assert!(err.contains("plate"), "{err}");
    let s = sim(SimConfig::default());
    let mut pose = s.sweep(1)[0].clone();
    // An outer tube's own material needs a step to begin at.
    let mut c = SimConfig::default();
    c.catheter.outer = Some(flexshape_sim::Material {
        albedo: [0.1; 3],
        gloss: flexshape_sim::Gloss::default(),
    });
    let err = sim(c).render(0, &pose).err().unwrap().to_string();
    assert!(err.contains("outer"), "{err}");
    pose.bend[0].length = 10.0;
    assert!(
        s.render(0, &pose)
            .err()
            .unwrap()
            .to_string()
            .contains("bend")
    );
}

#[test]
fn other_camera_counts_and_sizes() {
    let mut c = SimConfig::default();
    c.rig.cameras = 5;
    c.rig.width = 320;
    c.rig.height = 240;
    c.rig.focal = 400.0;
    let s = sim(c);
    let f = s.render(0, &s.sweep(1)[0]).unwrap();
    assert_eq!(f.views.len(), 5);
    for (cam, v) in s.rig().cameras.iter().zip(&f.views) {
        assert_eq!(v.image.dimensions(), (320, 240));
        assert!(
            v.mask.pixels().filter(|p| p[0] == 255).count() > 100,
            "{} sees too little",
            cam.name
        );
    }
}

#[test]
fn an_exposure_blurs_what_moves_and_keeps_the_middle_instant_as_truth() {
    let sim = sim(SimConfig::default());
    // 10 frames a second, the shutter open for half the interval: the tip travels millimetres
    // while it is open.
    let exposures = sim.motion_exposures(20, 10.0, 0.5, 5);
    let catheter = &sim.config().catheter;
    let tip = |pose: &CatheterPose| {
        let state = catheter.state(pose).expect("a pose");
        let truth = catheter.truth(0, pose, &state).expect("a truth");
        Point3::from(*truth.centerline.last().expect("a centerline"))
    };
    // The frame whose tip moves farthest while the shutter is open.
    let (at, poses) = exposures
        .iter()
        .enumerate()
        .max_by(|a, b| {
            let moved = |p: &[CatheterPose]| (tip(&p[0]) - tip(&p[4])).norm();
            moved(a.1).total_cmp(&moved(b.1))
        })
        .expect("frames");
    assert_eq!(poses.len(), 5);
    assert!((tip(&poses[0]) - tip(&poses[4])).norm() > 6.0);
    // One instant is a still frame, byte for byte.
    let still = sim.render(7, &poses[2]).expect("renders");
    let one = sim.render_exposure(7, &poses[2..3]).expect("renders");
    for (a, b) in still.views.iter().zip(&one.views) {
        assert_eq!(a.image, b.image);
        assert_eq!(a.mask, b.mask);
    }
    assert_eq!(still.truth.centerline, one.truth.centerline);
    // The middle instant is the frame's pose and its truth.
    assert_eq!(sim.motion(20, 10.0)[at], poses[2]);
    let blurred = sim.render_exposure(7, poses).expect("renders");
    assert_eq!(blurred.truth.centerline, still.truth.centerline);
    // The tip where it was when the shutter opened and when it closed; either may lie inside
    // the middle instant's tube (the catheter advancing or withdrawing along itself).
    let ends = [
        sim.render(7, &poses[0]).expect("renders"),
        sim.render(7, &poses[4]).expect("renders"),
    ];
    let tip_of = |f: &SimFrame| Point3::from(*f.truth.centerline.last().expect("a centerline"));
    let backgrounds = sim.backgrounds();
    let mut checked = 0;
    for (c, cam) in sim.rig().cameras.iter().enumerate() {
        assert_eq!(blurred.views[c].mask, still.views[c].mask, "camera {c}");
        // Where the tip was at one end of the exposure and no longer is at the middle instant,
        // the tube stayed about a fifth of it: the pixel is partly tube, partly backdrop.
        for end in &ends {
            let Ok(p) = cam.camera.project(&tip_of(end)) else {
                continue;
            };
            let Some((u, v)) = cam.camera.intrinsics.pixel_index(p.pixel) else {
                continue;
            };
            if still.views[c].mask.get_pixel(u, v)[0] != 0
                || end.views[c].mask.get_pixel(u, v)[0] == 0
            {
                continue;
            }
            let grey = |img: &image::RgbImage| {
                img.get_pixel(u, v).0.iter().map(|&x| x as f64).sum::<f64>()
            };
            let (bg, moving, there) = (
                grey(&backgrounds[c]),
                grey(&blurred.views[c].image),
                grey(&end.views[c].image),
            );
            let share = (moving - bg) / (there - bg);
            assert!(
                (there - bg).abs() > 60.0 && (0.05..0.6).contains(&share),
                "camera {c}: backdrop {bg}, tube {there}, blurred {moving} (share {share:.2})"
            );
            checked += 1;
        }
    }
    assert!(
        checked >= 1,
        "an end instant's tip lay off the middle's tube in {checked} cameras"
    );
}

#[test]
fn a_printed_plate_lies_under_the_tube_and_an_outer_tube_has_its_own_material() {
    use flexshape_curve::RadiusStep;
    use flexshape_sim::{Gloss, Material, Plate, PlatePattern, RenderSettings};
    let defaults = SimConfig::default();
    let dark = Material {
        albedo: [0.08, 0.08, 0.09],
        gloss: Gloss::default(),
    };
    let sim = sim(SimConfig {
        render: RenderSettings {
            plate: Some(Plate::new(PlatePattern::Dots)),
            ..defaults.render.clone()
        },
        catheter: flexshape_sim::Catheter {
            radius: 1.2,
            radius_steps: vec![RadiusStep {
                from_tip_mm: 70.0,
                radius_mm: 3.0,
            }],
            albedo: [0.6, 0.6, 0.6],
            outer: Some(dark),
            ..defaults.catheter.clone()
        },
        ..defaults
    });
    let backgrounds = sim.backgrounds();
    let cam = &sim.rig().cameras[0].camera;
    let depth = sim.config().render.backdrop_depth;
    // The plate's centre (a dot), a point between dots, and the cloth beyond the plate's edge.
    let at = |u: f64, v: f64| {
        let world = cam.pose.to_world(&Point3::new(u, v, depth));
        let p = cam.project(&world).unwrap().pixel;
        *backgrounds[0].get_pixel(p.x.round() as u32, p.y.round() as u32)
    };
    let [cx, cy] = Plate::new(PlatePattern::Dots).centre_mm;
    let (dot, paper, cloth) = (at(cx, cy), at(cx + 10.0, cy + 10.0), at(cx + 330.0, cy));
    assert!(dot.0.iter().all(|&v| v < 40), "dot {dot:?}");
    assert!(paper.0.iter().all(|&v| v > 150), "paper {paper:?}");
    assert!(
        cloth[1] > cloth[0] + 20 && cloth[1] > cloth[2] + 20,
        "cloth {cloth:?}"
    );
    // Along the tube: the inner tube light, the outer one dark.
    let f = &frames(&sim, 1)[0];
    let line = &f.truth.centerline;
    let mean = |range: std::ops::Range<usize>| {
        let (mut sum, mut n) = (0.0, 0);
        for p in &line[range] {
            let Ok(proj) = cam.project(&Point3::from(*p)) else {
                continue;
            };
            if let Some((u, v)) = cam.intrinsics.pixel_index(proj.pixel) {
                let px = f.views[0].image.get_pixel(u, v);
                if f.views[0].mask.get_pixel(u, v)[0] == 255 {
                    sum += px.0.iter().map(|&c| c as f64).sum::<f64>() / 3.0;
                    n += 1;
                }
            }
        }
        assert!(n > 10, "{n} samples");
        sum / n as f64
    };
    let step = line.len() - (70.0 / TRUTH_STEP) as usize;
    let (outer, inner) = (mean(step / 2..step - 20), mean(step + 20..line.len() - 20));
    assert!(inner > outer + 40.0, "inner {inner:.0}, outer {outer:.0}");
}
