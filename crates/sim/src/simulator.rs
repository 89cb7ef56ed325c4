//! The whole simulated rig: cameras, catheter, occluders and renderer, producing frames with
//! ground truth and writing recordings.

use std::ops::ControlFlow;
use std::path::Path;

use flexshape_camera::Camera;
use flexshape_camera::nalgebra::Point3;
use flexshape_recording::{Command, PoseRole, RecordingWriter, Truth};
use flexshape_rig::{Occluded, Rig};
use image::RgbImage;
use rand::rngs::Xoshiro256PlusPlus;
use rand::{RngExt, SeedableRng};
use serde::{Deserialize, Serialize};

use crate::catheter::{Catheter, CatheterPose};
use crate::clocks::FreeRunning;
use crate::error::SimError;
use crate::render::{RenderSettings, Renderer, View};
use crate::rig::SimRigConfig;
use crate::scene::{OCCLUDER_ALBEDO, Occluder, Scene};
use crate::sequence;

/// Everything that defines a simulation.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct SimConfig {
    /// Cameras and working volume.
    pub rig: SimRigConfig,
    /// Image formation.
    pub render: RenderSettings,
    /// Catheter geometry.
    pub catheter: Catheter,
    /// Number of spherical occluders, each between one camera and the volume (outside the
    /// volume, so it hides part of that camera's view without touching the catheter).
    pub occluders: usize,
    /// Seed of the pose sequence and occluder placement.
    pub seed: u64,
}

/// One simulated frame: a view per camera and the truth.
#[derive(Debug, Clone)]
pub struct SimFrame {
    /// Rendered images and exact masks, one per camera in rig order.
    pub views: Vec<View>,
    /// Ground truth.
    pub truth: Truth,
}

/// A ready-to-render simulated rig.
pub struct Simulator {
    config: SimConfig,
    rig: Rig,
    renderer: Renderer,
    occluders: Vec<Occluder>,
}

impl Simulator {
    /// Builds the rig and precomputes the renderer.
    pub fn new(config: SimConfig) -> Result<Self, SimError> {
        let mut rig = config.rig.rig()?;
        rig.processing
            .insert("shape".into(), config.catheter.shape_settings().into());
        let cameras: Vec<Camera> = config.rig.cameras()?.into_iter().map(|(_, c)| c).collect();
        let renderer = Renderer::new(&cameras, config.render.clone())?;
        let occluders = place_occluders(&cameras, config.occluders, config.seed);
        // Declared as a lab masks its fixtures: where each camera sees an occluder.
        if !occluders.is_empty() {
            for (c, camera) in rig.cameras.iter_mut().zip(&cameras) {
                c.occluded = Some(Occluded {
                    file: flexshape_recording::Layout::occlusion_file_relative(&c.name),
                    mask: occluded_by(camera, &occluders),
                });
            }
        }
        Ok(Simulator {
            config,
            rig,
            renderer,
            occluders,
        })
    }

    /// The settings.
    pub fn config(&self) -> &SimConfig {
        &self.config
    }

    /// The simulated rig as calibrated: what its recordings hold and a tracker uses. The true
    /// calibration unless the settings ask for a calibration error
    /// ([`SimRigConfig::calibration_error_px`]).
    pub fn rig(&self) -> &Rig {
        &self.rig
    }

    /// The rig's cameras as calibrated, in rig order.
    pub fn cameras(&self) -> Vec<Camera> {
        self.rig.cameras.iter().map(|c| c.camera.clone()).collect()
    }

    /// The default seeded sweep of `frames` poses.
    pub fn sweep(&self, frames: usize) -> Vec<CatheterPose> {
        sequence::sweep(&self.config.catheter, self.config.seed, frames)
    }

    /// The default seeded smooth motion: `frames` poses filmed at `rate_hz` (see
    /// [`crate::motion`]).
    pub fn motion(&self, frames: usize, rate_hz: f64) -> Vec<CatheterPose> {
        sequence::motion(&self.config.catheter, self.config.seed, frames, rate_hz)
    }

    /// The scene of the catheter in `pose` with the occluders.
    pub fn scene(&self, pose: &CatheterPose) -> Result<Scene, SimError> {
        let state = self.config.catheter.state(pose)?;
        Ok(Scene {
            tubes: vec![self.config.catheter.tube(&state)?],
            occluders: self.occluders.clone(),
        })
    }

    /// Renders frame number `frame` with the catheter in `pose`.
    pub fn render(&self, frame: u64, pose: &CatheterPose) -> Result<SimFrame, SimError> {
        let catheter = &self.config.catheter;
        let state = catheter.state(pose)?;
        let scene = Scene {
            tubes: vec![catheter.tube(&state)?],
            occluders: self.occluders.clone(),
        };
        Ok(SimFrame {
            views: self.renderer.render(&scene, frame),
            truth: catheter.truth(frame, pose, &state)?,
        })
    }

    /// Renders frame number `frame` exposed while the catheter moves through `poses` (evenly
    /// spaced instants while the shutter is open, see [`Renderer::render_exposure`]): moving
    /// parts blur along their path. The truth is the middle pose's, the instant a right shape
    /// is measured at. `SimError::Config` for no poses.
    pub fn render_exposure(
        &self,
        frame: u64,
        poses: &[CatheterPose],
    ) -> Result<SimFrame, SimError> {
        let Some(middle) = poses.get(poses.len() / 2) else {
            return Err(SimError::Config {
                field: "poses".into(),
                problem: "an exposure needs at least one pose".into(),
            });
        };
        let scenes = poses
            .iter()
            .map(|p| self.scene(p))
            .collect::<Result<Vec<_>, _>>()?;
        let catheter = &self.config.catheter;
        Ok(SimFrame {
            views: self.renderer.render_exposure(&scenes, frame),
            truth: catheter.truth(frame, middle, &catheter.state(middle)?)?,
        })
    }

    /// The default seeded smooth motion's poses at `steps` evenly spaced instants over each of
    /// `frames` exposures filmed at `rate_hz` with the shutter open for `shutter` of the frame
    /// interval (0–1), centred on the frame's instant ([`Simulator::motion`]'s pose): for
    /// [`Simulator::render_exposure`].
    pub fn motion_exposures(
        &self,
        frames: usize,
        rate_hz: f64,
        shutter: f64,
        steps: usize,
    ) -> Vec<Vec<CatheterPose>> {
        (0..frames)
            .map(|i| self.exposure_at(i as f64 / rate_hz.max(1e-9), rate_hz, shutter, steps))
            .collect()
    }

    /// As [`Simulator::motion_exposures`] for cameras that are not triggered together: per
    /// frame, each camera's exposure centred on its own capture time
    /// ([`FreeRunning::capture_time`]), and those times; for [`Simulator::render_free_running`].
    pub fn free_running_exposures(
        &self,
        frames: usize,
        rate_hz: f64,
        shutter: f64,
        steps: usize,
        clocks: &FreeRunning,
    ) -> Vec<(Vec<Vec<CatheterPose>>, Vec<f64>)> {
        let cameras = self.rig.cameras.len();
        (0..frames as u64)
            .map(|n| {
                let times: Vec<f64> = (0..cameras)
                    .map(|k| clocks.capture_time(self.config.seed, k, n, rate_hz))
                    .collect();
                let exposures = times
                    .iter()
                    .map(|&t| self.exposure_at(t, rate_hz, shutter, steps))
                    .collect();
                (exposures, times)
            })
            .collect()
    }

    /// The motion's poses at `steps` evenly spaced instants while a shutter open for `shutter`
    /// of the interval of `rate_hz` is open, centred on `t` seconds.
    fn exposure_at(&self, t: f64, rate_hz: f64, shutter: f64, steps: usize) -> Vec<CatheterPose> {
        let interval = 1.0 / rate_hz.max(1e-9);
        let steps = steps.max(1);
        (0..steps)
            .map(|k| {
                let within = if steps == 1 {
                    0.0
                } else {
                    k as f64 / (steps - 1) as f64 - 0.5
                };
                let at = t + within * shutter * interval;
                sequence::motion_at(&self.config.catheter, self.config.seed, at)
            })
            .collect()
    }

    /// Renders frame number `frame` of cameras that are not triggered together: camera `i`
    /// exposed while the catheter moves through `exposures[i]`
    /// ([`Simulator::free_running_exposures`]), so each sees it at its own instant; its exact
    /// masks are of its own exposure's middle pose. The truth is `truth_pose`'s, the instant
    /// the frame set refers to.
    pub fn render_free_running(
        &self,
        frame: u64,
        exposures: &[Vec<CatheterPose>],
        truth_pose: &CatheterPose,
    ) -> Result<SimFrame, SimError> {
        let scenes = exposures
            .iter()
            .map(|poses| poses.iter().map(|p| self.scene(p)).collect())
            .collect::<Result<Vec<Vec<Scene>>, _>>()?;
        let each: Vec<&[Scene]> = scenes.iter().map(Vec::as_slice).collect();
        let catheter = &self.config.catheter;
        Ok(SimFrame {
            views: self.renderer.render_exposures(&each, frame),
            truth: catheter.truth(frame, truth_pose, &catheter.state(truth_pose)?)?,
        })
    }

    /// Renders an arbitrary scene (any tubes and occluders) through the rig.
    pub fn render_scene(&self, scene: &Scene, frame: u64) -> Vec<View> {
        self.renderer.render(scene, frame)
    }

    /// Background images (no catheter; occluders stay, as they are part of the set), with the
    /// noise of an average of 16 frames.
    pub fn backgrounds(&self) -> Vec<RgbImage> {
        let scene = Scene {
            tubes: Vec::new(),
            occluders: self.occluders.clone(),
        };
        self.renderer.render_backgrounds(&scene, 0.25)
    }

    /// Writes a recording of `poses` to `dir` (see `flexshape_recording`), handing each frame
    /// to `on_frame` once it is on disk; `on_frame` returns `ControlFlow::Break` to stop early
    /// (e.g. on Ctrl-C). Refuses a non-empty `dir` unless `overwrite` (see
    /// [`RecordingWriter::create`]). Returns the number of frames written; every written file
    /// is complete.
    pub fn write_recording(
        &self,
        dir: &Path,
        poses: &[CatheterPose],
        overwrite: bool,
        on_frame: impl FnMut(&SimFrame) -> ControlFlow<()>,
    ) -> Result<u64, SimError> {
        self.write_commanded_recording(dir, poses, &[], overwrite, on_frame)
    }

    /// Creates a recording folder with this rig and its backgrounds, ready for
    /// [`Simulator::write_frame`].
    pub fn create_recording(
        &self,
        dir: &Path,
        overwrite: bool,
    ) -> Result<RecordingWriter, SimError> {
        let writer = RecordingWriter::create(dir, &self.rig, overwrite)?;
        for (cam, bg) in self.rig.cameras.iter().zip(self.backgrounds()) {
            writer.write_background(&cam.name, &bg)?;
        }
        // A calibration written off on purpose: the truth holds the cameras as they are.
        if self.config.rig.calibration_error_px > 0.0 {
            let truth = Rig {
                processing: self.rig.processing.clone(),
                ..self.config.rig.true_rig()?
            };
            let path = flexshape_recording::Layout::new(dir).true_rig();
            truth
                .save(&path)
                .map_err(|e| SimError::Recording(e.into()))?;
        }
        Ok(writer)
    }

    /// Writes a rendered frame: images, exact masks, truth, and its command if any.
    pub fn write_frame(
        &self,
        writer: &RecordingWriter,
        sim: &SimFrame,
        command: Option<&Command>,
    ) -> Result<(), SimError> {
        let frame = sim.truth.frame;
        for (cam, view) in self.rig.cameras.iter().zip(&sim.views) {
            writer.write_frame(&cam.name, frame, &view.image)?;
            writer.write_truth_mask(&cam.name, frame, &view.mask)?;
            writer.write_truth_markers(&cam.name, frame, &view.markers)?;
        }
        writer.write_truth(&sim.truth)?;
        if let Some(c) = command {
            writer.write_command(c)?;
        }
        Ok(())
    }

    /// As [`Simulator::write_recording`], also writing `commands[i]` (the tendon displacements
    /// that put the catheter in `poses[i]`) as `commands/<frame:06>.json`; `commands` is
    /// empty or one per pose.
    pub fn write_commanded_recording(
        &self,
        dir: &Path,
        poses: &[CatheterPose],
        commands: &[(Vec<f64>, PoseRole)],
        overwrite: bool,
        on_frame: impl FnMut(&SimFrame) -> ControlFlow<()>,
    ) -> Result<u64, SimError> {
        if !commands.is_empty() && commands.len() != poses.len() {
            return Err(crate::error::config_error(
                "commands",
                format!("{} commands for {} poses", commands.len(), poses.len()),
            ));
        }
        let render = |i: usize| {
            let frame = i as u64;
            let command = commands.get(i).map(|(y, role)| Command {
                frame,
                tendon_displacements: y.clone(),
                role: *role,
            });
            Ok((self.render(frame, &poses[i])?, command))
        };
        self.write_frames(dir, poses.len(), overwrite, render, on_frame)
    }

    /// As [`Simulator::write_recording`], each frame exposed while the catheter moves through
    /// its poses in `exposures` ([`Simulator::render_exposure`]; e.g. from
    /// [`Simulator::motion_exposures`]): moving parts blurred, the truth the middle pose's.
    pub fn write_exposed_recording(
        &self,
        dir: &Path,
        exposures: &[Vec<CatheterPose>],
        overwrite: bool,
        on_frame: impl FnMut(&SimFrame) -> ControlFlow<()>,
    ) -> Result<u64, SimError> {
        let render = |i: usize| Ok((self.render_exposure(i as u64, &exposures[i])?, None));
        self.write_frames(dir, exposures.len(), overwrite, render, on_frame)
    }

    /// As [`Simulator::write_exposed_recording`] for cameras that are not triggered together:
    /// frame `i` renders `frames[i]`'s per-camera exposures with `truth_poses[i]`'s truth
    /// ([`Simulator::render_free_running`]).
    pub fn write_free_running_recording(
        &self,
        dir: &Path,
        frames: &[Vec<Vec<CatheterPose>>],
        truth_poses: &[CatheterPose],
        overwrite: bool,
        on_frame: impl FnMut(&SimFrame) -> ControlFlow<()>,
    ) -> Result<u64, SimError> {
        if frames.len() != truth_poses.len() {
            return Err(crate::error::config_error(
                "truth poses",
                format!("{} for {} frames", truth_poses.len(), frames.len()),
            ));
        }
        let render = |i: usize| {
            Ok((
                self.render_free_running(i as u64, &frames[i], &truth_poses[i])?,
                None,
            ))
        };
        self.write_frames(dir, frames.len(), overwrite, render, on_frame)
    }

    /// A recording of masks as another tool draws them ([`crate::drawn_mask`]): for each of
    /// `poses`, every camera's mask of the whole true centerline stroked `width_px` wide, and
    /// the truth; no frames, no backgrounds. Its rig claims no marker bands (a mask shows
    /// none). Each frame is handed to `on_frame` (its truth) once it is on disk.
    pub fn write_drawn_mask_recording(
        &self,
        dir: &Path,
        poses: &[CatheterPose],
        width_px: f64,
        overwrite: bool,
        mut on_frame: impl FnMut(&Truth) -> ControlFlow<()>,
    ) -> Result<u64, SimError> {
        if !(width_px.is_finite() && width_px >= 1.0) {
            return Err(crate::error::config_error(
                "drawn mask width",
                format!("{width_px} px: give at least 1 pixel"),
            ));
        }
        let mut rig = self.rig.clone();
        if let Some(toml::Value::Table(shape)) = rig.processing.get_mut("shape") {
            for key in ["expected_bands", "tip_band", "sections"] {
                shape.remove(key);
            }
        }
        let writer = RecordingWriter::create_for_masks(dir, &rig, overwrite)?;
        let catheter = &self.config.catheter;
        for (i, pose) in poses.iter().enumerate() {
            let frame = i as u64;
            let truth = catheter.truth(frame, pose, &catheter.state(pose)?)?;
            let line: Vec<Point3<f64>> = truth.centerline.iter().map(|&p| p.into()).collect();
            for cam in &rig.cameras {
                let mask = crate::drawn_mask(&cam.camera, &line, width_px);
                writer.write_mask(&cam.name, frame, &mask)?;
            }
            writer.write_truth(&truth)?;
            if on_frame(&truth).is_break() {
                return Ok(frame + 1);
            }
        }
        Ok(poses.len() as u64)
    }

    /// Creates the recording and writes frames `0..count`, each as `render` makes it (with
    /// its command, if any), handing each to `on_frame` once it is on disk.
    fn write_frames(
        &self,
        dir: &Path,
        count: usize,
        overwrite: bool,
        mut render: impl FnMut(usize) -> Result<(SimFrame, Option<Command>), SimError>,
        mut on_frame: impl FnMut(&SimFrame) -> ControlFlow<()>,
    ) -> Result<u64, SimError> {
        let writer = self.create_recording(dir, overwrite)?;
        for i in 0..count {
            let (sim, command) = render(i)?;
            self.write_frame(&writer, &sim, command.as_ref())?;
            if on_frame(&sim).is_break() {
                return Ok(i as u64 + 1);
            }
        }
        Ok(count as u64)
    }
}

/// The pixels of `camera`'s image whose rays (through the pixel's centre) meet one of
/// `occluders`, as the renderer intersects them (255; 0 elsewhere).
fn occluded_by(camera: &Camera, occluders: &[Occluder]) -> image::GrayImage {
    let (w, h) = (camera.intrinsics.width, camera.intrinsics.height);
    image::GrayImage::from_fn(w, h, |x, y| {
        let hit = camera
            .ray(flexshape_camera::nalgebra::Point2::new(x as f64, y as f64))
            .is_ok_and(|ray| {
                occluders.iter().any(|o| {
                    crate::render::ray_sphere(
                        &ray.origin.coords,
                        &ray.direction,
                        &o.centre.coords,
                        o.radius,
                    )
                    .is_some()
                })
            });
        image::Luma([if hit { 255 } else { 0 }])
    })
}

/// Occluder `k` sits on the line from camera `k mod n` to the origin, 250 mm from the camera,
/// with radius 10–16 mm and a lateral offset of up to 40 mm.
fn place_occluders(cameras: &[Camera], count: usize, seed: u64) -> Vec<Occluder> {
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(seed ^ 0x0CC1_0DE5);
    (0..count)
        .map(|k| {
            let cam = &cameras[k % cameras.len()];
            let c = cam.centre();
            let axis = (Point3::origin() - c).normalize();
            let side = axis.cross(&flexshape_camera::nalgebra::Vector3::z());
            let side = if side.norm() < 1e-6 {
                axis.cross(&flexshape_camera::nalgebra::Vector3::y())
            } else {
                side
            }
            .normalize();
            let up = side.cross(&axis);
            let centre = c
                + axis * 250.0
                + side * rng.random_range(-40.0..40.0)
                + up * rng.random_range(-40.0..40.0);
            Occluder {
                centre,
                radius: rng.random_range(10.0..16.0),
                albedo: OCCLUDER_ALBEDO,
            }
        })
        .collect()
}
