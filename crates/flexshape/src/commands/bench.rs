//! `flexshape bench`: per-stage figures of the sensing chain on the simulated rig, at 1 and 2
//! threads (`flexshape_lab::bench`).

use flexshape_lab::bench::{BenchSettings, bench};

use crate::cli::BenchArgs;

pub fn run(args: &BenchArgs) -> anyhow::Result<()> {
    anyhow::ensure!(
        args.frames > 0 && args.rounds > 0 && args.track_frames > 1,
        "--frames and --rounds must be at least 1, --track-frames at least 2"
    );
    anyhow::ensure!(
        args.rate.is_finite() && args.rate > 0.0,
        "--rate must be a positive number of frames per second"
    );
    let settings = BenchSettings {
        frames: args.frames,
        rounds: args.rounds,
        track_frames: args.track_frames,
        rate_hz: args.rate,
    };
    let report = bench(super::sim_config(&args.sim), &settings)?;
    if args.json {
        println!("{}", serde_json::to_string_pretty(&report)?);
    } else {
        print!("{}", report.table());
    }
    Ok(())
}
