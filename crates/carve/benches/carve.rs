//! Carving baseline: lookup-table build and exact carving of the default simulated scene
//! (256³ voxels of 1 mm, 3 cameras at 640×480). RAYON_NUM_THREADS=1 for one core.

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use flexshape_carve::{HierarchicalCarver, LookupTable, OutsideImage};
use flexshape_rig::Volume;
use flexshape_silhouette::BitMask;
use flexshape_sim::{SimConfig, Simulator};

fn bench(c: &mut Criterion) {
    let sim = Simulator::new(SimConfig::default()).unwrap();
    let cameras = sim.cameras();
    let volume = sim.rig().volume;
    let frame = sim.render(0, &sim.sweep(1)[0]).unwrap();
    let masks: Vec<BitMask> = frame
        .views
        .iter()
        .map(|v| BitMask::from_gray(&v.mask))
        .collect();
    let refs: Vec<&BitMask> = masks.iter().collect();
    let mut group = c.benchmark_group("carve");
    group.sample_size(10);
    group.bench_function("lookup_table_build_256_3cam", |b| {
        b.iter(|| black_box(LookupTable::new(&cameras, &volume).unwrap()))
    });
    let table = LookupTable::new(&cameras, &volume).unwrap();
    group.bench_function("exact_carve_256_3cam", |b| {
        b.iter(|| black_box(table.carve(&refs, OutsideImage::Carve).unwrap()))
    });
    let fast = HierarchicalCarver::new(&cameras, &volume).unwrap();
    group.bench_function("hierarchical_carve_256_1mm_3cam", |b| {
        b.iter(|| black_box(fast.carve(&refs, OutsideImage::Carve).unwrap()))
    });
    let fine = Volume::new(volume.origin, [0.5; 3], [512; 3]).unwrap();
    let fast_fine = HierarchicalCarver::new(&cameras, &fine).unwrap();
    group.bench_function("hierarchical_carve_512_0.5mm_3cam", |b| {
        b.iter(|| black_box(fast_fine.carve(&refs, OutsideImage::Carve).unwrap()))
    });
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
