//! Silhouettes: per-camera object and marker masks from a frame and a background model (issue 3; not yet built).
