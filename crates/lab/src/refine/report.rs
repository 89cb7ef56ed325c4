//! A pose refinement as people read it: the before/after table, why it is not worth
//! writing when it is not, and the cameras it still leaves off.

use std::fmt;

use super::{OutlineResiduals, PRIOR_PX, Refinement, Verdict};

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
        }
    }

    /// What the images could not decide, one line each: which cameras moved (when other
    /// cameras' moving explains the frames as well), and the directions of a moved pose kept
    /// as calibrated.
    pub fn undecided(&self) -> Vec<String> {
        let mut out = Vec::new();
        if !self.alternatives.is_empty() {
            let moved: Vec<&str> = self
                .cameras
                .iter()
                .filter(|c| !c.held)
                .map(|c| c.name.as_str())
                .collect();
            let others: Vec<String> = self.alternatives.iter().map(|a| a.join(" and ")).collect();
            out.push(format!(
                "the images cannot tell which cameras moved: moving {} explains the frames as well as moving {} does. {} moved, and the world frame stays with the others; if one of those was knocked instead, the world frame moved with it by about {:.2} mm (--hold NAME keeps a camera you know is right in place)",
                others.join(", or "),
                moved.join(" and "),
                moved.join(" and "),
                self.world_open_mm
            ));
        }
        for c in self.cameras.iter().filter(|c| c.held_directions > 0) {
            out.push(format!(
                "camera {}: the outlines pin {} of its pose's 6 directions down less well than the calibration does (±{PRIOR_PX} px at the tube), and they stay as calibrated: record the tube in more varied shapes across the volume to refine them too",
                c.name, c.held_directions
            ));
        }
        out
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
