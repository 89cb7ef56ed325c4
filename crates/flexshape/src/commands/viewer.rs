//! The live viewer as the commands use it: started from `--viewer`, fed every processed frame
//! with the figures so far.

use std::collections::VecDeque;
use std::time::Instant;

use anyhow::Context;
use flexshape_track::{Pipeline, Processed, TrackRecord};
use flexshape_viewer::{Scene, Stats, Steering, Update, Viewer};

use crate::cli::ViewerArgs;

/// A started viewer and the recent frame times it shows as fps.
pub struct Live {
    viewer: Viewer,
    recent: VecDeque<Instant>,
    frames: usize,
}

/// Starts the viewer if `--viewer` was given, and prints its address.
pub fn start(args: &ViewerArgs, pipeline: &Pipeline) -> anyhow::Result<Option<Live>> {
    let Some(addr) = &args.viewer else {
        return Ok(None);
    };
    start_at(addr, args.allow_remote, pipeline).map(Some)
}

/// Starts the viewer at `addr` and prints its address.
pub fn start_at(addr: &str, allow_remote: bool, pipeline: &Pipeline) -> anyhow::Result<Live> {
    let v = pipeline.volume();
    let hi = v.max_corner();
    let scene = Scene {
        cameras: pipeline.camera_names().to_vec(),
        volume: [v.origin[0], v.origin[1], v.origin[2], hi.x, hi.y, hi.z],
        voxel: v.voxel_size[0],
    };
    let viewer = Viewer::start(addr, allow_remote, scene).context("cannot start the viewer")?;
    eprintln!("viewer: {}", viewer.url());
    Ok(Live {
        viewer,
        recent: VecDeque::new(),
        frames: 0,
    })
}

impl Live {
    /// The page's address.
    pub fn url(&self) -> &str {
        self.viewer.url()
    }

    /// Offers a frame of the closed loop (`model steer`) with its steering state.
    pub fn publish_steering(&mut self, p: Processed, record: TrackRecord, steering: Steering) {
        let update = self.update(p, record, None).with_steering(steering);
        self.viewer.publish(update);
    }

    /// Offers a frame (taking its images and results) with figures; `truth` is the
    /// centerline RMS and tip error against truth, mm, when known.
    pub fn publish(&mut self, p: Processed, record: TrackRecord, truth: Option<(f64, f64)>) {
        let update = self.update(p, record, truth);
        self.viewer.publish(update);
    }

    /// The frame with the figures so far.
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
    }
}
