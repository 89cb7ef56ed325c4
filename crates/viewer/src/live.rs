//! The viewer as a tracking loop uses it: started for a pipeline's rig and volume, fed every
//! processed frame, with the frame rate it shows worked out here.

use std::collections::VecDeque;
use std::sync::Arc;
use std::time::Instant;

use flexshape_camera::Camera;

use flexshape_record::TrackRecord;
use flexshape_track::{Pipeline, Processed};

use crate::{Frustum, Scene, Stats, Steering, Update, Viewer, ViewerError};

/// A started viewer and the recent frame times it shows as frames per second.
pub struct Live {
    viewer: Viewer,
    recent: VecDeque<Instant>,
    frames: usize,
    /// The rig's cameras, for the overlays.
    cameras: Arc<[Camera]>,
    /// The carving volume, `[xmin, ymin, zmin, xmax, ymax, zmax]`, world mm.
    volume: [f64; 6],
}

impl Scene {
    /// The scene of `pipeline`: its cameras and carving volume.
    pub fn of(pipeline: &Pipeline) -> Self {
        let v = pipeline.volume();
        let hi = v.max_corner();
        Scene {
            cameras: pipeline.camera_names().to_vec(),
            image_sizes: pipeline
                .cameras()
                .iter()
                .map(|c| [c.intrinsics.width, c.intrinsics.height])
                .collect(),
            frusta: pipeline.cameras().iter().map(Frustum::of).collect(),
            replay: None,
            volume: [v.origin[0], v.origin[1], v.origin[2], hi.x, hi.y, hi.z],
            voxel: v.voxel_size[0],
        }
    }
}

impl Live {
    /// Serves the viewer of `pipeline`'s frames at `addr` (`HOST:PORT`; a non-loopback
    /// address only with `allow_remote`).
    pub fn start(addr: &str, allow_remote: bool, pipeline: &Pipeline) -> Result<Self, ViewerError> {
        let scene = Scene::of(pipeline);
        Ok(Live {
            volume: scene.volume,
            viewer: Viewer::start(addr, allow_remote, scene)?,
            recent: VecDeque::new(),
            frames: 0,
            cameras: pipeline.cameras().into(),
        })
    }

    /// The page's address.
    pub fn url(&self) -> &str {
        self.viewer.url()
    }

    /// Offers a frame (taking its images and results) with the figures so far; `truth` is
    /// the centerline RMS and tip error against truth, mm, when known.
    pub fn publish(&mut self, p: Processed, record: TrackRecord, truth: Option<(f64, f64)>) {
        let update = self.update(p, record, truth);
        self.viewer.publish(update);
    }

    /// Offers a frame of the closed loop (`model steer`) with its steering state.
    pub fn publish_steering(&mut self, p: Processed, record: TrackRecord, steering: Steering) {
        let update = self.update(p, record, None).with_steering(steering);
        self.viewer.publish(update);
    }

    /// The frame with the figures so far: the frame rate over the last two seconds.
    fn update(&mut self, p: Processed, record: TrackRecord, truth: Option<(f64, f64)>) -> Update {
        let now = Instant::now();
        self.frames += 1;
        self.recent.push_back(now);
        while self
            .recent
            .front()
            .is_some_and(|t| now.duration_since(*t).as_secs_f64() > 2.0)
        {
            self.recent.pop_front();
        }
        let span = self
            .recent
            .front()
            .map(|t| now.duration_since(*t).as_secs_f64())
            .unwrap_or(0.0);
        let stats = Stats {
            frames: self.frames,
            fps: if span > 0.0 {
                (self.recent.len() - 1) as f64 / span
            } else {
                0.0
            },
            latency_ms: p.latency_ms,
            dropped: p.dropped,
            truth_rms_mm: truth.map(|t| t.0),
            truth_tip_mm: truth.map(|t| t.1),
        };
        Update::new(p, record, stats)
            .with_cameras(self.cameras.clone())
            .with_truth_within(self.volume)
    }
}
