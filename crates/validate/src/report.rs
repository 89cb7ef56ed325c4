//! The experiments' reports as people read them: per-axis RMS beside the paper's figures
//! (Section III), and the simulated validation with the image fit beside the hull alone.

use std::fmt;
use std::path::{Path, PathBuf};

use flexshape_fit::Method;
use serde::Serialize;

use crate::simulated::{
    AccuracyRun, Experiments, Judged, PrecisionRun, accuracy_experiment, precision_experiment,
};
use crate::{AccuracyReport, PrecisionReport, ValidateError, figures};

/// The paper's figures (Section III), rms x, y, z in mm.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct PaperFigures {
    /// Accuracy against the digitizer's stylus.
    pub accuracy: [f64; 3],
    /// Precision along the machined object's length.
    pub precision_along: [f64; 3],
    /// Precision at its bands.
    pub precision_bands: [f64; 3],
}

/// What the paper reports.
pub const PAPER: PaperFigures = PaperFigures {
    accuracy: [0.72, 0.61, 0.64],
    precision_along: [0.69, 0.59, 0.24],
    precision_bands: [0.49, 0.77, 0.47],
};

const HEADER: &str =
    "                                   rms x  rms y  rms z    paper (Section III)";

fn rms_line(f: &mut fmt::Formatter, name: &str, got: [f64; 3], paper: [f64; 3]) -> fmt::Result {
    writeln!(
        f,
        "{name:<34} {:>6.3} {:>6.3} {:>6.3}    {:>5.2} {:>5.2} {:>5.2}",
        got[0], got[1], got[2], paper[0], paper[1], paper[2]
    )
}

/// Three lines: the totals, a header, the per-axis RMS beside the paper's.
impl fmt::Display for AccuracyReport {
    fn fmt(&self, f: &mut fmt::Formatter) -> fmt::Result {
        writeln!(
            f,
            "Accuracy: {} point pairs registered (reference → sensed); 3-D rms {:.3} mm, max {:.3} mm",
            self.points, self.rms, self.max
        )?;
        writeln!(f, "{HEADER}")?;
        rms_line(f, "points (mm)", self.rms_axis(), PAPER.accuracy)
    }
}

/// The totals, a header, the per-axis RMS along the length (and at the marks, when there
/// are any) beside the paper's.
impl fmt::Display for PrecisionReport {
    fn fmt(&self, f: &mut fmt::Formatter) -> fmt::Result {
        writeln!(
            f,
            "Precision: {} poses; along the length 3-D rms {:.3} mm (max {:.3}), at the marks 3-D rms {:.3} mm (max {:.3})",
            self.poses, self.rms_along_3d, self.max_along, self.rms_marks_3d, self.max_marks
        )?;
        writeln!(f, "{HEADER}")?;
        rms_line(
            f,
            "along the length (mm)",
            self.rms_along,
            PAPER.precision_along,
        )?;
        if self.rms_marks_3d > 0.0 || self.max_marks > 0.0 {
            rms_line(
                f,
                "at the marked points (mm)",
                self.rms_marks,
                PAPER.precision_bands,
            )?;
        }
        Ok(())
    }
}

/// Both experiments tracked with the hull's centerline alone (`--method hull`).
#[derive(Debug, Clone, Serialize)]
pub struct HullReport {
    /// Accuracy.
    pub accuracy: AccuracyReport,
    /// Precision.
    pub precision: PrecisionReport,
}

/// Both experiments on the simulated rig, with the image fit and with the hull alone.
#[derive(Debug, Clone, Serialize)]
pub struct SimulatedValidation {
    /// Accuracy with the image fit.
    pub accuracy: AccuracyReport,
    /// Precision with the image fit.
    pub precision: PrecisionReport,
    /// The same poses with the hull alone.
    pub hull: HullReport,
    /// The paper's figures.
    pub paper: PaperFigures,
    /// Poses that gave no usable shape, with why.
    pub skipped: Vec<String>,
    /// Both fitted runs' records held against the truth.
    pub judged: Judged,
    /// The seed and settings.
    #[serde(skip)]
    pub experiments: Experiments,
    /// The fitted runs' data (for figures and files).
    #[serde(skip)]
    pub runs: (AccuracyRun, PrecisionRun),
}

impl SimulatedValidation {
    /// Runs both experiments of `experiments` with the image fit, then again with the hull.
    pub fn run(experiments: &Experiments) -> Result<Self, ValidateError> {
        let acc = accuracy_experiment(experiments)?;
        let pre = precision_experiment(experiments)?;
        let hull = Experiments {
            method: Method::Hull,
            ..experiments.clone()
        };
        Ok(SimulatedValidation {
            hull: HullReport {
                accuracy: accuracy_experiment(&hull)?.report,
                precision: precision_experiment(&hull)?.report,
            },
            accuracy: acc.report.clone(),
            precision: pre.report.clone(),
            paper: PAPER,
            skipped: acc.skipped.iter().chain(&pre.skipped).cloned().collect(),
            judged: acc.judged.and(pre.judged),
            experiments: experiments.clone(),
            runs: (acc, pre),
        })
    }

    /// Writes the experiments' figures and data to `dir`; returns the figures written.
    pub fn write(&self, dir: &Path) -> Result<Vec<PathBuf>, ValidateError> {
        let (acc, pre) = &self.runs;
        let mut files = figures::accuracy(dir, &acc.report, &acc.sensed)?;
        files.extend(figures::precision(
            dir,
            &pre.poses,
            &pre.sensed,
            &pre.sensed_marks,
            &pre.cloud,
        )?);
        crate::simulated::write_data(dir, acc, pre)?;
        Ok(files)
    }
}

/// Both reports, the fit beside the hull, and the skipped poses.
impl fmt::Display for SimulatedValidation {
    fn fmt(&self, f: &mut fmt::Formatter) -> fmt::Result {
        writeln!(
            f,
            "Simulated validation (seed {}; default rig: 3 cameras 640×480, 1 mm voxels; reference noise {} mm per axis)\n",
            self.experiments.seed, self.experiments.reference_noise_mm
        )?;
        writeln!(f, "{}", self.accuracy)?;
        write!(f, "{}", self.precision)?;
        writeln!(
            f,
            "\nThe tube fitted to the images against the hull's centerline alone (--method hull), rms x/y/z mm:"
        )?;
        let mut side = |name: &str, fit: [f64; 3], hull: [f64; 3]| {
            writeln!(
                f,
                "  {name:<26} fit {:.3} {:.3} {:.3}   hull {:.3} {:.3} {:.3}",
                fit[0], fit[1], fit[2], hull[0], hull[1], hull[2]
            )
        };
        side(
            "accuracy (points)",
            self.accuracy.rms_axis(),
            self.hull.accuracy.rms_axis(),
        )?;
        side(
            "precision along the length",
            self.precision.rms_along,
            self.hull.precision.rms_along,
        )?;
        side(
            "precision at the marks",
            self.precision.rms_marks,
            self.hull.precision.rms_marks,
        )?;
        writeln!(
            f,
            "\nHeld against the truth (centerline RMS ≤ 0.15 mm, tip ≤ 0.3 mm): {} pose(s) said right but off it, {} refused though right",
            self.judged.said_right_but_off, self.judged.refused_but_right
        )?;
        for s in &self.skipped {
            writeln!(f, "skipped {s}")?;
        }
        Ok(())
    }
}
