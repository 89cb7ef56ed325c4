//! A tube's radius along its length: constant, or stepping down toward the tip where the
//! instrument does (concentric-tube robots, a sheath over a thinner catheter). Steps are placed
//! by arc length from the tip, which every frame sees, rather than from the proximal end, which
//! the working volume may cut anywhere. Millimetres.

use serde::{Deserialize, Serialize};

/// From `from_tip_mm` of arc length from the tip on toward the proximal end, the tube's radius
/// is `radius_mm` (until the next step).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct RadiusStep {
    /// Where the step is: arc length from the tip, mm.
    pub from_tip_mm: f64,
    /// The radius proximal of it, mm.
    pub radius_mm: f64,
}

/// Why a radius profile cannot be used.
#[derive(Debug, Clone, PartialEq)]
pub struct ProfileError(pub String);

impl std::fmt::Display for ProfileError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

/// Checks that steps are at increasing, finite, positive distances from the tip and that every
/// radius lies in `radius_range` (mm).
pub fn check_steps(steps: &[RadiusStep], radius_range: (f64, f64)) -> Result<(), ProfileError> {
    let mut previous = 0.0;
    for (i, s) in steps.iter().enumerate() {
        if !(s.from_tip_mm.is_finite() && s.from_tip_mm > previous) {
            return Err(ProfileError(format!(
                "step {i}: from_tip_mm {} must be finite and beyond the step before ({previous} mm)",
                s.from_tip_mm
            )));
        }
        if !(s.radius_mm.is_finite() && (radius_range.0..=radius_range.1).contains(&s.radius_mm)) {
            return Err(ProfileError(format!(
                "step {i}: radius_mm {} must be between {} and {} mm",
                s.radius_mm, radius_range.0, radius_range.1
            )));
        }
        previous = s.from_tip_mm;
    }
    Ok(())
}

/// Which section `from_tip` mm from the tip lies in: 0 the tip's, `k` proximal of step `k − 1`.
pub fn section_at(steps: &[RadiusStep], from_tip: f64) -> usize {
    steps.partition_point(|s| s.from_tip_mm <= from_tip)
}

/// The radius `from_tip` mm from the tip: `tip` (the tip section's) or that of the last step
/// passed.
pub fn radius_at(tip: f64, steps: &[RadiusStep], from_tip: f64) -> f64 {
    match section_at(steps, from_tip) {
        0 => tip,
        k => steps[k - 1].radius_mm,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn radii_step_where_the_profile_says() {
        let steps = [
            RadiusStep {
                from_tip_mm: 40.0,
                radius_mm: 1.5,
            },
            RadiusStep {
                from_tip_mm: 90.0,
                radius_mm: 2.5,
            },
        ];
        for (s, r, k) in [
            (0.0, 1.0, 0),
            (39.9, 1.0, 0),
            (40.0, 1.5, 1),
            (89.0, 1.5, 1),
            (200.0, 2.5, 2),
        ] {
            assert_eq!(radius_at(1.0, &steps, s), r, "{s}");
            assert_eq!(section_at(&steps, s), k, "{s}");
        }
        assert_eq!(radius_at(1.0, &[], 500.0), 1.0);
        assert!(check_steps(&steps, (0.05, 100.0)).is_ok());
        let reversed = [steps[1], steps[0]];
        assert!(check_steps(&reversed, (0.05, 100.0)).is_err());
        let huge = [RadiusStep {
            from_tip_mm: 10.0,
            radius_mm: 1e9,
        }];
        assert!(check_steps(&huge, (0.05, 100.0)).is_err());
    }
}
