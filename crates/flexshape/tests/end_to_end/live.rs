//! `--ros2` and `--foxglove` from the command line: a ROS 2 subscriber in this test receives
//! the demo's records while it runs, and what cannot be served is refused saying what to do.

use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use flexshape_ros2::{CdrAdapter, CdrMessage};
use rustdds::policy::{Durability, History, Reliability};
use rustdds::{DomainParticipant, QosPolicyBuilder, TopicKind};

use crate::common;

#[test]
fn a_ros2_node_receives_the_demos_records_while_it_runs() {
    // A domain of this process's own (the library's test takes 100–199).
    let domain = 200 + (std::process::id() % 30) as u16;
    let mut demo = Command::new(env!("CARGO_BIN_EXE_flexshape"))
        .args(["demo", "--no-viewer", "--frames", "400", "--ros2"])
        .arg(domain.to_string())
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let node = DomainParticipant::new(domain).unwrap();
    let qos = QosPolicyBuilder::new()
        .reliability(Reliability::Reliable {
            max_blocking_time: rustdds::Duration::from_millis(100),
        })
        .durability(Durability::Volatile)
        .history(History::KeepLast { depth: 10 })
        .build();
    let topic = node
        .create_topic(
            "rt/flexshape/record".into(),
            "std_msgs::msg::dds_::String_".into(),
            &qos,
            TopicKind::NoKey,
        )
        .unwrap();
    let mut reader = node
        .create_subscriber(&qos)
        .unwrap()
        .create_datareader_no_key::<CdrMessage, CdrAdapter>(&topic, None)
        .unwrap();
    let mut records = Vec::new();
    let start = Instant::now();
    while records.len() < 3 && start.elapsed() < Duration::from_secs(60) {
        while let Ok(Some(sample)) = reader.take_next_sample() {
            let m = &sample.value().0;
            let n = u32::from_le_bytes(m[4..8].try_into().unwrap()) as usize;
            let json: serde_json::Value = serde_json::from_slice(&m[8..8 + n - 1]).unwrap();
            records.push(json);
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    let _ = demo.kill();
    let out = demo.wait_with_output().unwrap();
    let said = String::from_utf8_lossy(&out.stderr);
    assert!(
        records.len() >= 3,
        "{} records in 60 s; the demo said: {said}",
        records.len()
    );
    assert!(
        said.contains(&format!("ros2: publishing on domain {domain}")),
        "{said}"
    );
    assert!(records.iter().all(|r| r["status"] == "ok"), "{records:?}");
    assert!(
        records
            .windows(2)
            .all(|w| w[0]["frame"].as_u64() < w[1]["frame"].as_u64())
    );
}

#[test]
fn live_outputs_that_cannot_serve_say_what_to_do() {
    let e = common::fails(&[
        "demo",
        "--foxglove",
        "0.0.0.0:0",
        "--frames",
        "1",
        "--no-viewer",
    ]);
    assert!(e.contains("--allow-remote"), "{e}");
    let e = common::fails(&["demo", "--ros2", "300", "--frames", "1", "--no-viewer"]);
    assert!(e.contains("out of range") && e.contains("0–232"), "{e}");
    let o = Command::new(env!("CARGO_BIN_EXE_flexshape"))
        .args(["demo", "--ros2", "--frames", "1", "--no-viewer"])
        .env("ROS_DOMAIN_ID", "lab")
        .output()
        .unwrap();
    let e = common::text(&o);
    assert!(!o.status.success());
    assert!(
        e.contains("ROS_DOMAIN_ID=`lab`") && e.contains("--ros2 DOMAIN"),
        "{e}"
    );
}
