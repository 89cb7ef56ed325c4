//! Silhouettes of three 640×480 cameras (object + marker masks, closing, components) on the
//! default simulated scene: one core (cameras in turn) and two threads.

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use flexshape_silhouette::{BackgroundModel, Classifier, SilhouetteSettings, Silhouetter};
use flexshape_sim::{SimConfig, Simulator};
use image::RgbImage;

fn bench(c: &mut Criterion) {
    let sim = Simulator::new(SimConfig::default()).unwrap();
    let frames: Vec<Vec<RgbImage>> = sim
        .sweep(8)
        .iter()
        .enumerate()
        .map(|(i, p)| {
            sim.render(i as u64, p)
                .unwrap()
                .views
                .into_iter()
                .map(|v| v.image)
                .collect()
        })
        .collect();
    let models: Vec<BackgroundModel> = BackgroundModel::each(&sim.backgrounds()).unwrap();
    let mut group = c.benchmark_group("silhouette");
    for (name, classifier) in [
        ("colour_shadow", Classifier::colour_shadow()),
        ("green_matte", Classifier::green_matte()),
    ] {
        let sils: Vec<Silhouetter> = models
            .iter()
            .map(|m| {
                Silhouetter::new(
                    m,
                    SilhouetteSettings {
                        classifier: classifier.clone(),
                        ..Default::default()
                    },
                )
                .unwrap()
            })
            .collect();
        let mut i = 0;
        group.bench_function(format!("3cam_640x480_{name}_1core"), |b| {
            b.iter(|| {
                i = (i + 1) % frames.len();
                for (s, f) in sils.iter().zip(&frames[i]) {
                    black_box(s.process(f).unwrap());
                }
            })
        });
        group.bench_function(format!("3cam_640x480_{name}_2threads"), |b| {
            b.iter(|| {
                i = (i + 1) % frames.len();
                std::thread::scope(|scope| {
                    let other = scope.spawn(|| black_box(sils[2].process(&frames[i][2]).unwrap()));
                    for k in 0..2 {
                        black_box(sils[k].process(&frames[i][k]).unwrap());
                    }
                    other.join().ok();
                });
            })
        });
    }
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
