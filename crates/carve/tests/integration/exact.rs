//! Exact (lookup-table) carving on the simulated rig against ground truth.

use crate::common;

use std::f64::consts::PI;

use flexshape_camera::nalgebra::Point3;
use flexshape_carve::{CarveError, HierarchicalCarver, LookupTable, OutsideImage, PlyEncoding};
use flexshape_rig::Volume;
use flexshape_silhouette::BitMask;
use flexshape_sim::{SimConfig, Simulator};

#[test]
fn the_hull_contains_the_catheter_and_stays_close_to_its_volume() {
    let sim = Simulator::new(SimConfig::default()).unwrap();
    let volume = sim.rig().volume;
    let table = LookupTable::new(&sim.cameras(), &volume).unwrap();
    assert_eq!(table.memory_bytes(), 256 * 256 * 256 * 3 * 4);
    let silhouetters = common::silhouetters(&sim);
    let r = sim.config().catheter.radius;
    let mut worst_ratio: f64 = 0.0;
    for (n, pose) in sim.sweep(6).iter().enumerate() {
        let f = sim.render(n as u64, pose).unwrap();
        let truth_masks: Vec<BitMask> = f
            .views
            .iter()
            .map(|v| BitMask::from_gray(&v.mask))
            .collect();
        let sensed: Vec<BitMask> = silhouetters
            .iter()
            .zip(&f.views)
            .map(|(s, v)| s.process(&v.image).unwrap().object)
            .collect();
        let inside: Vec<Point3<f64>> = f
            .truth
            .centerline
            .iter()
            .map(|p| Point3::from(*p))
            .filter(|p| volume.contains(p))
            .collect();
        let length = inside.windows(2).map(|w| (w[1] - w[0]).norm()).sum::<f64>();
        let tube = PI * r * r * length;
        for (name, masks) in [("exact masks", &truth_masks), ("silhouettes", &sensed)] {
            let refs: Vec<&BitMask> = masks.iter().collect();
            let occ = table.carve(&refs, OutsideImage::Carve).unwrap();
            let missing = inside.iter().filter(|p| !occ.contains_point(p)).count();
            assert_eq!(
                missing,
                0,
                "frame {n}, {name}: {missing} of {} centerline samples carved away",
                inside.len()
            );
            let ratio = occ.volume_mm3() / tube;
            println!(
                "frame {n} {name}: {} voxels, hull / tube volume {ratio:.2}",
                occ.len()
            );
            worst_ratio = worst_ratio.max(ratio);
        }
    }
    // Measured 1.17–1.21 on these frames: three views bound a tube closely (voxel centres
    // sample the hull, so the count can fall below the circumscribed shape); 1.5 leaves room
    // for poses with ambiguous pockets.
    assert!(
        worst_ratio < 1.5,
        "hull is {worst_ratio:.2}× the tube volume"
    );
}

#[test]
fn bad_input_and_empty_masks() {
    let sim = Simulator::new(SimConfig::default()).unwrap();
    let cams = sim.cameras();
    let small = Volume::new([-40.0; 3], [2.0; 3], [40, 40, 40]).unwrap();
    assert!(matches!(
        LookupTable::new(&cams[..1], &small),
        Err(CarveError::TooFewCameras { cameras: 1 })
    ));
    // Far out on +x: behind camera 0, which looks from +x toward the origin.
    let far = Volume::new([5000.0, -20.0, -20.0], [1.0; 3], [40, 40, 40]).unwrap();
    let err = LookupTable::new(&cams, &far).unwrap_err();
    assert!(
        matches!(err, CarveError::VolumeNotInView { camera: 0 }),
        "{err}"
    );
    assert!(matches!(
        LookupTable::new(
            &cams,
            &Volume::new([0.0; 3], [0.01; 3], [2048, 2048, 512]).unwrap()
        ),
        Err(CarveError::TableTooLarge { .. })
    ));
    // A volume written as a literal, past `Volume::new`'s checks: refused by both carvers,
    // naming the field.
    let literal = Volume {
        voxel_size: [1.0, 1.0, 1e-300],
        ..small
    };
    for err in [
        LookupTable::new(&cams, &literal).err(),
        HierarchicalCarver::new(&cams, &literal).err(),
    ] {
        let err = err.expect("refused").to_string();
        assert!(err.contains("voxel_size"), "{err}");
    }
    let table = LookupTable::new(&cams, &small).unwrap();
    let empty = BitMask::new(640, 480);
    let full = BitMask::new(640, 480).not();
    let occ = table
        .carve(&[&empty, &full, &full], OutsideImage::Carve)
        .unwrap();
    assert!(occ.is_empty() && occ.to_cloud().points.is_empty());
    let all = table
        .carve(&[&full, &full, &full], OutsideImage::Carve)
        .unwrap();
    assert_eq!(
        all.len(),
        40 * 40 * 40,
        "the whole small volume is in every view"
    );
    assert!(matches!(
        table.carve(&[&full, &full], OutsideImage::Carve),
        Err(CarveError::MaskCount {
            masks: 2,
            cameras: 3
        })
    ));
    let wrong = BitMask::new(320, 240);
    let err = table
        .carve(&[&full, &wrong, &full], OutsideImage::Carve)
        .unwrap_err();
    assert!(
        err.to_string().contains("camera 1 is 320×240") && err.to_string().contains("640×480"),
        "{err}"
    );
    assert!(matches!(
        table.carve(
            &[&full, &full, &full],
            OutsideImage::Ignore { min_views: 0 }
        ),
        Err(CarveError::MinViews { .. })
    ));
}

#[test]
fn voxels_outside_some_images_follow_the_rule() {
    let sim = Simulator::new(SimConfig::default()).unwrap();
    // Reaches 400 mm along +x: beyond cam1's and cam2's fields of view, and behind cam0
    // (about 600 mm out on +x) only past 600 mm, so cam0 sees it all.
    let wide = Volume::new([-100.0, -50.0, -50.0], [10.0; 3], [50, 10, 10]).unwrap();
    let table = LookupTable::new(&sim.cameras(), &wide).unwrap();
    let full = BitMask::new(640, 480).not();
    let masks = [&full, &full, &full];
    let all_seen = table.carve(&masks, OutsideImage::Carve).unwrap();
    let two_of_three = table
        .carve(&masks, OutsideImage::Ignore { min_views: 2 })
        .unwrap();
    let one = table
        .carve(&masks, OutsideImage::Ignore { min_views: 1 })
        .unwrap();
    assert!(
        all_seen.len() < two_of_three.len() && two_of_three.len() <= one.len(),
        "{} {} {}",
        all_seen.len(),
        two_of_three.len(),
        one.len()
    );
    assert!(
        all_seen
            .voxels
            .iter()
            .all(|v| two_of_three.voxels.binary_search(v).is_ok())
    );
    // The PLY export lists every point.
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("cloud.ply");
    let cloud = all_seen.to_cloud();
    cloud.write_ply(&path, PlyEncoding::Ascii).unwrap();
    let text = std::fs::read_to_string(&path).unwrap();
    assert!(text.contains(&format!("element vertex {}", all_seen.len())));
    assert_eq!(text.lines().count(), 12 + all_seen.len());
    assert!(text.lines().nth(13).unwrap().ends_with(" 160 160 160 0"));
    // Binary: the same header but its format, then 17 bytes per point (3 floats, 3 colour
    // bytes, a ushort band), little-endian, read back exactly.
    cloud.write_ply(&path, PlyEncoding::Binary).unwrap();
    let bytes = std::fs::read(&path).unwrap();
    let end = bytes
        .windows(11)
        .position(|w| w == b"end_header\n")
        .unwrap()
        + 11;
    let header = std::str::from_utf8(&bytes[..end]).unwrap();
    assert!(header.contains("format binary_little_endian 1.0\n"));
    assert_eq!(
        header.replace("binary_little_endian", "ascii"),
        text[..end - 15]
    );
    assert_eq!(bytes.len() - end, 17 * cloud.points.len());
    for (k, p) in cloud.points.iter().enumerate() {
        let at = end + 17 * k;
        let f =
            |i: usize| f32::from_le_bytes(bytes[at + 4 * i..at + 4 * i + 4].try_into().unwrap());
        assert_eq!([f(0), f(1), f(2)], *p);
        assert_eq!(&bytes[at + 12..at + 17], &[160, 160, 160, 0, 0]);
    }
}
