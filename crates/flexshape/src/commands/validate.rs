//! `flexshape validate`: the paper's validation experiments (Section III) as tools, and on
//! the simulated rig.

use std::path::Path;

use anyhow::{Context, bail};
use flexshape_camera::nalgebra::Point3;
use flexshape_curve::Polyline;
use flexshape_fit::Method;
use flexshape_track::{RecordStatus, TrackRecord};
use flexshape_validate::simulated::{
    AccuracyRun, Experiments, PrecisionRun, accuracy_experiment, known_object, precision_experiment,
};
use flexshape_validate::{
    AccuracyReport, Extraction, KnownShape, PrecisionReport, accuracy, compare_shape, extract,
    precision,
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
        super::figures::accuracy(dir, &report, &sensed)?;
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
    let (mut poses, mut frames, mut skipped) = (Vec::new(), Vec::new(), Vec::new());
    let (mut sensed, mut sensed_marks) = (Vec::new(), Vec::new());
    for (line, r) in flexshape_track::read_records(&args.records)? {
        let usable = matches!(r.status, RecordStatus::Ok | RecordStatus::BandsMissing)
            && r.centerline.len() > 2;
        if !usable {
            skipped.push(format!(
                "line {line} (frame {}): status {}",
                r.frame, r.status
            ));
            continue;
        }
        let curve = Polyline::new(r.centerline.iter().map(|p| Point3::from(*p)).collect())
            .with_context(|| format!("{} line {line}", args.records.display()))?;
        let bands: Vec<Point3<f64>> = if known.marks.is_empty() {
            Vec::new()
        } else {
            r.bands.iter().map(|b| Point3::from(b.position)).collect()
        };
        match compare_shape(&known, &curve, &bands) {
            Ok(c) => {
                frames.push(r.frame);
                sensed.push(r.centerline.clone());
                sensed_marks.push(bands.iter().map(|p| [p.x, p.y, p.z]).collect());
                poses.push(c);
            }
            Err(e) => skipped.push(format!("line {line} (frame {}): {e}", r.frame)),
        }
    }
    if poses.is_empty() {
        bail!(
            "{}: no pose could be compared with the known shape ({})",
            args.records.display(),
            skipped.join("; ")
        );
    }
    let report = precision(&poses);
    if let Some(dir) = &args.plots {
        super::figures::precision(dir, &poses, &sensed, &sensed_marks, &[])?;
    }
    if args.json {
        let per_pose = poses
            .iter()
            .zip(&frames)
            .map(|(p, &f)| {
                let n = p.errors.len().max(1) as f64;
                let rms = (p
                    .errors
                    .iter()
                    .map(|e| e.iter().map(|v| v * v).sum::<f64>())
                    .sum::<f64>()
                    / n)
                    .sqrt();
                (f, p.offset_mm, rms)
            })
            .collect();
        let out = ShapeReport {
            precision: report,
            poses: per_pose,
            skipped,
        };
        println!("{}", serde_json::to_string_pretty(&out)?);
        return Ok(());
    }
    print_precision(&report);
    for s in &skipped {
        println!("skipped {s}");
    }
    Ok(())
}

/// The experiments' inputs in the tools' formats, so `validate points` and `validate shape`
/// can be run on them: `stylus_tracks.jsonl` + `stylus_reference.csv`, `object_tracks.jsonl`
/// + `object_known.csv` + `object_marks.csv`.
fn write_data(dir: &Path, acc: &AccuracyRun, pre: &PrecisionRun) -> anyhow::Result<()> {
    let write = |name: &str, text: String| {
        let path = dir.join(name);
        std::fs::write(&path, text).with_context(|| format!("cannot write {}", path.display()))
    };
    let jsonl = |records: &[TrackRecord]| -> anyhow::Result<String> {
        let mut out = String::new();
        for r in records {
            out.push_str(&serde_json::to_string(r)?);
            out.push('\n');
        }
        Ok(out)
    };
    let csv = |points: &mut dyn Iterator<Item = [f64; 3]>| -> String {
        let mut out = String::from("x,y,z\n");
        for p in points {
            out.push_str(&format!("{:.6},{:.6},{:.6}\n", p[0], p[1], p[2]));
        }
        out
    };
    // The stylus records with a tip pair with the reference points in order.
    let with_tip: Vec<TrackRecord> = acc
        .records
        .iter()
        .filter(|r| r.status.is_ok() && r.tip.is_some())
        .cloned()
        .collect();
    write("stylus_tracks.jsonl", jsonl(&with_tip)?)?;
    write(
        "stylus_reference.csv",
        csv(&mut acc.reference.iter().copied()),
    )?;
    write("object_tracks.jsonl", jsonl(&pre.records)?)?;
    let known = known_object()?;
    write(
        "object_known.csv",
        csv(&mut known.centerline.points().iter().map(|p| [p.x, p.y, p.z])),
    )?;
    write(
        "object_marks.csv",
        csv(&mut known.marks.iter().map(|p| [p.x, p.y, p.z])),
    )?;
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
        let mut files = super::figures::accuracy(dir, &acc.report, &acc.sensed)?;
        files.extend(super::figures::precision(
            dir,
            &pre.poses,
            &pre.sensed,
            &pre.sensed_marks,
            &pre.cloud,
        )?);
        write_data(dir, &acc, &pre)?;
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
        acc.report.rms_axis(),
        hull_acc.report.rms_axis(),
    );
    side(
        "precision along the length",
        pre.report.rms_along,
        hull_pre.report.rms_along,
    );
    side(
        "precision at the marks",
        pre.report.rms_marks,
        hull_pre.report.rms_marks,
    );
    for s in &skipped {
        println!("skipped {s}");
    }
    Ok(())
}
