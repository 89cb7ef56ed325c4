//! Videos and live streams through the ffmpeg program. Skipped with a message when ffmpeg is
//! not installed, unless `FLEXSHAPE_REQUIRE_FFMPEG=1` (CI sets it, and installs ffmpeg).

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Duration;

use flexshape_input::{
    CaptureSource, FrameImage, FrameSource, InputError, LiveSource, VideoSource, ffmpeg_available,
};
use image::RgbImage;

const SIZE: (u32, u32) = (64, 48);

fn ffmpeg_or_skip() -> bool {
    if ffmpeg_available() {
        return true;
    }
    assert!(
        std::env::var("FLEXSHAPE_REQUIRE_FFMPEG").as_deref() != Ok("1"),
        "FLEXSHAPE_REQUIRE_FFMPEG=1 but ffmpeg is not installed"
    );
    eprintln!("skipped: ffmpeg is not installed (apt install ffmpeg)");
    false
}

/// A frame whose pixels encode camera `cam` and frame `n`.
fn pattern(cam: u8, n: u8) -> RgbImage {
    RgbImage::from_fn(SIZE.0, SIZE.1, |x, y| {
        image::Rgb([n * 4, cam * 100 + (x as u8), y as u8])
    })
}

/// A lossless video (PNG in Matroska) of `frames` patterns at `fps`.
fn write_video(dir: &Path, cam: u8, frames: u8, fps: u32) -> PathBuf {
    let pngs = dir.join(format!("cam{cam}-png"));
    std::fs::create_dir_all(&pngs).unwrap();
    for n in 0..frames {
        pattern(cam, n)
            .save(pngs.join(format!("{n:04}.png")))
            .unwrap();
    }
    let out = dir.join(format!("cam{cam}.mkv"));
    let status = Command::new("ffmpeg")
        .args(["-y", "-loglevel", "error", "-framerate"])
        .arg(fps.to_string())
        .arg("-i")
        .arg(pngs.join("%04d.png"))
        .args(["-c:v", "png"])
        .arg(&out)
        .status()
        .unwrap();
    assert!(status.success());
    out
}

fn decoded(image: FrameImage) -> RgbImage {
    image.load("cam", SIZE).unwrap()
}

#[test]
fn videos_decode_every_frame_exactly_in_step() {
    if !ffmpeg_or_skip() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let videos: Vec<_> = (0..2)
        .map(|c| (format!("cam{c}"), write_video(dir.path(), c, 6, 25), SIZE))
        .collect();
    let mut source = VideoSource::open(&videos).unwrap();
    let mut n = 0u8;
    while let Some(set) = source.next_frame() {
        let set = set.unwrap();
        assert_eq!(set.frame, n as u64);
        for (c, image) in set.images.into_iter().enumerate() {
            assert!(
                decoded(image) == pattern(c as u8, n),
                "camera {c} frame {n}"
            );
        }
        n += 1;
    }
    assert_eq!(n, 6);
    assert!(source.next_frame().is_none());
}

#[test]
fn a_shorter_video_ends_the_stream_with_its_camera_named() {
    if !ffmpeg_or_skip() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let videos = vec![
        ("left".to_string(), write_video(dir.path(), 0, 4, 25), SIZE),
        ("right".to_string(), write_video(dir.path(), 1, 2, 25), SIZE),
    ];
    let mut source = VideoSource::open(&videos).unwrap();
    assert!(source.next_frame().unwrap().is_ok());
    assert!(source.next_frame().unwrap().is_ok());
    let err = source.next_frame().unwrap().unwrap_err();
    assert!(err.ends_input());
    let message = err.to_string();
    assert!(
        message.contains("`right`") && message.contains("after 2 frames"),
        "{message}"
    );
    assert!(source.next_frame().is_none());
}

#[test]
fn wrong_sizes_and_unreadable_videos_are_named() {
    if !ffmpeg_or_skip() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let video = write_video(dir.path(), 0, 2, 25);
    let err = VideoSource::open(&[("cam0".into(), video, (640, 480))])
        .err()
        .unwrap();
    let message = err.to_string();
    assert!(
        message.contains("64×48") && message.contains("`cam0`"),
        "{message}"
    );
    let junk = dir.path().join("junk.mp4");
    std::fs::write(&junk, b"not a video at all").unwrap();
    let err = VideoSource::open(&[("cam0".into(), junk, SIZE)])
        .err()
        .unwrap();
    assert!(matches!(err, InputError::Ffmpeg { .. }), "{err}");
    assert!(err.to_string().contains("junk.mp4"), "{err}");
    let missing = dir.path().join("missing.mp4");
    let err = VideoSource::open(&[("cam0".into(), missing, SIZE)])
        .err()
        .unwrap();
    assert!(err.to_string().contains("missing.mp4"), "{err}");
}

#[test]
fn live_input_pairs_each_cameras_frames_by_capture_time_and_counts_drops() {
    if !ffmpeg_or_skip() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    // Two "cameras" at 50 frames/s for 1.2 s, taken by a consumer that needs 100 ms a frame.
    let cameras: Vec<_> = (0..2)
        .map(|c| {
            let video = write_video(dir.path(), c, 60, 50);
            (format!("cam{c}"), video.display().to_string(), SIZE)
        })
        .collect();
    let mut source = LiveSource::open(&cameras).unwrap();
    assert!(source.is_live());
    let mut seen = Vec::new();
    while let Some(set) = source.next_frame() {
        let set = set.unwrap();
        // The videos' own timelines, frame n at n / 50 s in both.
        let captured = set.capture_time.unwrap();
        assert_eq!(captured.source, CaptureSource::Stream);
        let times = set.camera_times.clone().unwrap();
        let images: Vec<RgbImage> = set.images.into_iter().map(decoded).collect();
        // The red channel says which frame of its video each image is.
        let n: Vec<u8> = images.iter().map(|i| i.get_pixel(0, 0).0[0] / 4).collect();
        assert_eq!(images[1].get_pixel(0, 0).0[1], 100, "camera order kept");
        for (t, n) in times.iter().zip(&n) {
            assert!((t - f64::from(*n) / 50.0).abs() < 1e-6, "{times:?} {n}");
        }
        assert_eq!(captured.seconds, times[0].min(times[1]));
        seen.push(n);
        std::thread::sleep(Duration::from_millis(100));
    }
    assert!(
        (5..=25).contains(&seen.len()),
        "took {} frame sets of 60 frames at 50 fps",
        seen.len()
    );
    let firsts: Vec<u8> = seen.iter().map(|n| n[0]).collect();
    assert!(
        firsts.windows(2).all(|w| w[1] > w[0]),
        "newer each time: {firsts:?}"
    );
    // Paired by the streams' times: each set is one frame of both videos. (Taking each
    // camera's newest frame paired neighbours up to 4 frames apart on a loaded machine; a
    // decoder that falls farther behind than the frames kept loses sets, counted.)
    let paired = seen.iter().filter(|n| n[0] == n[1]).count();
    assert_eq!(paired, seen.len(), "{seen:?}");
    let dropped = source.dropped();
    assert!(
        dropped as usize + seen.len() >= 50 && dropped > 20,
        "dropped {dropped}, took {}",
        seen.len()
    );
}
