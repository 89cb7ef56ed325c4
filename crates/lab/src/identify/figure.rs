//! The paper's Fig. 10: sensed shapes against the fitted model's bending sections.

use std::path::Path;

use flexshape_curve::Section;
use flexshape_model::{Model, SensorFrame};
use flexshape_plot::{Mark, PALETTE, Series3, orthographic_views};

use super::ExperimentPose;
use crate::LabError;

/// The sensed curves against the model's bending sections, placed by the registration (base
/// at each frame's proximal band, orientation fixed), as `model_vs_sensed.png`/`.svg` in
/// `dir` (created if missing).
pub(super) fn model_vs_sensed(
    dir: &Path,
    model: &Model,
    frame: &SensorFrame,
    data: &[&ExperimentPose],
) -> Result<(), LabError> {
    let failed = |e: &dyn std::fmt::Display| LabError::Write {
        path: dir.join("model_vs_sensed.png"),
        reason: e.to_string(),
    };
    std::fs::create_dir_all(dir).map_err(|e| failed(&e))?;
    let p = model.params();
    let mut series = Vec::new();
    for (k, pose) in data.iter().enumerate() {
        let q = model
            .forward(&pose.y)
            .map_err(crate::LabError::model(format!("frame {}", pose.frame)))?
            .q;
        let section = Section {
            length: p.distal_length,
            kappa: [q[0], q[1]],
            strain: q[3],
        };
        let length = section.arc_length();
        let predicted: Vec<[f64; 3]> = (0..=length.ceil() as usize)
            .map(|i| {
                let local = section.local_frame((i as f64).min(length)).position;
                (pose.sensed.base + frame.rotation * local.coords).into()
            })
            .collect();
        let label = |s: &str| if k == 0 { s.to_string() } else { String::new() };
        series.push(Series3 {
            label: label("sensed"),
            points: pose.centerline.clone(),
            mark: Mark::Line,
            colour: PALETTE[0],
        });
        series.push(Series3 {
            label: label("model (fitted Km)"),
            points: predicted,
            mark: Mark::Dashed,
            colour: PALETTE[1],
        });
    }
    orthographic_views(
        "Sensed shapes against the model's prediction from the tendon displacements",
        &series,
        &dir.join("model_vs_sensed"),
    )
    .map_err(|e| failed(&e))?;
    Ok(())
}
