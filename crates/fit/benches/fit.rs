//! The tube fitted to one default-scene frame's images from the hull's centerline (3 cameras,
//! 640×480): the whole `refine` (fit, bands from colour, self-check, ghost check) and the fit
//! alone. Single-threaded code.

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use flexshape_carve::{BandRule, HierarchicalCarver, OutsideImage, find_bands};
use flexshape_fit::{FitSettings, Tube, TubeFitter, View};
use flexshape_shape::{ShapeEstimator, ShapeSettings};
use flexshape_silhouette::{BackgroundModel, Silhouette, SilhouetteSettings, Silhouetter};
use flexshape_sim::{SimConfig, SimFrame, Simulator};

fn bench(c: &mut Criterion) {
    let sim = Simulator::new(SimConfig::default()).unwrap();
    let rig = sim.rig();
    let cameras = sim.cameras();
    let frame = sim.render(3, &sim.sweep(4)[3]).unwrap();
    let models: Vec<BackgroundModel> = BackgroundModel::each(&sim.backgrounds()).unwrap();
    let sil = silhouettes(&models, &frame);
    let objects: Vec<_> = sil.iter().map(|s| &s.object).collect();
    let markers: Vec<_> = sil.iter().map(|s| &s.markers).collect();
    let carver = HierarchicalCarver::new(&cameras, &rig.volume).unwrap();
    let occ = carver.carve(&objects, OutsideImage::Carve).unwrap();
    let bands = find_bands(&occ, &cameras, &markers, &BandRule::default()).unwrap();
    let estimator =
        ShapeEstimator::new(ShapeSettings::from_processing(&rig.processing).unwrap()).unwrap();
    let hull = estimator.estimate(&occ, &bands);
    let names = rig.cameras.iter().map(|c| c.name.clone()).collect();
    let fitter = TubeFitter::new(cameras.clone(), names, FitSettings::default()).unwrap();
    let frame_views = views(&frame, &models, &sil);
    let centres = occ.centres();
    let start = Tube::through(&hull.points, hull.radius, [false, true], 15.0, 10.0).unwrap();
    let mut group = c.benchmark_group("fit");
    group.sample_size(20);
    group.bench_function("refine_from_the_hull_3cam", |b| {
        b.iter(|| {
            black_box(
                fitter
                    .refine(&estimator, &rig.volume, &frame_views, &hull, &centres, None)
                    .unwrap(),
            )
        })
    });
    group.bench_function("fit_only_3cam", |b| {
        b.iter(|| black_box(fitter.fit(&frame_views, start.clone(), true).unwrap()))
    });
    // Tracking: the next frame of a smooth motion filmed at 120 Hz, fitted from this one's
    // shape (silhouettes of the whole image here; the pipeline classifies only a box); and the
    // frame after, from the tube carried on as it moved between the two (what `track --follow`
    // does once two frames are in).
    let poses = sim.motion(3, 120.0);
    let rendered: Vec<SimFrame> = (0..3)
        .map(|i| sim.render(i, &poses[i as usize]).unwrap())
        .collect();
    let sils: Vec<Vec<Silhouette>> = rendered.iter().map(|f| silhouettes(&models, f)).collect();
    let objects: Vec<_> = sils[0].iter().map(|s| &s.object).collect();
    let markers: Vec<_> = sils[0].iter().map(|s| &s.markers).collect();
    let occ = carver.carve(&objects, OutsideImage::Carve).unwrap();
    let bands = find_bands(&occ, &cameras, &markers, &BandRule::default()).unwrap();
    let hull = estimator.estimate(&occ, &bands);
    let (first, fit0) = fitter
        .refine(
            &estimator,
            &rig.volume,
            &views(&rendered[0], &models, &sils[0]),
            &hull,
            &occ.centres(),
            None,
        )
        .unwrap();
    let views1 = views(&rendered[1], &models, &sils[1]);
    group.bench_function("follow_120hz_3cam", |b| {
        b.iter(|| {
            black_box(
                fitter
                    .follow(&estimator, &rig.volume, &views1, &first, (None, None), None)
                    .unwrap(),
            )
        })
    });
    let (second, fit1) = fitter
        .follow(&estimator, &rig.volume, &views1, &first, (None, None), None)
        .unwrap();
    let predicted = fit1
        .unwrap()
        .tube
        .carried_on(&fit0.unwrap().tube, 1.0, 3.0, 3.0)
        .unwrap();
    let views2 = views(&rendered[2], &models, &sils[2]);
    group.bench_function("follow_predicted_120hz_3cam", |b| {
        b.iter(|| {
            black_box(
                fitter
                    .follow(
                        &estimator,
                        &rig.volume,
                        &views2,
                        &second,
                        (Some(&predicted), None),
                        None,
                    )
                    .unwrap(),
            )
        })
    });
    group.finish();
}

/// Every camera's silhouette of `frame`.
fn silhouettes(models: &[BackgroundModel], frame: &SimFrame) -> Vec<Silhouette> {
    models
        .iter()
        .zip(&frame.views)
        .map(|(m, v)| {
            Silhouetter::new(m, SilhouetteSettings::default())
                .unwrap()
                .process(&v.image)
                .unwrap()
        })
        .collect()
}

/// How the fit sees `frame`.
fn views<'a>(
    frame: &'a SimFrame,
    models: &'a [BackgroundModel],
    sil: &'a [Silhouette],
) -> Vec<View<'a>> {
    frame
        .views
        .iter()
        .zip(models)
        .zip(sil)
        .map(|((v, m), s)| View {
            image: &v.image,
            background: m.means(),
            silhouette: &s.object,
            markers: &s.markers,
            shadow_like: Some(&s.shadow_like),
            hidden: None,
        })
        .collect()
}

criterion_group!(benches, bench);
criterion_main!(benches);
