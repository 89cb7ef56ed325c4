//! Tracked shapes live over the Foxglove WebSocket protocol (`flexshape track --foxglove`),
//! served by the official Foxglove SDK: Foxglove's "Open connection → Foxglove WebSocket"
//! shows the run while it goes on.
//!
//! The topics and their messages are the MCAP file's ([`flexshape_mcap::topics`]), byte for
//! byte: the centerline (`nav_msgs/msg/Path`), the tube's markers, the hull's cloud, each
//! camera's `CameraInfo`, `/tf_static`, the record as JSON — lengths in metres, stamps the
//! frames' capture times (ns since the Unix epoch). Differences a live connection needs:
//! - `/tf_static` goes with every frame, so a client that connects late still places the
//!   cameras;
//! - images and silhouettes go as `sensor_msgs/CompressedImage` ([`LiveOptions::images`]),
//!   at most [`LiveOptions::image_hz`] frames a second;
//! - a topic nobody subscribed to costs nothing: its messages are not even encoded.
//!
//! The server keeps at most [`BACKLOG`] messages per client: a client that falls behind
//! loses the oldest, tracking never waits for it.
//!
//! ```no_run
//! use flexshape_foxglove::{FoxgloveServer, LiveOptions};
//! # fn main() -> Result<(), Box<dyn std::error::Error>> {
//! let rig = flexshape_rig::Rig::load(std::path::Path::new("rig.toml"))?;
//! let mut live = FoxgloveServer::start("127.0.0.1:8765", false, &rig, LiveOptions::default())?;
//! println!("open {} in Foxglove", live.url());
//! // For every tracked frame: live.publish(&record, &processed);
//! # Ok(())
//! # }
//! ```

use std::net::{IpAddr, SocketAddr};
use std::sync::Arc;
use std::time::Duration;

pub use flexshape_mcap::LiveOptions;
use flexshape_mcap::{FrameTopics, ImageRate, TopicId, stamp_ns};
use flexshape_record::TrackRecord;
use flexshape_rig::Rig;
use flexshape_track::Processed;
use foxglove::{Context, PartialMetadata, RawChannel, Schema, WebSocketServer};
use thiserror::Error;

/// Foxglove's own default port, which its "Open connection" dialog proposes.
pub const DEFAULT_ADDRESS: &str = "127.0.0.1:8765";

/// Messages kept per client before the oldest are dropped (a slow client never slows
/// tracking; at 30 frames/s and about 20 messages a frame, a few seconds' worth).
pub const BACKLOG: usize = 2048;

/// Why the live connection cannot be served.
#[derive(Debug, Error)]
pub enum FoxgloveError {
    /// The address is not `HOST:PORT`.
    #[error("Foxglove address `{0}` is not HOST:PORT (e.g. {DEFAULT_ADDRESS})")]
    Address(String),
    /// A non-loopback address without consent.
    #[error(
        "Foxglove address {0} is reachable from other machines, and the protocol has no password: give --allow-remote if anyone who can reach it may see the cameras, or use 127.0.0.1"
    )]
    Remote(SocketAddr),
    /// The server could not start (the port is taken, …).
    #[error(
        "cannot serve Foxglove on {addr}: {source} (is another program using the port? try another one, or port 0 for any free one)"
    )]
    Start {
        /// The address asked for.
        addr: SocketAddr,
        /// What the SDK said.
        source: foxglove::FoxgloveError,
    },
    /// A topic could not be set up.
    #[error("cannot offer the topic {topic}: {source}")]
    Channel {
        /// The topic.
        topic: String,
        /// What the SDK said.
        source: foxglove::FoxgloveError,
    },
    /// The server's thread pool could not be made.
    #[error("cannot start the Foxglove server's threads: {0}")]
    Runtime(std::io::Error),
}

/// A Foxglove WebSocket server publishing every tracked frame; stops when dropped.
pub struct FoxgloveServer {
    server: Option<foxglove::WebSocketServerHandle>,
    /// The server's own threads (one worker: it only forwards bytes).
    runtime: Option<tokio::runtime::Runtime>,
    /// This server's channels alone (not the SDK's global context).
    _context: Arc<Context>,
    topics: FrameTopics,
    channels: Vec<(TopicId, Arc<RawChannel>)>,
    images: ImageRate,
    url: String,
}

impl FoxgloveServer {
    /// Serves `rig`'s topics at `addr` (`HOST:PORT`; port 0 picks a free one). A
    /// non-loopback address is refused unless `allow_remote`, and then logged as a warning.
    pub fn start(
        addr: &str,
        allow_remote: bool,
        rig: &Rig,
        options: LiveOptions,
    ) -> Result<Self, FoxgloveError> {
        let addr: SocketAddr = addr
            .parse()
            .map_err(|_| FoxgloveError::Address(addr.to_string()))?;
        if !addr.ip().is_loopback() {
            if !allow_remote {
                return Err(FoxgloveError::Remote(addr));
            }
            tracing::warn!(
                "the Foxglove server at {addr} is reachable from other machines: anyone who can reach it sees the cameras"
            );
        }
        let context = Context::new();
        let topics = FrameTopics::new(rig, options.images);
        let mut channels = Vec::new();
        for t in topics.topics() {
            let schema = Schema::new(t.schema_name, t.schema_encoding, t.schema.into_bytes());
            let channel = context
                .channel_builder(t.name.clone())
                .message_encoding(t.message_encoding)
                .schema(schema)
                .build_raw()
                .map_err(|source| FoxgloveError::Channel {
                    topic: t.name.clone(),
                    source,
                })?;
            channels.push((t.id, channel));
        }
        let runtime = tokio::runtime::Builder::new_multi_thread()
            .worker_threads(1)
            .thread_name("foxglove")
            .enable_all()
            .build()
            .map_err(FoxgloveError::Runtime)?;
        let server = WebSocketServer::new()
            .name("flexshape")
            .bind(addr.ip().to_string(), addr.port())
            .context(&context)
            .message_backlog_size(BACKLOG)
            .tokio_runtime(runtime.handle())
            .start_blocking()
            .map_err(|source| FoxgloveError::Start { addr, source })?;
        let host = match addr.ip() {
            IpAddr::V4(ip) if ip.is_unspecified() => "127.0.0.1".to_string(),
            IpAddr::V6(ip) if ip.is_unspecified() => "[::1]".to_string(),
            IpAddr::V6(ip) => format!("[{ip}]"),
            ip => ip.to_string(),
        };
        let url = format!("ws://{host}:{}", server.port());
        Ok(FoxgloveServer {
            server: Some(server),
            runtime: Some(runtime),
            _context: context,
            topics,
            channels,
            images: ImageRate::new(options.image_hz),
            url,
        })
    }

    /// The address to open in Foxglove (`ws://HOST:PORT`).
    pub fn url(&self) -> &str {
        &self.url
    }

    /// The port served (the one picked when port 0 was asked for).
    pub fn port(&self) -> u16 {
        self.server.as_ref().map_or(0, |s| s.port())
    }

    /// Clients connected now.
    pub fn clients(&self) -> usize {
        self.server.as_ref().map_or(0, |s| s.client_count())
    }

    /// Publishes one tracked frame to every client subscribed to its topics. Never blocks on
    /// a client.
    pub fn publish(&mut self, record: &TrackRecord, p: &Processed) {
        let stamp = stamp_ns(record);
        let meta = PartialMetadata::with_log_time(stamp);
        let images_due = self.images.due();
        let channel = |id: TopicId| {
            self.channels
                .iter()
                .find(|(topic, _)| *topic == id)
                .map(|(_, c)| c)
        };
        let subscribed = |id: TopicId| channel(id).filter(|c| c.has_sinks());
        if let Some(c) = subscribed(TopicId::Transforms) {
            c.log_with_meta(&self.topics.transforms(stamp), meta);
        }
        let mut sent_images = false;
        let wanted = |id: TopicId| (images_due || !id.is_view()) && subscribed(id).is_some();
        let _ = self.topics.messages(record, p, wanted, |id, data| {
            if let Some(c) = channel(id) {
                c.log_with_meta(data, meta);
                sent_images |= id.is_view();
            }
            Ok::<(), std::convert::Infallible>(())
        });
        if sent_images {
            self.images.sent();
        }
    }
}

impl Drop for FoxgloveServer {
    /// Closes every connection and waits (up to a second) for the clients to be told.
    fn drop(&mut self) {
        if let Some(server) = self.server.take() {
            let shutdown = server.stop();
            if let Some(runtime) = &self.runtime {
                // The timer needs the runtime's context: made inside the block.
                runtime.block_on(async {
                    let _ = tokio::time::timeout(Duration::from_secs(1), shutdown.wait()).await;
                });
            }
        }
        if let Some(runtime) = self.runtime.take() {
            runtime.shutdown_timeout(Duration::from_millis(200));
        }
    }
}
