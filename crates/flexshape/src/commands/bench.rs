//! `flexshape bench`: per-stage figures of the sensing chain on the simulated rig, at 1 and 2
//! threads (`flexshape_lab::bench`).

use flexshape_lab::bench::{BenchSettings, bench};

use crate::cli::BenchArgs;

pub fn run(args: &BenchArgs) -> anyhow::Result<()> {
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
