//! `flexshape model plan`: which preload lets the paper's experiment determine every
//! stiffness of a catheter, and the intervals a sensing accuracy gives (library:
//! `flexshape_model::plan_experiment`).

use anyhow::{bail, ensure};
use flexshape_model::{DETERMINED_SHARE, SensingAccuracy, plan_experiment};
use serde::Serialize;

use crate::cli::ModelPlanArgs;

/// The plan, as printed with `--json`.
#[derive(Debug, Serialize)]
struct Report {
    /// Per candidate preload (ε0): the RMS `[ε0, ε1]` of its poses and the predicted relative
    /// error (1 σ, the sensing's bias part) of `[Kx, Kz, Ka0, Ka1]`.
    candidates: Vec<Candidate>,
    /// Per stiffness the smallest preload that determines it to 10 %, if any does.
    determined_from: [Option<f64>; 4],
    /// Per stiffness none determines: the preload (axial) or curvature accuracy in percent
    /// (bending) that would.
    needed: [Option<f64>; 4],
}

#[derive(Debug, Serialize)]
struct Candidate {
    preload: f64,
    rms_strain: [f64; 2],
    relative_error: [f64; 4],
}

const NAMES: [&str; 4] = ["Kx", "Kz", "Ka0", "Ka1"];

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
    let report = Report {
        candidates: design
            .candidates
            .iter()
            .map(|c| Candidate {
                preload: c.plan.preload_strain,
                rms_strain: c.rms_strain,
                relative_error: c.relative_error,
            })
            .collect(),
        determined_from: design
            .first_determining
            .map(|i| i.map(|i| design.candidates[i].plan.preload_strain)),
        needed: std::array::from_fn(|j| {
            design.needed[j].map(|v| if j < 2 { v * 100.0 } else { v })
        }),
    };
    if args.json {
        println!("{}", serde_json::to_string_pretty(&report)?);
        return Ok(());
    }
    print_table(&report, args);
    // The design to run: the smallest preload that determines all, else the largest allowed.
    let all = report.determined_from.iter().all(Option::is_some);
    let preload = if all {
        report
            .determined_from
            .iter()
            .flatten()
            .copied()
            .fold(0.0, f64::max)
    } else {
        preloads[preloads.len() - 1]
    };
    println!(
        "\nTo simulate {}: flexshape simulate --out EXP --model {} --poses {} --preload {preload}",
        if all { "it" } else { "the best allowed" },
        args.params.display(),
        args.poses
    );
    Ok(())
}

/// The preloads tried: 0.002 doubled up to `max_strain`, and `max_strain` itself.
fn candidate_preloads(max_strain: f64) -> Vec<f64> {
    let mut preloads = vec![0.002];
    while preloads
        .last()
        .is_some_and(|p| p * 2.0 <= max_strain * (1.0 + 1e-9))
    {
        preloads.push(preloads[preloads.len() - 1] * 2.0);
    }
    if preloads
        .last()
        .is_some_and(|p| *p < max_strain * (1.0 - 1e-9))
    {
        preloads.push(max_strain);
    }
    preloads
}

/// The predicted errors per candidate preload, and what determines each stiffness.
fn print_table(report: &Report, args: &ModelPlanArgs) {
    println!(
        "The paper's experiment ({} workspace poses up to {:.0}°, one per tendon to register) on \
         this catheter, sensed with curvatures within {} % and strains within {:.1e}: predicted \
         1-σ error of each stiffness from the sensing's bias (a run's scatter adds to it)",
        args.poses, args.max_bend, args.bias.curvature_accuracy, args.bias.strain_accuracy
    );
    println!(
        "{:>9} {:>16} {:>9} {:>9} {:>9} {:>9}",
        "preload", "rms ε0, ε1", "Kx", "Kz", "Ka0", "Ka1"
    );
    for c in &report.candidates {
        let cell = |e: f64| {
            if e.is_finite() {
                format!(
                    "±{:.1}%{}",
                    e * 100.0,
                    if e <= DETERMINED_SHARE { "" } else { "*" }
                )
            } else {
                "—".into()
            }
        };
        println!(
            "{:>9.3} {:>7.4}, {:>7.4} {:>9} {:>9} {:>9} {:>9}",
            c.preload,
            c.rms_strain[0],
            c.rms_strain[1],
            cell(c.relative_error[0]),
            cell(c.relative_error[1]),
            cell(c.relative_error[2]),
            cell(c.relative_error[3])
        );
    }
    println!("(* not determined to {:.0} %)", DETERMINED_SHARE * 100.0);
    for (j, name) in NAMES.iter().enumerate() {
        match (report.determined_from[j], report.needed[j]) {
            (Some(p), _) => println!("{name}: determined from preload {p:.3}"),
            (None, Some(v)) if j < 2 => println!(
                "{name}: not determined by any pose set; the sensed curvatures would have to be \
                 right within {v:.3} % (or the tendons less stiff next to the catheter)"
            ),
            (None, Some(v)) => println!(
                "{name}: not determined up to preload {:.3}; about {v:.3} would do (if the \
                 catheter takes it), or a better strain accuracy",
                args.max_strain
            ),
            (None, None) => println!("{name}: the experiment does not exercise it"),
        }
    }
}
