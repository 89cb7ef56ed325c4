//! A tracked experiment's data: each frame's commanded tendon displacements beside the
//! bending section the cameras sensed.

use std::collections::BTreeMap;
use std::ops::ControlFlow;
use std::path::Path;
use std::sync::atomic::AtomicBool;

use flexshape_model::nalgebra_types::DVector;
use flexshape_model::{Model, SensedPose};
use flexshape_record::TrackRecord;
use flexshape_recording::PoseRole;
use flexshape_track::{Processed, Recording};

use crate::LabError;

/// One commanded, sensed pose.
#[derive(Debug, Clone)]
pub struct ExperimentPose {
    /// The frame it was sensed in.
    pub frame: u64,
    /// Commanded tendon displacements, mm (one per tendon).
    pub y: DVector<f64>,
    /// Its role in the experiment, when the recording says.
    pub role: Option<PoseRole>,
    /// The sensed bending section (world frame).
    pub sensed: SensedPose,
    /// The tracked centerline, world mm.
    pub centerline: Vec<[f64; 3]>,
}

impl ExperimentPose {
    /// Whether this is the relaxed reference pose: marked so, or (unmarked) every tendon at
    /// zero.
    pub fn is_reference(&self) -> bool {
        match self.role {
            Some(r) => r == PoseRole::Reference,
            None => self.y.iter().all(|v| *v == 0.0),
        }
    }
}

/// A tracked experiment: the poses that can be used, and the frames that cannot, each with
/// why.
#[derive(Debug, Clone, Default)]
pub struct Experiment {
    /// Commanded poses with a usable sensed shape.
    pub poses: Vec<ExperimentPose>,
    /// Commanded frames left out (`frame N: why`).
    pub skipped: Vec<String>,
}

impl Experiment {
    /// The experiment in tracking `records` (pairs of line or frame index and record) read
    /// from `source`: each record's own tendon displacements, else the ones `logged` for its
    /// frame. Records without displacements are not part of it; none with any, or a count
    /// that is not the model's tendons, is an error naming the line.
    pub fn from_records(
        records: Vec<(usize, TrackRecord)>,
        logged: &BTreeMap<u64, Vec<f64>>,
        model: &Model,
        source: &Path,
    ) -> Result<Self, LabError> {
        let n = model.params().tendons.len();
        let mut out = Experiment::default();
        let mut commanded = 0;
        for (line, record) in records {
            let Some(y) = record
                .tendon_displacements
                .clone()
                .or_else(|| logged.get(&record.frame).cloned())
            else {
                continue;
            };
            commanded += 1;
            if y.len() != n {
                return Err(LabError::data(
                    format!("{} line {line}", source.display()),
                    format!(
                        "frame {} has {} tendon displacements but the model has {n} tendons",
                        record.frame,
                        y.len()
                    ),
                ));
            }
            match flexshape_steer::sensed_pose(&record) {
                Ok(sensed) => out.poses.push(ExperimentPose {
                    frame: record.frame,
                    y: DVector::from_vec(y),
                    role: record.role,
                    sensed,
                    centerline: record.centerline,
                }),
                Err(why) => out.skipped.push(format!("frame {}: {why}", record.frame)),
            }
        }
        if commanded == 0 {
            return Err(LabError::data(
                source.display(),
                "no record carries `tendon_displacements`; track a recording that has commands/ \
                 (e.g. from `flexshape simulate --model`), or give them per frame with \
                 --displacements FILE.csv",
            ));
        }
        Ok(out)
    }
}

/// Tendon displacements logged per frame: a CSV file of lines `frame,y0,…,y(N-1)` (mm) for
/// a model of `tendons` tendons.
pub fn read_displacements(
    path: &Path,
    tendons: usize,
) -> Result<BTreeMap<u64, Vec<f64>>, LabError> {
    let rows = flexshape_rig::files::read_csv_numbers(
        path,
        tendons + 1,
        &format!(
            "`frame,y0,…,y{}` ({} numbers: the model has {tendons} tendons)",
            tendons.saturating_sub(1),
            tendons + 1
        ),
    )?;
    let mut map = BTreeMap::new();
    for row in rows {
        let frame = row[0];
        if !(frame >= 0.0 && frame.fract() == 0.0) {
            return Err(LabError::data(
                path.display(),
                format!("frame {frame} is not a frame number"),
            ));
        }
        if map.insert(frame as u64, row[1..].to_vec()).is_some() {
            return Err(LabError::data(
                path.display(),
                format!("frame {frame} is given twice"),
            ));
        }
    }
    Ok(map)
}

/// The tracking records of `data`: a JSON Lines file from `flexshape track`, or a recording
/// folder, tracked here by `workers` threads until done or `stop` is set. Pairs of (line or
/// frame index, record).
pub fn records_of(
    data: &Path,
    workers: usize,
    stop: &AtomicBool,
) -> Result<Vec<(usize, TrackRecord)>, LabError> {
    if !data.is_dir() {
        return Ok(flexshape_record::read_records(data)?);
    }
    let read_as_recording = |e: &dyn std::fmt::Display| {
        LabError::data(
            data.display(),
            format!(
                "a folder is read as a recording (give a `flexshape track` JSON Lines file otherwise): {e}"
            ),
        )
    };
    let mut recording = Recording::open(data).map_err(|e| read_as_recording(&e))?;
    let pipeline = recording.pipeline()?;
    let mut records = Vec::new();
    let end = flexshape_track::run(
        &mut recording.source,
        &pipeline,
        workers,
        stop,
        |p: Processed| {
            records.push((records.len(), p.record()));
            ControlFlow::Continue(())
        },
    );
    if let Some(e) = end.input_error {
        return Err(LabError::data(
            data.display(),
            format!("the input broke after {} frames: {e}", records.len()),
        ));
    }
    if stop.load(std::sync::atomic::Ordering::Relaxed) {
        return Err(LabError::Interrupted {
            path: data.to_path_buf(),
        });
    }
    Ok(records)
}
