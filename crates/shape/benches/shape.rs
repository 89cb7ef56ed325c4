//! Shape estimation of one default-scene frame (cloud carved from sensed silhouettes):
//! ordering + slicing, smoothing, bands and arc fits. `RAYON_NUM_THREADS` does not matter
//! (single-threaded code).

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use flexshape_carve::{BandRule, HierarchicalCarver, OutsideImage, find_bands};
use flexshape_shape::{ArcFitSettings, ShapeEstimator, ShapeSettings};
use flexshape_silhouette::{BackgroundModel, SilhouetteSettings, Silhouetter};
use flexshape_sim::{SimConfig, Simulator};

fn bench(c: &mut Criterion) {
    let sim = Simulator::new(SimConfig::default()).unwrap();
    let cameras = sim.cameras();
    let frame = sim.render(3, &sim.sweep(4)[3]).unwrap();
    let sil: Vec<_> = sim
        .backgrounds()
        .iter()
        .zip(&frame.views)
        .map(|(b, v)| {
            let model = BackgroundModel::from_frames(std::slice::from_ref(b)).unwrap();
            Silhouetter::new(&model, SilhouetteSettings::default())
                .unwrap()
                .process(&v.image)
                .unwrap()
        })
        .collect();
    let objects: Vec<_> = sil.iter().map(|s| &s.object).collect();
    let markers: Vec<_> = sil.iter().map(|s| &s.markers).collect();
    let carver = HierarchicalCarver::new(&cameras, &sim.rig().volume).unwrap();
    let occ = carver.carve(&objects, OutsideImage::Carve).unwrap();
    let bands = find_bands(&occ, &cameras, &markers, &BandRule::default()).unwrap();
    let full = ShapeEstimator::new(ShapeSettings::default()).unwrap();
    let no_fit = ShapeEstimator::new(ShapeSettings {
        arc_fit: ArcFitSettings {
            enabled: false,
            ..ArcFitSettings::default()
        },
        ..ShapeSettings::default()
    })
    .unwrap();
    let mut group = c.benchmark_group("shape");
    group.bench_function("bands_find_visibility_3cam", |b| {
        b.iter(|| black_box(find_bands(&occ, &cameras, &markers, &BandRule::default()).unwrap()))
    });
    group.bench_function("shape_without_arc_fit", |b| {
        b.iter(|| black_box(no_fit.estimate(&occ, &bands)))
    });
    group.bench_function("shape_with_arc_fits", |b| {
        b.iter(|| black_box(full.estimate(&occ, &bands)))
    });
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
