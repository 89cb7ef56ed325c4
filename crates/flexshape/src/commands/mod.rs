//! One module per command.

mod background;
mod bench;
mod calibrate;
mod capture;
mod carve;
mod demo;
mod frames;
mod live;
mod model;
mod model_fit;
mod model_plan;
mod model_steer;
mod report;
mod rig_check;
mod rig_import;
mod rig_refine;
mod ros2;
mod silhouettes;
mod simulate;
mod track;
mod validate;
mod view;
mod viewer;

use flexshape_sim::{Catheter, RenderSettings, SimConfig, SimRigConfig};

use crate::cli::{Cli, Command, ModelCommand, RigCommand, SimArgs, ValidateCommand};

/// Runs the parsed command.
pub fn run(cli: Cli) -> anyhow::Result<()> {
    match cli.command {
        Command::Demo(args) => demo::run(&args),
        Command::Simulate(args) => simulate::run(&args),
        Command::Background(args) => background::run(&args),
        Command::Capture(args) => capture::run(&args),
        Command::Silhouettes(args) => silhouettes::run(&args),
        Command::Track(args) => track::run(&args),
        Command::Carve(args) => carve::run(&args),
        Command::Bench(args) => bench::run(&args),
        Command::Model { command } => match command {
            ModelCommand::Template => model::template(),
            ModelCommand::Forward(args) => model::forward(&args),
            ModelCommand::Inverse(args) => model::inverse(&args),
            ModelCommand::Fit(args) => model_fit::run(&args),
            ModelCommand::Plan(args) => model_plan::run(&args),
            ModelCommand::Steer(args) => model_steer::run(&args),
        },
        Command::Validate(args) => match &args.command {
            Some(ValidateCommand::Points(a)) => validate::points(a),
            Some(ValidateCommand::Shape(a)) => validate::shape(a),
            None if args.simulate => validate::simulate(&args),
            None => anyhow::bail!("give `--simulate`, or a subcommand: `points` or `shape`"),
        },
        Command::Report(args) => report::run(&args),
        Command::View(args) => view::run(&args),
        Command::Calibrate(args) => calibrate::run(&args),
        Command::Rig { command } => match command {
            RigCommand::Check(args) => rig_check::run(&args),
            RigCommand::Import(args) => rig_import::import(&args),
            RigCommand::Export(args) => rig_import::export(&args),
            RigCommand::Refine(args) => rig_refine::run(&args),
        },
    }
}

/// The PLY encoding `--ascii-ply` asks for.
pub(crate) fn ply_encoding(ascii: bool) -> flexshape_carve::PlyEncoding {
    if ascii {
        flexshape_carve::PlyEncoding::Ascii
    } else {
        flexshape_carve::PlyEncoding::Binary
    }
}

/// The simulator settings the shared arguments describe.
fn sim_config(args: &SimArgs) -> SimConfig {
    let defaults = SimConfig::default();
    let (width, height) = args.size;
    let gloss = |g: [f64; 2]| flexshape_sim::Gloss {
        strength: g[0],
        shininess: g[1],
    };
    let albedo = args.body_albedo.unwrap_or(defaults.catheter.albedo);
    let body_gloss = args.gloss.map_or(defaults.catheter.gloss, gloss);
    let outer = (args.outer_albedo.is_some() || args.outer_gloss.is_some()).then(|| {
        flexshape_sim::Material {
            albedo: args.outer_albedo.unwrap_or(albedo),
            gloss: args.outer_gloss.map_or(body_gloss, gloss),
        }
    });
    SimConfig {
        rig: SimRigConfig {
            cameras: args.cams,
            width,
            height,
            focal: args.focal.unwrap_or(800.0 * width as f64 / 640.0),
            calibration_error_px: args.calibration_error,
            miscalibrated: args.miscalibrated.clone(),
            ..defaults.rig
        },
        render: RenderSettings {
            shadows: args.shadows,
            noise_sigma: args.noise,
            seed: args.seed,
            supersampling: args.supersampling.unwrap_or(defaults.render.supersampling),
            backdrop_albedo: args
                .backdrop_albedo
                .unwrap_or(defaults.render.backdrop_albedo),
            fold_depth: args.fold_depth,
            fold_shift_mm: args.fold_shift,
            plate: args.plate.map(|p| flexshape_sim::Plate::new(p.into())),
            ..defaults.render
        },
        catheter: Catheter {
            radius: args.radius,
            radius_steps: args
                .radius_steps
                .as_ref()
                .map(|s| s.0.clone())
                .unwrap_or_default(),
            albedo,
            gloss: body_gloss,
            outer,
            ..defaults.catheter
        },
        occluders: args.occluders,
        seed: args.seed,
    }
}

/// Cores available to this process (at least 1).
fn cores() -> usize {
    std::thread::available_parallelism().map_or(1, |n| n.get())
}

/// A rig TOML, or a folder of OpenCV camera files (with the default volume).
pub(crate) fn load_rig(path: &std::path::Path) -> anyhow::Result<flexshape_rig::Rig> {
    use anyhow::Context;
    let (rig, skipped) = flexshape_rig::Rig::open(path)
        .with_context(|| format!("{} is not a valid rig", path.display()))?;
    for s in &skipped {
        eprintln!("warning: {s}");
    }
    Ok(rig)
}

/// The pipeline with its centerline method set from `--method`, if given.
pub(crate) fn with_method(
    pipeline: flexshape_track::Pipeline,
    method: Option<crate::cli::MethodArg>,
) -> Result<flexshape_track::Pipeline, flexshape_track::TrackError> {
    match method {
        None => Ok(pipeline),
        Some(m) => {
            let settings = flexshape_fit::FitSettings {
                method: m.into(),
                ..pipeline.fit_settings().clone()
            };
            pipeline.with_fit_settings(settings)
        }
    }
}
