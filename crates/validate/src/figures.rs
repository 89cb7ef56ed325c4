//! The figures of the validation experiments and of a tracking output (PNG + SVG), as
//! `flexshape validate` and `flexshape report` write them. Each function returns the files it
//! wrote; world mm.

use std::path::{Path, PathBuf};

use flexshape_curve::Section;
use flexshape_plot::{
    HistogramSeries, Mark, PALETTE, PlotError, Series3, histograms, orthographic_views,
};
use flexshape_record::{TrackArcFit, TrackRecord};

use crate::{AccuracyReport, PoseComparison, ValidateError};

impl From<PlotError> for ValidateError {
    fn from(e: PlotError) -> Self {
        ValidateError::Figure(e.to_string())
    }
}

/// `dir`, created if missing.
fn folder(dir: &Path) -> Result<(), ValidateError> {
    std::fs::create_dir_all(dir)
        .map_err(|e| ValidateError::Figure(format!("cannot create {}: {e}", dir.display())))
}

fn series(label: impl Into<String>, points: Vec<[f64; 3]>, mark: Mark, k: usize) -> Series3 {
    Series3 {
        label: label.into(),
        points,
        mark,
        colour: PALETTE[k % PALETTE.len()],
    }
}

fn per_axis(title: &str, errors: &[[f64; 3]], stem: &Path) -> Result<Vec<PathBuf>, ValidateError> {
    let series: Vec<HistogramSeries> = ["x", "y", "z"]
        .iter()
        .enumerate()
        .map(|(a, name)| HistogramSeries {
            label: format!("{name} error"),
            values: errors.iter().map(|e| e[a]).collect(),
            colour: PALETTE[a],
        })
        .collect();
    Ok(histograms(title, "error (mm)", &series, stem)?)
}

/// Fig. 5(b): sensed points and the registered reference, and the per-axis errors.
pub fn accuracy(
    dir: &Path,
    report: &AccuracyReport,
    sensed: &[[f64; 3]],
) -> Result<Vec<PathBuf>, ValidateError> {
    folder(dir)?;
    let mut files = orthographic_views(
        &format!(
            "Accuracy: sensed vs reference after registration (rms {:.2} / {:.2} / {:.2} mm)",
            report.rms_x, report.rms_y, report.rms_z
        ),
        &[
            series("sensed", sensed.to_vec(), Mark::Circles, 0),
            series(
                "reference (registered)",
                report.registered_reference.clone(),
                Mark::Crosses,
                1,
            ),
        ],
        &dir.join("accuracy"),
    )?;
    files.extend(per_axis(
        "Accuracy: per-axis errors",
        &report.error_vectors,
        &dir.join("accuracy_errors"),
    )?);
    Ok(files)
}

/// Fig. 6: the first pose's cloud with its curve, every pose against the registered known
/// shape, and the per-axis errors along the length.
pub fn precision(
    dir: &Path,
    poses: &[PoseComparison],
    sensed: &[Vec<[f64; 3]>],
    sensed_marks: &[Vec<[f64; 3]>],
    cloud: &[[f64; 3]],
) -> Result<Vec<PathBuf>, ValidateError> {
    folder(dir)?;
    let mut files = Vec::new();
    if !cloud.is_empty() && !sensed.is_empty() {
        files.extend(orthographic_views(
            "Precision: point cloud and fitted curve (first pose)",
            &[
                series("carved voxels", cloud.to_vec(), Mark::Dots, 5),
                series("fitted curve", sensed[0].clone(), Mark::Line, 0),
                series(
                    "bands",
                    sensed_marks.first().cloned().unwrap_or_default(),
                    Mark::Crosses,
                    2,
                ),
            ],
            &dir.join("precision_cloud"),
        )?);
    }
    let mut all = Vec::new();
    for (k, (p, s)) in poses.iter().zip(sensed).enumerate() {
        let label = |what: &str| {
            if k == 0 {
                what.to_string()
            } else {
                String::new()
            }
        };
        all.push(series(label("sensed"), s.clone(), Mark::Line, 0));
        all.push(series(
            label("known (registered)"),
            p.registered.clone(),
            Mark::Dashed,
            1,
        ));
        all.push(series(
            label("known marks"),
            p.registered_marks.clone(),
            Mark::Crosses,
            2,
        ));
    }
    files.extend(orthographic_views(
        "Precision: sensed shapes against the known shape",
        &all,
        &dir.join("precision_shapes"),
    )?);
    let errors: Vec<[f64; 3]> = poses
        .iter()
        .flat_map(|p| p.errors.iter().copied())
        .collect();
    files.extend(per_axis(
        "Precision: per-axis errors along the length",
        &errors,
        &dir.join("precision_errors"),
    )?);
    Ok(files)
}

/// Points of a circular-arc fit (1 mm apart), world mm: the constant-curvature section in the
/// plane of the base tangent (local y) and the bend direction (local z, where κx bends).
fn arc_points(fit: &TrackArcFit) -> Vec<[f64; 3]> {
    let section = Section {
        length: fit.length,
        kappa: [fit.curvature, 0.0],
        strain: 0.0,
    };
    let n = fit.length.max(1.0).ceil() as usize;
    (0..=n)
        .map(|i| {
            let p = section
                .local_frame(fit.length * i as f64 / n as f64)
                .position;
            std::array::from_fn(|c| {
                fit.base[c] + fit.base_tangent[c] * p.y + fit.bend_direction[c] * p.z
            })
        })
        .collect()
}

/// Figures of a tracking output: all shapes (Fig. 7b), arc fits against the curves (Fig. 11),
/// and the per-stage times.
pub fn report(dir: &Path, records: &[TrackRecord]) -> Result<Vec<PathBuf>, ValidateError> {
    folder(dir)?;
    let shaped: Vec<&TrackRecord> = records
        .iter()
        .filter(|r| !r.centerline.is_empty())
        .collect();
    if shaped.is_empty() {
        return Err(ValidateError::Input("no record has a shape to plot".into()));
    }
    let mut files = Vec::new();
    let mut shapes = Vec::new();
    for (k, r) in shaped.iter().enumerate() {
        shapes.push(series(
            format!("frame {}", r.frame),
            r.centerline.clone(),
            Mark::Line,
            k,
        ));
    }
    if shapes.len() > 8 {
        for s in &mut shapes {
            s.label.clear();
        }
    }
    shapes.push(series(
        "bands",
        shaped
            .iter()
            .flat_map(|r| r.bands.iter().map(|b| b.position))
            .collect(),
        Mark::Crosses,
        1,
    ));
    shapes.push(series(
        "tips",
        shaped.iter().filter_map(|r| r.tip).collect(),
        Mark::Circles,
        3,
    ));
    files.extend(orthographic_views(
        &format!("{} tracked shapes", shaped.len()),
        &shapes,
        &dir.join("shapes"),
    )?);
    let mut fits = Vec::new();
    for (k, r) in shaped.iter().enumerate() {
        if let Some(f) = &r.arc_fit {
            let first = k == 0;
            fits.push(series(
                if first { "sensed" } else { "" },
                r.centerline.clone(),
                Mark::Line,
                0,
            ));
            fits.push(series(
                if first { "circular arc" } else { "" },
                arc_points(f),
                Mark::Dashed,
                1,
            ));
        }
    }
    if !fits.is_empty() {
        files.extend(orthographic_views(
            "Sensed curves and their circular-arc fits",
            &fits,
            &dir.join("arc_fits"),
        )?);
    }
    let stages: Vec<HistogramSeries> = ["silhouettes", "carve", "bands", "shape", "fit"]
        .iter()
        .enumerate()
        .map(|(k, name)| HistogramSeries {
            label: format!("{name} (ms)"),
            values: shaped
                .iter()
                .map(|r| {
                    let t = &r.timings_ms;
                    [t.silhouettes, t.carve, t.bands, t.shape, t.fit][k]
                })
                .collect(),
            colour: PALETTE[k],
        })
        .collect();
    files.extend(histograms(
        "Time per stage",
        "ms",
        &stages,
        &dir.join("timings"),
    )?);
    Ok(files)
}
