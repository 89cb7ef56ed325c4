//! A processed frame as the record `flexshape track` writes ([`flexshape_record`]), and the
//! tally of a run's records for progress and the summary.

use flexshape_input::CaptureSource;
use flexshape_record::{
    CapturedFrom, ClockTally, Method, RecordStatus, StageSummary, StageTimings, TrackArcFit,
    TrackBand, TrackCompression, TrackRecord, TrackSummary, quantile, stage_summaries,
};
use flexshape_shape::Status;

use crate::instants::Instants;
use crate::pipeline::Tracked;
use crate::runner::{Processed, RunEnd};

impl Tracked {
    /// This frame's record, numbered `frame`.
    pub fn record(&self, frame: u64) -> TrackRecord {
        let t = self;
        let s = &t.shape;
        let reason = match &s.status {
            Status::Ok => None,
            Status::NoObject { voxels } => Some(format!("{voxels} voxels carved")),
            Status::Ambiguous { reason }
            | Status::Inconsistent { reason }
            | Status::BadSilhouette { reason } => Some(reason.clone()),
            Status::LeavesVolume => {
                Some("the tube leaves the volume: the tip is outside it; enlarge the volume".into())
            }
            Status::BandsMissing { found, expected } => {
                Some(format!("{found} of {expected} bands found"))
            }
        };
        let status = RecordStatus::from(&s.status);
        let has_shape = !s.points.is_empty();
        let arc_fit = s.arc_fit.as_ref().map(|f| {
            let [x, y, z] = f.axes;
            let k = f.curvature.max(1e-300);
            // The bend direction is (−κz, 0, κx)/κ in the section frame.
            let (bx, bz) = (-f.kappa[1] / k, f.kappa[0] / k);
            TrackArcFit {
                curvature: f.curvature,
                base: f.origin,
                base_tangent: y,
                bend_direction: std::array::from_fn(|i| bx * x[i] + bz * z[i]),
                residual_mm: f.residual_mean,
                length: f.length,
                kappa_x: None,
                kappa_z: None,
            }
        });
        TrackRecord {
            centerline: s.points.clone(),
            tip: has_shape.then_some(s.tip),
            tip_direction: has_shape.then_some(s.tip_direction),
            arc_length: s.length,
            bands: s
                .bands
                .iter()
                .map(|b| TrackBand {
                    position: b.position,
                    arc_length: b.arc_length,
                })
                .collect(),
            arc_fit,
            voxels: t.occupancy.len(),
            timings_ms: t.timings,
            curvature: s.curvature.clone(),
            compression: s
                .compression
                .iter()
                .map(|c| TrackCompression {
                    name: c.name.clone(),
                    strain: c.strain,
                    length: c.length,
                })
                .collect(),
            method: Some(if t.fit.is_some() {
                Method::Fit
            } else {
                Method::Hull
            }),
            radius: has_shape.then_some(s.radius),
            radius_steps: t
                .fit
                .as_ref()
                .filter(|_| has_shape)
                .map_or_else(Vec::new, |f| f.tube.steps.clone()),
            centerline_sigma: s.sigma.clone(),
            cameras: t.fit.as_ref().map_or_else(Vec::new, |f| f.cameras.clone()),
            ghost_mm: t.fit.as_ref().and_then(|f| f.ghost_mm),
            carried_mm: match t.instants {
                Instants::Carried { shift_mm } => Some(shift_mm),
                _ => None,
            },
            lag_ms: match t.instants {
                Instants::Unknown { lag_s, centre_s } => Some((centre_s.abs() + lag_s) * 1e3),
                _ => None,
            },
            start: t.fit.as_ref().map(|_| t.start.clone()),
            background_updated: t.background_updated.clone(),
            shadow_voxels: t.shadow_voxels,
            background_restored: t.background_restored.clone(),
            direction_guessed: s.direction_guessed,
            ..TrackRecord::bare(frame, status, reason)
        }
    }
}

impl Processed {
    /// The frame's record: its shape or its error, command, name and
    /// latency.
    pub fn record(&self) -> TrackRecord {
        let p = self;
        let record = match &p.result {
            Ok(t) => t.record(p.frame),
            Err(e) => TrackRecord::error(p.frame, e.clone()),
        };
        TrackRecord {
            image: p.name.clone(),
            latency_ms: Some(p.latency_ms),
            captured_s: p.capture_time.map(|c| c.seconds),
            captured_from: p.capture_time.map(|c| captured_from(c.source)),
            camera_captured_s: p.camera_times.clone().unwrap_or_default(),
            processed_s: p.processed_s,
            ..record.with_command(p.command.clone())
        }
    }
}

/// What a record calls where a frame's capture time came from.
pub fn captured_from(source: CaptureSource) -> CapturedFrom {
    match source {
        CaptureSource::Clock => CapturedFrom::Clock,
        CaptureSource::Timestamps => CapturedFrom::Timestamps,
        CaptureSource::FileTime => CapturedFrom::FileTime,
        CaptureSource::Stream => CapturedFrom::Stream,
    }
}

/// Counts and times of a run so far, for progress and the summary.
#[derive(Debug, Clone)]
pub struct Tally {
    started: std::time::Instant,
    timings: Vec<StageTimings>,
    latencies: Vec<f64>,
    ok: usize,
    errors: usize,
    frames: usize,
    direction_guessed: usize,
    shadow_frames: usize,
    file_times: usize,
    clocks: ClockTally,
}

impl Default for Tally {
    fn default() -> Self {
        Tally {
            started: std::time::Instant::now(),
            timings: Vec::new(),
            latencies: Vec::new(),
            ok: 0,
            errors: 0,
            frames: 0,
            direction_guessed: 0,
            shadow_frames: 0,
            file_times: 0,
            clocks: ClockTally::default(),
        }
    }
}

impl Tally {
    /// Starts counting now.
    pub fn new() -> Self {
        Tally::default()
    }

    /// Counts one record.
    pub fn add(&mut self, record: &TrackRecord) {
        self.frames += 1;
        match record.status {
            RecordStatus::Ok => self.ok += 1,
            RecordStatus::Error => self.errors += 1,
            _ => {}
        }
        self.direction_guessed += usize::from(record.direction_guessed);
        self.shadow_frames += usize::from(record.shadow_voxels > 0);
        self.file_times += usize::from(record.captured_from == Some(CapturedFrom::FileTime));
        self.clocks.add(
            record.captured_s,
            &record.camera_captured_s,
            record.lag_ms.is_some(),
        );
        if record.status != RecordStatus::Error {
            self.timings.push(record.timings_ms);
        }
        if let Some(l) = record.latency_ms {
            self.latencies.push(l);
        }
    }

    /// Frames counted.
    pub fn frames(&self) -> usize {
        self.frames
    }

    /// Seconds since the tally started.
    pub fn seconds(&self) -> f64 {
        self.started.elapsed().as_secs_f64()
    }

    /// The summary of the run, given how it ended.
    pub fn summary(&self, end: &RunEnd) -> TrackSummary {
        let seconds = self.seconds();
        let mut latencies = self.latencies.clone();
        TrackSummary {
            frames: self.frames,
            ok: self.ok,
            errors: self.errors,
            stopped: end.stopped || end.input_error.is_some(),
            seconds,
            fps: self.frames as f64 / seconds.max(1e-9),
            stages: stage_summaries(&self.timings),
            dropped: end.dropped,
            unpaired: end.unpaired,
            latency_ms: (!latencies.is_empty()).then(|| StageSummary {
                stage: "latency".into(),
                median_ms: quantile(&mut latencies, 0.5),
                p95_ms: quantile(&mut latencies, 0.95),
            }),
            input_error: end.input_error.as_ref().map(|e| e.to_string()),
            startup_s: None,
            direction_guessed: self.direction_guessed,
            shadow_frames: self.shadow_frames,
            refined_rig: None,
            file_time_frames: self.file_times,
            camera_clocks: self.clocks.clocks(),
            between_captures: self.clocks.between(),
            truth: None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_run_of_frames_without_a_direction_says_once_which_setting_decides_it() {
        let mut tally = Tally::new();
        let mut record = TrackRecord::error(0, String::new());
        record.status = RecordStatus::Ambiguous;
        record.direction_guessed = true;
        for _ in 0..3 {
            tally.add(&record);
        }
        tally.add(&TrackRecord::error(3, String::new()));
        let summary = tally.summary(&RunEnd::default());
        assert_eq!(summary.direction_guessed, 3);
        let line = summary.line(false, false);
        assert_eq!(line.matches("proximal_hint").count(), 1, "{line}");
        assert!(line.contains("3 of 4 frames"), "{line}");
        // Frames that had a direction say nothing of it.
        let quiet = Tally::new().summary(&RunEnd::default()).line(false, false);
        assert!(!quiet.contains("proximal_hint"), "{quiet}");
        assert!(!quiet.contains("shadow"), "{quiet}");
    }

    #[test]
    fn a_run_whose_hulls_held_a_shadow_says_once_what_casts_it() {
        let mut tally = Tally::new();
        let mut record = TrackRecord::error(0, String::new());
        record.status = RecordStatus::Ok;
        tally.add(&record);
        record.shadow_voxels = 1200;
        for _ in 0..2 {
            tally.add(&record);
        }
        let summary = tally.summary(&RunEnd::default());
        assert_eq!(summary.shadow_frames, 2);
        let line = summary.line(false, false);
        assert_eq!(line.matches("lamp").count(), 2, "{line}");
        assert!(line.contains("2 of 3 frames' hulls"), "{line}");
        let json = serde_json::to_string(&summary).unwrap();
        assert!(json.contains("\"shadow_frames\":2"), "{json}");
    }

    #[test]
    fn a_refined_rig_that_could_not_tell_which_camera_moved_says_how_far_the_world_may_have() {
        let refined = |world_open_mm| TrackSummary {
            refined_rig: Some(flexshape_rig::Refined {
                moved: vec!["cam2".into()],
                world_open_mm,
            }),
            ..Tally::new().summary(&RunEnd::default())
        };
        let line = refined(1.92).line(false, false);
        assert!(
            line.contains("cam2 moved") && line.contains("1.92 mm"),
            "{line}"
        );
        let json = serde_json::to_string(&refined(1.92)).unwrap();
        assert!(
            json.contains("\"refined_rig\":{\"moved\":[\"cam2\"]"),
            "{json}"
        );
        // Decided by the images: the field, but nothing to say.
        assert!(!refined(0.0).line(false, false).contains("refined"));
        let plain = Tally::new().summary(&RunEnd::default());
        assert!(!serde_json::to_string(&plain).unwrap().contains("refined"));
    }
}
