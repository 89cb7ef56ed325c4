//! Tracked shapes live as ROS 2 topics (`flexshape track --ros2`), published over DDS by
//! RustDDS: no ROS installation is needed to build or run, and any ROS 2 node on the same
//! domain (`ROS_DOMAIN_ID`) and network sees them — `ros2 topic echo /flexshape/centerline`,
//! RViz, a lab's controller.
//!
//! The topics and messages are the MCAP file's ([`flexshape_mcap::topics`]): the centerline
//! (`nav_msgs/msg/Path`), the tube's markers, the hull's cloud, each camera's `CameraInfo`,
//! `/tf_static`; lengths in metres, header stamps the frames' capture times (also each
//! sample's DDS source timestamp). Where ROS 2 differs from the file:
//! - `/flexshape/record` is a `std_msgs/msg/String` holding the JSON record (ROS 2 has no
//!   JSON encoding);
//! - `/tf_static` goes once, reliable and transient local (depth 1), as tf2's static
//!   broadcaster does: nodes that start later still receive it;
//! - images and silhouettes go as `sensor_msgs/msg/CompressedImage` ([`LiveOptions::images`])
//!   at most [`LiveOptions::image_hz`] frames a second, and only to topics some reader on the
//!   domain subscribed to;
//! - every other topic is reliable, volatile, keeping the last [`DEPTH`] messages: a slow
//!   subscriber loses the oldest, tracking never waits for it.
//!
//! Topic names follow ROS 2's DDS mapping (`rt/flexshape/centerline`, type
//! `nav_msgs::msg::dds_::Path_`).
//!
//! ```no_run
//! use flexshape_ros2::{LiveOptions, Ros2Publisher};
//! # fn main() -> Result<(), Box<dyn std::error::Error>> {
//! let rig = flexshape_rig::Rig::load(std::path::Path::new("rig.toml"))?;
//! let mut ros = Ros2Publisher::start(0, &rig, LiveOptions::default())?;
//! // For every tracked frame: ros.publish(&record, &processed);
//! # Ok(())
//! # }
//! ```

mod raw;

use flexshape_mcap::msgs;
use flexshape_mcap::{FrameTopics, ImageRate, Topic, TopicId, stamp_ns};
use flexshape_record::TrackRecord;
use flexshape_rig::Rig;
use flexshape_track::Processed;
use rustdds::no_key::DataWriter;
use rustdds::policy::{Durability, History, Reliability};
use rustdds::{DomainParticipant, QosPolicies, QosPolicyBuilder, Timestamp, TopicKind};
use thiserror::Error;

pub use flexshape_mcap::LiveOptions;
pub use raw::{CdrAdapter, CdrMessage};

/// Messages each writer keeps for a reader that has not acknowledged them (rclcpp's default
/// depth): older ones are dropped, the writer never blocks tracking.
pub const DEPTH: i32 = 10;

/// The highest ROS 2 domain id: DDS's port mapping runs out of ports above it.
pub const MAX_DOMAIN: u16 = 232;

/// Why the topics cannot be published.
#[derive(Debug, Error)]
pub enum Ros2Error {
    /// The domain id is out of ROS 2's range.
    #[error("ROS 2 domain {0} is out of range: give 0–{MAX_DOMAIN} (ROS_DOMAIN_ID's range)")]
    Domain(u16),
    /// The DDS participant could not start (no network interface, the domain out of range).
    #[error(
        "cannot join ROS 2 domain {domain}: {source} (is a network interface up? is another program using the domain's ports?)"
    )]
    Participant {
        /// The domain asked for.
        domain: u16,
        /// What RustDDS said.
        source: rustdds::dds::CreateError,
    },
    /// A topic or its writer could not be made.
    #[error("cannot publish {topic}: {source}")]
    Topic {
        /// The topic.
        topic: String,
        /// What RustDDS said.
        source: rustdds::dds::CreateError,
    },
}

/// The DDS side of one topic.
struct Writer {
    id: TopicId,
    /// Its DDS name, `rt/...`: readers' subscriptions are matched against it.
    dds_name: String,
    writer: DataWriter<CdrMessage, CdrAdapter>,
}

/// A ROS 2 publisher of every tracked frame on the rig's topics.
pub struct Ros2Publisher {
    /// Dropped before the participant they belong to (fields drop in this order), which
    /// must outlive them to remove them cleanly.
    writers: Vec<Writer>,
    participant: DomainParticipant,
    topics: FrameTopics,
    tf_sent: bool,
    images: ImageRate,
    /// Writes refused so far (said once in the log, counted).
    failed_writes: u64,
}

impl Ros2Publisher {
    /// Joins ROS 2 domain `domain` (0–232, as `ROS_DOMAIN_ID`) and offers `rig`'s topics.
    pub fn start(domain: u16, rig: &Rig, options: LiveOptions) -> Result<Self, Ros2Error> {
        if domain > MAX_DOMAIN {
            return Err(Ros2Error::Domain(domain));
        }
        let participant = DomainParticipant::new(domain)
            .map_err(|source| Ros2Error::Participant { domain, source })?;
        let topics = FrameTopics::new(rig, options.images);
        let mut writers = Vec::new();
        for t in topics.topics() {
            let (dds_name, type_name) = dds_names(&t);
            let qos = qos(t.id);
            let made = participant
                .create_topic(dds_name.clone(), type_name, &qos, TopicKind::NoKey)
                .and_then(|topic| {
                    participant
                        .create_publisher(&qos)?
                        .create_datawriter_no_key::<CdrMessage, CdrAdapter>(&topic, None)
                })
                .map_err(|source| Ros2Error::Topic {
                    topic: t.name.clone(),
                    source,
                })?;
            writers.push(Writer {
                id: t.id,
                dds_name,
                writer: made,
            });
        }
        Ok(Ros2Publisher {
            participant,
            topics,
            writers,
            tf_sent: false,
            images: ImageRate::new(options.image_hz),
            failed_writes: 0,
        })
    }

    /// The ROS 2 domain joined.
    pub fn domain(&self) -> u16 {
        self.participant.domain_id()
    }

    /// Writes the middleware refused so far (a full send buffer, a closed socket); each
    /// lost message is one, tracking goes on.
    pub fn failed_writes(&self) -> u64 {
        self.failed_writes
    }

    /// Publishes one tracked frame. Never blocks on a subscriber.
    pub fn publish(&mut self, record: &TrackRecord, p: &Processed) {
        let stamp = stamp_ns(record);
        if !self.tf_sent {
            let tf = self.topics.transforms(stamp);
            self.write(TopicId::Transforms, tf, stamp);
            self.tf_sent = true;
        }
        let images_due = self.images.due();
        // Images are encoded only for topics some reader on the domain subscribed to.
        let watched: Vec<String> = match images_due {
            true => self
                .participant
                .discovered_readers()
                .iter()
                .map(|r| r.subscription_topic_data.topic_name().clone())
                .collect(),
            false => Vec::new(),
        };
        let wanted = |id: TopicId| {
            !id.is_view()
                || images_due
                    && self
                        .writers
                        .iter()
                        .any(|w| w.id == id && watched.contains(&w.dds_name))
        };
        let mut out: Vec<(TopicId, Vec<u8>)> = Vec::new();
        let _ = self.topics.messages(record, p, wanted, |id, data| {
            let data = match id {
                TopicId::Record => string_message(data),
                _ => data.to_vec(),
            };
            out.push((id, data));
            Ok::<(), std::convert::Infallible>(())
        });
        if out.iter().any(|(id, _)| id.is_view()) {
            self.images.sent();
        }
        for (id, data) in out {
            self.write(id, data, stamp);
        }
    }

    /// Writes one message, its source timestamp the frame's.
    fn write(&mut self, id: TopicId, data: Vec<u8>, stamp_ns: u64) {
        let Some(w) = self.writers.iter().find(|w| w.id == id) else {
            return;
        };
        let written = w.writer.write(CdrMessage(data), Some(timestamp(stamp_ns)));
        if let Err(e) = written {
            if self.failed_writes == 0 {
                tracing::warn!("ROS 2: a message on {} was lost: {e}", w.dds_name);
            }
            self.failed_writes += 1;
        }
    }
}

/// A topic's DDS names, as ROS 2 maps them: `rt` before the topic, `pkg::msg::dds_::Type_`
/// for `pkg/msg/Type`; the record travels as a `std_msgs/msg/String`.
fn dds_names(t: &Topic) -> (String, String) {
    let type_name = match t.id {
        TopicId::Record => msgs::STRING.name,
        _ => t.schema_name,
    };
    let dds_type = match type_name.rsplit_once('/') {
        Some((package, name)) => format!("{}::dds_::{name}_", package.replace('/', "::")),
        None => type_name.to_string(),
    };
    (format!("rt{}", t.name), dds_type)
}

/// A topic's QoS: `/tf_static` reliable, transient local, depth 1 (tf2's static broadcaster);
/// the rest reliable, volatile, depth [`DEPTH`].
fn qos(id: TopicId) -> QosPolicies {
    let reliable = Reliability::Reliable {
        max_blocking_time: rustdds::Duration::from_millis(10),
    };
    let (durability, depth) = match id {
        TopicId::Transforms => (Durability::TransientLocal, 1),
        _ => (Durability::Volatile, DEPTH),
    };
    QosPolicyBuilder::new()
        .reliability(reliable)
        .durability(durability)
        .history(History::KeepLast { depth })
        .build()
}

/// The record's JSON as a `std_msgs/msg/String`.
fn string_message(json: &[u8]) -> Vec<u8> {
    msgs::string(&String::from_utf8_lossy(json))
}

/// ns since the Unix epoch as an RTPS time (seconds, and 2⁻³² s fractions).
fn timestamp(stamp_ns: u64) -> Timestamp {
    let seconds = stamp_ns / 1_000_000_000;
    let fraction = ((stamp_ns % 1_000_000_000) << 32) / 1_000_000_000;
    Timestamp::from_ticks((seconds << 32) | fraction)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn topics_take_ros2s_dds_names() {
        let topic = |id, name: &str, schema_name| Topic {
            id,
            name: name.into(),
            schema_name,
            schema_encoding: "ros2msg",
            schema: String::new(),
            message_encoding: "cdr",
            qos: None,
        };
        assert_eq!(
            dds_names(&topic(
                TopicId::Centerline,
                "/flexshape/centerline",
                "nav_msgs/msg/Path"
            )),
            (
                "rt/flexshape/centerline".to_string(),
                "nav_msgs::msg::dds_::Path_".to_string()
            )
        );
        let record = topic(
            TopicId::Record,
            "/flexshape/record",
            "flexshape.TrackRecord",
        );
        assert_eq!(dds_names(&record).1, "std_msgs::msg::dds_::String_");
    }

    #[test]
    fn stamps_become_rtps_times() {
        let t = timestamp(1_700_000_000_250_000_000);
        assert_eq!(t.to_ticks() >> 32, 1_700_000_000);
        assert_eq!(t.to_ticks() & 0xFFFF_FFFF, 1 << 30, "a quarter second");
    }
}
