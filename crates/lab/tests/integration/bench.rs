//! `flexshape bench` as a library: the tracking workload is one continuous run.

use flexshape_lab::bench::{BenchSettings, bench};

/// The motion played back and forth (it reverses five times) is followed frame after frame:
/// only the run's first frame starts from its hull. Each of these was once carved again:
/// - when a predicted start whose control points had drifted along the tube was dropped for
///   the previous frame's shape (a frame's motion behind), every other frame of the backward
///   passes needed three measurements, and two ended `inconsistent` (seed 1: 99.2 %);
/// - when a tip's last control points crowded toward it, the self-check read the tube as
///   folded through itself (seed 2: 99.3 %);
/// - when a fit that settled on its first boundaries failed a camera's check, it went back
///   to the hull instead of measuring again (seed 1: 99.7 %).
#[test]
fn a_motion_played_back_and_forth_is_followed_throughout() {
    let settings = BenchSettings {
        frames: 1,
        rounds: 5,
        track_frames: 60,
        rate_hz: 120.0,
    };
    // The motion `flexshape bench` measures by default (seed 1), and another.
    for seed in [1, 2] {
        let config = flexshape_sim::SimConfig {
            seed,
            ..Default::default()
        };
        let report = bench(config, &settings).unwrap();
        assert_eq!(report.tracking.len(), 2);
        for figures in &report.tracking {
            let threads = figures.threads;
            assert_eq!(
                figures.followed,
                Some(1.0),
                "seed {seed}, {threads} threads"
            );
            assert_eq!(figures.accuracy.right, figures.accuracy.frames);
        }
    }
}
