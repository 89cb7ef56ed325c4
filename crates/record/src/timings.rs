//! How long each stage of the chain took on one frame.

use serde::{Deserialize, Serialize};

/// Milliseconds per stage of one frame.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
pub struct StageTimings {
    /// All cameras' silhouettes.
    #[serde(serialize_with = "crate::precision::ms")]
    pub silhouettes: f64,
    /// Carving.
    #[serde(serialize_with = "crate::precision::ms")]
    pub carve: f64,
    /// Marker bands in the carved volume.
    #[serde(serialize_with = "crate::precision::ms")]
    pub bands: f64,
    /// Shape estimation from the hull.
    #[serde(serialize_with = "crate::precision::ms")]
    pub shape: f64,
    /// The tube fitted to the images and its self-check (0 with the hull method).
    #[serde(default, serialize_with = "crate::precision::ms")]
    pub fit: f64,
}

impl std::ops::AddAssign for StageTimings {
    /// Adds another run's time per stage (a frame run twice counts both).
    fn add_assign(&mut self, more: StageTimings) {
        self.silhouettes += more.silhouettes;
        self.carve += more.carve;
        self.bands += more.bands;
        self.shape += more.shape;
        self.fit += more.fit;
    }
}

impl StageTimings {
    /// All stages together, ms.
    pub fn total(&self) -> f64 {
        self.stages().iter().map(|s| s.1).sum()
    }

    /// The stages' names and times, in pipeline order.
    pub fn stages(&self) -> [(&'static str, f64); 5] {
        [
            ("silhouettes", self.silhouettes),
            ("carve", self.carve),
            ("bands", self.bands),
            ("shape", self.shape),
            ("fit", self.fit),
        ]
    }
}
