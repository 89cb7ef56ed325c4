//! Browsers get the newest frame, never a backlog: frames published faster than they are
//! encoded and sent are skipped, and a browser connecting late starts from the newest.

use crate::common;

use std::time::{Duration, Instant};

use flexshape_viewer::Viewer;
use tokio_tungstenite::tungstenite::Message;

#[tokio::test]
async fn a_late_browser_starts_from_the_newest_frame_and_skips_the_backlog() {
    let scene = common::scene();
    let viewer = Viewer::start("127.0.0.1:0", false, scene).unwrap();
    for frame in 0..500 {
        viewer.publish(common::update(frame, image::RgbImage::new(64, 48)));
    }
    let mut socket = common::connect(&viewer).await;
    let mut frames = Vec::new();
    let mut images = 0;
    let deadline = Instant::now() + Duration::from_secs(20);
    // Until the newest frame and the camera images that follow it have arrived.
    while frames.last() != Some(&499) || images == 0 {
        assert!(Instant::now() < deadline, "frames seen: {frames:?}");
        match common::next_message(&mut socket).await {
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
