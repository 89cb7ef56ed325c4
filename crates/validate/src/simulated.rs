//! Both validation experiments on the simulated rig, with known truth:
//!
//! - **Accuracy**: a ball-ended stylus (a straight rod, radius 3 mm) enters the volume through
//!   its bottom face at random places and tilts (up to 35°); the sensed point is the tracked
//!   tip, the reference is the true ball centre as a digitizer would report it — in its own
//!   frame (an unknown random rigid transform) with Gaussian noise.
//! - **Precision**: a rigid S-bent rod ("machined" like the paper's aluminium object: a 120 mm
//!   lead, then two 70 mm arcs of opposite 60 mm radius) with three bands, moved to random
//!   poses through the bottom face; each sensed shape is compared with the known one.

use std::path::Path;

use flexshape_camera::nalgebra::{Matrix3, Point3, Quaternion, Rotation3, UnitQuaternion, Vector3};
use flexshape_curve::{Frame, Polyline};
use flexshape_fit::{FitSettings, Method};
use flexshape_record::{RecordStatus, TrackRecord};
use flexshape_recording::{RightBounds, TruthErrors};
use flexshape_register::RigidTransform;
use flexshape_silhouette::BackgroundModel;
use flexshape_sim::{
    BAND_ALBEDO, BODY_ALBEDO, Catheter, CatheterPose, Gloss, Scene, SimConfig, Simulator, Tube,
};
use flexshape_track::{Pipeline, Tracked};
use rand::rngs::Xoshiro256PlusPlus;
use rand::{RngExt, SeedableRng};
use rand_distr::{Distribution, Normal, StandardNormal};
use serde::Serialize;

use crate::{
    AccuracyReport, KnownShape, PoseComparison, PrecisionReport, ValidateError, accuracy,
    compare_shape, precision,
};

/// What to simulate.
#[derive(Debug, Clone, PartialEq)]
pub struct Experiments {
    /// Seed of poses, instrument frame and noise.
    pub seed: u64,
    /// Stylus poses (the paper: 25).
    pub probe_poses: usize,
    /// Object poses (the paper: 4).
    pub object_poses: usize,
    /// The reference instrument's noise per axis, mm (a MicroScribe G2 is specified to
    /// 0.23 mm).
    pub reference_noise_mm: f64,
    /// How the centerline is found: fitted to the images (the default) or the hull's.
    pub method: Method,
}

impl Default for Experiments {
    fn default() -> Self {
        Experiments {
            seed: 1,
            probe_poses: 25,
            object_poses: 8,
            reference_noise_mm: 0.1,
            method: Method::Fit,
        }
    }
}

/// The accuracy experiment's data and result.
#[derive(Debug, Clone, Serialize)]
pub struct AccuracyRun {
    /// Sensed tips, world mm.
    pub sensed: Vec<[f64; 3]>,
    /// The instrument's readings, its own frame, mm.
    pub reference: Vec<[f64; 3]>,
    /// The true ball centres, world mm.
    pub truth: Vec<[f64; 3]>,
    /// Registration and errors.
    pub report: AccuracyReport,
    /// Poses that gave no tip, with why.
    pub skipped: Vec<String>,
    /// Every pose's tracking record.
    pub records: Vec<TrackRecord>,
    /// The records held against the truth.
    pub judged: Judged,
}

/// The precision experiment's data and result.
#[derive(Debug, Clone, Serialize)]
pub struct PrecisionRun {
    /// Per pose: the sensed centerline (world mm).
    pub sensed: Vec<Vec<[f64; 3]>>,
    /// Per pose: the sensed band centres.
    pub sensed_marks: Vec<Vec<[f64; 3]>>,
    /// Per pose: the comparison with the known shape.
    pub poses: Vec<PoseComparison>,
    /// The first pose's carved voxel centres (for the Fig. 6a plot).
    pub cloud: Vec<[f64; 3]>,
    /// Pooled figures.
    pub report: PrecisionReport,
    /// Poses that gave no usable shape, with why.
    pub skipped: Vec<String>,
    /// Every pose's tracking record.
    pub records: Vec<TrackRecord>,
    /// The records held against the truth.
    pub judged: Judged,
}

/// Records held against the simulator's truth ([`RightBounds`]): what a status says of a
/// shape and what the truth says of it.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize)]
pub struct Judged {
    /// Records whose status says the shape is right that the truth says is not.
    pub said_right_but_off: usize,
    /// Records refused (any status but `ok`) whose shape the truth says is right.
    pub refused_but_right: usize,
}

impl Judged {
    /// Counts one record: whether its status said `ok`, and whether its shape is right by
    /// the truth (`None`: it carries none).
    fn count(&mut self, said_ok: bool, right: Option<bool>) {
        match (said_ok, right) {
            (true, Some(true)) | (false, None | Some(false)) => {}
            (true, None | Some(false)) => self.said_right_but_off += 1,
            (false, Some(true)) => self.refused_but_right += 1,
        }
    }

    /// Both runs' counts together.
    pub fn and(self, other: Judged) -> Judged {
        Judged {
            said_right_but_off: self.said_right_but_off + other.said_right_but_off,
            refused_but_right: self.refused_but_right + other.refused_but_right,
        }
    }
}

/// The simulated rig and its sensing chain.
struct Bench {
    sim: Simulator,
    pipeline: Pipeline,
}

impl Bench {
    fn new(e: &Experiments, expected_bands: usize) -> Result<Self, ValidateError> {
        let seed = e.seed;
        let defaults = SimConfig::default();
        let config = SimConfig {
            seed,
            render: flexshape_sim::RenderSettings {
                seed,
                ..defaults.render.clone()
            },
            ..defaults
        };
        let sim = Simulator::new(config).map_err(|e| ValidateError::Pipeline(e.to_string()))?;
        let backgrounds = BackgroundModel::each(&sim.backgrounds())
            .map_err(|e| ValidateError::Pipeline(e.to_string()))?;
        let rig = sim.rig();
        let pipeline = Pipeline::new(rig, &backgrounds, &rig.volume)
            .map_err(|e| ValidateError::Pipeline(e.to_string()))?;
        let mut shape = pipeline.shape_settings().clone();
        shape.expected_bands = expected_bands;
        shape.sections.clear();
        shape.arc_fit.enabled = false;
        let fit = FitSettings {
            method: e.method,
            ..pipeline.fit_settings().clone()
        };
        let pipeline = pipeline
            .with_shape_settings(shape)
            .and_then(|p| p.with_fit_settings(fit))
            .map_err(|e| ValidateError::Pipeline(e.to_string()))?;
        Ok(Bench { sim, pipeline })
    }

    /// Whether `record`'s shape is right by `truth` (the true centerline, world mm, proximal
    /// to distal), [`RightBounds::default`]; `None` when it carries none.
    fn right(&self, record: &TrackRecord, truth: &[Point3<f64>]) -> Option<bool> {
        let volume = &self.sim.rig().volume;
        let truth: Vec<[f64; 3]> = truth.iter().map(|p| [p.x, p.y, p.z]).collect();
        let errors = TruthErrors::between(&truth, &record.centerline, record.tip?, |p| {
            volume.contains(p)
        })?;
        Some(errors.within(RightBounds::default()))
    }

    fn track(&self, scene: &Scene, frame: u64) -> Result<(TrackRecord, Tracked), ValidateError> {
        let views = self.sim.render_scene(scene, frame);
        let images: Vec<_> = views.iter().map(|v| &v.image).collect();
        let tracked = self
            .pipeline
            .process(&images)
            .map_err(|e| ValidateError::Pipeline(format!("pose {frame}: {e}")))?;
        Ok((tracked.record(frame), tracked))
    }
}

/// What a refused pose's line says when the truth says its shape is right.
fn right_note(right: Option<bool>) -> &'static str {
    if right == Some(true) {
        " (right by the truth: refused though right)"
    } else {
        ""
    }
}

/// `line`'s points every `step` mm or closer, its ends included.
fn sampled(line: &Polyline, step: f64) -> Vec<Point3<f64>> {
    let n = (line.length() / step).ceil().max(1.0) as usize;
    (0..=n)
        .map(|i| line.point_at(line.length() * i as f64 / n as f64))
        .collect()
}

/// Half the default volume's edge less a margin, mm.
const INSIDE: f64 = 118.0;
/// The volume's bottom face, mm.
const BOTTOM: f64 = -128.0;

/// The accuracy experiment (paper, Section III-A, Fig. 5).
pub fn accuracy_experiment(e: &Experiments) -> Result<AccuracyRun, ValidateError> {
    let bench = Bench::new(e, 0)?;
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(e.seed ^ 0xACC0_AC55);
    let (mut sensed, mut truth, mut skipped) = (Vec::new(), Vec::new(), Vec::new());
    let mut records = Vec::new();
    let mut judged = Judged::default();
    for k in 0..e.probe_poses {
        let (entry, dir, tip) = loop {
            let entry = Point3::new(
                rng.random_range(-50.0..50.0),
                rng.random_range(-50.0..50.0),
                BOTTOM,
            );
            let dir = tilted(&mut rng, 35f64.to_radians());
            let tip = entry + dir * rng.random_range(100.0..200.0);
            if within(&tip) && tip.z < INSIDE - 10.0 {
                break (entry, dir, tip);
            }
        };
        let line = Polyline::new(
            (0..=((tip - entry).norm() as usize + 80))
                .map(|i| entry - dir * 80.0 + dir * i as f64)
                .chain(std::iter::once(tip))
                .collect(),
        )
        .map_err(|e| ValidateError::Pipeline(e.to_string()))?;
        let true_line = sampled(&line, 0.5);
        let scene = Scene {
            tubes: vec![Tube {
                centerline: line,
                radius: 3.0,
                steps: Vec::new(),
                bands: Vec::new(),
                albedo: BODY_ALBEDO,
                band_albedo: BAND_ALBEDO,
                gloss: Gloss::default(),
                outer: None,
            }],
            occluders: Vec::new(),
        };
        let (record, _) = bench.track(&scene, k as u64)?;
        let said_ok = record.status == RecordStatus::Ok;
        let right = bench.right(&record, &true_line);
        judged.count(said_ok, right);
        match (said_ok, record.tip) {
            (true, Some(t)) => {
                sensed.push(Point3::from(t));
                truth.push(tip);
            }
            _ => skipped.push(format!(
                "pose {k}: {} {}{}",
                record.status,
                record.reason.clone().unwrap_or_default(),
                right_note(right)
            )),
        }
        records.push(record);
    }
    // The instrument's frame and noise.
    let instrument = RigidTransform {
        rotation: random_rotation(&mut rng),
        translation: Vector3::new(
            rng.random_range(-300.0..300.0),
            rng.random_range(-300.0..300.0),
            rng.random_range(-300.0..300.0),
        ),
    }
    .inverse();
    let noise = Normal::new(0.0, e.reference_noise_mm.max(0.0))
        .map_err(|err| ValidateError::Input(err.to_string()))?;
    let reference: Vec<Point3<f64>> = truth
        .iter()
        .map(|p| {
            instrument.apply(p)
                + Vector3::new(
                    noise.sample(&mut rng),
                    noise.sample(&mut rng),
                    noise.sample(&mut rng),
                )
        })
        .collect();
    let report = accuracy(&sensed, &reference)?;
    let xyz = |v: &[Point3<f64>]| v.iter().map(|p| [p.x, p.y, p.z]).collect();
    Ok(AccuracyRun {
        sensed: xyz(&sensed),
        reference: xyz(&reference),
        truth: xyz(&truth),
        report,
        skipped,
        records,
        judged,
    })
}

/// The machined S-bent object: its geometry and pose.
fn object(base: Frame) -> (Catheter, CatheterPose) {
    let catheter = Catheter {
        radius: 3.0,
        base,
        proximal_length: 120.0,
        bend_length: 140.0,
        band_width: 5.0,
        extra_bands: vec![70.0],
        radius_steps: Vec::new(),
        ..Catheter::default()
    };
    let k = 1.0 / 60.0;
    let pose = CatheterPose::two_section(&catheter, [k, 0.0], [-k, 0.0], 70.0, [0.0, 0.0], 0.0);
    (catheter, pose)
}

/// The object's known shape in its own frame (its base at the origin, lead along +y).
pub fn known_object() -> Result<KnownShape, ValidateError> {
    let (catheter, pose) = object(Frame::identity());
    let state = catheter
        .state(&pose)
        .map_err(|e| ValidateError::Pipeline(e.to_string()))?;
    let centerline = state
        .chain
        .polyline(0.5)
        .map_err(|e| ValidateError::Pipeline(e.to_string()))?;
    let marks = state
        .band_centres
        .iter()
        .map(|&s| state.chain.frame_at(s).position)
        .collect();
    Ok(KnownShape { centerline, marks })
}

/// The precision experiment (paper, Section III-B, Fig. 6).
pub fn precision_experiment(e: &Experiments) -> Result<PrecisionRun, ValidateError> {
    let known = known_object()?;
    let bench = Bench::new(e, known.marks.len())?;
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(e.seed ^ 0x0B1E_C7ED);
    let mut run = PrecisionRun {
        sensed: Vec::new(),
        sensed_marks: Vec::new(),
        poses: Vec::new(),
        cloud: Vec::new(),
        report: precision(&[]),
        skipped: Vec::new(),
        records: Vec::new(),
        judged: Judged::default(),
    };
    for k in 0..e.object_poses {
        let (catheter, pose) = loop {
            // Lead along the tilted direction, rolled about it; the bend starts 60–100 mm
            // below the centre.
            let dir = tilted(&mut rng, 25f64.to_radians());
            let roll = rng.random_range(0.0..std::f64::consts::TAU);
            let lift = Rotation3::rotation_between(&Vector3::z(), &dir)
                .unwrap_or_else(Rotation3::identity);
            let axes = Matrix3::from_columns(&[Vector3::x(), Vector3::z(), -Vector3::y()]);
            let rotation = lift
                * Rotation3::from_axis_angle(&Vector3::z_axis(), roll)
                * Rotation3::from_matrix_unchecked(axes);
            let bend_base = Point3::new(
                rng.random_range(-30.0..30.0),
                rng.random_range(-30.0..30.0),
                rng.random_range(-100.0..-60.0),
            );
            let base = Frame {
                position: bend_base - dir * 120.0,
                rotation,
            };
            let (catheter, pose) = object(base);
            let state = catheter
                .state(&pose)
                .map_err(|e| ValidateError::Pipeline(e.to_string()))?;
            let inside = state
                .chain
                .sample_frames(2.0)
                .iter()
                .all(|(_, f)| within(&f.position));
            if inside {
                break (catheter, pose);
            }
        };
        let state = catheter
            .state(&pose)
            .map_err(|e| ValidateError::Pipeline(e.to_string()))?;
        let scene = Scene {
            tubes: vec![
                catheter
                    .tube(&state)
                    .map_err(|e| ValidateError::Pipeline(e.to_string()))?,
            ],
            occluders: Vec::new(),
        };
        let (record, tracked) = bench.track(&scene, k as u64)?;
        run.records.push(record.clone());
        let truth: Vec<Point3<f64>> = state
            .chain
            .sample_frames(0.5)
            .iter()
            .map(|(_, f)| f.position)
            .collect();
        let right = bench.right(&record, &truth);
        run.judged.count(record.status.is_ok(), right);
        if !record.status.is_ok() {
            run.skipped.push(format!(
                "pose {k}: {} {}{}",
                record.status,
                record.reason.unwrap_or_default(),
                right_note(right)
            ));
            continue;
        }
        let curve = Polyline::new(record.centerline.iter().map(|p| Point3::from(*p)).collect())
            .map_err(|e| ValidateError::Pipeline(e.to_string()))?;
        let marks: Vec<Point3<f64>> = record
            .bands
            .iter()
            .map(|b| Point3::from(b.position))
            .collect();
        run.poses.push(compare_shape(&known, &curve, &marks)?);
        if run.cloud.is_empty() {
            run.cloud = tracked.occupancy.centres();
        }
        run.sensed.push(record.centerline);
        run.sensed_marks
            .push(marks.iter().map(|p| [p.x, p.y, p.z]).collect());
    }
    if run.poses.is_empty() {
        return Err(ValidateError::Input(format!(
            "no pose gave a shape: {}",
            run.skipped.join("; ")
        )));
    }
    run.report = precision(&run.poses);
    Ok(run)
}

/// Inside the volume away from its side and top faces, or below it (where the lead enters).
fn within(p: &Point3<f64>) -> bool {
    p.z < BOTTOM || (p.x.abs() < INSIDE && p.y.abs() < INSIDE && p.z < INSIDE)
}

/// A unit direction within `max_tilt` of +z, area-uniform on the cap.
fn tilted(rng: &mut Xoshiro256PlusPlus, max_tilt: f64) -> Vector3<f64> {
    let cos = 1.0 - rng.random::<f64>() * (1.0 - max_tilt.cos());
    let sin = (1.0 - cos * cos).sqrt();
    let phi = rng.random_range(0.0..std::f64::consts::TAU);
    Vector3::new(sin * phi.cos(), sin * phi.sin(), cos)
}

/// A uniformly random rotation.
fn random_rotation(rng: &mut Xoshiro256PlusPlus) -> Rotation3<f64> {
    let mut n = || -> f64 { rng.sample(StandardNormal) };
    let q = Quaternion::new(n(), n(), n(), n());
    UnitQuaternion::from_quaternion(q).to_rotation_matrix()
}

/// The experiments' inputs in the tools' formats, so `validate points` and `validate shape`
/// can be run on them: `stylus_tracks.jsonl` + `stylus_reference.csv`, `object_tracks.jsonl`
/// + `object_known.csv` + `object_marks.csv`.
pub fn write_data(dir: &Path, acc: &AccuracyRun, pre: &PrecisionRun) -> Result<(), ValidateError> {
    let write = |name: &str, text: String| {
        let path = dir.join(name);
        std::fs::write(&path, text)
            .map_err(|e| ValidateError::Input(format!("cannot write {}: {e}", path.display())))
    };
    let jsonl = |records: &[TrackRecord]| -> Result<String, ValidateError> {
        let mut out = String::new();
        for r in records {
            let line = serde_json::to_string(r)
                .map_err(|e| ValidateError::Input(format!("cannot encode a record: {e}")))?;
            out.push_str(&line);
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
