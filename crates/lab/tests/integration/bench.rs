//! `flexshape bench` as a library: the tracking workload is one continuous run.

use flexshape_lab::bench::{BenchSettings, bench};

/// The motion played back and forth (it reverses five times) is followed frame after frame:
/// only the run's first frame starts from its hull. When a predicted start whose control
/// points had drifted along the tube was dropped for the previous frame's shape (a frame's
/// motion behind), every other frame of the backward passes needed three measurements, and
/// two of them ended `inconsistent` and were carved again (99.2 % followed).
#[test]
fn a_motion_played_back_and_forth_is_followed_throughout() {
    let settings = BenchSettings {
        frames: 1,
        rounds: 5,
        track_frames: 60,
        rate_hz: 120.0,
    };
    // The motion `flexshape bench` measures by default (seed 1).
    let config = flexshape_sim::SimConfig {
        seed: 1,
        ..Default::default()
    };
    let report = bench(config, &settings).unwrap();
    assert_eq!(report.tracking.len(), 2);
    for figures in &report.tracking {
        assert_eq!(figures.followed, Some(1.0), "{} threads", figures.threads);
        assert_eq!(figures.accuracy.right, figures.accuracy.frames);
    }
}
