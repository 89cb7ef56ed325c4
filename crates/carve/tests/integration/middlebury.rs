//! Real data: the Middlebury "dinoSparseRing" set (16 calibrated 640×480 photographs of a
//! dinosaur on black cloth, `../shared/data/`). Silhouettes from our silhouette stage, the
//! bounding box carved at 0.5 mm with the 15 views its authors list as good, and the hull
//! projected back into each view must agree with that view's silhouette.

use std::path::PathBuf;

use flexshape_camera::Camera;
use flexshape_camera::nalgebra::Point3;
use flexshape_carve::{HierarchicalCarver, Occupancy, OutsideImage};
use flexshape_rig::Volume;
use flexshape_rig::middlebury::read_par;
use flexshape_silhouette::{
    BackgroundModel, BitMask, Classifier, Difference, KeepComponents, SilhouetteSettings,
    Silhouetter,
};

fn data_dir() -> Option<PathBuf> {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../../shared/data/middlebury-dino-sparse-ring");
    if dir.is_dir() {
        Some(dir)
    } else {
        assert!(
            std::env::var("FLEXSHAPE_REQUIRE_SHARED").as_deref() != Ok("1"),
            "FLEXSHAPE_REQUIRE_SHARED=1 but {} is missing",
            dir.display()
        );
        eprintln!(
            "SKIPPED: {} not found (the shared data sits beside the repository)",
            dir.display()
        );
        None
    }
}

/// The authors' recipe (threshold 0.19 of full scale on black) in our silhouette stage; the
/// closing fills the dark shadows on the body.
fn silhouette(image: &image::RgbImage) -> BitMask {
    let black = BackgroundModel::uniform(image.width(), image.height(), [0.0; 3], 2.0).unwrap();
    let settings = SilhouetteSettings {
        classifier: Classifier::Difference(Difference {
            min_difference: 0.19 * 255.0,
            noise_factor: 4.0,
        }),
        close_radius: 10,
        keep: KeepComponents::Largest,
        ..SilhouetteSettings::default()
    };
    Silhouetter::new(&black, settings)
        .unwrap()
        .process(image)
        .unwrap()
        .object
}

/// The hull as seen by `cam`: pixel centres covered by the projection of an occupied voxel's
/// cube. A ray that meets the hull enters it through a surface voxel (one with an empty face
/// neighbour), so only those are drawn; each cube projects to the convex hull of its corners
/// (these cameras have no distortion).
fn render_hull(occ: &Occupancy, cam: &Camera) -> BitMask {
    let v = &occ.volume;
    let (w, h) = (
        cam.intrinsics.width as usize,
        cam.intrinsics.height as usize,
    );
    let mut grid = vec![false; v.voxel_count() as usize];
    for &i in &occ.voxels {
        grid[i as usize] = true;
    }
    let [nx, ny, nz] = v.dims.map(|d| d as i64);
    let filled = |i: i64, j: i64, k: i64| {
        (0..nx).contains(&i)
            && (0..ny).contains(&j)
            && (0..nz).contains(&k)
            && grid[(i + nx * (j + ny * k)) as usize]
    };
    let mut out = BitMask::new(w, h);
    for &index in &occ.voxels {
        let [i, j, k] = occ.ijk(index).map(|c| c as i64);
        let surface = [(1, 0, 0), (0, 1, 0), (0, 0, 1)]
            .iter()
            .any(|&(a, b, c)| !filled(i + a, j + b, k + c) || !filled(i - a, j - b, k - c));
        if !surface {
            continue;
        }
        let corners: Vec<[f64; 2]> = (0..8)
            .map(|n| {
                let p = Point3::new(
                    v.origin[0] + (i + (n & 1)) as f64 * v.voxel_size[0],
                    v.origin[1] + (j + (n >> 1 & 1)) as f64 * v.voxel_size[1],
                    v.origin[2] + (k + (n >> 2)) as f64 * v.voxel_size[2],
                );
                let px = cam.project(&p).unwrap().pixel;
                [px.x, px.y]
            })
            .collect();
        let hull = convex_hull(corners);
        let (x0, x1) = hull
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), p| {
                (a.min(p[0]), b.max(p[0]))
            });
        let (y0, y1) = hull
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), p| {
                (a.min(p[1]), b.max(p[1]))
            });
        for y in (y0.ceil().max(0.0) as usize)..=(y1.floor().min(h as f64 - 1.0) as usize) {
            for x in (x0.ceil().max(0.0) as usize)..=(x1.floor().min(w as f64 - 1.0) as usize) {
                let (px, py) = (x as f64, y as f64);
                let inside = (0..hull.len()).all(|e| {
                    let (a, b) = (hull[e], hull[(e + 1) % hull.len()]);
                    (b[0] - a[0]) * (py - a[1]) - (b[1] - a[1]) * (px - a[0]) >= 0.0
                });
                if inside {
                    out.set(x, y, true);
                }
            }
        }
    }
    out
}

/// Counter-clockwise (in a y-down image: as the cross product sees it) convex hull, Andrew's
/// monotone chain.
fn convex_hull(mut p: Vec<[f64; 2]>) -> Vec<[f64; 2]> {
    p.sort_by(|a, b| a.partial_cmp(b).unwrap());
    let cross = |o: [f64; 2], a: [f64; 2], b: [f64; 2]| {
        (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])
    };
    let mut hull: Vec<[f64; 2]> = Vec::new();
    for pass in 0..2 {
        let start = hull.len();
        let points: Vec<[f64; 2]> = if pass == 0 {
            p.clone()
        } else {
            p.iter().rev().copied().collect()
        };
        for q in points {
            while hull.len() >= start + 2
                && cross(hull[hull.len() - 2], hull[hull.len() - 1], q) <= 0.0
            {
                hull.pop();
            }
            hull.push(q);
        }
        hull.pop();
    }
    hull
}

#[test]
fn dino_hull_agrees_with_every_silhouette() {
    let Some(dir) = data_dir() else { return };
    let views = read_par(&dir.join("dinoSR_par.txt"), 640, 480, 1000.0).unwrap();
    assert_eq!(views.len(), 16);
    let good = std::fs::read_to_string(dir.join("dinoSR_good_silhouette_images.txt")).unwrap();
    let good: Vec<&str> = good.split_whitespace().collect();
    assert_eq!(good.len(), 15);
    let mut cameras = Vec::new();
    let mut masks = Vec::new();
    for view in views.iter().filter(|v| good.contains(&v.image.as_str())) {
        let image = image::open(dir.join(&view.image)).unwrap().to_rgb8();
        cameras.push(view.camera.clone());
        masks.push(silhouette(&image));
    }
    // The authors' tight bounding box (metres → mm), with 2 mm to spare.
    let volume = Volume::from_bounds(
        [-61.897 - 2.0, -18.874 - 2.0, -57.845 - 2.0],
        [10.897 + 2.0, 68.227 + 2.0, 15.495 + 2.0],
        0.5,
    )
    .unwrap();
    let refs: Vec<&BitMask> = masks.iter().collect();
    let carver = HierarchicalCarver::new(&cameras, &volume).unwrap();
    // Parts of the dino leave some images: those views do not constrain what they miss.
    let occ = carver
        .carve(&refs, OutsideImage::Ignore { min_views: 10 })
        .unwrap();
    assert!(
        occ.voxels.len() > 100_000,
        "{} voxels carved",
        occ.voxels.len()
    );
    let mut worst = 1.0f64;
    for (n, (cam, mask)) in cameras.iter().zip(&masks).enumerate() {
        let hull = render_hull(&occ, cam);
        let iou = hull.iou(mask);
        eprintln!("view {n} ({}): IoU {iou:.4}", good[n]);
        worst = worst.min(iou);
    }
    eprintln!("worst IoU {worst:.4}, {} voxels", occ.voxels.len());
    assert!(worst >= 0.95, "worst silhouette IoU {worst:.4}");
}
