//! Closed-loop steering on the simulated rig (the paper's future work): the catheter is posed
//! by its *true* model from the commanded tendon displacements, rendered by the simulated
//! cameras, sensed by the whole chain (silhouettes, hull, tube fitted to the images), and the
//! sensed shape is fed to [`TipController`], which steers the tip to targets while it learns
//! the stiffnesses online from the stream.
//!
//! Frames and units: targets and tips in the model frame at the bending base (+y along the
//! proximal axis), mm; the base frame is known (the catheter's mount), so no registration poses
//! are needed.
//!
//! ```no_run
//! use std::ops::ControlFlow;
//! use flexshape_model::ManipulatorParams;
//! use flexshape_sim::SimConfig;
//! use flexshape_steer::{SteerSettings, reachable_targets, steer};
//!
//! # fn main() -> Result<(), Box<dyn std::error::Error>> {
//! // The real catheter's bending stiffnesses are 30 % above what the controller assumes.
//! let nominal = ManipulatorParams::paper_like();
//! let mut truth = nominal.clone();
//! truth.stiffness.kx *= 1.3;
//! truth.stiffness.kz *= 1.3;
//! let targets = reachable_targets(&truth, 3, 0.002)?;
//! let (steps, learnt) = steer(&SimConfig::default(), &truth, &nominal, &targets,
//!     &SteerSettings::default(), |step| {
//!         println!("frame {}: tip {:?} mm from target {}", step.frame, step.sensed_error_mm,
//!             step.target_index);
//!         ControlFlow::Continue(())
//!     })?;
//! println!("{} frames; stiffnesses learnt: {learnt:?}", steps.len());
//! # Ok(())
//! # }
//! ```

mod report;

pub use report::SteerSummary;

use std::ops::ControlFlow;

use flexshape_curve::Frame;
use flexshape_model::nalgebra_types::{Point3, Vector3};
use flexshape_model::{
    ControlSettings, ManipulatorParams, Model, ModelError, SensedPose, SensorFrame, Stiffness,
    TipController, geometry, taut_command,
};
use flexshape_record::{RecordStatus, TrackRecord};
use flexshape_silhouette::BackgroundModel;
use flexshape_sim::{Catheter, CatheterPose, SimConfig, SimError, Simulator};
use flexshape_track::{Pipeline, TrackError, Tracked};
use image::RgbImage;
use serde::Serialize;
use thiserror::Error;

/// Why the loop could not run.
#[derive(Debug, Error)]
pub enum SteerError {
    /// The simulated rig or a frame.
    #[error("simulator: {0}")]
    Sim(#[from] SimError),
    /// The sensing chain.
    #[error("sensing: {0}")]
    Track(#[from] TrackError),
    /// The model or the controller.
    #[error("model: {0}")]
    Model(#[from] ModelError),
    /// A background model from the simulated empty scene.
    #[error("background: {0}")]
    Background(String),
    /// A figure could not be written.
    #[error("cannot write the figure to {0}")]
    Figure(String),
}

/// How the loop runs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SteerSettings {
    /// The controller's settings.
    pub control: ControlSettings,
    /// Frames spent on each target.
    pub steps_per_target: usize,
}

impl Default for SteerSettings {
    fn default() -> Self {
        SteerSettings {
            control: ControlSettings::default(),
            steps_per_target: 8,
        }
    }
}

/// One frame of the loop.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SteerStep {
    /// Frame number.
    pub frame: u64,
    /// Index of the target.
    pub target_index: usize,
    /// The target, model frame, mm.
    pub target: [f64; 3],
    /// The target in the world frame, mm: placed at the sensed bending base (at rest when the
    /// frame gave no shape).
    pub target_world: [f64; 3],
    /// The commanded tendon displacements, mm.
    pub y: Vec<f64>,
    /// The sensing chain's status for the frame.
    pub status: RecordStatus,
    /// The sensed tip, model frame, mm (when the frame gave a shape).
    pub sensed_tip: Option<[f64; 3]>,
    /// Its distance from the target, mm.
    pub sensed_error_mm: Option<f64>,
    /// The true tip's distance from the target, mm (the simulator's truth).
    pub true_error_mm: f64,
    /// The stiffnesses the controller used for this command.
    pub stiffness: [f64; 4],
    /// The curvatures `[κx, κz]` its model expected of the command, 1/mm.
    pub commanded_kappa: [f64; 2],
    /// The sensed curvatures `[κx, κz]` (the arc fit in the model frame), 1/mm.
    pub sensed_kappa: Option<[f64; 2]>,
}

/// The simulated catheter built as the model describes it: its proximal section `L0` long
/// (most of it below the volume) and its bending section `L1`, with the bending base where the
/// default catheter has it, so the model's `ε0` moves the bending base as on a real rig.
pub fn catheter_for(default: &Catheter, params: &ManipulatorParams) -> Catheter {
    let bend_base = default.base.position + default.base.tangent() * default.proximal_length;
    Catheter {
        proximal_length: params.proximal_length,
        bend_length: params.distal_length,
        base: Frame {
            position: bend_base - default.base.tangent() * params.proximal_length,
            rotation: default.base.rotation,
        },
        ..default.clone()
    }
}

/// The model frame of a catheter whose mount is known: its base frame's orientation, and the
/// bending base at rest as the origin of `ε0`.
pub fn known_frame(catheter: &Catheter) -> SensorFrame {
    SensorFrame {
        rotation: catheter.base.rotation,
        reference_base: Some(
            catheter.base.position + catheter.base.tangent() * catheter.proximal_length,
        ),
        axis_residual: 0.0,
        direction_residual: 0.0,
    }
}

/// What a tracking record says about the bending section (world frame), or why it cannot be
/// used: a right shape with a circular-arc fit, a band at the bending base and a tip.
pub fn sensed_pose(r: &TrackRecord) -> Result<SensedPose, String> {
    if !r.status.is_ok() {
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

/// `n` targets the catheter of `truth` can reach (model frame, mm): its own tips for bends
/// of 40°–100° in directions turning by the golden angle, at `preload` compression.
pub fn reachable_targets(
    truth: &ManipulatorParams,
    n: usize,
    preload: f64,
) -> Result<Vec<Point3<f64>>, ModelError> {
    let model = Model::new(truth.clone())?;
    let golden = std::f64::consts::TAU * (1.0 - (5f64.sqrt() - 1.0) / 2.0);
    (0..n)
        .map(|i| {
            let angle = (40.0 + 60.0 * ((i * 7) % 11) as f64 / 10.0).to_radians();
            let k = angle / truth.distal_length;
            let phi = golden * i as f64;
            let c = taut_command(&model, [k * phi.cos(), k * phi.sin()], preload)?;
            Ok(geometry::bend_tip(truth, &c.q))
        })
        .collect()
}

/// What the loop saw at one frame, for a live display.
pub struct SteerFrame<'a> {
    /// The sensing chain (its cameras and volume).
    pub pipeline: &'a Pipeline,
    /// The rendered images, one per camera in the rig's order.
    pub images: Vec<RgbImage>,
    /// What the chain made of them.
    pub tracked: Tracked,
    /// Its record.
    pub record: TrackRecord,
}

/// Steers the catheter of `truth` (what the simulator poses) to each of `targets` in turn
/// with a controller that starts from `nominal`, on the rig of `config` (its catheter's
/// section lengths taken from `truth`). `on_step` sees every frame and may stop the loop.
pub fn steer(
    config: &SimConfig,
    truth: &ManipulatorParams,
    nominal: &ManipulatorParams,
    targets: &[Point3<f64>],
    settings: &SteerSettings,
    mut on_step: impl FnMut(&SteerStep) -> ControlFlow<()>,
) -> Result<(Vec<SteerStep>, Option<Stiffness>), SteerError> {
    steer_with_frames(config, truth, nominal, targets, settings, |step, _| {
        on_step(step)
    })
}

/// As [`steer`], handing `on_step` each frame's images and tracking results too (taken, not
/// copied), e.g. for the live viewer.
pub fn steer_with_frames(
    config: &SimConfig,
    truth: &ManipulatorParams,
    nominal: &ManipulatorParams,
    targets: &[Point3<f64>],
    settings: &SteerSettings,
    mut on_step: impl FnMut(&SteerStep, SteerFrame<'_>) -> ControlFlow<()>,
) -> Result<(Vec<SteerStep>, Option<Stiffness>), SteerError> {
    let mut config = config.clone();
    config.catheter = catheter_for(&config.catheter, truth);
    let sim = Simulator::new(config)?;
    let backgrounds = BackgroundModel::each(&sim.backgrounds())
        .map_err(|e| SteerError::Background(e.to_string()))?;
    let rig = sim.rig();
    let pipeline = Pipeline::new(rig, &backgrounds, &rig.volume)?;
    let catheter = sim.config().catheter.clone();
    let frame_of = known_frame(&catheter);
    // The truth poses the catheter; the sensing side knows only the nominal model.
    let real = Model::new(truth.clone())?;
    let known = Model::new(nominal.clone())?;
    let Some(first) = targets.first() else {
        return Ok((Vec::new(), None));
    };
    let mut control = TipController::new(nominal, *first, settings.control)?;
    let mut steps = Vec::new();
    let mut sensed = None;
    let mut frame = 0u64;
    'targets: for (index, target) in targets.iter().enumerate() {
        control.set_target(*target);
        for _ in 0..settings.steps_per_target {
            let stiffness = control.stiffness().diagonal();
            let y = control.step(sensed.take())?;
            let q = real.forward(&y)?.q;
            let pose = CatheterPose::arc(&catheter, [q[0], q[1]], [q[2], q[3]], 0.0);
            let rendered = sim.render(frame, &pose)?;
            let images: Vec<RgbImage> = rendered.views.into_iter().map(|v| v.image).collect();
            let tracked = pipeline.process(&images.iter().collect::<Vec<_>>())?;
            let record = tracked.record(frame);
            let posed = sensed_pose(&record).ok();
            let base = posed
                .as_ref()
                .map(|s| s.base)
                .or(frame_of.reference_base)
                .unwrap_or_else(Point3::origin);
            let target_world = base + frame_of.rotation * target.coords;
            let observation = posed.map(|s| frame_of.observation(&known, &s, y.clone()));
            let sensed_tip = observation.as_ref().and_then(|o| o.tip);
            let true_tip = geometry::bend_tip(truth, &q);
            let step = SteerStep {
                frame,
                target_index: index,
                target: [target.x, target.y, target.z],
                target_world: [target_world.x, target_world.y, target_world.z],
                y: y.iter().copied().collect(),
                status: record.status.clone(),
                sensed_tip: sensed_tip.map(|t| [t.x, t.y, t.z]),
                sensed_error_mm: sensed_tip.map(|t| (t - target).norm()),
                true_error_mm: (true_tip - target).norm(),
                stiffness,
                commanded_kappa: control.commanded_kappa(),
                sensed_kappa: observation.as_ref().map(|o| [o.q[0], o.q[1]]),
            };
            sensed = observation;
            frame += 1;
            let seen = SteerFrame {
                pipeline: &pipeline,
                images,
                tracked,
                record,
            };
            let stop = on_step(&step, seen).is_break();
            steps.push(step);
            if stop {
                break 'targets;
            }
        }
    }
    Ok((steps, control.estimate().map(|e| e.stiffness)))
}

/// The tip's error over the frames (sensed and true, log scale), the curvature the
/// controller's model expected of each command against the sensed one, and the stiffnesses
/// the controller used, relative to the truth.
/// Written as `steer.png`/`.svg` in `dir` (created if missing); `truth` is the true `[Kx, Kz]`.
pub fn figure(
    dir: &std::path::Path,
    steps: &[SteerStep],
    truth: [f64; 2],
) -> Result<(), SteerError> {
    use flexshape_plot::{PALETTE, TimePanel, TimeSeries, timelines};
    let failed = |e: &dyn std::fmt::Display| SteerError::Figure(format!("{}: {e}", dir.display()));
    std::fs::create_dir_all(dir).map_err(|e| failed(&e))?;
    let line = |label: &str, k: usize, value: &dyn Fn(&SteerStep) -> f64| TimeSeries {
        label: label.into(),
        points: steps.iter().map(|s| (s.frame as f64, value(s))).collect(),
        colour: PALETTE[k],
    };
    let panels = [
        TimePanel {
            y_label: "tip error (mm)".into(),
            series: vec![
                line("sensed", 0, &|s| s.sensed_error_mm.unwrap_or(f64::NAN)),
                line("true", 1, &|s| s.true_error_mm),
            ],
            log: true,
        },
        TimePanel {
            y_label: "curvature |κ| (1/m)".into(),
            series: vec![
                line("commanded (model)", 4, &|s| {
                    1000.0 * s.commanded_kappa[0].hypot(s.commanded_kappa[1])
                }),
                line("sensed", 5, &|s| {
                    s.sensed_kappa
                        .map_or(f64::NAN, |k| 1000.0 * k[0].hypot(k[1]))
                }),
            ],
            log: false,
        },
        TimePanel {
            y_label: "stiffness used − truth (%)".into(),
            series: vec![
                line("Kx", 2, &|s| 100.0 * (s.stiffness[0] / truth[0] - 1.0)),
                line("Kz", 3, &|s| 100.0 * (s.stiffness[1] / truth[1] - 1.0)),
            ],
            log: false,
        },
    ];
    timelines(
        "Closed loop: the tip steered to targets, the stiffnesses learnt online",
        "frame",
        &panels,
        &dir.join("steer"),
    )
    .map_err(|e| failed(&e))?;
    Ok(())
}
