//! The closed loop's state reaches the browser with its frame: the target in the world frame,
//! the stiffnesses in use and the run's history; frames of plain tracking carry none.

use crate::common;

use std::time::{Duration, Instant};

use flexshape_viewer::{Steering, SteeringSample, Viewer};
use tokio_tungstenite::tungstenite::Message;

/// The frame messages a browser connecting now receives, until one of frame `last`.
async fn frames_until(viewer: &Viewer, last: u64) -> Vec<serde_json::Value> {
    let mut socket = common::connect(viewer).await;
    let deadline = Instant::now() + Duration::from_secs(20);
    let mut frames = Vec::new();
    loop {
        assert!(Instant::now() < deadline, "no frame {last}");
        if let Message::Text(text) = common::next_message(&mut socket).await {
            let m: serde_json::Value = serde_json::from_str(&text).unwrap();
            if m["type"] == "frame" {
                let done = m["record"]["frame"] == last;
                frames.push(m);
                if done {
                    return frames;
                }
            }
        }
    }
}

#[tokio::test]
async fn a_steered_frame_carries_the_target_and_the_history() {
    let viewer = Viewer::start("127.0.0.1:0", false, common::scene()).unwrap();
    viewer.publish(common::update(0, image::RgbImage::new(64, 48)));
    let plain = frames_until(&viewer, 0).await;
    assert!(
        plain.iter().all(|m| m.get("steering").is_none()),
        "{plain:?}"
    );
    let history: Vec<SteeringSample> = (0..3)
        .map(|f| SteeringSample {
            frame: f,
            target_index: 0,
            sensed_error_mm: (f > 0).then_some(4.0 / (f as f64 + 1.0)),
            true_error_mm: Some(4.0 / (f as f64 + 1.0)),
            commanded_kappa: [0.004, -0.002],
            sensed_kappa: (f > 0).then_some([0.0041, -0.0019]),
        })
        .collect();
    let steering = Steering {
        target: [12.5, -3.0, 40.0],
        target_index: 0,
        targets: 4,
        stiffness: [353.0, 611.0],
        true_stiffness: Some([352.0, 611.0]),
        history,
    };
    viewer.publish(common::update(1, image::RgbImage::new(64, 48)).with_steering(steering));
    let m = frames_until(&viewer, 1).await.pop().unwrap();
    let s = &m["steering"];
    assert_eq!(s["target"], serde_json::json!([12.5, -3.0, 40.0]));
    assert_eq!(s["targets"], 4);
    assert_eq!(s["true_stiffness"][0], 352.0);
    assert_eq!(s["history"].as_array().unwrap().len(), 3);
    assert!(s["history"][0]["sensed_error_mm"].is_null());
    assert_eq!(s["history"][2]["sensed_kappa"][0], 0.0041);
}
