//! Every numeric setting at special values: refused by the settings check naming it (and the
//! value as written: `1e300`, not 301 digits), or a frame runs to a result — never a panic, an abort on a huge allocation, or a run without end.
//! (A hand-built campaign found `slice_mm = 300` overflowing, `span_mm = 0.001` asking for
//! 432 GB and `extend_mm = 1e9` aborting; the fuzz tests only check the settings, this runs
//! them.)

use crate::common;

use flexshape_silhouette::BackgroundModel;
use flexshape_track::Pipeline;

const FLOATS: [f64; 6] = [0.0, 1e-9, 0.05, 1e6, 1e300, -1.0];
const INTEGERS: [i64; 4] = [0, 1, 1_000_000, 4_294_967_296];

#[test]
fn every_numeric_setting_at_special_values_is_refused_or_runs() {
    let (sim, _) = common::simulated_chain();
    let frame = sim.render(0, &sim.sweep(1)[0]).unwrap();
    let images: Vec<_> = frame.views.iter().map(|v| &v.image).collect();
    let backgrounds: Vec<_> = BackgroundModel::each(&sim.backgrounds()).unwrap();
    let floats: &[(&str, &str)] = &[
        ("fit", "span_mm"),
        ("fit", "spacing_mm"),
        ("fit", "search_px"),
        ("fit", "huber_px"),
        ("fit", "min_contrast"),
        ("fit", "extend_mm"),
        ("fit", "slide_prior"),
        ("fit", "end_anchor"),
        ("fit", "max_residual_px"),
        ("fit", "max_p90_px"),
        ("fit", "min_found"),
        ("fit", "min_iou"),
        ("fit", "max_ghost_mm"),
        ("fit", "max_sigma_mm"),
        ("fit", "track_margin_px"),
        ("fit", "track_max_move_mm"),
        ("shape", "slice_mm"),
        ("shape", "sample_mm"),
        ("shape", "radius_mm"),
        ("silhouette", "max_foreground"),
        ("silhouette", "max_foreground_growth"),
    ];
    let integers: &[(&str, &str)] = &[
        ("fit", "max_iterations"),
        ("fit", "max_unexplained_px"),
        ("fit", "explain_px"),
        ("shape", "cell_voxels"),
        ("shape", "expected_bands"),
        ("shape", "min_voxels"),
        ("silhouette", "close_radius"),
    ];
    let values = floats
        .iter()
        .flat_map(|&(t, k)| FLOATS.iter().map(move |&v| (t, k, toml::Value::Float(v))))
        .chain(integers.iter().flat_map(|&(t, k)| {
            INTEGERS
                .iter()
                .map(move |&v| (t, k, toml::Value::Integer(v)))
        }));
    let (mut refused, mut ran) = (0, 0);
    for (table, key, value) in values {
        let mut rig = sim.rig().clone();
        let stage = rig
            .processing
            .entry(table)
            .or_insert_with(|| toml::Value::Table(toml::Table::new()));
        if let toml::Value::Table(t) = stage {
            t.insert(key.to_string(), value.clone());
        }
        let setting = format!("[processing.{table}] {key} = {value}");
        let Ok(pipeline) = Pipeline::new(&rig, &backgrounds, &rig.volume) else {
            refused += 1;
            let Err(e) = Pipeline::check_settings(&rig) else {
                panic!("{setting}: rig check passes what track refuses");
            };
            // The value as written, not 1e300 or 1e-300 spelled out in some 300 digits.
            let said = e.to_string();
            assert!(!said.contains("0000000000"), "{setting}: {said}");
            continue;
        };
        // Said first: an abort would leave no other trace of which setting it was.
        eprintln!("{setting}");
        let start = std::time::Instant::now();
        let _ = pipeline.process(&images);
        let took = start.elapsed().as_secs_f64();
        assert!(took < 20.0, "{setting}: one frame took {took:.1} s");
        ran += 1;
    }
    println!("{refused} refused, {ran} ran a frame");
    assert!(refused > 0 && ran > 0);
}

/// A `[processing]` table no stage reads (a misspelled `[processing.shap]`) and a
/// `per_camera` table for a camera the rig does not have (`cam9`, `CAM0`) are refused by the
/// settings check and by the pipeline alike, naming the table; before, their settings were
/// ignored, invalid values and all. The rig's own camera names are taken.
#[test]
fn tables_no_stage_reads_and_cameras_the_rig_lacks_are_refused() {
    let (sim, _) = common::simulated_chain();
    let backgrounds: Vec<_> = BackgroundModel::each(&sim.backgrounds()).unwrap();
    let with = |extra: &str| {
        let mut rig = sim.rig().clone();
        let table: toml::Table = extra.parse().unwrap();
        let toml::Value::Table(processing) = &table["processing"] else {
            panic!("{extra}");
        };
        for (k, v) in processing {
            rig.processing.insert(k.clone(), v.clone());
        }
        rig
    };
    for (extra, named) in [
        ("[processing.shap]\nslice_mm = 1e-300", "[processing.shap]"),
        (
            "[processing.silhouette.per_camera.cam9]\nclose_radius = 1",
            "[processing.silhouette.per_camera.cam9]",
        ),
        (
            "[processing.silhouette.per_camera.CAM0]\nclose_radius = 1",
            "[processing.silhouette.per_camera.CAM0]",
        ),
    ] {
        let rig = with(extra);
        let checked = Pipeline::check_settings(&rig).unwrap_err().to_string();
        assert!(checked.contains(named), "{extra}: {checked}");
        let built = Pipeline::new(&rig, &backgrounds, &rig.volume)
            .err()
            .unwrap()
            .to_string();
        assert_eq!(built, checked, "{extra}");
    }
    let rig = with("[processing.silhouette.per_camera.cam0]\nclose_radius = 1");
    Pipeline::check_settings(&rig).unwrap();
    Pipeline::new(&rig, &backgrounds, &rig.volume).unwrap();
}
