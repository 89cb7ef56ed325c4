//! Simulated data to plan a rig and rehearse a pipeline (`flexshape simulate`): a recording
//! of the catheter sweeping, moving or driven through a model experiment, and a calibration
//! session of target images seen by the rig's cameras, each with its ground truth.

use std::ops::ControlFlow;
use std::path::{Path, PathBuf};

use flexshape_calib::{Board, Pattern};
use flexshape_model::{CommandedPose, ExperimentPlan, Model, Role};
use flexshape_recording::{PoseRole, RecordingWriter, Truth};
use flexshape_sim::{
    BoardRenderer, CatheterPose, FreeRunning, PrintedBoard, PrintedMarkers, PrintedPattern,
    SimConfig, SimFrame, Simulator, calibration_views,
};

use flexshape_silhouette::BackgroundModel;
use flexshape_track::Pipeline;

use crate::LabError;

/// What a simulated recording shows.
#[derive(Debug, Clone)]
pub enum Scenario {
    /// `frames` poses sweeping the workspace (the bending plane turning while the bend
    /// swings).
    Sweep {
        /// Frames.
        frames: usize,
    },
    /// A smooth motion filmed at `rate_hz` (timestamps written).
    Motion {
        /// Frames.
        frames: usize,
        /// Frame rate, frames per second.
        rate_hz: f64,
        /// Share of the frame interval the shutter is open, 0–1: what moves meanwhile is
        /// blurred along its path (rendered at [`EXPOSURE_INSTANTS`] instants and averaged).
        /// 0 films each frame at its instant.
        shutter: f64,
        /// Cameras that are not triggered together: each captures frame n at its own time
        /// (written to `timestamps/<cam>.csv`; the truth and `timestamps.csv` keep n / rate).
        /// `None`: every camera at the frame's instant.
        clocks: Option<FreeRunning>,
        /// The motion's speed against the simulator's own (1; 0.2 at 30 frames/s moves the
        /// tip up to about 1 mm a frame, as at 150 frames/s at 1): an instrument that moves
        /// slower or faster than the default motion.
        pace: f64,
    },
    /// The paper's experiment for `model` (reference, registration and workspace poses), the
    /// catheter made as the model describes it; the commands are written beside the frames.
    /// Made by [`Scenario::experiment`].
    Experiment {
        /// The manipulator model.
        model: Box<Model>,
        /// The planned commands, one per frame.
        commands: Vec<CommandedPose>,
    },
}

/// Instants a frame is rendered at while its shutter is open: at the simulator's fastest
/// motion filmed at 10 frames/s with the shutter open half the interval, the tip moves about
/// 0.5 mm between two (under a pixel on the default rig), so the copies blur into one. Odd, so
/// that the middle one, whose shape is the truth, is the frame's instant.
pub const EXPOSURE_INSTANTS: usize = 17;

impl Scenario {
    /// The experiment `plan` for `model`, planned once here.
    pub fn experiment(model: Model, plan: &ExperimentPlan) -> Result<Self, LabError> {
        let commands = flexshape_model::experiment(&model, plan)
            .map_err(LabError::model("cannot plan the experiment"))?;
        Ok(Scenario::Experiment {
            model: Box::new(model),
            commands,
        })
    }

    /// The frames it films.
    pub fn frames(&self) -> usize {
        match self {
            Scenario::Sweep { frames } | Scenario::Motion { frames, .. } => *frames,
            Scenario::Experiment { commands, .. } => commands.len(),
        }
    }
}

/// The sensing chain set up for a simulated rig: its rig (with the `[processing]` describing
/// its catheter) and its backgrounds as captured, carving the rig's volume.
pub fn chain(sim: &Simulator) -> Result<Pipeline, LabError> {
    let backgrounds = BackgroundModel::each(&sim.backgrounds())
        .map_err(|e| LabError::data("the simulated backgrounds", e.to_string()))?;
    let rig = sim.rig();
    Ok(Pipeline::new(rig, &backgrounds, &rig.volume)?)
}

/// Writes the recording of `scenario` on the rig of `config` into `out` (an existing one
/// only with `overwrite`); `on_frame` sees each frame as it is written and may stop early.
/// Returns the frames written and the frames planned.
pub fn simulate_recording(
    mut config: SimConfig,
    scenario: &Scenario,
    out: &Path,
    overwrite: bool,
    on_frame: impl FnMut(&SimFrame) -> ControlFlow<()>,
) -> Result<(u64, usize), LabError> {
    if let Scenario::Experiment { model, .. } = scenario {
        config.catheter = flexshape_steer::catheter_for(&config.catheter, model.params());
    }
    let sim = Simulator::new(config).map_err(LabError::simulator)?;
    let (poses, commands) = match scenario {
        Scenario::Sweep { frames } => (sim.sweep(*frames), Vec::new()),
        Scenario::Motion {
            frames,
            rate_hz,
            shutter,
            clocks: Some(clocks),
            pace,
        } => {
            let steps = if *shutter > 0.0 { EXPOSURE_INSTANTS } else { 1 };
            let paced = FreeRunning {
                phases_s: clocks.phases_s.iter().map(|p| p * pace).collect(),
                jitter_s: clocks.jitter_s * pace,
            };
            let motion_hz = motion_rate(*rate_hz, *pace);
            let (exposures, times): (Vec<_>, Vec<_>) = sim
                .free_running_exposures(*frames, motion_hz, *shutter, steps, &paced)
                .into_iter()
                .unzip();
            let truth_poses = sim.motion(*frames, motion_hz);
            let written = sim
                .write_free_running_recording(out, &exposures, &truth_poses, overwrite, on_frame)
                .map_err(write_error(out))?;
            write_timestamps(out, written, *rate_hz)?;
            let writer = RecordingWriter::reopen(out);
            for (k, cam) in sim.rig().cameras.iter().enumerate() {
                let own: Vec<(u64, f64)> = (0..written)
                    .map(|n| (n, times[n as usize][k] / pace))
                    .collect();
                writer
                    .write_camera_timestamps(&cam.name, &own)
                    .map_err(|e| LabError::Write {
                        path: out.to_path_buf(),
                        reason: format!("camera {}'s timestamps: {e}", cam.name),
                    })?;
            }
            return Ok((written, exposures.len()));
        }
        Scenario::Motion {
            frames,
            rate_hz,
            shutter,
            pace,
            ..
        } if *shutter > 0.0 => {
            let exposures = sim.motion_exposures(
                *frames,
                motion_rate(*rate_hz, *pace),
                *shutter,
                EXPOSURE_INSTANTS,
            );
            let written = sim
                .write_exposed_recording(out, &exposures, overwrite, on_frame)
                .map_err(write_error(out))?;
            write_timestamps(out, written, *rate_hz)?;
            return Ok((written, exposures.len()));
        }
        Scenario::Motion {
            frames,
            rate_hz,
            pace,
            ..
        } => (
            sim.motion(*frames, motion_rate(*rate_hz, *pace)),
            Vec::new(),
        ),
        Scenario::Experiment { commands, .. } => {
            let catheter = &sim.config().catheter;
            commands
                .iter()
                .map(|c| {
                    let q = c.q;
                    let pose = CatheterPose::arc(catheter, [q[0], q[1]], [q[2], q[3]], 0.0);
                    let role = match c.role {
                        Role::Reference => PoseRole::Reference,
                        Role::Register => PoseRole::Register,
                        Role::Pose => PoseRole::Pose,
                    };
                    (pose, (c.y.iter().copied().collect(), role))
                })
                .unzip()
        }
    };
    let written = sim
        .write_commanded_recording(out, &poses, &commands, overwrite, on_frame)
        .map_err(write_error(out))?;
    if let Scenario::Motion { rate_hz, .. } = scenario {
        write_timestamps(out, written, *rate_hz)?;
    }
    Ok((written, poses.len()))
}

/// As [`simulate_recording`], masks instead of frames: every camera's mask of the catheter's
/// whole centerline drawn as a line `width_px` wide ([`Simulator::write_drawn_mask_recording`]),
/// as another tool's fixed-width masks or a hand-drawn line give them, with the truth; the
/// rig claims no marker bands. A model experiment is not drawn (its commands need the frames'
/// tendon displacements filmed). `on_frame` sees each frame's truth as it is written.
pub fn simulate_drawn_masks(
    config: SimConfig,
    scenario: &Scenario,
    width_px: f64,
    out: &Path,
    overwrite: bool,
    on_frame: impl FnMut(&Truth) -> ControlFlow<()>,
) -> Result<(u64, usize), LabError> {
    let sim = Simulator::new(config).map_err(LabError::simulator)?;
    let (poses, rate_hz) = match scenario {
        Scenario::Sweep { frames } => (sim.sweep(*frames), None),
        Scenario::Motion {
            frames,
            rate_hz,
            pace,
            ..
        } => (
            sim.motion(*frames, motion_rate(*rate_hz, *pace)),
            Some(*rate_hz),
        ),
        Scenario::Experiment { .. } => {
            return Err(LabError::data(
                "drawn masks",
                "a model experiment is filmed, not drawn: leave --model out",
            ));
        }
    };
    let written = sim
        .write_drawn_mask_recording(out, &poses, width_px, overwrite, on_frame)
        .map_err(write_error(out))?;
    if let Some(hz) = rate_hz {
        write_timestamps(out, written, hz)?;
    }
    Ok((written, poses.len()))
}

/// Writing the recording at `out` failed.
fn write_error(out: &Path) -> impl Fn(flexshape_sim::SimError) -> LabError + '_ {
    move |e| LabError::Write {
        path: out.to_path_buf(),
        reason: e.to_string(),
    }
}

/// The timestamps of `written` frames filmed at `rate_hz` into the recording at `out`: frame
/// n at n / rate_hz seconds (the middle of its exposure).
/// The rate the simulator's own motion is sampled at so that, filmed at `rate_hz`, it moves at
/// `pace` times its speed: frame n is the motion's instant `pace · n / rate_hz`, so every clock
/// of the film (phases, jitter, shutter) is scaled alike and the timestamps stay in real
/// seconds.
fn motion_rate(rate_hz: f64, pace: f64) -> f64 {
    rate_hz / pace.max(1e-9)
}

fn write_timestamps(out: &Path, written: u64, rate_hz: f64) -> Result<(), LabError> {
    let times: Vec<(u64, f64)> = (0..written).map(|n| (n, n as f64 / rate_hz)).collect();
    RecordingWriter::reopen(out)
        .write_timestamps(&times)
        .map_err(|e| LabError::Write {
            path: out.to_path_buf(),
            reason: format!("the timestamps: {e}"),
        })
}

/// A calibration session of target images, as a lab would take it.
#[derive(Debug, Clone, PartialEq)]
pub struct BoardSession {
    /// Views per camera with the board facing that camera.
    pub own: usize,
    /// Views per camera after the first that it shares with the first camera.
    pub shared: usize,
    /// Image noise, grey levels (1 σ).
    pub noise: f64,
    /// Seed of the board poses and the noise.
    pub seed: u64,
}

/// What [`simulate_boards`] wrote.
#[derive(Debug, Clone)]
pub struct BoardImages {
    /// Images written.
    pub images: usize,
    /// Each camera's name and image folder (`out/images/NAME`).
    pub folders: Vec<(String, PathBuf)>,
    /// The true rig (`out/truth/rig.toml`; the board poses beside it in `boards.json`).
    pub truth: PathBuf,
}

/// Renders `board` seen by the cameras of `config` in the views of `session` into
/// `out/images/CAMERA/VIEW.png`, with the true rig and board poses in `out/truth/`;
/// `on_image` is called after each image.
pub fn simulate_boards(
    config: &SimConfig,
    board: &Board,
    session: &BoardSession,
    out: &Path,
    mut on_image: impl FnMut(),
) -> Result<BoardImages, LabError> {
    let printed = printed(board)?;
    let rig = config.rig.true_rig().map_err(LabError::simulator)?;
    let cameras: Vec<_> = rig.cameras.iter().map(|c| c.camera.clone()).collect();
    let views = calibration_views(
        &cameras,
        &printed,
        session.own,
        session.shared,
        session.seed,
    );
    let renderers = cameras
        .iter()
        .map(|c| {
            BoardRenderer::new(c).ok_or_else(|| {
                LabError::data(
                    "the simulated rig",
                    "a camera's lens cannot be inverted over its image",
                )
            })
        })
        .collect::<Result<Vec<_>, _>>()?;
    let write_failed = |path: &Path, e: &dyn std::fmt::Display| LabError::Write {
        path: path.to_path_buf(),
        reason: e.to_string(),
    };
    let mut images = 0;
    for (i, view) in views.iter().enumerate() {
        for &k in &view.cameras {
            let dir = out.join("images").join(&rig.cameras[k].name);
            std::fs::create_dir_all(&dir).map_err(|e| write_failed(&dir, &e))?;
            let seed = session.seed ^ (i as u64 * 31 + k as u64);
            let img = renderers[k].render(&printed, &view.pose, session.noise, seed);
            let path = dir.join(format!("{}.png", view.name));
            img.save(&path).map_err(|e| write_failed(&path, &e))?;
            images += 1;
            on_image();
        }
    }
    let truth = out.join("truth").join("rig.toml");
    rig.save(&truth).map_err(|e| write_failed(&truth, &e))?;
    // The board poses (board → world: x_world = R·x_board + t, mm), per image name.
    let boards: Vec<serde_json::Value> = views
        .iter()
        .map(|v| {
            let m = v.pose.rotation.to_rotation_matrix();
            let rows: Vec<Vec<f64>> = (0..3).map(|r| (0..3).map(|c| m[(r, c)]).collect()).collect();
            serde_json::json!({
                "image": v.name,
                "rotation": rows,
                "translation": v.pose.translation.vector.as_slice(),
                "cameras": v.cameras.iter().map(|&k| rig.cameras[k].name.clone()).collect::<Vec<_>>(),
            })
        })
        .collect();
    let boards_path = out.join("truth").join("boards.json");
    let text = serde_json::to_string_pretty(&boards).map_err(|e| write_failed(&boards_path, &e))?;
    std::fs::write(&boards_path, text).map_err(|e| write_failed(&boards_path, &e))?;
    Ok(BoardImages {
        images,
        folders: rig
            .cameras
            .iter()
            .map(|c| (c.name.clone(), out.join("images").join(&c.name)))
            .collect(),
        truth,
    })
}

/// The printed board of a calibration target: circle dots half as wide as the distance to
/// their nearest neighbour.
fn printed(board: &Board) -> Result<PrintedBoard, LabError> {
    let pattern = match board.pattern {
        Pattern::Chessboard => PrintedPattern::Chessboard,
        Pattern::Charuco(m) => {
            PrintedPattern::Charuco(PrintedMarkers::new(m.side, m.dictionary).ok_or_else(|| {
                LabError::data(
                    "the board",
                    format!("dictionary {}: not known", m.dictionary),
                )
            })?)
        }
        Pattern::Circles { asymmetric } => PrintedPattern::Circles {
            asymmetric,
            diameter: board.square * if asymmetric { 0.7 } else { 0.5 },
        },
    };
    Ok(PrintedBoard {
        cols: board.cols,
        rows: board.rows,
        square: board.square,
        pattern,
    })
}
