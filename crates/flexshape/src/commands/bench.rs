//! `flexshape bench`: per-stage figures of the sensing chain on the simulated rig, at 1 and 2
//! threads (`flexshape_lab::bench`), or with `--soak N` a long run of the demo reported per
//! window of frames (`flexshape_lab::soak`).

use flexshape_lab::bench::{BenchSettings, bench};
use flexshape_lab::soak::{SoakSettings, soak, table_header};

use crate::cli::BenchArgs;
use crate::interrupt::Interrupt;

pub fn run(args: &BenchArgs) -> anyhow::Result<()> {
    if let Some(frames) = args.soak {
        return run_soak(args, frames);
    }
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

/// `--soak N`: a row per window as it ends, then the summary (or the report as JSON).
fn run_soak(args: &BenchArgs, frames: u64) -> anyhow::Result<()> {
    anyhow::ensure!(
        frames > 0 && args.window > 0,
        "--soak and --window must be at least 1 frame"
    );
    anyhow::ensure!(
        args.soak_fps.is_finite() && args.soak_fps > 0.0,
        "--soak-fps must be a positive number of frames per second"
    );
    anyhow::ensure!(args.threads > 0, "--threads must be at least 1");
    let stop = Interrupt::install();
    let settings = SoakSettings {
        frames,
        window: args.window,
        fps: args.soak_fps,
        threads: args.threads,
        ..SoakSettings::default()
    };
    if !args.json {
        println!("{}", table_header());
    }
    let report = soak(super::sim_config(&args.sim), &settings, stop.flag(), |w| {
        if !args.json {
            println!("{w}");
        }
    })?;
    if args.json {
        println!("{}", serde_json::to_string_pretty(&report)?);
    } else {
        println!("{report}");
    }
    Ok(())
}
