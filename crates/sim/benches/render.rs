//! Simulator speed: rig setup and one frame of three 640×480 cameras (default scene, with and
//! without shadows), on the rayon pool of the machine (set RAYON_NUM_THREADS=1 for one core).

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use flexshape_sim::{SimConfig, Simulator};

fn render(c: &mut Criterion) {
    let mut group = c.benchmark_group("sim");
    group.sample_size(20);
    group.bench_function("setup_3cam_640x480", |b| {
        b.iter(|| black_box(Simulator::new(SimConfig::default()).unwrap()))
    });
    for shadows in [false, true] {
        let mut config = SimConfig::default();
        config.render.shadows = shadows;
        let sim = Simulator::new(config).unwrap();
        let poses = sim.sweep(16);
        let name = if shadows {
            "frame_3cam_640x480_shadows"
        } else {
            "frame_3cam_640x480"
        };
        let mut i = 0;
        group.bench_function(name, |b| {
            b.iter(|| {
                i = (i + 1) % poses.len();
                black_box(sim.render(i as u64, &poses[i]).unwrap())
            })
        });
    }
    group.finish();
}

criterion_group!(benches, render);
criterion_main!(benches);
