//! `flexshape validate`: the paper's validation experiments (Section III) as tools, and on
//! the simulated rig.

use std::path::Path;

use anyhow::{Context, bail};
use flexshape_camera::nalgebra::Point3;
use flexshape_curve::Polyline;
use flexshape_fit::Method;
use flexshape_validate::simulated::{Experiments, accuracy_experiment, precision_experiment};
use flexshape_validate::{
    AccuracyReport, Extraction, KnownShape, PrecisionReport, accuracy, compare_records, extract,
    figures, precision,
};
use serde::Serialize;

use crate::cli::{ValidateArgs, ValidatePointsArgs, ValidateShapeArgs};

/// The paper's figures (Section III): accuracy against the digitizer, precision along the
/// machined object and at its bands, mm per axis.
const PAPER_ACCURACY: [f64; 3] = [0.72, 0.61, 0.64];
const PAPER_ALONG: [f64; 3] = [0.69, 0.59, 0.24];
const PAPER_BANDS: [f64; 3] = [0.49, 0.77, 0.47];

/// Points from a CSV of `x,y,z` lines; a first line that is not numeric is a header.
fn read_points(path: &Path) -> anyhow::Result<Vec<Point3<f64>>> {
    Ok(
        flexshape_rig::files::read_csv_numbers(path, 3, "`x,y,z` (three numbers)")?
            .into_iter()
            .map(|v| Point3::new(v[0], v[1], v[2]))
            .collect(),
    )
}

fn rms_line(name: &str, got: [f64; 3], paper: [f64; 3]) -> String {
    format!(
        "{name:<34} {:>6.3} {:>6.3} {:>6.3}    {:>5.2} {:>5.2} {:>5.2}",
        got[0], got[1], got[2], paper[0], paper[1], paper[2]
    )
}

const HEADER: &str =
    "                                   rms x  rms y  rms z    paper (Section III)";

pub fn points(args: &ValidatePointsArgs) -> anyhow::Result<()> {
    let sensed = match (&args.sensed, &args.sensed_from) {
        (Some(csv), _) => read_points(csv)?,
        (None, Some(jsonl)) => {
            let how: Extraction = args
                .extract
                .parse()
                .map_err(|e: String| anyhow::anyhow!("--extract {e}"))?;
            let mut points = Vec::new();
            for (line, r) in flexshape_track::read_records(jsonl)? {
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
    print_accuracy(&report);
    println!(
        "translation [{:.3}, {:.3}, {:.3}] mm; rotation rows {:?}",
        report.translation[0],
        report.translation[1],
        report.translation[2],
        report.rotation.map(|r| r.map(|v| (v * 1e6).round() / 1e6))
    );
    Ok(())
}

fn print_accuracy(r: &AccuracyReport) {
    println!(
        "Accuracy: {} point pairs registered (reference → sensed); 3-D rms {:.3} mm, max {:.3} mm",
        r.points, r.rms, r.max
    );
    println!("{HEADER}");
    println!("{}", rms_line("points (mm)", r.rms_axis(), PAPER_ACCURACY));
}

fn print_precision(r: &PrecisionReport) {
    println!(
        "Precision: {} poses; along the length 3-D rms {:.3} mm (max {:.3}), at the marks 3-D rms {:.3} mm (max {:.3})",
        r.poses, r.rms_along_3d, r.max_along, r.rms_marks_3d, r.max_marks
    );
    println!("{HEADER}");
    println!(
        "{}",
        rms_line("along the length (mm)", r.rms_along, PAPER_ALONG)
    );
    if r.rms_marks_3d > 0.0 || r.max_marks > 0.0 {
        println!(
            "{}",
            rms_line("at the marked points (mm)", r.rms_marks, PAPER_BANDS)
        );
    }
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
    let records = flexshape_track::read_records(&args.records)?;
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
    print_precision(&report);
    for s in &run.skipped {
        println!("skipped {s}");
    }
    Ok(())
}

#[derive(Serialize)]
struct SimulatedReport {
    accuracy: AccuracyReport,
    precision: PrecisionReport,
    /// The same experiments with the hull's centerline alone (`--method hull`).
    hull: HullReport,
    paper: PaperFigures,
    skipped: Vec<String>,
}

#[derive(Serialize)]
struct HullReport {
    accuracy: AccuracyReport,
    precision: PrecisionReport,
}

#[derive(Serialize)]
struct PaperFigures {
    accuracy: [f64; 3],
    precision_along: [f64; 3],
    precision_bands: [f64; 3],
}

pub fn simulate(args: &ValidateArgs) -> anyhow::Result<()> {
    let experiments = Experiments {
        seed: args.seed,
        ..Experiments::default()
    };
    eprintln!(
        "simulating {} stylus poses and {} poses of the S-bent object …",
        experiments.probe_poses, experiments.object_poses
    );
    let acc = accuracy_experiment(&experiments).context("the simulated accuracy experiment")?;
    let pre = precision_experiment(&experiments).context("the simulated precision experiment")?;
    // The same poses with the hull's centerline alone, to show what the image fit gains.
    let hull_experiments = Experiments {
        method: Method::Hull,
        ..experiments.clone()
    };
    let hull_acc = accuracy_experiment(&hull_experiments)
        .context("the simulated accuracy experiment (hull)")?;
    let hull_pre = precision_experiment(&hull_experiments)
        .context("the simulated precision experiment (hull)")?;
    if let Some(dir) = &args.out {
        let mut files = figures::accuracy(dir, &acc.report, &acc.sensed)?;
        files.extend(figures::precision(
            dir,
            &pre.poses,
            &pre.sensed,
            &pre.sensed_marks,
            &pre.cloud,
        )?);
        flexshape_validate::simulated::write_data(dir, &acc, &pre)?;
        eprintln!(
            "wrote {} figures and the experiments' data to {}",
            files.len(),
            dir.display()
        );
    }
    let skipped: Vec<String> = acc.skipped.iter().chain(&pre.skipped).cloned().collect();
    if args.json {
        let out = SimulatedReport {
            accuracy: acc.report,
            precision: pre.report,
            hull: HullReport {
                accuracy: hull_acc.report,
                precision: hull_pre.report,
            },
            paper: PaperFigures {
                accuracy: PAPER_ACCURACY,
                precision_along: PAPER_ALONG,
                precision_bands: PAPER_BANDS,
            },
            skipped,
        };
        println!("{}", serde_json::to_string_pretty(&out)?);
        return Ok(());
    }
    println!(
        "Simulated validation (seed {}; default rig: 3 cameras 640×480, 1 mm voxels; reference noise {} mm per axis)\n",
        args.seed, experiments.reference_noise_mm
    );
    print_accuracy(&acc.report);
    println!();
    print_precision(&pre.report);
    print_fit_against_hull(
        [&acc.report, &hull_acc.report],
        [&pre.report, &hull_pre.report],
    );
    for s in &skipped {
        println!("skipped {s}");
    }
    Ok(())
}

/// The image fit's figures beside the hull's alone (`--method hull`), rms x/y/z mm.
fn print_fit_against_hull(accuracy: [&AccuracyReport; 2], precision: [&PrecisionReport; 2]) {
    println!(
        "\nThe tube fitted to the images against the hull's centerline alone (--method hull), rms x/y/z mm:"
    );
    let side = |name: &str, fit: [f64; 3], hull: [f64; 3]| {
        println!(
            "  {name:<26} fit {:.3} {:.3} {:.3}   hull {:.3} {:.3} {:.3}",
            fit[0], fit[1], fit[2], hull[0], hull[1], hull[2]
        )
    };
    side(
        "accuracy (points)",
        accuracy[0].rms_axis(),
        accuracy[1].rms_axis(),
    );
    side(
        "precision along the length",
        precision[0].rms_along,
        precision[1].rms_along,
    );
    side(
        "precision at the marks",
        precision[0].rms_marks,
        precision[1].rms_marks,
    );
}
