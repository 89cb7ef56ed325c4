//! `flexshape model plan`: which preload lets the paper's experiment determine every
//! stiffness of a catheter, and the intervals a sensing accuracy gives (library:
//! `flexshape_model::plan_experiment`).

use anyhow::{bail, ensure};
use flexshape_model::{PlanReport, SensingAccuracy, candidate_preloads, plan_experiment};

use crate::cli::ModelPlanArgs;

pub fn run(args: &ModelPlanArgs) -> anyhow::Result<()> {
    let model = super::model::load(&args.params)?;
    ensure!(
        (1..=10_000).contains(&args.poses),
        "--poses {}: give 1 to 10000",
        args.poses
    );
    ensure!(
        args.max_bend.is_finite() && args.max_bend > 0.0 && args.max_bend <= 270.0,
        "--max-bend {}: give degrees above 0 and at most 270",
        args.max_bend
    );
    if !(args.max_strain.is_finite() && (0.002..=0.5).contains(&args.max_strain)) {
        bail!(
            "--max-strain {}: give a compression strain from 0.002 to 0.5",
            args.max_strain
        );
    }
    let accuracy =
        super::model::sensing_accuracy(&args.bias, SensingAccuracy::default().position_mm)?;
    let preloads = candidate_preloads(args.max_strain);
    let design = plan_experiment(
        model.params(),
        args.poses,
        args.max_bend.to_radians(),
        &preloads,
        &accuracy,
    )?;
    let report = PlanReport::of(&design, args.poses, args.max_bend, accuracy);
    if args.json {
        println!("{}", serde_json::to_string_pretty(&report)?);
        return Ok(());
    }
    print!("{report}");
    let (preload, all) = report.preload_to_run();
    println!(
        "\nTo simulate {}: flexshape simulate --out EXP --model {} --poses {} --preload {preload}",
        if all { "it" } else { "the best allowed" },
        args.params.display(),
        args.poses
    );
    Ok(())
}
