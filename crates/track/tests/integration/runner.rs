//! Frames in flight: the runner hands results over in input order, whatever the number of
//! workers, keeps going past a bad frame, stops cleanly, and reports an input that breaks.

use crate::common;

use std::ops::ControlFlow;
use std::sync::atomic::AtomicBool;

use flexshape_input::{FrameImage, FrameSet, FrameSource, InputError};
use flexshape_track::{Pipeline, Processed, Tally, TrackRecord, run};

/// Pre-rendered frames; `bad` frames have an image of the wrong size, and the source breaks
/// (as a video whose camera ends early) after `breaks_after` frames.
struct Frames {
    sets: Vec<FrameSet>,
    next: usize,
    breaks_after: Option<usize>,
}

impl FrameSource for Frames {
    fn next_frame(&mut self) -> Option<Result<FrameSet, InputError>> {
        if self.breaks_after == Some(self.next) {
            return Some(Err(InputError::Ended {
                camera: "cam1".into(),
                frames: self.next as u64,
            }));
        }
        let set = self.sets.get(self.next)?.clone();
        self.next += 1;
        Some(Ok(set))
    }
}

fn setup(n: usize, bad: &[usize]) -> (Pipeline, Vec<FrameSet>) {
    let (sim, pipeline) = common::simulated_chain();
    let sets = sim
        .sweep(n)
        .iter()
        .enumerate()
        .map(|(i, pose)| {
            let frame = sim.render(10 + i as u64, pose).unwrap();
            let mut images: Vec<_> = frame
                .views
                .into_iter()
                .map(|v| FrameImage::Decoded(v.image))
                .collect();
            if bad.contains(&i) {
                images[2] = FrameImage::Decoded(image::RgbImage::new(32, 24));
            }
            FrameSet::new(10 + i as u64, images)
        })
        .collect();
    (pipeline, sets)
}

fn records(
    pipeline: &Pipeline,
    sets: &[FrameSet],
    workers: usize,
    breaks_after: Option<usize>,
    stop_after: Option<usize>,
) -> (Vec<TrackRecord>, flexshape_track::RunEnd) {
    let mut source = Frames {
        sets: sets.to_vec(),
        next: 0,
        breaks_after,
    };
    let mut out = Vec::new();
    let end = run(
        &mut source,
        pipeline,
        workers,
        &AtomicBool::new(false),
        |p: Processed| {
            assert_eq!(p.images.len(), if p.result.is_ok() { 3 } else { 0 });
            out.push(TrackRecord::from_processed(&p));
            match stop_after {
                Some(k) if out.len() >= k => ControlFlow::Break(()),
                _ => ControlFlow::Continue(()),
            }
        },
    );
    (out, end)
}

#[test]
fn results_come_in_input_order_and_match_one_worker() {
    let (pipeline, sets) = setup(8, &[3]);
    let (one, end1) = records(&pipeline, &sets, 1, None, None);
    let (three, end3) = records(&pipeline, &sets, 3, None, None);
    for (end, recs) in [(&end1, &one), (&end3, &three)] {
        assert_eq!(end.frames, 8);
        assert!(!end.stopped && end.input_error.is_none());
        let frames: Vec<u64> = recs.iter().map(|r| r.frame).collect();
        assert_eq!(frames, (10..18).collect::<Vec<_>>());
    }
    for (a, b) in one.iter().zip(&three) {
        assert_eq!(a.status, b.status);
        assert_eq!(a.centerline, b.centerline, "frame {}", a.frame);
    }
    // The bad frame is an error record naming the camera and the size; the others are shapes.
    let bad = &three[3];
    assert_eq!(bad.status, "error");
    let reason = bad.reason.as_deref().unwrap();
    assert!(
        reason.contains("cam2") && reason.contains("32×24"),
        "{reason}"
    );
    assert_eq!(three.iter().filter(|r| r.status == "ok").count(), 7);
    let mut tally = Tally::new();
    three.iter().for_each(|r| tally.add(r));
    let summary = tally.summary(&end3);
    assert_eq!((summary.frames, summary.ok, summary.errors), (8, 7, 1));
    assert!(summary.latency_ms.unwrap().median_ms > 0.0);
}

#[test]
fn a_stop_hands_over_what_was_taken_and_a_broken_input_is_reported() {
    let (pipeline, sets) = setup(8, &[]);
    let (recs, end) = records(&pipeline, &sets, 2, None, Some(2));
    assert!(end.stopped);
    // A sink that says stop is handed nothing more, though the workers had taken more.
    assert_eq!(recs.len(), 2);
    assert_eq!(end.frames, 2);
    assert!(recs.iter().zip(10..).all(|(r, f)| r.frame == f));
    let (recs, end) = records(&pipeline, &sets, 2, Some(5), None);
    assert_eq!(recs.len(), 5);
    let message = end.input_error.unwrap().to_string();
    assert!(
        message.contains("cam1") && message.contains("after 5 frames"),
        "{message}"
    );
}
