//! The experiment plan as people read it (`flexshape model plan`): the predicted error of
//! each stiffness per candidate preload, and what determines each.

use std::fmt;

use serde::Serialize;

use crate::{DETERMINED_SHARE, ExperimentDesign, SensingAccuracy};

const NAMES: [&str; 4] = ["Kx", "Kz", "Ka0", "Ka1"];

/// The preloads worth trying up to `max_strain`: 0.002 doubled while it stays below, and
/// `max_strain` itself.
pub fn candidate_preloads(max_strain: f64) -> Vec<f64> {
    let mut preloads = vec![0.002];
    while preloads
        .last()
        .is_some_and(|p| p * 2.0 <= max_strain * (1.0 + 1e-9))
    {
        preloads.push(preloads[preloads.len() - 1] * 2.0);
    }
    if preloads
        .last()
        .is_some_and(|p| *p < max_strain * (1.0 - 1e-9))
    {
        preloads.push(max_strain);
    }
    preloads
}

/// One candidate preload's line of the plan.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PlanCandidate {
    /// The preload strain (ε0 asked of every pose).
    pub preload: f64,
    /// RMS `[ε0, ε1]` of its poses.
    pub rms_strain: [f64; 2],
    /// Predicted relative error (1 σ, the sensing's bias part) of `[Kx, Kz, Ka0, Ka1]`.
    pub relative_error: [f64; 4],
}

/// A plan's report; printing it gives the table and what determines each stiffness.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PlanReport {
    /// Per candidate preload.
    pub candidates: Vec<PlanCandidate>,
    /// Per stiffness the smallest preload that determines it to [`DETERMINED_SHARE`], if any.
    pub determined_from: [Option<f64>; 4],
    /// Per stiffness none determines: the preload (axial) or curvature accuracy in percent
    /// (bending) that would.
    pub needed: [Option<f64>; 4],
    /// Workspace poses planned.
    #[serde(skip)]
    pub poses: usize,
    /// Largest bending angle, degrees.
    #[serde(skip)]
    pub max_bend_deg: f64,
    /// The sensing accuracy judged with.
    #[serde(skip)]
    pub accuracy: SensingAccuracy,
}

impl PlanReport {
    /// The report of `design`, planned with `poses` poses up to `max_bend_deg` degrees and
    /// judged with `accuracy`.
    pub fn of(
        design: &ExperimentDesign,
        poses: usize,
        max_bend_deg: f64,
        accuracy: SensingAccuracy,
    ) -> Self {
        PlanReport {
            candidates: design
                .candidates
                .iter()
                .map(|c| PlanCandidate {
                    preload: c.plan.preload_strain,
                    rms_strain: c.rms_strain,
                    relative_error: c.relative_error,
                })
                .collect(),
            determined_from: design
                .first_determining
                .map(|i| i.map(|i| design.candidates[i].plan.preload_strain)),
            needed: std::array::from_fn(|j| {
                design.needed[j].map(|v| if j < 2 { v * 100.0 } else { v })
            }),
            poses,
            max_bend_deg,
            accuracy,
        }
    }

    /// The design to run: the smallest preload that determines every stiffness (and `true`),
    /// else the largest tried (and `false`).
    pub fn preload_to_run(&self) -> (f64, bool) {
        let all = self.determined_from.iter().all(Option::is_some);
        let preload = if all {
            self.determined_from
                .iter()
                .flatten()
                .copied()
                .fold(0.0, f64::max)
        } else {
            self.candidates.last().map_or(0.0, |c| c.preload)
        };
        (preload, all)
    }
}

/// `x` with at most six decimals and no trailing zeros.
fn trimmed(x: f64) -> String {
    let s = format!("{x:.6}");
    s.trim_end_matches('0').trim_end_matches('.').to_string()
}

impl fmt::Display for PlanReport {
    fn fmt(&self, f: &mut fmt::Formatter) -> fmt::Result {
        writeln!(
            f,
            "The paper's experiment ({} workspace poses up to {:.0}°, one per tendon to register) on \
             this catheter, sensed with curvatures within {} % and strains within {:.1e}: predicted \
             1-σ error of each stiffness from the sensing's bias (a run's scatter adds to it)",
            self.poses,
            self.max_bend_deg,
            trimmed(self.accuracy.curvature_share * 100.0),
            self.accuracy.strain
        )?;
        writeln!(
            f,
            "{:>9} {:>16} {:>9} {:>9} {:>9} {:>9}",
            "preload", "rms ε0, ε1", "Kx", "Kz", "Ka0", "Ka1"
        )?;
        let cell = |e: f64| {
            if e.is_finite() {
                let mark = if e <= DETERMINED_SHARE { "" } else { "*" };
                format!("±{:.1}%{mark}", e * 100.0)
            } else {
                "—".into()
            }
        };
        for c in &self.candidates {
            let e = c.relative_error.map(cell);
            writeln!(
                f,
                "{:>9.3} {:>7.4}, {:>7.4} {:>9} {:>9} {:>9} {:>9}",
                c.preload, c.rms_strain[0], c.rms_strain[1], e[0], e[1], e[2], e[3]
            )?;
        }
        writeln!(f, "(* not determined to {:.0} %)", DETERMINED_SHARE * 100.0)?;
        let largest = self.candidates.last().map_or(0.0, |c| c.preload);
        for (j, name) in NAMES.iter().enumerate() {
            match (self.determined_from[j], self.needed[j]) {
                (Some(p), _) => writeln!(f, "{name}: determined from preload {p:.3}"),
                (None, Some(v)) if j < 2 => writeln!(
                    f,
                    "{name}: not determined by any pose set; the sensed curvatures would have to be \
                     right within {v:.3} % (or the tendons less stiff next to the catheter)"
                ),
                (None, Some(v)) => writeln!(
                    f,
                    "{name}: not determined up to preload {largest:.3}; about {v:.3} would do (if the \
                     catheter takes it), or a better strain accuracy"
                ),
                (None, None) => writeln!(f, "{name}: the experiment does not exercise it"),
            }?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::candidate_preloads;

    #[test]
    fn preloads_double_up_to_the_largest_allowed() {
        assert_eq!(
            candidate_preloads(0.02),
            vec![0.002, 0.004, 0.008, 0.016, 0.02]
        );
        assert_eq!(candidate_preloads(0.016), vec![0.002, 0.004, 0.008, 0.016]);
        assert_eq!(candidate_preloads(0.002), vec![0.002]);
    }
}
