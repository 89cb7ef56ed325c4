//! The `flexshape` binary end to end.

use crate::common;

use common::{flexshape, text};

use std::path::Path;

#[test]
fn simulate_writes_the_recording_layout_and_refuses_to_overwrite() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("rec");
    let o = flexshape(&["simulate", "--out", out.to_str().unwrap(), "--frames", "5"]);
    assert!(o.status.success(), "{}", text(&o));
    assert!(
        text(&o).contains("wrote 5 frames × 3 cameras"),
        "{}",
        text(&o)
    );
    let mut expected = vec!["rig.toml".to_string()];
    for cam in ["cam0", "cam1", "cam2"] {
        expected.push(format!("calibration/{cam}.yml"));
        expected.push(format!("background/{cam}.png"));
        for f in 0..5 {
            expected.push(format!("frames/{cam}/{f:06}.png"));
            expected.push(format!("truth/masks/{cam}/{f:06}.png"));
        }
    }
    for f in 0..5 {
        expected.push(format!("truth/{f:06}.json"));
    }
    for rel in &expected {
        assert!(out.join(rel).is_file(), "{rel} missing");
    }
    assert!(!out.join("frames/cam0/000005.png").exists());
    // A second run into the same folder is refused and leaves it as it was.
    let before = std::fs::read(out.join("truth/000004.json")).unwrap();
    let o = flexshape(&[
        "simulate",
        "--out",
        out.to_str().unwrap(),
        "--frames",
        "2",
        "--seed",
        "9",
    ]);
    assert!(!o.status.success());
    assert!(text(&o).contains("--overwrite"), "{}", text(&o));
    assert_eq!(
        std::fs::read(out.join("truth/000004.json")).unwrap(),
        before
    );
    // The written rig checks out.
    let o = flexshape(&["rig", "check", out.join("rig.toml").to_str().unwrap()]);
    assert!(o.status.success(), "{}", text(&o));
    assert!(
        text(&o).contains("3 cameras") && text(&o).contains("volume corners in view 8/8"),
        "{}",
        text(&o)
    );
    // The simulated catheter's band ends at its tip: that decides a floating tube's direction.
    assert!(text(&o).contains("(tip_band)"), "{}", text(&o));
    // A bare calibration folder sets nothing: it says which setting would decide it.
    let o = flexshape(&["rig", "check", out.join("calibration").to_str().unwrap()]);
    assert!(o.status.success(), "{}", text(&o));
    assert!(
        text(&o).contains("will be ambiguous: set [processing.shape] proximal_hint"),
        "{}",
        text(&o)
    );
}

#[test]
fn rig_check_names_the_bad_field() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("rec");
    let o = flexshape(&[
        "simulate",
        "--out",
        out.to_str().unwrap(),
        "--frames",
        "1",
        "--cams",
        "2",
        "--size",
        "320x240",
    ]);
    assert!(o.status.success(), "{}", text(&o));
    let cam = out.join("calibration/cam1.yml");
    let yaml = std::fs::read_to_string(&cam).unwrap();
    std::fs::write(&cam, yaml.replacen("image_width: 320", "image_width: 0", 1)).unwrap();
    let o = flexshape(&["rig", "check", out.join("rig.toml").to_str().unwrap()]);
    assert!(!o.status.success());
    let t = text(&o);
    assert!(t.contains("cam1.yml") && t.contains("image_width"), "{t}");
    let o = flexshape(&[
        "rig",
        "check",
        Path::new("/nonexistent/rig.toml").to_str().unwrap(),
    ]);
    assert!(!o.status.success());
    assert!(text(&o).contains("/nonexistent/rig.toml"), "{}", text(&o));
    // A folder named like a rig file is not read as a calibration folder.
    let folder = dir.path().join("other/rig.toml");
    std::fs::create_dir_all(&folder).unwrap();
    let e = text(&flexshape(&["rig", "check", folder.to_str().unwrap()]));
    assert!(e.contains("is a folder, not a rig file"), "{e}");
    // What `track` refuses, `rig check` refuses: a processing setting out of range, and a
    // volume no camera sees.
    std::fs::write(&cam, yaml).unwrap();
    let rig_path = out.join("rig.toml");
    let rig = std::fs::read_to_string(&rig_path).unwrap();
    std::fs::write(
        &rig_path,
        rig.replacen(
            "[processing.shape]\n",
            "[processing.shape]\nslice_mm = 300\n",
            1,
        ),
    )
    .unwrap();
    let o = flexshape(&["rig", "check", rig_path.to_str().unwrap()]);
    assert!(!o.status.success());
    assert!(text(&o).contains("slice_mm"), "{}", text(&o));
    std::fs::write(
        &rig_path,
        rig.replacen(
            "origin = [-128.0, -128.0, -128.0]",
            "origin = [5000.0, 5000.0, 5000.0]",
            1,
        ),
    )
    .unwrap();
    let o = flexshape(&["rig", "check", rig_path.to_str().unwrap()]);
    assert!(!o.status.success());
    assert!(text(&o).contains("see none of the volume"), "{}", text(&o));
    std::fs::write(&rig_path, rig).unwrap();
    let o = flexshape(&["rig", "check", rig_path.to_str().unwrap()]);
    assert!(o.status.success(), "{}", text(&o));
}

#[test]
fn demo_runs_headless_and_reports_accuracy_and_speed() {
    let dir = tempfile::tempdir().unwrap();
    let rec = dir.path().join("rec");
    let o = flexshape(&[
        "demo",
        "--frames",
        "3",
        "--no-viewer",
        "--out",
        rec.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", text(&o));
    let t = text(&o);
    let rows: Vec<&str> = t
        .lines()
        .filter(|l| l.trim_start().starts_with(['0', '1', '2']))
        .collect();
    assert_eq!(rows.len(), 3, "one row per frame: {t}");
    assert!(
        t.contains("3 frames, 3 ok; against truth over 3 frames"),
        "{t}"
    );
    // The figures it prints are the real ones: sub-millimetre against truth.
    let figure = |after: &str| -> f64 {
        let rest = &t[t.find(after).unwrap_or_else(|| panic!("{after}: {t}")) + after.len()..];
        rest.split_whitespace().next().unwrap().parse().unwrap()
    };
    assert!(figure("centerline rms median") < 0.3, "{t}");
    assert!(figure("tip median") < 0.8, "{t}");
    assert!(figure("the chain takes") > 0.0, "{t}");
    assert!(t.contains("the carved hull holds ≥ 100.0 %"), "{t}");
    // The recording it wrote carries the model's commands beside the truth.
    let command = std::fs::read_to_string(rec.join("commands/000002.json")).unwrap();
    assert!(command.contains("tendon_displacements"), "{command}");
    assert!(rec.join("truth/000002.json").is_file());
}

/// An error whose message already names its cause says it once.
#[test]
fn an_error_names_its_cause_once() {
    let dir = tempfile::tempdir().unwrap();
    let missing = dir.path().join("nowhere.toml");
    let o = flexshape(&["rig", "check", missing.to_str().unwrap()]);
    assert!(!o.status.success());
    let t = text(&o);
    assert_eq!(t.matches("No such file").count(), 1, "{t}");
}

#[test]
fn bad_arguments_are_clear() {
    let o = flexshape(&["simulate", "--out", "/tmp/never", "--size", "640by480"]);
    assert!(!o.status.success());
    assert!(text(&o).contains("WIDTHxHEIGHT"), "{}", text(&o));
    let o = flexshape(&["demo", "--frames", "1", "--cams", "0"]);
    assert!(!o.status.success());
    assert!(text(&o).contains("cameras"), "{}", text(&o));
    let o = flexshape(&["track", "/nonexistent", "--threads", "0"]);
    assert!(!o.status.success());
    assert!(text(&o).contains("at least 1"), "{}", text(&o));
    // A camera name becomes a file name: `../x` would write outside --out.
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("cal");
    let o = flexshape(&[
        "calibrate",
        "--board",
        "9x6",
        "--square",
        "25",
        "--images",
        &format!("../x={}", dir.path().display()),
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(!o.status.success());
    assert!(text(&o).contains("camera name `../x`"), "{}", text(&o));
    assert!(!dir.path().join("x.yml").exists() && !out.exists());
}

#[test]
fn background_and_silhouettes_commands() {
    let dir = tempfile::tempdir().unwrap();
    let rec = dir.path().join("rec");
    let o = flexshape(&[
        "simulate",
        "--out",
        rec.to_str().unwrap(),
        "--frames",
        "2",
        "--shadows",
    ]);
    assert!(o.status.success(), "{}", text(&o));
    // Diagnostics of a recorded frame against its truth, with debug images.
    let dbg = dir.path().join("dbg");
    let o = flexshape(&[
        "silhouettes",
        rec.to_str().unwrap(),
        "--frame",
        "1",
        "--out",
        dbg.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", text(&o));
    let t = text(&o);
    assert_eq!(t.matches("IoU vs truth 0.9").count(), 3, "{t}");
    for f in ["cam0_object.png", "cam1_markers.png", "cam2_debug.png"] {
        assert!(dbg.join(f).is_file(), "{f} missing");
    }
    let o = flexshape(&["silhouettes", rec.to_str().unwrap(), "--frame", "7"]);
    assert!(!o.status.success());
    assert!(text(&o).contains("no frame 000007"), "{}", text(&o));
    // The same frame from plain image folders (a rig being set up has no recording yet).
    let folder = |c: &str| format!("{c}={}", rec.join("frames").join(c).display());
    let o = flexshape(&[
        "silhouettes",
        "--images",
        &folder("cam0"),
        "--images",
        &folder("cam1"),
        "--images",
        &folder("cam2"),
        "--rig",
        rec.join("rig.toml").to_str().unwrap(),
        "--backgrounds",
        rec.join("background").to_str().unwrap(),
        "--frame",
        "1",
    ]);
    let t = text(&o);
    assert!(o.status.success(), "{t}");
    assert!(
        t.contains("frame 000001 (000001)") && t.contains("shape: ok"),
        "{t}"
    );
    assert_eq!(t.matches("outline ").count(), 3, "{t}");
    // A background model from several frames of the empty scene.
    let frames = dir.path().join("bg");
    std::fs::create_dir(&frames).unwrap();
    for k in 0..3u8 {
        let img = image::RgbImage::from_fn(32, 24, |x, y| {
            image::Rgb([100 + k, (x * 3) as u8, (y * 5) as u8])
        });
        img.save(frames.join(format!("{k}.png"))).unwrap();
    }
    let model = dir.path().join("model/cam0.png");
    let o = flexshape(&[
        "background",
        "--images",
        frames.to_str().unwrap(),
        "--out",
        model.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", text(&o));
    assert!(text(&o).contains("from 3 frame(s)"), "{}", text(&o));
    assert!(model.is_file() && dir.path().join("model/cam0.spread.png").is_file());
    let empty = dir.path().join("empty");
    std::fs::create_dir(&empty).unwrap();
    let o = flexshape(&[
        "background",
        "--images",
        empty.to_str().unwrap(),
        "--out",
        model.to_str().unwrap(),
    ]);
    assert!(!o.status.success());
    assert!(text(&o).contains("no PNG or JPEG images"), "{}", text(&o));
}

/// Every numeric option takes a negative number as its value (a volume centred on the origin
/// has them); invalid ones are refused by the option's own check, which names it.
#[test]
fn negative_numbers_reach_the_options() {
    let dir = tempfile::tempdir().unwrap();
    let out = |name: &str| dir.path().join(name).to_str().unwrap().to_string();
    let cases: Vec<(Vec<String>, &str)> = vec![
        (
            vec![
                "track".into(),
                out("none"),
                "--volume".into(),
                "-128,-128,-128,128,128,128".into(),
            ],
            "cannot open the recording",
        ),
        (
            vec!["track".into(), out("none"), "--voxel".into(), "-1".into()],
            "cannot open the recording",
        ),
        (
            vec![
                "simulate".into(),
                "--out".into(),
                out("a"),
                "--noise".into(),
                "-1".into(),
            ],
            "noise_sigma",
        ),
        (
            vec![
                "simulate".into(),
                "--out".into(),
                out("b"),
                "--radius".into(),
                "-3".into(),
            ],
            "radius",
        ),
        (
            vec![
                "simulate".into(),
                "--out".into(),
                out("c"),
                "--focal".into(),
                "-800".into(),
            ],
            "focal",
        ),
        (
            vec![
                "simulate".into(),
                "--out".into(),
                out("d"),
                "--fold-depth".into(),
                "-0.1".into(),
            ],
            "fold_depth",
        ),
        (vec!["bench".into(), "--rate".into(), "-1".into()], "--rate"),
        (
            vec![
                "bench".into(),
                "--soak".into(),
                "5".into(),
                "--threads".into(),
                "0".into(),
            ],
            "--threads",
        ),
        (
            vec![
                "demo".into(),
                "--no-viewer".into(),
                "--fps".into(),
                "-2".into(),
            ],
            "--fps",
        ),
        (
            vec![
                "calibrate".into(),
                "--board".into(),
                "9x6".into(),
                "--square".into(),
                "-1".into(),
                "--images".into(),
                format!("cam0={}", out("")),
                "--out".into(),
                out("cal"),
            ],
            "square size -1",
        ),
        (
            vec![
                "simulate".into(),
                "chessboards".into(),
                "--out".into(),
                out("boards"),
                "--square".into(),
                "-30".into(),
            ],
            "square",
        ),
        (
            vec![
                "rig".into(),
                "import".into(),
                "kalibr".into(),
                out("none.yaml"),
                "-o".into(),
                out("imported"),
                "--volume".into(),
                "-100,-100,-100,100,100,100".into(),
                "--voxel".into(),
                "-1".into(),
            ],
            "none.yaml",
        ),
    ];
    for (args, expected) in cases {
        let refs: Vec<&str> = args.iter().map(String::as_str).collect();
        let o = flexshape(&refs);
        let t = text(&o);
        assert!(!t.contains("unexpected argument"), "{args:?}: {t}");
        assert!(!o.status.success(), "{args:?}: {t}");
        assert!(t.contains(expected), "{args:?}: {t}");
    }
}

#[test]
fn bench_prints_per_stage_figures_as_json() {
    let o = flexshape(&[
        "bench",
        "--frames",
        "2",
        "--rounds",
        "1",
        "--track-frames",
        "3",
        "--json",
    ]);
    assert!(o.status.success(), "{}", text(&o));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let results = v["results"].as_array().unwrap();
    assert_eq!(results.len(), 2);
    for r in results {
        let stages: Vec<&str> = r["stages"]
            .as_array()
            .unwrap()
            .iter()
            .map(|s| s["stage"].as_str().unwrap())
            .collect();
        assert_eq!(stages, ["silhouettes", "carve", "bands", "shape", "fit"]);
        assert!(r["throughput_fps"].as_f64().unwrap() > 0.0);
    }
    assert!(v["png_decode_ms"].as_f64().unwrap() > 0.0);
    // Tracking figures over the motion: the frames after the first follow the one before.
    let tracking = v["tracking"].as_array().unwrap();
    assert_eq!(tracking.len(), 2);
    assert!(tracking[0]["followed"].as_f64().unwrap() > 0.0);
    // Each workload's records against the simulator's truth (measured: 2 of 2 and 3 of 3
    // right, centerline within 0.04 mm, tips within 0.12 mm).
    for (workload, frames) in [(&results[0], 2), (&tracking[0], 3)] {
        let a = &workload["accuracy"];
        assert_eq!(a["frames"], frames, "{a}");
        assert_eq!(a["right"], frames, "{a}");
        let rms = a["centerline_rms_mm"].as_array().unwrap();
        let tip = a["tip_mm"].as_array().unwrap();
        assert!(rms[1].as_f64().unwrap() < 0.08, "{a}");
        assert!(tip[1].as_f64().unwrap() < 0.3, "{a}");
        assert!(rms[0].as_f64().unwrap() > 0.0, "{a}");
    }
}

#[test]
fn model_template_inverse_and_forward_agree() {
    let dir = tempfile::tempdir().unwrap();
    let params = dir.path().join("m.toml");
    let o = flexshape(&["model", "template"]);
    assert!(o.status.success(), "{}", text(&o));
    std::fs::write(&params, &o.stdout).unwrap();
    let p = params.to_str().unwrap();
    let o = flexshape(&[
        "model",
        "inverse",
        "--params",
        p,
        "--values",
        "0.01,-0.005,0.006",
    ]);
    assert!(o.status.success(), "{}", text(&o));
    let y = String::from_utf8_lossy(&o.stdout)
        .trim()
        .rsplit(": ")
        .next()
        .unwrap()
        .replace(' ', "");
    let o = flexshape(&["model", "forward", "--params", p, "--values", &y]);
    let t = text(&o);
    assert!(
        t.contains("κx 0.010000") && t.contains("κz -0.005000") && t.contains("ε0 0.006000"),
        "{t}"
    );
    assert!(t.contains("slack tendons: none"), "{t}");
    // CSV in, CSV out; wrong sizes and bad files are named.
    let csv = dir.path().join("y.csv");
    std::fs::write(&csv, format!("# y0..y3\n{y}\n-3,5,0,0\n")).unwrap();
    let o = flexshape(&[
        "model",
        "forward",
        "--params",
        p,
        "--csv",
        csv.to_str().unwrap(),
    ]);
    let out = String::from_utf8_lossy(&o.stdout).to_string();
    assert_eq!(out.lines().count(), 3, "{out}");
    assert!(out.lines().last().unwrap().ends_with(",0 2"), "{out}");
    let o = flexshape(&["model", "forward", "--params", p, "--values", "1,2,3"]);
    assert!(!o.status.success() && text(&o).contains("3 displacements for a model with 4 tendons"));
    // A device is not a CSV file: refused at once, not read without end.
    let o = flexshape(&["model", "forward", "--params", p, "--csv", "/dev/zero"]);
    assert!(
        !o.status.success() && text(&o).contains("not a regular file"),
        "{}",
        text(&o)
    );
    std::fs::write(&params, "proximal_length = 1000.0\n").unwrap();
    let o = flexshape(&["model", "forward", "--params", p, "--values", "1,2,3,4"]);
    assert!(
        !o.status.success() && text(&o).contains("m.toml"),
        "{}",
        text(&o)
    );
}

#[test]
fn validate_points_registers_and_reports_per_axis_rms() {
    let dir = tempfile::tempdir().unwrap();
    // Reference points in an instrument frame; sensed = R·ref + t with ±0.2 mm wobble.
    let (c, s) = (0.6f64.cos(), 0.6f64.sin());
    let mut reference = String::from("x,y,z\n");
    let mut sensed = String::from("# sensed tips\n");
    for i in 0..12 {
        let p = [
            (i as f64 * 1.7).sin() * 60.0,
            (i as f64 * 0.9).cos() * 50.0,
            i as f64 * 8.0 - 40.0,
        ];
        let wobble = if i % 2 == 0 { 0.2 } else { -0.2 };
        let q = [
            c * p[0] - s * p[1] + 10.0 + wobble,
            s * p[0] + c * p[1] - 5.0,
            p[2] + 100.0 - wobble,
        ];
        reference += &format!("{},{},{}\n", p[0], p[1], p[2]);
        sensed += &format!("{},{},{}\n", q[0], q[1], q[2]);
    }
    let (r, se) = (dir.path().join("ref.csv"), dir.path().join("sensed.csv"));
    std::fs::write(&r, &reference).unwrap();
    std::fs::write(&se, &sensed).unwrap();
    let args = |extra: &[&str]| {
        let mut a = vec![
            "validate",
            "points",
            "--sensed",
            se.to_str().unwrap(),
            "--reference",
            r.to_str().unwrap(),
        ];
        a.extend_from_slice(extra);
        flexshape(&a)
    };
    let o = args(&["--json"]);
    assert!(o.status.success(), "{}", text(&o));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(v["points"], 12);
    let rms = v["rms"].as_f64().unwrap();
    assert!(rms > 0.15 && rms < 0.3, "rms {rms}");
    assert!(v["rms_y"].as_f64().unwrap() < 0.1, "no wobble along y: {v}");
    let t = v["translation"].as_array().unwrap();
    assert!((t[2].as_f64().unwrap() - 100.0).abs() < 0.2, "{v}");
    assert!(text(&args(&[])).contains("paper (Section III"));
    // Bad input is named.
    std::fs::write(&se, "1,2,3\n4,5,6\n").unwrap();
    let o = args(&[]);
    assert!(
        !o.status.success() && text(&o).contains("pairs"),
        "{}",
        text(&o)
    );
    std::fs::write(&se, "1,2,3\n4,5\n").unwrap();
    let o = args(&[]);
    assert!(
        !o.status.success() && text(&o).contains("sensed.csv line 2"),
        "{}",
        text(&o)
    );
    std::fs::write(&r, "0,0,0\n1,0,0\n2,0,0\n").unwrap();
    std::fs::write(&se, "0,0,0\n1,0,0\n2,0,0\n").unwrap();
    let o = args(&[]);
    assert!(
        !o.status.success() && text(&o).contains("on one line"),
        "{}",
        text(&o)
    );
}

/// `rig import` writes a rig `track` and `rig check` load, refuses to replace it, asks for
/// what a format lacks; `rig export` writes what imports back.
#[test]
fn rig_import_and_export_round_trip_other_tools_calibrations() {
    let fixtures =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../rig/tests/fixtures/import");
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("rig");
    let o = out.to_str().unwrap();
    let chain = fixtures.join("camchain.yaml");
    let text = common::run(&["rig", "import", "kalibr", chain.to_str().unwrap(), "-o", o]);
    assert!(text.contains("cam2") && text.contains("mm apart"), "{text}");
    let check = common::run(&["rig", "check", &format!("{o}/rig.toml")]);
    assert!(check.contains("3 cameras"), "{check}");
    // Without --volume, the volume is a box every camera sees.
    assert_eq!(
        check.matches("volume corners in view 8/8").count(),
        3,
        "{check}"
    );
    let e = common::fails(&["rig", "import", "kalibr", chain.to_str().unwrap(), "-o", o]);
    assert!(
        e.contains("already exist") && e.contains("--overwrite"),
        "{e}"
    );
    common::run(&[
        "rig",
        "import",
        "kalibr",
        chain.to_str().unwrap(),
        "-o",
        o,
        "--overwrite",
    ]);
    // A projection matrix holds neither the image size nor the unit.
    let p = fixtures.join("cam0_P.txt");
    let other = dir.path().join("p");
    let e = common::fails(&[
        "rig",
        "import",
        "projection",
        p.to_str().unwrap(),
        "-o",
        other.to_str().unwrap(),
        "--unit",
        "mm",
    ]);
    assert!(e.contains("image size") && e.contains("WxH"), "{e}");
    let e = common::fails(&[
        "rig",
        "import",
        "projection",
        p.to_str().unwrap(),
        "-o",
        other.to_str().unwrap(),
        "--size",
        "640x480",
    ]);
    assert!(e.contains("unit"), "{e}");
    common::run(&[
        "rig",
        "import",
        "projection",
        p.to_str().unwrap(),
        "-o",
        other.to_str().unwrap(),
        "--size",
        "640x480",
        "--unit",
        "mm",
    ]);
    assert!(other.join("cam0_P.yml").is_file());
    // Never over its own input: a matrix saved as cam0_P.yml, imported into its own folder.
    let same = dir.path().join("same");
    std::fs::create_dir_all(&same).unwrap();
    let input = same.join("cam0_P.yml");
    std::fs::copy(&p, &input).unwrap();
    let matrix = std::fs::read(&input).unwrap();
    let e = common::fails(&[
        "rig",
        "import",
        "projection",
        input.to_str().unwrap(),
        "-o",
        same.to_str().unwrap(),
        "--size",
        "640x480",
        "--unit",
        "mm",
        "--overwrite",
    ]);
    assert!(e.contains("the input") && e.contains("elsewhere"), "{e}");
    assert_eq!(std::fs::read(&input).unwrap(), matrix);
    // Nor an export into the folder of camera files it reads.
    let e = common::fails(&[
        "rig",
        "export",
        o,
        "--format",
        "camera-info",
        "-o",
        o,
        "--overwrite",
    ]);
    assert!(e.contains("the input") && e.contains("elsewhere"), "{e}");
    assert!(!out.join("cam0.yaml").exists());
    // Out again as COLMAP, and back in.
    let colmap = dir.path().join("colmap");
    common::run(&[
        "rig",
        "export",
        &format!("{o}/rig.toml"),
        "--format",
        "colmap",
        "-o",
        colmap.to_str().unwrap(),
    ]);
    let back = dir.path().join("back");
    let text = common::run(&[
        "rig",
        "import",
        "colmap",
        colmap.to_str().unwrap(),
        "--unit",
        "mm",
        "-o",
        back.to_str().unwrap(),
    ]);
    assert!(text.contains("cam1"), "{text}");
    let a = std::fs::read_to_string(out.join("cam1.yml")).unwrap();
    let b = std::fs::read_to_string(back.join("cam1.yml")).unwrap();
    assert!(a.contains("image_width: 640") && b.contains("image_width: 640"));
}

/// Standard output on a full disk or a closed pipe: one clear line (or, for the pipe, a quiet
/// end with status 141 as Unix tools give), never a panic.
#[test]
fn a_full_disk_or_closed_pipe_on_stdout_is_no_panic() {
    use std::process::{Command, Stdio};
    let bin = env!("CARGO_BIN_EXE_flexshape");
    let dir = tempfile::tempdir().unwrap();
    let chain = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../rig/tests/fixtures/import/camchain.yaml");
    let out = dir.path().join("rig");
    let import = vec![
        "rig",
        "import",
        "kalibr",
        chain.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
    ];
    if std::path::Path::new("/dev/full").exists() {
        for args in [vec!["model", "template"], import] {
            let o = Command::new(bin)
                .args(&args)
                .stdout(std::fs::File::create("/dev/full").unwrap())
                .output()
                .unwrap();
            let err = String::from_utf8_lossy(&o.stderr);
            assert_eq!(o.status.code(), Some(1), "{args:?}: {err}");
            assert!(!err.contains("panicked"), "{args:?}: {err}");
            assert!(
                err.contains("cannot write to the standard output"),
                "{args:?}: {err}"
            );
        }
    }
    // A pipe closed after the first line.
    let mut child = Command::new(bin)
        .args(["model", "template"])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    drop(child.stdout.take());
    let o = child.wait_with_output().unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!err.contains("panicked"), "{err}");
    assert!(
        matches!(o.status.code(), Some(0) | Some(141)),
        "{:?}: {err}",
        o.status
    );
}

#[test]
fn rig_check_takes_a_volume_rounds_and_summarises_many_cameras() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("rec");
    let o = out.to_str().unwrap();
    common::run(&["simulate", "--out", o, "--frames", "1", "--cams", "6"]);
    let rig = format!("{o}/rig.toml");
    let check = common::run(&[
        "rig",
        "check",
        &rig,
        "--volume",
        "-50,-50,-50,50,50,50",
        "--voxel",
        "0.3",
    ]);
    assert!(
        check.contains("333×333×333 voxels of 0.3 mm from (-50, -50, -50) to (49.9, 49.9, 49.9)")
            && check.contains("(--volume / --voxel)"),
        "{check}"
    );
    // Six cameras: 15 pairs in one line, not one line each.
    assert!(
        check.contains("angles between camera axes, 15 pairs: narrowest")
            && !check.contains("angle between"),
        "{check}"
    );
    assert!(!check.contains("0000000"), "float noise: {check}");
}
