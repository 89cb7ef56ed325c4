//! Helpers shared by the binary's integration tests.
#![allow(dead_code)] // each test file uses its own subset

use std::path::Path;
use std::process::{Command, Output};

/// Runs the `flexshape` binary.
pub fn flexshape(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_flexshape"))
        .args(args)
        .output()
        .expect("flexshape runs")
}

/// Standard output and error together.
pub fn text(o: &Output) -> String {
    format!(
        "{}{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    )
}

/// Runs and asserts success; standard output.
pub fn run(args: &[&str]) -> String {
    let o = flexshape(args);
    assert!(o.status.success(), "flexshape {args:?}: {}", text(&o));
    String::from_utf8_lossy(&o.stdout).into_owned()
}

/// Runs and asserts failure; standard output and error.
pub fn fails(args: &[&str]) -> String {
    let o = flexshape(args);
    assert!(
        !o.status.success(),
        "flexshape {args:?} should fail: {}",
        text(&o)
    );
    text(&o)
}

/// Fraction of non-white pixels of a PNG and its number of distinct colours.
pub fn ink(png: &Path) -> (f64, usize) {
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

/// True when ffmpeg is installed; otherwise says the test is skipped, or fails when
/// `FLEXSHAPE_REQUIRE_FFMPEG=1` (CI).
pub fn ffmpeg_or_skip() -> bool {
    if flexshape_input::ffmpeg_available() {
        return true;
    }
    assert!(
        std::env::var("FLEXSHAPE_REQUIRE_FFMPEG").as_deref() != Ok("1"),
        "FLEXSHAPE_REQUIRE_FFMPEG=1 but ffmpeg is not installed"
    );
    eprintln!("skipped the video part: ffmpeg is not installed (apt install ffmpeg)");
    false
}

/// The frame records (those with a `frame`) of a JSON Lines file `track` or `carve` wrote.
pub fn frame_records(path: &Path) -> Vec<serde_json::Value> {
    std::fs::read_to_string(path)
        .unwrap()
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .filter(|v: &serde_json::Value| v.get("frame").is_some())
        .collect()
}
