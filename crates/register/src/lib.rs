//! Rigid registration of point sets (Kabsch/Umeyama and non-linear refinement) for validation and model frames (issue 6; not yet built).
