//! Mutation fuzzing of everything a user hands the tracker as a file: camera files (YAML and
//! JSON), rig files with every stage's settings (parsed, then checked as `track` and `rig check`
//! do), frames (PNG decoding with the size check), a recording's `timestamps.csv`, the
//! records and model frames `model fit` and `track --model-frame` read back, and every
//! calibration format `rig import` reads (projection text, KITTI lines, `.npy`, Middlebury,
//! CameraInfo, Kalibr, COLMAP, OpenCV stereo as FileStorage YAML/JSON and `.npz`), each read
//! and, when it gives cameras, made into a rig as the import does. Valid
//! seeds are mutated (bytes flipped, inserted, deleted, duplicated; tokens such as `1e308`,
//! `.nan`, `-0`, `[[cameras]]` spliced in) by a seeded generator; every input must give a
//! value or an error, never a panic.
//!
//! CI runs `FLEXSHAPE_FUZZ_EXECS` (default 2,000) inputs per target; a longer run:
//! `FLEXSHAPE_FUZZ_EXECS=1000000 cargo test --release -p flexshape-track --test integration fuzz -- --nocapture`
//! (figures in `docs/benchmarks.md`).

use std::panic::{AssertUnwindSafe, catch_unwind};
use std::path::Path;

use flexshape_record::{ModelFrame, TrackRecord};
use flexshape_recording::RecordingReader;
use flexshape_rig::import::{self, Format, ImportOptions, Unit};
use flexshape_rig::{Rig, Volume, camera_file, files};
use flexshape_track::Pipeline;

/// Tokens spliced into inputs: special numbers, syntax, and keys the readers look for.
const TOKENS: &[&str] = &[
    "1e308",
    "-1e308",
    "1e-300",
    "nan",
    ".nan",
    ".inf",
    "-.inf",
    "inf",
    "-0",
    "0",
    "-1",
    "18446744073709551616",
    "4294967296",
    "999999999",
    "0.0",
    "1e9",
    "[",
    "]",
    "{",
    "}",
    ",",
    ":",
    "=",
    "\n",
    "\"",
    "'",
    "#",
    "[[cameras]]",
    "[processing.shape]",
    "[processing.fit]",
    "[processing.silhouette]",
    "slice_mm = ",
    "sample_mm = ",
    "cell_voxels = ",
    "dims = [",
    "voxel_size = ",
    "origin = [",
    "rows: ",
    "cols: ",
    "data: [",
    "!!opencv-matrix",
    "%YAML:1.0",
    "---",
    "camera_matrix",
    "distortion_coefficients",
    "image_width: ",
    "R: ",
    "T: ",
    "tvec",
    "rvec",
    "true",
    "false",
    "\u{0}",
    "é",
    "IHDR",
    "IDAT",
    "IEND",
];

/// A small deterministic generator (xorshift64*).
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }

    fn below(&mut self, n: usize) -> usize {
        (self.next() % n.max(1) as u64) as usize
    }
}

/// `seed` with one to four random mutations.
fn mutate(seed: &[u8], rng: &mut Rng) -> Vec<u8> {
    let mut b = seed.to_vec();
    for _ in 0..1 + rng.below(4) {
        let at = rng.below(b.len() + 1);
        match rng.below(6) {
            0 if !b.is_empty() => {
                let i = rng.below(b.len());
                b[i] ^= 1 << rng.below(8);
            }
            1 | 2 => {
                let t = TOKENS[rng.below(TOKENS.len())].as_bytes();
                b.splice(at..at, t.iter().copied());
            }
            3 if !b.is_empty() => {
                let end = (at + 1 + rng.below(16)).min(b.len());
                b.drain(at.min(end)..end);
            }
            4 if !b.is_empty() => {
                let start = rng.below(b.len());
                let end = (start + 1 + rng.below(32)).min(b.len());
                let piece: Vec<u8> = b[start..end].to_vec();
                b.splice(at..at, piece);
            }
            _ => {
                // A number replaced by a token: where parsers meet their edge cases.
                if let Some(i) = (0..b.len())
                    .map(|k| (at + k) % b.len())
                    .find(|&k| b[k].is_ascii_digit())
                {
                    let mut end = i;
                    while end < b.len() && (b[end].is_ascii_digit() || b[end] == b'.') {
                        end += 1;
                    }
                    let t = TOKENS[rng.below(12)].as_bytes();
                    b.splice(i..end, t.iter().copied());
                }
            }
        }
    }
    b
}

fn execs() -> usize {
    std::env::var("FLEXSHAPE_FUZZ_EXECS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(2_000)
}

/// One fuzz run at a time: each silences the panic hook while it runs, and two interleaved
/// would leave it silenced for the rest of the test binary.
static HOOK: std::sync::Mutex<()> = std::sync::Mutex::new(());

/// Runs `target` on mutants of `seeds`; fails naming the first input that panics.
fn fuzz(name: &str, seeds: &[Vec<u8>], seed: u64, target: impl Fn(&[u8])) {
    let _one_at_a_time = HOOK.lock().unwrap_or_else(|e| e.into_inner());
    let mut rng = Rng(seed);
    let n = execs();
    let start = std::time::Instant::now();
    let previous = std::panic::take_hook();
    std::panic::set_hook(Box::new(|_| {}));
    let mut failure = None;
    for i in 0..n {
        let input = mutate(&seeds[i % seeds.len()], &mut rng);
        if catch_unwind(AssertUnwindSafe(|| target(&input))).is_err() {
            failure = Some((i, input));
            break;
        }
    }
    std::panic::set_hook(previous);
    if let Some((i, input)) = failure {
        panic!(
            "{name}: input {i} panicked: {:?}",
            String::from_utf8_lossy(&input)
        );
    }
    let s = start.elapsed().as_secs_f64();
    println!(
        "{name}: {n} inputs in {s:.1} s ({:.0}/s), no panic",
        n as f64 / s
    );
}

fn camera_yaml() -> String {
    std::fs::read_to_string(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../rig/tests/fixtures/ours_camera.yml"),
    )
    .unwrap()
}

#[test]
fn camera_files_never_panic() {
    let yaml = camera_yaml();
    let cam = camera_file::parse(&yaml, false, Path::new("seed.yml")).unwrap();
    let json = camera_file::to_json(&cam.intrinsics, cam.pose.as_ref());
    let seeds = vec![yaml.into_bytes()];
    fuzz("camera YAML", &seeds, 1, |b| {
        let _ = camera_file::parse(&String::from_utf8_lossy(b), false, Path::new("x.yml"));
    });
    fuzz("camera JSON", &[json.into_bytes()], 2, |b| {
        let _ = camera_file::parse(&String::from_utf8_lossy(b), true, Path::new("x.json"));
    });
}

#[test]
fn rig_files_and_their_settings_never_panic() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::create_dir_all(dir.path().join("calibration")).unwrap();
    std::fs::write(dir.path().join("calibration/cam0.yml"), camera_yaml()).unwrap();
    let seed = r#"
[volume]
origin = [-128.0, -128.0, -128.0]
voxel_size = 1.0
dims = [256, 256, 256]

[[cameras]]
name = "cam0"
file = "calibration/cam0.yml"
image_size = [640, 480]

[processing.silhouette]
close_radius = 1
max_foreground = 0.5
max_foreground_growth = 5.0

[processing.shape]
cell_voxels = 4
slice_mm = 1.0
sample_mm = 1.0
expected_bands = 2
tip_band = true
min_voxels = 50
radius_mm = 3.0

[[processing.shape.sections]]
from_band = 0
name = "bending"
nominal_mm = 157.5

[processing.fit]
span_mm = 20.0
spacing_mm = 2.0
search_px = 3.0
huber_px = 0.5
max_iterations = 30
track_margin_px = 24.0
max_sigma_mm = 0.05
"#;
    let path = dir.path().join("rig.toml");
    fuzz("rig TOML + settings", &[seed.as_bytes().to_vec()], 3, |b| {
        if let Ok(rig) = Rig::parse(&String::from_utf8_lossy(b), &path) {
            let _ = Pipeline::check_settings(&rig);
        }
    });
}

#[test]
fn frames_never_panic() {
    let dir = tempfile::tempdir().unwrap();
    let mut png = Vec::new();
    let image =
        image::RgbImage::from_fn(16, 12, |x, y| image::Rgb([x as u8 * 9, y as u8 * 13, 77]));
    image::DynamicImage::ImageRgb8(image)
        .write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png)
        .unwrap();
    let path = dir.path().join("frame.png");
    fuzz("PNG frame", &[png], 4, |b| {
        std::fs::write(&path, b).unwrap();
        let _ = files::read_image(&path, Some((16, 12)));
    });
}

#[test]
fn timestamps_never_panic() {
    let dir = tempfile::tempdir().unwrap();
    let root = dir.path();
    std::fs::create_dir_all(root.join("calibration")).unwrap();
    std::fs::create_dir_all(root.join("frames/cam0")).unwrap();
    std::fs::write(root.join("calibration/cam0.yml"), camera_yaml()).unwrap();
    for n in 0..3 {
        std::fs::write(root.join(format!("frames/cam0/{n:06}.png")), b"").unwrap();
    }
    let reader = RecordingReader::open(root).unwrap();
    let seed = b"frame,seconds\n0,1732450000.000\n1,1732450000.008333\n2,1732450000.016667\n";
    fuzz("timestamps.csv", &[seed.to_vec()], 5, |b| {
        std::fs::write(root.join("timestamps.csv"), b).unwrap();
        let _ = reader.read_timestamps();
    });
}

#[test]
fn records_and_model_frames_never_panic() {
    // What `model fit` and `track --model-frame` read back: a record line, a model frame.
    let record = br#"{"frame":3,"status":"ok","centerline":[[0.0,0.0,-128.0],[0.5,0.0,-20.0]],"tip":[0.5,0.0,-20.0],"tip_direction":[0.0,0.0,1.0],"arc_length":108.0,"bands":[{"position":[0.0,0.0,-60.0],"arc_length":68.0}],"arc_fit":{"curvature":0.012,"base":[0.0,0.0,-60.0],"base_tangent":[0.0,0.0,1.0],"bend_direction":[1.0,0.0,0.0],"residual_mm":0.01,"length":40.0},"voxels":0,"timings_ms":{"silhouettes":1.0,"carve":0.0,"bands":0.0,"shape":0.0},"curvature":[0.0,0.012],"tendon_displacements":[0.1,-0.2,0.3],"role":"pose"}"#;
    let frame = br#"{"rotation":[[1.0,0.0,0.0],[0.0,1.0,0.0],[0.0,0.0,1.0]],"reference_base":[0.0,0.0,-60.0],"residual_deg":[0.1,0.2]}"#;
    let good: ModelFrame = serde_json::from_slice(frame).unwrap();
    let seed: TrackRecord = serde_json::from_slice(record).unwrap();
    assert!(
        seed.with_model_frame(&good)
            .arc_fit
            .unwrap()
            .kappa_x
            .is_some()
    );
    fuzz(
        "record + model frame JSON",
        &[record.to_vec(), frame.to_vec()],
        6,
        |b| {
            if let Ok(r) = serde_json::from_slice::<TrackRecord>(b) {
                let _ = r.with_model_frame(&good);
            }
            if let Ok(f) = serde_json::from_slice::<ModelFrame>(b)
                && f.validate().is_ok()
            {
                let r: TrackRecord = serde_json::from_slice(record).unwrap();
                let _ = r.with_model_frame(&f);
            }
        },
    );
}

/// What every import target is read with: millimetres, and an image size for the formats
/// that do not hold one.
const IMPORT_OPTIONS: ImportOptions = ImportOptions {
    unit: Some(Unit::Millimetre),
    size: Some((640, 480)),
};

/// A fixture of `rig import`'s tests, as bytes.
fn import_fixture(path: &str) -> Vec<u8> {
    std::fs::read(
        Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../rig/tests/fixtures")
            .join(path),
    )
    .unwrap()
}

/// Reads the mutant `b` written to `file` (in `dir`, beside the other files a format reads)
/// as `format`, and makes a rig of what it gives, as `rig import` does.
fn import_one(dir: &Path, file: &str, format: Format, input: &Path, b: &[u8]) {
    std::fs::write(dir.join(file), b).unwrap();
    if let Ok(read) = import::read(format, &[input.to_path_buf()], IMPORT_OPTIONS) {
        let _ = import::rig_of(read.cameras, Volume::default(), input);
    }
}

#[test]
fn calibration_imports_never_panic() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // One target per format, from the files `rig import`'s own tests read; a COLMAP model's
    // two files are mutated in turn.
    let targets: [(&str, &str, &str, Format); 10] = [
        (
            "projection text",
            "import/cam0_P.txt",
            "p.txt",
            Format::Projection,
        ),
        (
            "KITTI lines",
            "import/kitti_calib.txt",
            "calib.txt",
            Format::Projection,
        ),
        (
            "projection .npy",
            "import/P_all.npy",
            "p.npy",
            Format::Projection,
        ),
        (
            "CameraInfo",
            "import/left.yaml",
            "left.yaml",
            Format::CameraInfo,
        ),
        (
            "Kalibr camchain",
            "import/camchain.yaml",
            "camchain.yaml",
            Format::Kalibr,
        ),
        (
            "OpenCV stereo YAML",
            "opencv_stereo/stereo.yml",
            "stereo.yml",
            Format::OpencvStereo,
        ),
        (
            "OpenCV stereo JSON",
            "opencv_stereo/stereo.json",
            "stereo.json",
            Format::OpencvStereo,
        ),
        (
            "OpenCV stereo .npz",
            "opencv_stereo/stereo.npz",
            "stereo.npz",
            Format::OpencvStereo,
        ),
        (
            "COLMAP cameras.txt",
            "import/colmap/cameras.txt",
            "colmap/cameras.txt",
            Format::Colmap,
        ),
        (
            "COLMAP images.txt",
            "import/colmap/images.txt",
            "colmap/images.txt",
            Format::Colmap,
        ),
    ];
    std::fs::create_dir_all(d.join("colmap")).unwrap();
    for name in ["cameras.txt", "images.txt"] {
        let fixture = import_fixture(&format!("import/colmap/{name}"));
        std::fs::write(d.join("colmap").join(name), fixture).unwrap();
    }
    for (i, (name, fixture, file, format)) in targets.into_iter().enumerate() {
        let input = match format {
            Format::Colmap => d.join("colmap"),
            _ => d.join(file),
        };
        let seed = import_fixture(fixture);
        // The seed itself imports: the mutants start from a readable file.
        std::fs::write(d.join(file), &seed).unwrap();
        let read = import::read(format, std::slice::from_ref(&input), IMPORT_OPTIONS);
        assert!(read.is_ok_and(|r| !r.cameras.is_empty()), "{name}");
        fuzz(name, std::slice::from_ref(&seed), 10 + i as u64, |b| {
            import_one(d, file, format, &input, b)
        });
        // Left as it was for the next target reading the same folder.
        std::fs::write(d.join(file), seed).unwrap();
    }
    // Middlebury `*_par.txt` (two views, images 640×480 given).
    let par = b"2\na.png 1000 0 320 0 1010 240 0 0 1 1 0 0 0 1 0 0 0 1 0.01 -0.02 0.5\nb.png 1000 0 320 0 1010 240 0 0 1 0 1 0 -1 0 0 0 0 1 0 0 0.6\n";
    let input = d.join("x_par.txt");
    std::fs::write(&input, par).unwrap();
    let read = import::read(
        Format::Middlebury,
        std::slice::from_ref(&input),
        IMPORT_OPTIONS,
    );
    assert!(read.is_ok_and(|r| r.cameras.len() == 2), "Middlebury");
    fuzz("Middlebury", &[par.to_vec()], 20, |b| {
        import_one(d, "x_par.txt", Format::Middlebury, &input, b)
    });
}
