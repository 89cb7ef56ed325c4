//! What the manipulator was commanded to do in a frame: its tendon displacements (the model's
//! input `y`) and the frame's role in the model experiment.

use serde::{Deserialize, Serialize};

/// The role of a commanded pose in the model experiment (paper, Section V).
#[derive(
    Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize, schemars::JsonSchema,
)]
#[serde(rename_all = "snake_case")]
pub enum PoseRole {
    /// The relaxed pose (all displacements zero): the origin of the proximal compression.
    Reference,
    /// Articulated toward one tendon: used to register the model frame's orientation.
    Register,
    /// A pose of the data set.
    #[default]
    Pose,
}

/// `commands/<frame:06>.json`: one commanded pose.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Command {
    /// Frame number.
    pub frame: u64,
    /// Tendon displacements `y`, mm, in the model's tendon order (positive pulls).
    pub tendon_displacements: Vec<f64>,
    /// Its role in the experiment.
    #[serde(default)]
    pub role: PoseRole,
}
