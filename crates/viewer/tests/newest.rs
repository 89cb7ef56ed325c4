//! Browsers get the newest frame, never a backlog: frames published faster than they are
//! encoded and sent are skipped, and a browser connecting late starts from the newest.

use std::time::{Duration, Instant};

use flexshape_track::{Processed, TrackRecord};
use flexshape_viewer::{Scene, Stats, Update, Viewer};
use futures_util::StreamExt;
use tokio_tungstenite::tungstenite::Message;

fn update(frame: u64) -> Update {
    let processed = Processed {
        frame,
        name: None,
        command: None,
        truth: None,
        warnings: Vec::new(),
        images: vec![image::RgbImage::new(64, 48)],
        result: Err("no shape in this test".into()),
        captured: Instant::now(),
        latency_ms: 1.0,
        dropped: 0,
        capture_time: None,
        processed_s: None,
    };
    let stats = Stats {
        frames: frame as usize + 1,
        ..Stats::default()
    };
    Update::new(processed, TrackRecord::error(frame, "test".into()), stats)
}

#[tokio::test]
async fn a_late_browser_starts_from_the_newest_frame_and_skips_the_backlog() {
    let scene = Scene {
        cameras: vec!["cam0".into()],
        volume: [-128.0, -128.0, -128.0, 128.0, 128.0, 128.0],
        voxel: 1.0,
    };
    let viewer = Viewer::start("127.0.0.1:0", false, scene).unwrap();
    for frame in 0..500 {
        viewer.publish(update(frame));
    }
    let url = format!("ws://{}/ws", viewer.addr());
    let (mut socket, _) = tokio_tungstenite::connect_async(url).await.unwrap();
    let mut frames = Vec::new();
    let mut images = 0;
    let deadline = Instant::now() + Duration::from_secs(20);
    // Until the newest frame and the camera images that follow it have arrived.
    while frames.last() != Some(&499) || images == 0 {
        assert!(Instant::now() < deadline, "frames seen: {frames:?}");
        let message = tokio::time::timeout(Duration::from_secs(10), socket.next())
            .await
            .expect("a message within 10 s")
            .unwrap()
            .unwrap();
        match message {
            Message::Text(text) => {
                let m: serde_json::Value = serde_json::from_str(&text).unwrap();
                if m["type"] == "frame" {
                    frames.push(m["record"]["frame"].as_u64().unwrap());
                } else {
                    assert_eq!(m["type"], "hello", "{m}");
                    assert_eq!(m["scene"]["cameras"][0], "cam0");
                }
            }
            Message::Binary(bytes) => {
                // [kind, camera, JPEG…]: a frame image of camera 0.
                assert_eq!(&bytes[..2], &[0, 0]);
                assert_eq!(&bytes[2..4], &[0xFF, 0xD8], "JPEG");
                images += 1;
            }
            _ => {}
        }
    }
    assert!(frames.windows(2).all(|w| w[1] > w[0]), "{frames:?}");
    assert!(frames.len() <= 3, "a backlog was sent: {frames:?}");
    assert!(images >= 1);
}
