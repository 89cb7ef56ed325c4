//! The live web viewer, served by the flexshape binary itself (no internet needed): each
//! camera's frame and silhouette with marker bands, the carved cloud with the fitted
//! centerline, bands and tip in three orthogonal views and a rotatable 3-D view, and live
//! figures (fps, latency, drops, arc length, curvature, tip).
//!
//! Tracking hands every frame to [`Viewer::publish`], which only swaps it into a one-slot
//! mailbox: encoding (JPEG/PNG, JSON) happens on the viewer's own thread at a capped rate, and
//! every browser gets the newest encoded frame when it is ready for one, so a slow browser or
//! a slow network never slows tracking. World frame, mm.
//!
//! A recording tracked with the viewer open ([`Live`] works out the frame rate it shows):
//!
//! ```no_run
//! use std::ops::ControlFlow;
//! use std::sync::atomic::AtomicBool;
//! use flexshape_track::{Recording, run};
//! use flexshape_viewer::Live;
//!
//! # fn main() -> Result<(), Box<dyn std::error::Error>> {
//! let mut recording = Recording::open("recording".as_ref())?;
//! let pipeline = recording.pipeline()?;
//! let mut viewer = Live::start("127.0.0.1:8080", false, &pipeline)?;
//! println!("open {}", viewer.url());
//! run(&mut recording.source, &pipeline, 2, &AtomicBool::new(false), |p| {
//!     let record = p.record();
//!     viewer.publish(p, record, None);
//!     ControlFlow::Continue(())
//! });
//! # Ok(())
//! # }
//! ```

mod encode;
mod limits;
mod live;
mod origin;
mod overlay;
mod replay;
mod server;

use std::net::{SocketAddr, TcpListener};
use std::sync::Arc;

use thiserror::Error;
use tokio::sync::watch;

pub use encode::{Stats, Steering, SteeringSample, Update};
pub use limits::Limits;
pub use live::Live;
pub use overlay::{CameraOverlay, overlays};
pub use replay::{Control, RecordStream, RecordingReplay, ReplayState, Replayed, replay, scene_of};

/// Why the viewer could not start.
#[derive(Debug, Error)]
pub enum ViewerError {
    /// The address is not `HOST:PORT`.
    #[error("viewer address `{0}` is not HOST:PORT (e.g. 127.0.0.1:8080)")]
    Address(String),
    /// A non-loopback address without the explicit flag.
    #[error(
        "viewer address {0} is reachable from other machines, which would show them the cameras; use 127.0.0.1, or confirm with --allow-remote"
    )]
    Remote(SocketAddr),
    /// The port could not be bound.
    #[error(
        "cannot serve the viewer on {addr}: {error} (is another program using the port? try another one, or port 0 for any free one)"
    )]
    Bind {
        /// The address.
        addr: SocketAddr,
        /// What the system said.
        error: std::io::Error,
    },
    /// The server's thread or runtime could not start.
    #[error("cannot start the viewer's server: {0}")]
    Runtime(std::io::Error),
}

/// What the page shows around the frames: camera names and image sizes, and the carving
/// volume.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Scene {
    /// Camera names, in the rig's order.
    pub cameras: Vec<String>,
    /// Each camera's image `[width, height]`, pixels (the overlays' frame; empty when not
    /// known).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub image_sizes: Vec<[u32; 2]>,
    /// Each camera's place and view in the world, for the 3-D view's frusta (empty when not
    /// known).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub frusta: Vec<Frustum>,
    /// The carving volume's corners, world mm: `[xmin, ymin, zmin, xmax, ymax, zmax]`.
    pub volume: [f64; 6],
    /// Voxel edge, mm.
    pub voxel: f64,
    /// Records of a replay (`flexshape view`): the page shows its controls and sends them back.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub replay: Option<usize>,
}

/// Where a camera is and what it sees, world frame: its centre (mm), its axes (x right, y down,
/// z along the optical axis; unit vectors) and the image's corners as `(x, y)` of the
/// normalized image plane at `z = 1` (top-left, top-right, bottom-right, bottom-left; without
/// lens distortion).
#[derive(Debug, Clone, serde::Serialize)]
pub struct Frustum {
    /// Camera centre, world mm.
    pub centre: [f64; 3],
    /// The camera's x, y and z axes in the world frame.
    pub axes: [[f64; 3]; 3],
    /// The image corners on the plane `z = 1`.
    pub corners: [[f64; 2]; 4],
}

impl Frustum {
    /// The frustum of `camera`.
    pub fn of(camera: &flexshape_camera::Camera) -> Self {
        let k = &camera.intrinsics;
        let r = camera.pose.rotation.matrix();
        let c = camera.centre();
        // Pixel (u, v) on the plane z = 1; the image's edges are half a pixel beyond the
        // outer pixels' centres.
        let at = |u: f64, v: f64| [(u - k.cx) / k.fx, (v - k.cy) / k.fy];
        let (w, h) = (f64::from(k.width) - 0.5, f64::from(k.height) - 0.5);
        Frustum {
            centre: [c.x, c.y, c.z],
            axes: std::array::from_fn(|i| [r[(i, 0)], r[(i, 1)], r[(i, 2)]]),
            corners: [at(-0.5, -0.5), at(w, -0.5), at(w, h), at(-0.5, h)],
        }
    }
}

/// A running viewer. Dropping it leaves the server running until the process ends.
pub struct Viewer {
    url: String,
    addr: SocketAddr,
    mailbox: watch::Sender<Option<Arc<Update>>>,
    controls: Option<std::sync::mpsc::Receiver<Control>>,
}

impl Viewer {
    /// Serves the viewer at `addr` (`HOST:PORT`; port 0 picks a free port) with the default
    /// [`Limits`]. A non-loopback address is refused unless `allow_remote`, and then logged as
    /// a warning.
    pub fn start(addr: &str, allow_remote: bool, scene: Scene) -> Result<Viewer, ViewerError> {
        Self::start_with(addr, allow_remote, scene, Limits::default())
    }

    /// As [`Viewer::start`], with these connection limits.
    pub fn start_with(
        addr: &str,
        allow_remote: bool,
        scene: Scene,
        limits: Limits,
    ) -> Result<Viewer, ViewerError> {
        let addr: SocketAddr = addr
            .parse()
            .map_err(|_| ViewerError::Address(addr.to_string()))?;
        if !addr.ip().is_loopback() {
            if !allow_remote {
                return Err(ViewerError::Remote(addr));
            }
            tracing::warn!(
                "the viewer at {addr} is reachable from other machines: anyone who can reach it sees the cameras"
            );
        }
        let listener =
            TcpListener::bind(addr).map_err(|error| ViewerError::Bind { addr, error })?;
        let bound = listener
            .local_addr()
            .map_err(|error| ViewerError::Bind { addr, error })?;
        listener
            .set_nonblocking(true)
            .map_err(|error| ViewerError::Bind { addr, error })?;
        let (mailbox, updates) = watch::channel(None);
        // A replay's page sends controls back; a live viewer's page sends none.
        let (controls_tx, controls) = match scene.replay {
            Some(_) => {
                let (tx, rx) = std::sync::mpsc::channel();
                (Some(tx), Some(rx))
            }
            None => (None, None),
        };
        let runtime = tokio::runtime::Builder::new_multi_thread()
            .worker_threads(1)
            .thread_name("viewer")
            .enable_all()
            .build()
            .map_err(ViewerError::Runtime)?;
        std::thread::Builder::new()
            .name("viewer".into())
            .spawn(move || {
                runtime.block_on(server::serve(listener, scene, updates, limits, controls_tx))
            })
            .map_err(ViewerError::Runtime)?;
        let host = if bound.ip().is_unspecified() {
            "127.0.0.1".to_string()
        } else {
            bound.ip().to_string()
        };
        Ok(Viewer {
            url: format!("http://{host}:{}/", bound.port()),
            addr: bound,
            mailbox,
            controls,
        })
    }

    /// The page's address, e.g. `http://127.0.0.1:8080/`.
    pub fn url(&self) -> &str {
        &self.url
    }

    /// The bound socket address.
    pub fn addr(&self) -> SocketAddr {
        self.addr
    }

    /// The controls the page of a replay sends (its scene's `replay` set), once.
    pub fn take_controls(&mut self) -> Option<std::sync::mpsc::Receiver<Control>> {
        self.controls.take()
    }

    /// Offers a frame to the browsers; replaces any frame not yet encoded. Never blocks.
    pub fn publish(&self, update: Update) {
        self.mailbox.send_replace(Some(Arc::new(update)));
    }
}
