//! The figures are drawn, written and not blank. They stay in `target/tmp/plots/` as
//! artifacts of the test run.

use std::path::PathBuf;

use flexshape_plot::{HistogramSeries, Mark, PALETTE, Series3, histograms, orthographic_views};

fn artifacts() -> PathBuf {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("plots");
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// Fraction of pixels that differ from white, and how many distinct colours appear.
fn ink(png: &std::path::Path) -> (f64, usize) {
    let img = image::open(png).unwrap().to_rgb8();
    let inked = img.pixels().filter(|p| p.0 != [255, 255, 255]).count();
    let mut colours: Vec<[u8; 3]> = img.pixels().map(|p| p.0).collect();
    colours.sort_unstable();
    colours.dedup();
    (
        inked as f64 / (img.width() * img.height()) as f64,
        colours.len(),
    )
}

/// Counts the pixels close to `colour`.
fn pixels_of(png: &std::path::Path, colour: [u8; 3]) -> usize {
    let img = image::open(png).unwrap().to_rgb8();
    img.pixels()
        .filter(|p| (0..3).all(|c| (p.0[c] as i32 - colour[c] as i32).abs() < 30))
        .count()
}

#[test]
fn orthographic_views_draw_every_series() {
    let helix: Vec<[f64; 3]> = (0..400)
        .map(|i| {
            let t = i as f64 * 0.03;
            [40.0 * t.cos(), 40.0 * t.sin(), 8.0 * t]
        })
        .collect();
    let cloud: Vec<[f64; 3]> = helix
        .iter()
        .flat_map(|p| (0..6).map(move |k| [p[0] + k as f64 * 0.5, p[1] - 1.0, p[2] + 0.7]))
        .collect();
    let series = vec![
        Series3 {
            label: "cloud".into(),
            points: cloud,
            mark: Mark::Dots,
            colour: PALETTE[5],
        },
        Series3 {
            label: "spline".into(),
            points: helix.clone(),
            mark: Mark::Line,
            colour: PALETTE[0],
        },
        Series3 {
            label: "model".into(),
            points: helix.iter().map(|p| [p[0] + 3.0, p[1], p[2]]).collect(),
            mark: Mark::Dashed,
            colour: PALETTE[1],
        },
        Series3 {
            label: "bands".into(),
            points: vec![helix[0], helix[200], helix[399]],
            mark: Mark::Crosses,
            colour: PALETTE[2],
        },
    ];
    let stem = artifacts().join("helix_views");
    let files = orthographic_views("helix", &series, &stem).unwrap();
    assert_eq!(files.len(), 2);
    let (inked, colours) = ink(&files[0]);
    assert!(inked > 0.03 && inked < 0.6, "{inked}");
    assert!(colours > 20, "{colours}");
    // Every series' colour is on the image.
    for s in &series {
        assert!(pixels_of(&files[0], s.colour) > 50, "{} missing", s.label);
    }
    let svg = std::fs::read_to_string(&files[1]).unwrap();
    assert!(svg.contains("<svg") && svg.contains("helix") && svg.contains("top (x–y)"));
    // Nothing to draw is an error, not an empty picture.
    assert!(orthographic_views("none", &[], &artifacts().join("none")).is_err());
}

#[test]
fn histograms_show_the_distributions() {
    let values = |shift: f64| -> Vec<f64> {
        (0..500)
            .map(|i| ((i * 7919) % 1000) as f64 / 1000.0 - 0.5 + shift)
            .collect()
    };
    let series: Vec<HistogramSeries> = ["x", "y", "z"]
        .iter()
        .enumerate()
        .map(|(k, a)| HistogramSeries {
            label: format!("{a} error"),
            values: values(k as f64 * 0.1),
            colour: PALETTE[k],
        })
        .collect();
    let files = histograms("errors", "mm", &series, &artifacts().join("errors")).unwrap();
    let (inked, _) = ink(&files[0]);
    assert!(inked > 0.1, "{inked}");
    for s in &series {
        assert!(pixels_of(&files[0], s.colour) > 500, "{} missing", s.label);
    }
    assert!(histograms("none", "mm", &[], &artifacts().join("none")).is_err());
}
