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

    /// The rig: cameras (files `calibration/camK.yml`) and the working volume.
    pub fn rig(&self) -> Result<Rig, SimError> {
        let cameras = self
            .cameras()?
            .into_iter()
            .map(|(name, camera)| RigCamera {
                file: Layout::calibration_file_relative(&name),
                name,
                camera,
            })
            .collect();
        Ok(Rig {
            cameras,
            volume: self.volume,
            processing: ProcessingTable::new(),
        })
    }
}
