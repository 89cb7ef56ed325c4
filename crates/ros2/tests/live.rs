//! A ROS 2 subscriber (a second DDS participant in this process, on a domain of its own)
//! receives the tracked frames live: the MCAP file's messages under ROS 2's DDS names, the
//! record as a `std_msgs/String`, and `/tf_static` latched for a subscriber that joined late.

use std::collections::BTreeMap;
use std::time::{Duration, Instant};

use flexshape_lab::demo::Demo;
use flexshape_mcap::{FrameTopics, ImageFormat, TopicId, stamp_ns};
use flexshape_model::{ManipulatorParams, Model};
use flexshape_record::TrackRecord;
use flexshape_ros2::{CdrAdapter, CdrMessage, LiveOptions, Ros2Publisher};
use flexshape_sim::SimConfig;
use flexshape_track::Processed;
use rustdds::no_key::DataReader;
use rustdds::policy::{Durability, History, Reliability};
use rustdds::{DomainParticipant, QosPolicyBuilder, TopicKind};

/// A message's header stamp (ns): its first two fields after the encapsulation header.
fn header_stamp(m: &[u8]) -> u64 {
    let sec = u32::from_le_bytes(m[4..8].try_into().unwrap());
    let nsec = u32::from_le_bytes(m[8..12].try_into().unwrap());
    u64::from(sec) * 1_000_000_000 + u64::from(nsec)
}

/// `m` is `expected` with at most 3 bytes of zero padding after it (DDS pads to 4).
fn same_message(m: &[u8], expected: &[u8]) -> bool {
    m.len() - expected.len() < 4
        && m.starts_with(expected)
        && m[expected.len()..].iter().all(|&b| b == 0)
}

#[test]
fn a_ros2_subscriber_receives_the_tracked_frames_live() {
    let model = Model::new(ManipulatorParams::paper_like()).unwrap();
    let demo = Demo::new(SimConfig::default(), model, None, 1).unwrap();
    let frames = demo.tracked(3);
    assert!(frames.iter().all(|(r, _)| r.status.as_str() == "ok"));
    let rig = demo.simulator().rig();
    // A domain of this process's own, so that parallel runs on one machine do not mix.
    let domain = 100 + (std::process::id() % 100) as u16;
    let mut ros = Ros2Publisher::start(domain, rig, LiveOptions::default()).unwrap();
    assert_eq!(ros.domain(), domain);
    // The cameras' poses go with the first frame, before anyone subscribed.
    ros.publish(&frames[0].0, &frames[0].1);

    let node = DomainParticipant::new(domain).unwrap();
    let reader = |name: &str, ty: &str, durability| -> DataReader<CdrMessage, CdrAdapter> {
        let qos = QosPolicyBuilder::new()
            .reliability(Reliability::Reliable {
                max_blocking_time: rustdds::Duration::from_millis(100),
            })
            .durability(durability)
            .history(History::KeepLast { depth: 10 })
            .build();
        let topic = node
            .create_topic(name.into(), ty.into(), &qos, TopicKind::NoKey)
            .unwrap();
        node.create_subscriber(&qos)
            .unwrap()
            .create_datareader_no_key::<CdrMessage, CdrAdapter>(&topic, None)
            .unwrap()
    };
    let mut readers = [
        (
            "centerline",
            reader(
                "rt/flexshape/centerline",
                "nav_msgs::msg::dds_::Path_",
                Durability::Volatile,
            ),
        ),
        (
            "record",
            reader(
                "rt/flexshape/record",
                "std_msgs::msg::dds_::String_",
                Durability::Volatile,
            ),
        ),
        (
            "tf",
            reader(
                "rt/tf_static",
                "tf2_msgs::msg::dds_::TFMessage_",
                Durability::TransientLocal,
            ),
        ),
        (
            "image",
            reader(
                "rt/flexshape/cam1/image",
                "sensor_msgs::msg::dds_::CompressedImage_",
                Durability::Volatile,
            ),
        ),
    ];
    let mut received: BTreeMap<&str, Vec<Vec<u8>>> = BTreeMap::new();
    let start = Instant::now();
    let mut k = 1;
    while received.len() < readers.len() && start.elapsed() < Duration::from_secs(30) {
        let (record, p) = &frames[k % frames.len()];
        ros.publish(record, p);
        k += 1;
        std::thread::sleep(Duration::from_millis(50));
        for (name, r) in &mut readers {
            while let Ok(Some(sample)) = r.take_next_sample() {
                received
                    .entry(*name)
                    .or_default()
                    .push(sample.value().0.clone());
            }
        }
    }
    assert_eq!(
        received.keys().copied().collect::<Vec<_>>(),
        ["centerline", "image", "record", "tf"],
        "after {k} frames"
    );
    assert_eq!(ros.failed_writes(), 0);

    let file = FrameTopics::new(rig, ImageFormat::Jpeg);
    let by_time: BTreeMap<u64, &(TrackRecord, Processed)> =
        frames.iter().map(|f| (stamp_ns(&f.0), f)).collect();
    let expected = |id: TopicId, (record, p): &(TrackRecord, Processed)| {
        let mut out = None;
        file.messages(
            record,
            p,
            |t| t == id,
            |_, d| {
                out = Some(d.to_vec());
                Ok::<_, ()>(())
            },
        )
        .unwrap();
        out.unwrap()
    };
    // The centerline and the image: the file's bytes of the frame their stamps name.
    for (name, id) in [
        ("centerline", TopicId::Centerline),
        ("image", TopicId::Image(1)),
    ] {
        let m = &received[name][0];
        let frame = by_time[&header_stamp(m)];
        assert!(same_message(m, &expected(id, frame)), "{name}");
    }
    // The record: its JSON in a std_msgs/String.
    let m = &received["record"][0];
    let n = u32::from_le_bytes(m[4..8].try_into().unwrap()) as usize;
    let json: serde_json::Value = serde_json::from_slice(&m[8..8 + n - 1]).unwrap();
    assert_eq!(json["status"], "ok");
    assert!(frames.iter().any(|(r, _)| json["frame"] == r.frame));
    // The poses, latched: the first frame's, sent before this node joined, and only once.
    let tf = &received["tf"];
    assert_eq!(tf.len(), 1);
    let first = stamp_ns(&frames[0].0);
    assert!(same_message(&tf[0], &file.transforms(first)));
}
