//! Shared by the viewer's tests.
#![allow(dead_code)] // each test binary uses its own part

use std::time::{Duration, Instant};

use flexshape_record::TrackRecord;
use flexshape_track::Processed;
use flexshape_viewer::{Scene, Stats, Update, Viewer};
use futures_util::StreamExt;
use tokio_tungstenite::tungstenite::Message;
use tokio_tungstenite::{MaybeTlsStream, WebSocketStream};

/// A browser's connection to the viewer's WebSocket.
pub type Socket = WebSocketStream<MaybeTlsStream<tokio::net::TcpStream>>;

/// Connects to `viewer`'s WebSocket as the page does.
pub async fn connect(viewer: &Viewer) -> Socket {
    let url = format!("ws://{}/ws", viewer.addr());
    tokio_tungstenite::connect_async(url).await.unwrap().0
}

/// The next message on `socket`, within 10 s.
pub async fn next_message(socket: &mut Socket) -> Message {
    tokio::time::timeout(Duration::from_secs(10), socket.next())
        .await
        .expect("a message within 10 s")
        .unwrap()
        .unwrap()
}

/// One camera, the default volume.
pub fn scene() -> Scene {
    Scene {
        cameras: vec!["cam0".into()],
        image_sizes: Vec::new(),
        frusta: Vec::new(),
        replay: None,
        volume: [-128.0, -128.0, -128.0, 128.0, 128.0, 128.0],
        voxel: 1.0,
    }
}

/// Frame `frame` of one camera showing `image`, without a shape, as the runner hands it over.
pub fn update(frame: u64, image: image::RgbImage) -> Update {
    let processed = Processed {
        frame,
        name: None,
        command: None,
        truth: None,
        warnings: Vec::new(),
        images: vec![image],
        result: Err("no shape in this test".into()),
        captured: Instant::now(),
        latency_ms: 1.0,
        dropped: 0,
        capture_time: None,
        camera_times: None,
        processed_s: None,
    };
    let stats = Stats {
        frames: frame as usize + 1,
        ..Stats::default()
    };
    Update::new(processed, TrackRecord::error(frame, "test".into()), stats)
}
