//! `flexshape model fit`: the paper's tensionless stiffness estimation from a tracking output
//! whose records carry the commanded tendon displacements.

use anyhow::{Context, bail};
use flexshape_model::nalgebra_types::{DVector, Point3, Vector3};
use flexshape_model::{
    ManipulatorParams, Model, Observation, SensedPose, SensorFrame, estimate_stiffness,
    estimate_tendons, tip_error,
};
use flexshape_recording::PoseRole;
use flexshape_track::TrackRecord;
use serde::Serialize;

use crate::cli::ModelFitArgs;

/// The report, as printed with `--json`.
#[derive(Debug, Serialize)]
struct Report {
    /// `[Kx, Kz, Ka0, Ka1]` from the parameter file.
    nominal: [f64; 4],
    /// The estimate (nominal where not estimated).
    estimated: [f64; 4],
    /// Which were estimated.
    estimated_from_data: [bool; 4],
    /// Standard errors of the estimate.
    standard_error: [f64; 4],
    /// Relative stiffness error per relative error of the sensed configuration.
    sensitivity: [f64; 4],
    /// Ka0 and Ka1 in series: nominal, estimated.
    serial_axial: [f64; 2],
    /// Mean tip error, % of L1: nominal model, fitted model.
    tip_error_percent: [f64; 2],
    /// Largest tip error, % of L1: nominal, fitted.
    max_tip_error_percent: [f64; 2],
    /// Data poses used.
    observations: usize,
    /// Registration poses used.
    registration_poses: usize,
    /// Whether a relaxed reference pose gave ε0.
    reference_pose: bool,
    /// Frames left out, with why.
    skipped: Vec<String>,
    /// Registration residuals, degrees: axis, bending directions.
    registration_residual_deg: [f64; 2],
    /// Model frame → world rotation (rows).
    rotation: [[f64; 3]; 3],
    /// With `--tendons`: the estimated tendon positions, or why they are not determined.
    #[serde(skip_serializing_if = "Option::is_none")]
    tendons: Option<TendonReport>,
}

/// The tendon-position estimate.
#[derive(Debug, Serialize)]
struct TendonReport {
    /// `[dx, dz]` per tendon, mm (absent when not determined).
    positions: Vec<[f64; 2]>,
    /// Their standard errors, mm.
    standard_error: Vec<[f64; 2]>,
    /// Column-scaled Jacobian condition.
    condition: f64,
    /// RMS residual, mm.
    rms_mm: f64,
    /// Why they could not be estimated.
    #[serde(skip_serializing_if = "Option::is_none")]
    refused: Option<String>,
}

pub fn run(args: &ModelFitArgs) -> anyhow::Result<()> {
    let model = super::model::load(&args.params)?;
    let text = std::fs::read_to_string(&args.data)
        .with_context(|| format!("cannot read {}", args.data.display()))?;
    let mut poses: Vec<(u64, DVector<f64>, Option<PoseRole>, SensedPose)> = Vec::new();
    let mut skipped = Vec::new();
    let mut commanded = 0;
    for (i, line) in text.lines().enumerate() {
        let place = || format!("{} line {}", args.data.display(), i + 1);
        let value: serde_json::Value = match serde_json::from_str(line) {
            Ok(v) => v,
            Err(_) if line.trim().is_empty() => continue,
            Err(e) => bail!("{}: not JSON ({e})", place()),
        };
        if value.get("summary").is_some() {
            continue;
        }
        let record: TrackRecord = serde_json::from_value(value)
            .with_context(|| format!("{}: not a tracking record", place()))?;
        let Some(y) = record.tendon_displacements.clone() else {
            continue;
        };
        commanded += 1;
        let n = model.params().tendons.len();
        if y.len() != n {
            bail!(
                "{}: frame {} has {} tendon displacements but the model has {n} tendons",
                place(),
                record.frame,
                y.len()
            );
        }
        match sensed(&record) {
            Ok(s) => poses.push((record.frame, DVector::from_vec(y), record.role, s)),
            Err(why) => skipped.push(format!("frame {}: {why}", record.frame)),
        }
    }
    if commanded == 0 {
        bail!(
            "{}: no record carries `tendon_displacements`; track a recording that has commands/ \
             (e.g. from `flexshape simulate --model`) or add them to each record",
            args.data.display()
        );
    }
    let report = fit(&model, &poses, skipped, args.tendons)?;
    if args.json {
        println!("{}", serde_json::to_string_pretty(&report)?);
    } else {
        print_table(&report);
    }
    Ok(())
}

/// What a record says about the bending section, or why it cannot be used.
fn sensed(r: &TrackRecord) -> Result<SensedPose, String> {
    if r.status != "ok" {
        return Err(format!(
            "status {}{}",
            r.status,
            r.reason
                .as_deref()
                .map(|s| format!(" ({s})"))
                .unwrap_or_default()
        ));
    }
    let (Some(fit), Some(band), Some(tip)) = (&r.arc_fit, r.bands.first(), r.tip) else {
        return Err("no arc fit, band or tip".into());
    };
    let tangent = Vector3::from(fit.base_tangent);
    let bend = Vector3::from(fit.bend_direction);
    Ok(SensedPose {
        base: Point3::from(band.position),
        tangent,
        curvature: tangent.cross(&bend) * fit.curvature,
        bend_strain: r.compression.first().map(|c| c.strain),
        tip: Point3::from(tip),
    })
}

fn fit(
    model: &Model,
    poses: &[(u64, DVector<f64>, Option<PoseRole>, SensedPose)],
    skipped: Vec<String>,
    with_tendons: bool,
) -> anyhow::Result<Report> {
    let is_reference = |y: &DVector<f64>, role: &Option<PoseRole>| match role {
        Some(r) => *r == PoseRole::Reference,
        None => y.iter().all(|v| *v == 0.0),
    };
    let reference = poses
        .iter()
        .find(|(_, y, role, _)| is_reference(y, role))
        .map(|p| &p.3);
    let data: Vec<_> = poses
        .iter()
        .filter(|(_, y, role, _)| !is_reference(y, role))
        .collect();
    let marked: Vec<(DVector<f64>, SensedPose)> = data
        .iter()
        .filter(|p| p.2 == Some(PoseRole::Register))
        .map(|p| (p.1.clone(), p.3.clone()))
        .collect();
    // Without marked registration poses, every pose registers (by the nominal model).
    let articulated = if marked.is_empty() {
        data.iter().map(|p| (p.1.clone(), p.3.clone())).collect()
    } else {
        marked
    };
    let frame = SensorFrame::register(model, reference, &articulated)
        .context("cannot register the model frame to the sensor")?;
    let observations: Vec<Observation> = data
        .iter()
        .map(|(_, y, _, s)| frame.observation(model, s, y.clone()))
        .collect();
    let estimate = estimate_stiffness(model.params(), &observations)
        .context("cannot estimate the stiffnesses")?;
    // The nominal model's tip error needs complete configurations only where no tip is sensed;
    // every observation here has one.
    let (nominal_mean, nominal_max) = tip_error(model.params(), &observations)?;
    let nominal = model.params().stiffness;
    let tendons = with_tendons.then(|| {
        let fitted = ManipulatorParams {
            stiffness: estimate.stiffness,
            ..model.params().clone()
        };
        let complete: Vec<Observation> = observations
            .iter()
            .filter(|o| o.measured.iter().all(|m| *m))
            .cloned()
            .collect();
        match estimate_tendons(&fitted, &complete, false) {
            Ok(t) => TendonReport {
                positions: t.params.tendons.iter().map(|t| [t.dx, t.dz]).collect(),
                standard_error: t.standard_error,
                condition: t.condition,
                rms_mm: t.rms_mm,
                refused: None,
            },
            Err(e) => TendonReport {
                positions: Vec::new(),
                standard_error: Vec::new(),
                condition: f64::INFINITY,
                rms_mm: f64::NAN,
                refused: Some(e.to_string()),
            },
        }
    });
    let m = frame.rotation.matrix();
    Ok(Report {
        nominal: nominal.diagonal(),
        estimated: estimate.stiffness.diagonal(),
        estimated_from_data: estimate.estimated,
        standard_error: estimate.standard_error,
        sensitivity: estimate.sensitivity,
        serial_axial: [nominal.serial_axial(), estimate.serial_axial],
        tip_error_percent: [nominal_mean, estimate.tip_error_percent],
        max_tip_error_percent: [nominal_max, estimate.max_tip_error_percent],
        observations: estimate.observations,
        registration_poses: articulated.len(),
        reference_pose: reference.is_some(),
        skipped,
        registration_residual_deg: [
            frame.axis_residual.to_degrees(),
            frame.direction_residual.to_degrees(),
        ],
        rotation: std::array::from_fn(|r| std::array::from_fn(|c| m[(r, c)])),
        tendons,
    })
}

fn print_table(r: &Report) {
    println!(
        "Tensionless model estimation (paper, Table I): {} poses, {} registration poses, {}",
        r.observations,
        r.registration_poses,
        if r.reference_pose {
            "relaxed reference pose found (ε0 measured)"
        } else {
            "no relaxed reference pose (ε0 not measured: Ka0 and Ka1 keep their nominal values)"
        }
    );
    println!(
        "registration residuals: axis {:.2}°, bending directions {:.2}°",
        r.registration_residual_deg[0], r.registration_residual_deg[1]
    );
    println!();
    println!(
        "{:<34} {:>12} {:>12} {:>12} {:>12}",
        "", "nominal", "estimated", "± std. err.", "sensitivity"
    );
    let names = [
        "Bending stiffness Kx (N·mm²)",
        "Bending stiffness Kz (N·mm²)",
        "Axial stiffness Ka0 (N/ε)",
        "Axial stiffness Ka1 (N/ε)",
    ];
    for (j, name) in names.iter().enumerate() {
        if r.estimated_from_data[j] {
            println!(
                "{name:<34} {:>12.1} {:>12.1} {:>12.1} {:>11.1}×",
                r.nominal[j], r.estimated[j], r.standard_error[j], r.sensitivity[j]
            );
        } else {
            println!("{name:<34} {:>12.1} {:>12}", r.nominal[j], "not measured");
        }
    }
    println!(
        "{:<34} {:>12.1} {:>12.1}",
        "Axial stiffness Ka, serial (N/ε)", r.serial_axial[0], r.serial_axial[1]
    );
    println!(
        "{:<34} {:>11.2}% {:>11.2}%",
        "Tip position error (mean, % of L1)", r.tip_error_percent[0], r.tip_error_percent[1]
    );
    println!(
        "{:<34} {:>11.2}% {:>11.2}%",
        "Tip position error (max, % of L1)", r.max_tip_error_percent[0], r.max_tip_error_percent[1]
    );
    println!(
        "\nsensitivity: relative stiffness error per relative error of the sensed κ or ε (stiff \
         tendons amplify sensing bias)"
    );
    if let Some(t) = &r.tendons {
        match &t.refused {
            Some(why) => println!("tendon positions: not estimated: {why}"),
            None => {
                println!(
                    "tendon positions (mm, section frame; condition {:.1e}, rms {:.3} mm):",
                    t.condition, t.rms_mm
                );
                for (i, (p, e)) in t.positions.iter().zip(&t.standard_error).enumerate() {
                    println!(
                        "  tendon {i}: dx {:.3} ± {:.3}, dz {:.3} ± {:.3}",
                        p[0], e[0], p[1], e[1]
                    );
                }
            }
        }
    }
    for s in &r.skipped {
        println!("skipped {s}");
    }
}
