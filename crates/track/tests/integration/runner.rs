//! Frames in flight: the runner hands results over in input order, whatever the number of
//! workers, keeps going past a bad frame, stops cleanly, and reports an input that breaks; a
//! followed recording gives the same records on every run.

use crate::common;
use flexshape_fit::FitSettings;

use std::ops::ControlFlow;
use std::sync::atomic::AtomicBool;
use std::time::Duration;

use flexshape_input::{FrameImage, FrameSet, FrameSource, InputError};
use flexshape_record::TrackRecord;
use flexshape_track::{Pipeline, Processed, Recent, Tally, Tracked, run};

/// Pre-rendered frames; `bad` frames have an image of the wrong size, and the source breaks
/// (as a video whose camera ends early) after `breaks_after` frames; `slow` frames take a
/// while to read.
struct Frames {
    sets: Vec<FrameSet>,
    next: usize,
    breaks_after: Option<usize>,
    slow: Option<(usize, Duration)>,
}

impl FrameSource for Frames {
    fn next_frame(&mut self) -> Option<Result<FrameSet, InputError>> {
        if let Some((frame, delay)) = self.slow
            && frame == self.next
        {
            std::thread::sleep(delay);
        }
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
    let mut sets = render(&sim, &sim.sweep(n), 10);
    for &i in bad {
        sets[i].images[2] = FrameImage::Decoded(image::RgbImage::new(32, 24));
    }
    (pipeline, sets)
}

/// The frame sets of `poses`, numbered from `first`.
fn render(
    sim: &flexshape_sim::Simulator,
    poses: &[flexshape_sim::CatheterPose],
    first: u64,
) -> Vec<FrameSet> {
    poses
        .iter()
        .zip(first..)
        .map(|(pose, i)| {
            let frame = sim.render(i, pose).unwrap();
            let images = frame
                .views
                .into_iter()
                .map(|v| FrameImage::Decoded(v.image))
                .collect();
            FrameSet::new(i, images)
        })
        .collect()
}

fn records(
    pipeline: &Pipeline,
    sets: &[FrameSet],
    workers: usize,
    breaks_after: Option<usize>,
    stop_after: Option<usize>,
) -> (Vec<TrackRecord>, flexshape_track::RunEnd) {
    records_from(
        Frames {
            sets: sets.to_vec(),
            next: 0,
            breaks_after,
            slow: None,
        },
        pipeline,
        workers,
        stop_after,
    )
}

fn records_from(
    mut source: Frames,
    pipeline: &Pipeline,
    workers: usize,
    stop_after: Option<usize>,
) -> (Vec<TrackRecord>, flexshape_track::RunEnd) {
    let mut out = Vec::new();
    let end = run(
        &mut source,
        pipeline,
        workers,
        &AtomicBool::new(false),
        |p: Processed| {
            assert_eq!(p.images.len(), if p.result.is_ok() { 3 } else { 0 });
            out.push(p.record());
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

/// With `n` workers, frame `k` of a followed recording starts from what frames `0..=k − n`
/// left, whatever order the workers finish in: the records are those of that rule applied one
/// frame at a time (before, each frame started from whichever frame had finished last, and
/// two runs of one recording differed).
#[test]
fn a_followed_recording_starts_each_frame_from_a_fixed_earlier_one() {
    let (sim, pipeline) = common::simulated_chain();
    let pipeline = pipeline.following(true).unwrap();
    assert!(pipeline.tracks());
    let sets = render(&sim, &sim.motion(14, 240.0), 0);
    for workers in [2, 3] {
        let mut recent = Recent::new(&pipeline);
        let mut after = Vec::new();
        let mut expected = Vec::new();
        for (k, set) in sets.iter().enumerate() {
            let prior = k
                .checked_sub(workers)
                .and_then(|before| Recent::for_frame(&after[before], k as u64));
            let p = Processed::of(&pipeline, set.clone(), prior.as_deref());
            recent.update(k as u64, p.result.as_ref().ok().and_then(Tracked::prior));
            after.push(recent.clone());
            expected.push(p.record());
        }
        let followed = expected
            .iter()
            .filter(|r| r.start == Some(flexshape_record::Start::Previous))
            .count();
        assert!(
            followed >= 10,
            "{followed} of 14 frames followed with {workers} workers"
        );
        for _ in 0..2 {
            let (got, _) = records(&pipeline, &sets, workers, None, None);
            assert_eq!(got.len(), expected.len());
            for (a, b) in got.iter().zip(&expected) {
                assert_eq!(
                    (&a.status, &a.start, &a.centerline),
                    (&b.status, &b.start, &b.centerline),
                    "frame {} with {workers} workers",
                    a.frame
                );
            }
        }
    }
}

/// Backgrounds that follow a changed backdrop are part of what frames start from: with `n`
/// workers frame `k` reads them as frames `0..=k − n` left them, in input order, tracked or
/// not. Before, a frame read whatever the workers had done when it started: a frame read late
/// (a slow source) saw an earlier frame's new backgrounds, read early it did not, and two runs
/// of a recording whose backdrop had changed differed.
#[test]
fn backgrounds_that_follow_the_backdrop_are_read_in_input_order() {
    // Folds slid 20 mm since the capture: the first frame's backgrounds follow them.
    let (sim, pipeline) = common::chain_of(common::folds_moved(20.0));
    let sets = render(&sim, &sim.sweep(4), 0);
    let run_with = |workers, slow| {
        let source = Frames {
            sets: sets.clone(),
            next: 0,
            breaks_after: None,
            slow,
        };
        // Each run from the backgrounds as captured.
        records_from(source, &pipeline.clone(), workers, None).0
    };
    let updated = |r: &[TrackRecord]| -> Vec<bool> {
        r.iter().map(|r| !r.background_updated.is_empty()).collect()
    };
    // One worker: frame 1 starts from frame 0's backgrounds.
    let one = run_with(1, None);
    assert_eq!(updated(&one), [true, false, false, false]);
    // Two: frame 1 starts from the backgrounds as captured, and follows the backdrop itself,
    // even when it is read after frame 0 has ended.
    let fast = run_with(2, None);
    let late = run_with(2, Some((1, Duration::from_millis(1500))));
    assert_eq!(updated(&fast)[..2], [true, true]);
    for (a, b) in fast.iter().zip(&late) {
        assert!(a.status == "ok", "frame {}: {:?}", a.frame, a.reason);
        assert_eq!(
            (&a.status, &a.background_updated),
            (&b.status, &b.background_updated),
            "frame {}",
            a.frame
        );
        assert!(
            a.centerline == b.centerline,
            "frame {}: shapes differ",
            a.frame
        );
    }
}

/// A sink that panics ends the run with its panic instead of leaving the workers waiting for
/// frames to be handed (a followed recording's frames wait for earlier frames' outcomes).
#[test]
fn a_sink_that_panics_ends_the_run() {
    let (pipeline, sets) = setup(8, &[]);
    for pipeline in [pipeline.clone(), pipeline.following(true).unwrap()] {
        let sets = sets.clone();
        let (tx, rx) = std::sync::mpsc::channel();
        std::thread::spawn(move || {
            let mut source = Frames {
                sets,
                next: 0,
                breaks_after: None,
                slow: None,
            };
            let outcome = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
                run(
                    &mut source,
                    &pipeline,
                    2,
                    &AtomicBool::new(false),
                    |_: Processed| -> ControlFlow<()> { panic!("the sink broke") },
                )
            }));
            let _ = tx.send(outcome.is_err());
        });
        let panicked = rx
            .recv_timeout(std::time::Duration::from_secs(120))
            .expect("the run did not end after its sink panicked");
        assert!(panicked);
    }
}

/// A followed frame starts from the newest right shape carried on as it moved since the newest
/// right shape at least as many frames before it as the frame is ahead (a move measured over
/// one frame, doubled, would double the fits' own scatter), or the oldest one at hand.
#[test]
fn a_prediction_extrapolates_no_farther_than_it_measured() {
    let (sim, pipeline) = common::simulated_chain();
    let pipeline = pipeline.following(true).unwrap();
    let limit = pipeline.fit_settings().track_max_move_mm;
    // Followed from one another, so that their tubes pair up control point for control point.
    let mut priors: Vec<flexshape_track::Prior> = Vec::new();
    for (i, pose) in sim.motion(3, 240.0).iter().enumerate() {
        let frame = sim.render(i as u64, pose).unwrap();
        let images: Vec<_> = frame.views.iter().map(|v| &v.image).collect();
        let tracked = pipeline.process_after(&images, priors.last()).unwrap();
        priors.push(tracked.prior().unwrap());
    }
    let mut recent = Recent::new(&pipeline);
    for (k, p) in priors.iter().enumerate() {
        recent.update(k as u64, Some(p.clone()));
    }
    let control = |p: &flexshape_track::Prior| p.tube().centerline.control().to_vec();
    // (frame to start, the earlier shape's frame, frames ahead over frames between)
    for (seq, earlier, ratio) in [(3, 1, 1.0), (4, 0, 1.0), (5, 0, 1.5)] {
        let ahead = (seq - 2) as f64;
        let expected = priors[2]
            .predicted(&priors[earlier], ratio, limit, limit * ahead)
            .unwrap();
        let got = recent.for_frame(seq).unwrap();
        assert_eq!(control(&got), control(&expected), "frame {seq}");
    }
    // Both differ from the other choice, so the test tells them apart.
    let doubled = priors[2]
        .predicted(&priors[1], 2.0, limit, 2.0 * limit)
        .unwrap();
    assert_ne!(control(&doubled), control(&recent.for_frame(4).unwrap()));
    // A frame that was not right forgets what came before it.
    recent.update(3, None);
    assert!(recent.for_frame(4).is_none());

    // The move limit is per frame: a start two frames on may move a point up to twice it.
    // With the limit at 3/4 of the largest move between frames 0 and 2, a prediction one
    // frame on from them would be refused, and two frames on it is made.
    let largest = control(&priors[2])
        .iter()
        .zip(control(&priors[0]))
        .map(|(a, b)| (0..3).map(|c| (a[c] - b[c]).powi(2)).sum::<f64>().sqrt())
        .fold(0.0, f64::max);
    let tight = FitSettings {
        track_max_move_mm: 0.75 * largest,
        ..pipeline.fit_settings().clone()
    };
    let tight = pipeline.clone().with_fit_settings(tight).unwrap();
    let mut lane = Recent::new(&tight);
    lane.update(0, Some(priors[0].clone()));
    lane.update(2, Some(priors[2].clone()));
    let limit = 0.75 * largest;
    assert!(priors[2].predicted(&priors[0], 1.0, limit, limit).is_none());
    let got = lane.for_frame(4).unwrap();
    assert_ne!(
        control(&got),
        control(&priors[2]),
        "no prediction two frames on"
    );
}
