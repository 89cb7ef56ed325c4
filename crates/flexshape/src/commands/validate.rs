//! `flexshape validate`: the paper's validation experiments (Section III) as tools, and on
//! the simulated rig.

use std::path::Path;

use anyhow::{Context, bail};
use flexshape_camera::nalgebra::Point3;
use flexshape_curve::Polyline;
use flexshape_validate::simulated::Experiments;
use flexshape_validate::{
    Extraction, KnownShape, PrecisionReport, SimulatedValidation, accuracy, compare_records,
    extract, figures, precision,
};
use serde::Serialize;

use crate::cli::{ValidateArgs, ValidatePointsArgs, ValidateShapeArgs};

/// Points from a CSV of `x,y,z` lines; a first line that is not numeric is a header.
fn read_points(path: &Path) -> anyhow::Result<Vec<Point3<f64>>> {
    Ok(
        flexshape_rig::files::read_csv_numbers(path, 3, "`x,y,z` (three numbers)")?
            .into_iter()
            .map(|v| Point3::new(v[0], v[1], v[2]))
            .collect(),
    )
}

pub fn points(args: &ValidatePointsArgs) -> anyhow::Result<()> {
    let sensed = match (&args.sensed, &args.sensed_from) {
        (Some(csv), _) => read_points(csv)?,
        (None, Some(jsonl)) => {
            let how: Extraction = args
                .extract
                .parse()
                .map_err(|e: String| anyhow::anyhow!("--extract {e}"))?;
            let mut points = Vec::new();
            for (line, r) in flexshape_record::read_records(jsonl)? {
                let p = extract(&r, how)
                    .map_err(|e| anyhow::anyhow!("{} line {line}: {e}", jsonl.display()))?;
                points.push(Point3::from(p));
            }
            points
        }
        (None, None) => bail!("give the sensed points with --sensed or --sensed-from"),
    };
    let reference = read_points(&args.reference)?;
    let report = accuracy(&sensed, &reference).with_context(|| {
        format!(
            "cannot register {} to the sensed points",
            args.reference.display()
        )
    })?;
    if let Some(dir) = &args.plots {
        let sensed: Vec<[f64; 3]> = sensed.iter().map(|p| [p.x, p.y, p.z]).collect();
        figures::accuracy(dir, &report, &sensed)?;
    }
    if args.json {
        println!("{}", serde_json::to_string_pretty(&report)?);
        return Ok(());
    }
    print!("{report}");
    println!(
        "translation [{:.3}, {:.3}, {:.3}] mm; rotation rows {:?}",
        report.translation[0],
        report.translation[1],
        report.translation[2],
        report.rotation.map(|r| r.map(|v| (v * 1e6).round() / 1e6))
    );
    Ok(())
}

#[derive(Serialize)]
struct ShapeReport {
    precision: PrecisionReport,
    /// Per pose: frame, arc-length offset and 3-D rms along the length.
    poses: Vec<(u64, f64, f64)>,
    skipped: Vec<String>,
}

pub fn shape(args: &ValidateShapeArgs) -> anyhow::Result<()> {
    let centerline = Polyline::new(read_points(&args.known)?)
        .with_context(|| format!("{}: not a centerline", args.known.display()))?;
    let marks = match &args.marks {
        Some(p) => read_points(p)?,
        None => Vec::new(),
    };
    let known = KnownShape { centerline, marks };
    let records = flexshape_record::read_records(&args.records)?;
    let run = compare_records(&known, records, &args.records)?;
    let report = precision(&run.poses);
    if let Some(dir) = &args.plots {
        figures::precision(dir, &run.poses, &run.sensed, &run.sensed_marks, &[])?;
    }
    if args.json {
        let out = ShapeReport {
            precision: report,
            poses: run.per_pose(),
            skipped: run.skipped,
        };
        println!("{}", serde_json::to_string_pretty(&out)?);
        return Ok(());
    }
    print!("{report}");
    for s in &run.skipped {
        println!("skipped {s}");
    }
    Ok(())
}

pub fn simulate(args: &ValidateArgs) -> anyhow::Result<()> {
    let experiments = Experiments {
        seed: args.seed,
        probe_poses: args.probe_poses as usize,
        object_poses: args.object_poses as usize,
        ..Experiments::default()
    };
    eprintln!(
        "simulating {} stylus poses and {} poses of the S-bent object …",
        experiments.probe_poses, experiments.object_poses
    );
    let validation =
        SimulatedValidation::run(&experiments).context("the simulated validation experiments")?;
    if let Some(dir) = &args.out {
        let files = validation.write(dir)?;
        eprintln!(
            "wrote {} figures and the experiments' data to {}",
            files.len(),
            dir.display()
        );
    }
    if args.json {
        println!("{}", serde_json::to_string_pretty(&validation)?);
    } else {
        print!("{validation}");
    }
    Ok(())
}
