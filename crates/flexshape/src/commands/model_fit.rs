//! `flexshape model fit`: the paper's tensionless stiffness estimation from a tracking output
//! whose records carry the commanded tendon displacements (`flexshape_lab::identify`).

use anyhow::Context;
use flexshape_lab::identify::{
    Experiment, IdentifySettings, identify, load_model, load_model_frame, read_displacements,
    records_of,
};

use crate::cli::ModelFitArgs;

pub fn run(args: &ModelFitArgs) -> anyhow::Result<()> {
    let model = load_model(&args.params)?;
    let logged = match &args.displacements {
        None => Default::default(),
        Some(path) => read_displacements(path, model.params().tendons.len())?,
    };
    if args.data.is_dir() {
        eprintln!("tracking {} …", args.data.display());
    }
    let stop = crate::interrupt::Interrupt::install();
    let records = records_of(&args.data, super::cores(), stop.flag())
        .with_context(|| format!("--data {}", args.data.display()))?;
    let experiment = Experiment::from_records(records, &logged, &model, &args.data)?;
    let settings = IdentifySettings {
        tendons: args.tendons,
        accuracy: super::model::sensing_accuracy(&args.bias, args.position_accuracy)?,
        known_frame: args.frame.as_deref().map(load_model_frame).transpose()?,
    };
    let found = identify(&model, &experiment, &settings)?;
    if let Some(dir) = &args.plots {
        found.figure(&experiment, dir)?;
    }
    if let Some(path) = &args.save_frame {
        let text = serde_json::to_string_pretty(&found.model_frame())?;
        std::fs::write(path, text + "\n")
            .with_context(|| format!("cannot write the model frame to {}", path.display()))?;
    }
    if args.json {
        println!("{}", serde_json::to_string_pretty(&found.report)?);
    } else {
        print!("{}", found.report.table());
    }
    Ok(())
}
