//! The hierarchical carver gives exactly the lookup table's occupancy.

use flexshape_carve::{HierarchicalCarver, LookupTable, OutsideImage};
use flexshape_rig::Volume;
use flexshape_silhouette::BitMask;
use flexshape_sim::{SimConfig, SimRigConfig, Simulator};
use proptest::prelude::*;

#[test]
fn identical_to_exact_on_the_default_scene() {
    let sim = Simulator::new(SimConfig::default()).unwrap();
    let cameras = sim.cameras();
    let volume = sim.rig().volume;
    let table = LookupTable::new(&cameras, &volume).unwrap();
    let fast = HierarchicalCarver::new(&cameras, &volume).unwrap();
    for (n, pose) in sim.sweep(4).iter().enumerate() {
        let f = sim.render(n as u64, pose).unwrap();
        let masks: Vec<BitMask> = f
            .views
            .iter()
            .map(|v| BitMask::from_gray(&v.mask))
            .collect();
        let refs: Vec<&BitMask> = masks.iter().collect();
        for rule in [OutsideImage::Carve, OutsideImage::Ignore { min_views: 2 }] {
            let a = table.carve(&refs, rule).unwrap();
            let b = fast.carve(&refs, rule).unwrap();
            assert!(!a.is_empty());
            assert_eq!(a.voxels, b.voxels, "frame {n}, {rule:?}");
        }
    }
}

/// Masks of random discs and rectangles with a sprinkle of single pixels.
fn random_masks(cams: &[flexshape_camera::Camera], seed: u64) -> Vec<BitMask> {
    let mut s = seed | 1;
    let mut next = move |n: u64| {
        s ^= s << 13;
        s ^= s >> 7;
        s ^= s << 17;
        s % n.max(1)
    };
    cams.iter()
        .map(|c| {
            let (w, h) = (c.intrinsics.width as usize, c.intrinsics.height as usize);
            let mut m = BitMask::new(w, h);
            for _ in 0..1 + next(4) {
                let (cx, cy, r) = (
                    next(w as u64) as i64,
                    next(h as u64) as i64,
                    5 + next((w / 3) as u64) as i64,
                );
                let square = next(2) == 0;
                for y in (cy - r).max(0)..(cy + r).min(h as i64) {
                    for x in (cx - r).max(0)..(cx + r).min(w as i64) {
                        if square || (x - cx).pow(2) + (y - cy).pow(2) <= r * r {
                            m.set(x as usize, y as usize, true);
                        }
                    }
                }
            }
            for _ in 0..next(200) {
                m.set(next(w as u64) as usize, next(h as u64) as usize, true);
            }
            m
        })
        .collect()
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(40))]

    #[test]
    fn identical_to_exact_on_random_rigs_volumes_and_masks(
        seed in any::<u64>(),
        cams in 2usize..6,
        focal in 250.0..1200.0f64,
        k1 in -0.35..0.15f64,
        k2 in -0.1..0.2f64,
        origin in prop::array::uniform3(-260.0..60.0f64),
        voxel in prop::array::uniform3(2.0..12.0f64),
        dims in prop::array::uniform3(3u32..45),
        min_views in 1usize..3,
    ) {
        let rig = SimRigConfig {
            cameras: cams,
            width: 160,
            height: 120,
            focal: focal / 4.0,
            distortion: [k1, k2, 0.001, -0.001, 0.0],
            seed,
            ..SimRigConfig::default()
        };
        let Ok(cameras) = rig.cameras() else { return Ok(()) };
        let cameras: Vec<_> = cameras.into_iter().map(|(_, c)| c).collect();
        let volume = Volume::new(origin, voxel, dims).unwrap();
        let Ok(table) = LookupTable::new(&cameras, &volume) else { return Ok(()) };
        let fast = HierarchicalCarver::new(&cameras, &volume).unwrap();
        let masks = random_masks(&cameras, seed);
        let refs: Vec<&BitMask> = masks.iter().collect();
        for rule in [OutsideImage::Carve, OutsideImage::Ignore { min_views: min_views.min(cams) }] {
            let a = table.carve(&refs, rule).unwrap();
            let b = fast.carve(&refs, rule).unwrap();
            prop_assert_eq!(&a.voxels, &b.voxels, "{:?}", rule);
        }
    }
}

/// The random cases above are not vacuous: most build a table, most carve something, and many
/// have voxels that some camera does not see (where the two rules differ).
#[test]
fn random_cases_cover_occupied_and_partly_unseen_volumes() {
    let (mut built, mut occupied, mut partly_unseen) = (0, 0, 0);
    for seed in 0..60u64 {
        let f = |k: u64, lo: f64, hi: f64| {
            lo + (hi - lo) * (((seed * 2654435761 + k * 40503) % 1000) as f64 / 1000.0)
        };
        let rig = SimRigConfig {
            cameras: 2 + (seed % 4) as usize,
            width: 160,
            height: 120,
            focal: f(1, 250.0, 1200.0) / 4.0,
            distortion: [f(2, -0.35, 0.15), f(3, -0.1, 0.2), 0.001, -0.001, 0.0],
            seed,
            ..SimRigConfig::default()
        };
        let Ok(cameras) = rig.cameras() else { continue };
        let cameras: Vec<_> = cameras.into_iter().map(|(_, c)| c).collect();
        let origin = [f(4, -260.0, 60.0), f(5, -260.0, 60.0), f(6, -260.0, 60.0)];
        let voxel = [f(7, 2.0, 12.0), f(8, 2.0, 12.0), f(9, 2.0, 12.0)];
        let dims = [
            f(10, 3.0, 45.0) as u32,
            f(11, 3.0, 45.0) as u32,
            f(12, 3.0, 45.0) as u32,
        ];
        let volume = Volume::new(origin, voxel, dims).unwrap();
        let Ok(table) = LookupTable::new(&cameras, &volume) else {
            continue;
        };
        built += 1;
        let fast = HierarchicalCarver::new(&cameras, &volume).unwrap();
        let masks = random_masks(&cameras, seed);
        let refs: Vec<&BitMask> = masks.iter().collect();
        let all = table.carve(&refs, OutsideImage::Carve).unwrap();
        let some = table
            .carve(&refs, OutsideImage::Ignore { min_views: 1 })
            .unwrap();
        assert_eq!(
            all.voxels,
            fast.carve(&refs, OutsideImage::Carve).unwrap().voxels,
            "seed {seed}"
        );
        assert_eq!(
            some.voxels,
            fast.carve(&refs, OutsideImage::Ignore { min_views: 1 })
                .unwrap()
                .voxels,
            "seed {seed}"
        );
        occupied += !all.is_empty() as usize;
        partly_unseen += (all.voxels != some.voxels) as usize;
    }
    assert!(
        built >= 40 && occupied >= 20 && partly_unseen >= 10,
        "built {built}, occupied {occupied}, partly unseen {partly_unseen}"
    );
}
