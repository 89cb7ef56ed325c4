//! A Foxglove client (the WebSocket protocol spoken by hand, as Foxglove's app speaks it)
//! connects to a live server, subscribes, and receives the tracked frames: the same bytes
//! the MCAP file holds, stamped with the frames' times.

use std::collections::BTreeMap;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, mpsc};
use std::time::{Duration, Instant};

use flexshape_foxglove::{FoxgloveError, FoxgloveServer, LiveOptions};
use flexshape_lab::demo::Demo;
use flexshape_mcap::{FrameTopics, ImageFormat, TopicId, stamp_ns};
use flexshape_model::{ManipulatorParams, Model};
use flexshape_record::TrackRecord;
use flexshape_sim::SimConfig;
use flexshape_track::Processed;
use futures_util::{SinkExt, StreamExt};
use tokio_tungstenite::tungstenite::Message;
use tokio_tungstenite::tungstenite::client::IntoClientRequest;

fn demo() -> Demo {
    let model = Model::new(ManipulatorParams::paper_like()).unwrap();
    Demo::new(SimConfig::default(), model, None, 1).unwrap()
}

/// What the client received on one topic: (log time, payload).
type Received = BTreeMap<String, Vec<(u64, Vec<u8>)>>;

/// Connects to `url` as Foxglove does, subscribes to `topics`, and collects messages until
/// every topic has one (or 20 s pass). Says on `subscribed` when its subscriptions are sent.
async fn client(
    url: String,
    topics: Vec<String>,
    subscribed: mpsc::Sender<()>,
) -> (Received, BTreeMap<String, serde_json::Value>) {
    let mut request = url.into_client_request().unwrap();
    request
        .headers_mut()
        .insert("sec-websocket-protocol", "foxglove.sdk.v1".parse().unwrap());
    let (mut ws, response) = tokio_tungstenite::connect_async(request).await.unwrap();
    assert_eq!(
        response.headers()["sec-websocket-protocol"],
        "foxglove.sdk.v1"
    );
    let deadline = Instant::now() + Duration::from_secs(20);
    let mut advertised = BTreeMap::new();
    let mut by_subscription = BTreeMap::new();
    let mut received = Received::new();
    while Instant::now() < deadline {
        let next = tokio::time::timeout(Duration::from_millis(200), ws.next()).await;
        let Ok(Some(Ok(message))) = next else {
            continue;
        };
        match message {
            Message::Text(text) => {
                let v: serde_json::Value = serde_json::from_str(&text).unwrap();
                if v["op"] != "advertise" {
                    continue;
                }
                let mut subscriptions = Vec::new();
                for c in v["channels"].as_array().unwrap() {
                    let topic = c["topic"].as_str().unwrap().to_string();
                    advertised.insert(topic.clone(), c.clone());
                    if topics.contains(&topic) {
                        let id = by_subscription.len() as u64 + 1;
                        by_subscription.insert(id, topic);
                        subscriptions.push(serde_json::json!({"id": id, "channelId": c["id"]}));
                    }
                }
                if !subscriptions.is_empty() {
                    let subscribe =
                        serde_json::json!({"op": "subscribe", "subscriptions": subscriptions});
                    ws.send(Message::Text(subscribe.to_string().into()))
                        .await
                        .unwrap();
                    let _ = subscribed.send(());
                }
            }
            Message::Binary(data) => {
                assert_eq!(data[0], 1, "opcode: message data");
                let id = u32::from_le_bytes(data[1..5].try_into().unwrap());
                let log_time = u64::from_le_bytes(data[5..13].try_into().unwrap());
                let topic = &by_subscription[&u64::from(id)];
                received
                    .entry(topic.clone())
                    .or_default()
                    .push((log_time, data[13..].to_vec()));
                if topics.iter().all(|t| received.contains_key(t)) {
                    break;
                }
            }
            _ => {}
        }
    }
    let _ = ws.close(None).await;
    (received, advertised)
}

#[test]
fn a_foxglove_client_receives_the_tracked_frames_live() {
    let demo = demo();
    let frames = demo.tracked(3);
    assert!(frames.iter().all(|(r, _)| r.status.as_str() == "ok"));
    let rig = demo.simulator().rig();
    let mut live =
        FoxgloveServer::start("127.0.0.1:0", false, rig, LiveOptions::default()).unwrap();
    assert_ne!(live.port(), 0);
    assert_eq!(live.url(), format!("ws://127.0.0.1:{}", live.port()));

    let topics: Vec<String> = [
        "/flexshape/centerline",
        "/flexshape/record",
        "/tf_static",
        "/flexshape/cam1/image",
        "/flexshape/cam1/silhouette",
    ]
    .map(String::from)
    .to_vec();
    let (said, subscribed) = mpsc::channel();
    let url = live.url().to_string();
    let wanted = topics.clone();
    let done = Arc::new(AtomicBool::new(false));
    let client_done = done.clone();
    let client = std::thread::spawn(move || {
        let runtime = tokio::runtime::Builder::new_current_thread()
            .enable_all()
            .build()
            .unwrap();
        let got = runtime.block_on(client(url, wanted, said));
        client_done.store(true, Ordering::SeqCst);
        got
    });
    // Publish as a run would, frame after frame, until the client has what it asked for.
    subscribed.recv_timeout(Duration::from_secs(20)).unwrap();
    let start = Instant::now();
    let mut k = 0;
    let mut clients = 0;
    while !done.load(Ordering::SeqCst) && start.elapsed() < Duration::from_secs(20) {
        let (record, p) = &frames[k % frames.len()];
        live.publish(record, p);
        clients = clients.max(live.clients());
        k += 1;
        std::thread::sleep(Duration::from_millis(30));
    }
    assert_eq!(clients, 1);
    let (received, advertised) = client.join().unwrap();

    // Advertised as the MCAP file has them: ROS 2 schemas, CDR.
    assert_eq!(
        advertised["/flexshape/centerline"]["schemaName"],
        "nav_msgs/msg/Path"
    );
    assert_eq!(advertised["/flexshape/centerline"]["encoding"], "cdr");
    assert_eq!(
        advertised["/flexshape/centerline"]["schemaEncoding"],
        "ros2msg"
    );
    assert_eq!(
        advertised["/flexshape/cam1/image"]["schemaName"],
        "sensor_msgs/msg/CompressedImage"
    );
    assert_eq!(advertised["/flexshape/record"]["encoding"], "json");

    // Every message is the MCAP file's message of the frame its log time names.
    let file_topics = FrameTopics::new(rig, ImageFormat::Jpeg);
    let by_time: BTreeMap<u64, &(TrackRecord, Processed)> =
        frames.iter().map(|f| (stamp_ns(&f.0), f)).collect();
    for (id, topic) in [
        (TopicId::Centerline, "/flexshape/centerline"),
        (TopicId::Image(1), "/flexshape/cam1/image"),
        (TopicId::Silhouette(1), "/flexshape/cam1/silhouette"),
    ] {
        let got = received
            .get(topic)
            .unwrap_or_else(|| panic!("nothing on {topic}: {:?}", received.keys()));
        let (time, data) = &got[0];
        let (record, p) = by_time[time];
        let mut expected = None;
        file_topics
            .messages(
                record,
                p,
                |t| t == id,
                |_, d| {
                    expected = Some(d.to_vec());
                    Ok::<_, ()>(())
                },
            )
            .unwrap();
        assert_eq!(Some(data), expected.as_ref(), "{topic}");
    }
    let (time, data) = &received["/flexshape/record"][0];
    let json: serde_json::Value = serde_json::from_slice(data).unwrap();
    assert_eq!(json["frame"], by_time[time].0.frame);
    assert_eq!(json["status"], "ok");
    let (time, data) = &received["/tf_static"][0];
    assert_eq!(data, &file_topics.transforms(*time));

    drop(live);
}

#[test]
fn addresses_that_cannot_serve_are_refused_with_what_to_do() {
    let demo = demo();
    let rig = demo.simulator().rig();
    let options = LiveOptions::default();
    let e = FoxgloveServer::start("8765", false, rig, options)
        .err()
        .unwrap();
    assert!(matches!(e, FoxgloveError::Address(_)), "{e}");
    let e = FoxgloveServer::start("0.0.0.0:0", false, rig, options)
        .err()
        .unwrap();
    assert!(e.to_string().contains("--allow-remote"), "{e}");
    let first = FoxgloveServer::start("127.0.0.1:0", false, rig, options).unwrap();
    let taken = format!("127.0.0.1:{}", first.port());
    let e = FoxgloveServer::start(&taken, false, rig, options)
        .err()
        .unwrap();
    assert!(e.to_string().contains("port 0"), "{e}");
}
