//! A pose refinement as people read it: the before/after table, why it is not worth
//! writing when it is not, and the cameras it still leaves off.

use std::fmt;

use crate::refine::{MAX_SIGMA_MM, OutlineResiduals, Refinement, Verdict};

/// The frames used, and per camera its outline RMS, image shift, rotation and move, before
/// and after.
impl fmt::Display for Refinement {
    fn fmt(&self, f: &mut fmt::Formatter) -> fmt::Result {
        writeln!(
            f,
            "{} of {} frames used ({} steps of the joint fit); frames right (tracked from scratch): {} with the rig's poses, {} with the refined ones",
            self.used, self.frames, self.steps, self.right_before, self.right_after
        )?;
        writeln!(
            f,
            "{:<12} {:>5} {:>22} {:>32} {:>9} {:>9} {:>9}",
            "camera",
            "held",
            "outline RMS px",
            "image shift px (x, y)",
            "turned °",
            "moved mm",
            "± mm"
        )?;
        let shift =
            |o: &OutlineResiduals| format!("({:+.2}, {:+.2})", o.shift_px[0], o.shift_px[1]);
        for c in &self.cameras {
            writeln!(
                f,
                "{:<12} {:>5} {:>22} {:>32} {:>9.3} {:>9.2} {:>9.3}",
                c.name,
                if c.held { "yes" } else { "" },
                format!("{:.3} → {:.3}", c.before.rms_px, c.after.rms_px),
                format!("{} → {}", shift(&c.before), shift(&c.after)),
                c.rotation_rad.to_degrees(),
                c.centre_moved_mm,
                c.sigma_mm
            )?;
        }
        Ok(())
    }
}

impl Refinement {
    /// Gain of the overall outline RMS, percent.
    pub fn gain_percent(&self) -> f64 {
        let (before, after) = self.overall_rms();
        100.0 * (1.0 - after / before.max(1e-12))
    }

    /// Why the refined poses are not worth writing, or `None` when they are.
    pub fn not_worth_writing(&self) -> Option<String> {
        let (before, after) = self.overall_rms();
        let gain = self.gain_percent();
        match self.verdict() {
            Verdict::Better => None,
            Verdict::NoBetter => Some(format!(
                "the rig's poses already explain the outlines ({before:.3} → {after:.3} px RMS, {gain:.0} % better, {} → {} frames right): the refinement is within its own noise; keep the rig (nothing written)",
                self.right_before, self.right_after
            )),
            Verdict::Undetermined { camera, sigma_mm } => Some(format!(
                "the frames do not pin camera {camera}'s pose down (±{sigma_mm:.2} mm at the tube, 1 σ; at most {MAX_SIGMA_MM}): the tubes fit a family of poses — with two cameras they always do; with more, record the tube in more varied shapes across the volume. Nothing written: calibrate the rig again instead"
            )),
        }
    }

    /// A warning per camera the refined pose still leaves more than `limit_px` (the
    /// self-check's limit) off.
    pub fn warnings(&self, limit_px: f64) -> Vec<String> {
        self.cameras
            .iter()
            .filter(|c| c.after.rms_px > limit_px)
            .map(|c| format!(
                "camera {} still leaves its outlines {:.2} px RMS off (the self-check allows {limit_px:.2}): its lens model (intrinsics, distortion) may be off too, which refining the pose cannot mend; calibrate it again",
                c.name, c.after.rms_px
            ))
            .collect()
    }
}
