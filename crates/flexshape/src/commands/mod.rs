//! One module per command.

mod demo;
mod rig_check;
mod simulate;

use flexshape_sim::SimConfig;

use crate::cli::{Cli, Command, RigCommand, SimArgs};

/// Runs the parsed command.
pub fn run(cli: Cli) -> anyhow::Result<()> {
    match cli.command {
        Command::Demo(args) => demo::run(&args),
        Command::Simulate(args) => simulate::run(&args),
        Command::Rig { command: RigCommand::Check { path } } => rig_check::run(&path),
    }
}

/// The simulator settings the shared arguments describe.
fn sim_config(args: &SimArgs) -> SimConfig {
    let mut c = SimConfig::default();
    c.seed = args.seed;
    c.rig.cameras = args.cams;
    (c.rig.width, c.rig.height) = args.size;
    c.rig.focal = args.focal.unwrap_or(800.0 * args.size.0 as f64 / 640.0);
    c.render.shadows = args.shadows;
    c.render.noise_sigma = args.noise;
    c.render.seed = args.seed;
    c.occluders = args.occluders;
    c.catheter.radius = args.radius;
    c
}
