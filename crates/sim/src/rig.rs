//! The simulated camera rig: by default three near-orthogonal 640×480 cameras about 600 mm from
//! the centre of a 305 mm (12 in) working cube, as in the paper.

use flexshape_camera::nalgebra::{Point3, Rotation3, Unit, Vector3};
use flexshape_camera::{Camera, Distortion, Intrinsics, Pose};
use flexshape_recording::Layout;
use flexshape_rig::{ProcessingTable, Rig, RigCamera, Volume};
use rand::rngs::Xoshiro256PlusPlus;
use rand::{RngExt, SeedableRng};
use serde::{Deserialize, Serialize};

use crate::error::{SimError, config_error};

/// How the simulated cameras are placed and what they are like.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SimRigConfig {
    /// Number of cameras. The first three look along world −x, −y and −z (from +x, +y and +z,
    /// the last from above); more cameras sit on a ring 30° above the horizon.
    pub cameras: usize,
    /// Image width, pixels.
    pub width: u32,
    /// Image height, pixels.
    pub height: u32,
    /// Focal length, pixels (800 px at 640×480 gives a 44° × 33° field of view).
    pub focal: f64,
    /// Distance from each camera to the world origin, mm.
    pub distance: f64,
    /// OpenCV distortion `[k1, k2, p1, p2, k3]` of a typical 6–8 mm lens.
    pub distortion: [f64; 5],
    /// Perturb every camera a little (pose by ≤ 3°, ±20 mm; focal ±1.5 %; principal point
    /// ±6 px; distortion ±10 %), so no two are alike and none is exactly axis-aligned.
    pub jitter: bool,
    /// Seed of the perturbations.
    pub seed: u64,
    /// The working volume written into the rig file.
    pub volume: Volume,
    /// How far off the written calibration is, px: each camera's calibrated orientation is
    /// turned by this many pixels' angle (`px / fx` rad) about a seeded axis across its
    /// optical axis, so the volume's image lies about this far from where the calibration puts
    /// it (what a rig bumped or a calibration of a few pixels' error gives). The images are
    /// rendered through the true cameras. 0: the calibration is exact.
    #[serde(default)]
    pub calibration_error_px: f64,
    /// The cameras (rig indices) whose calibration is off by `calibration_error_px`; empty:
    /// every camera (a camera knocked after calibration: only that one).
    #[serde(default)]
    pub miscalibrated: Vec<usize>,
}

impl Default for SimRigConfig {
    fn default() -> Self {
        SimRigConfig {
            cameras: 3,
            width: 640,
            height: 480,
            focal: 800.0,
            distance: 600.0,
            distortion: [-0.12, 0.08, 0.0005, -0.0003, -0.01],
            jitter: true,
            seed: 7,
            volume: Volume::default(),
            calibration_error_px: 0.0,
            miscalibrated: Vec::new(),
        }
    }
}

impl SimRigConfig {
    fn validate(&self) -> Result<(), SimError> {
        if !(1..=64).contains(&self.cameras) {
            return Err(config_error("cameras", "must be between 1 and 64"));
        }
        for (name, v) in [("width", self.width), ("height", self.height)] {
            if !(16..=8192).contains(&v) {
                return Err(config_error(name, "image size must be 16 to 8192 pixels"));
            }
        }
        if !(self.focal.is_finite() && self.focal > 0.0) {
            return Err(config_error("focal", "must be a positive number of pixels"));
        }
        if !(self.distance.is_finite() && self.distance > 0.0) {
            return Err(config_error(
                "distance",
                "must be a positive distance in mm",
            ));
        }
        if !(self.calibration_error_px.is_finite() && self.calibration_error_px >= 0.0) {
            return Err(config_error(
                "calibration_error_px",
                "must be a non-negative number of pixels",
            ));
        }
        if let Some(k) = self.miscalibrated.iter().find(|&&k| k >= self.cameras) {
            return Err(config_error(
                "miscalibrated",
                format!("camera {k} is not in a rig of {} cameras", self.cameras),
            ));
        }
        if self.distortion.iter().any(|d| !d.is_finite()) {
            return Err(config_error("distortion", "coefficients must be finite"));
        }
        self.volume
            .validate()
            .map_err(|e| config_error("volume", e.to_string()))
    }

    /// Unit direction from the origin to camera `k`, and the world direction that is "up" in
    /// its image.
    fn placement(&self, k: usize) -> (Vector3<f64>, Vector3<f64>) {
        match k {
            0 => (Vector3::x(), Vector3::z()),
            1 => (Vector3::y(), Vector3::z()),
            2 => (Vector3::z(), Vector3::y()),
            _ => {
                let ring = (self.cameras - 3).max(1) as f64;
                let azimuth = (45.0 + 360.0 * (k - 3) as f64 / ring).to_radians();
                let elevation = 30f64.to_radians();
                let dir = Vector3::new(
                    elevation.cos() * azimuth.cos(),
                    elevation.cos() * azimuth.sin(),
                    elevation.sin(),
                );
                (dir, Vector3::z())
            }
        }
    }

    /// The cameras, named `cam0`, `cam1`, …
    pub fn cameras(&self) -> Result<Vec<(String, Camera)>, SimError> {
        self.validate()?;
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(self.seed);
        let mut jit = |scale: f64| {
            if self.jitter {
                rng.random_range(-1.0..1.0) * scale
            } else {
                0.0
            }
        };
        (0..self.cameras)
            .map(|k| {
                let (dir, up) = self.placement(k);
                // Tilt the viewing direction about a random axis perpendicular to it.
                let right = dir.cross(&up).normalize();
                let tilt_axis = Unit::new_normalize(
                    right * jit(1.0) + right.cross(&dir) * jit(1.0) + right * 1e-12,
                );
                let dir = Rotation3::from_axis_angle(&tilt_axis, jit(3f64.to_radians())) * dir;
                let target = Point3::new(jit(5.0), jit(5.0), jit(5.0));
                let centre = Point3::from(dir * (self.distance + jit(20.0)));
                let mut pose = Pose::look_at(centre, target, up);
                let roll = Rotation3::from_axis_angle(&Vector3::z_axis(), jit(2f64.to_radians()));
                pose.rotation = roll * pose.rotation;
                pose.translation = roll * pose.translation;
                let f = self.focal * (1.0 + jit(0.015));
                let [k1, k2, p1, p2, k3] = self.distortion.map(|c| c * (1.0 + jit(0.1)));
                let distortion = Distortion::from_opencv(&[k1, k2, p1, p2, k3])
                    .map_err(|e| config_error("distortion", e.to_string()))?;
                let intrinsics = Intrinsics::new(
                    self.width,
                    self.height,
                    f * (1.0 + jit(0.003)),
                    f * (1.0 + jit(0.003)),
                    (self.width as f64 - 1.0) / 2.0 + jit(6.0),
                    (self.height as f64 - 1.0) / 2.0 + jit(6.0),
                    distortion,
                )
                .map_err(|e| config_error("focal", e.to_string()))?;
                Ok((format!("cam{k}"), Camera::new(intrinsics, pose)))
            })
            .collect()
    }

    /// The cameras as calibrated: [`SimRigConfig::cameras`] with the calibration error
    /// [`SimRigConfig::calibration_error_px`] on [`SimRigConfig::miscalibrated`] (the same
    /// cameras when it is 0). Each camera's error is its own whichever others are off.
    pub fn calibrated_cameras(&self) -> Result<Vec<(String, Camera)>, SimError> {
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(self.seed ^ 0xCA11_B0FF);
        let mut cameras = self.cameras()?;
        if self.calibration_error_px == 0.0 {
            return Ok(cameras);
        }
        for (k, (_, camera)) in cameras.iter_mut().enumerate() {
            let across = rng.random_range(0.0..std::f64::consts::TAU);
            if !(self.miscalibrated.is_empty() || self.miscalibrated.contains(&k)) {
                continue;
            }
            let axis = Unit::new_normalize(Vector3::new(across.cos(), across.sin(), 0.0));
            let angle = self.calibration_error_px / camera.intrinsics.fx;
            // Turned about its own centre (camera frame): x' = δR·(R·X + t).
            let turn = Rotation3::from_axis_angle(&axis, angle);
            camera.pose.rotation = turn * camera.pose.rotation;
            camera.pose.translation = turn * camera.pose.translation;
        }
        Ok(cameras)
    }

    /// The rig as calibrated (what a recording holds and a tracker uses): cameras (files
    /// `calibration/camK.yml`, with the calibration error) and the working volume.
    pub fn rig(&self) -> Result<Rig, SimError> {
        self.rig_of(self.calibrated_cameras()?)
    }

    /// The true rig, the images are rendered through ([`SimRigConfig::rig`] without the
    /// calibration error).
    pub fn true_rig(&self) -> Result<Rig, SimError> {
        self.rig_of(self.cameras()?)
    }

    fn rig_of(&self, cameras: Vec<(String, Camera)>) -> Result<Rig, SimError> {
        let cameras = cameras
            .into_iter()
            .map(|(name, camera)| RigCamera {
                file: Layout::calibration_file_relative(&name),
                name,
                camera,
                occluded: None,
            })
            .collect();
        Ok(Rig {
            cameras,
            volume: self.volume,
            processing: ProcessingTable::new(),
            refined: None,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_calibration_error_moves_the_volumes_image_by_that_many_pixels() {
        let exact = SimRigConfig::default();
        assert_eq!(
            exact.calibrated_cameras().unwrap(),
            exact.cameras().unwrap()
        );
        let off = SimRigConfig {
            calibration_error_px: 2.0,
            ..exact.clone()
        };
        assert_eq!(off.true_rig().unwrap(), exact.rig().unwrap());
        let truth = off.cameras().unwrap();
        let calibrated = off.calibrated_cameras().unwrap();
        let mut directions = Vec::new();
        for ((_, t), (_, c)) in truth.iter().zip(&calibrated) {
            // Where the camera stands is kept: only its orientation is off.
            assert!((t.centre() - c.centre()).norm() < 1e-9);
            for p in [Point3::origin(), Point3::new(60.0, -40.0, 80.0)] {
                let moved = c.project(&p).unwrap().pixel - t.project(&p).unwrap().pixel;
                assert!((1.8..2.3).contains(&moved.norm()), "{moved}");
                directions.push(moved.normalize());
            }
        }
        // Each camera off its own way.
        assert!(
            directions[0].dot(&directions[2]) < 0.99 && directions[2].dot(&directions[4]) < 0.99
        );
        // One camera knocked: only it is off, the same way as when all are.
        let one = SimRigConfig {
            miscalibrated: vec![2],
            ..off.clone()
        };
        let knocked = one.calibrated_cameras().unwrap();
        assert_eq!(knocked[0], truth[0]);
        assert_eq!(knocked[1], truth[1]);
        assert_eq!(knocked[2], calibrated[2]);
        let absent = SimRigConfig {
            miscalibrated: vec![3],
            ..off.clone()
        };
        let err = absent.rig().unwrap_err().to_string();
        assert!(err.contains("miscalibrated"), "{err}");
        let bad = SimRigConfig {
            calibration_error_px: -1.0,
            ..exact
        };
        assert!(bad.rig().is_err());
    }
}
