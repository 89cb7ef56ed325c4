//! Settings of the shape stage (`[processing.shape]` in the rig file). Lengths in mm.

use flexshape_curve::{RadiusStep, check_steps};
use flexshape_rig::quoted;
use serde::{Deserialize, Serialize};

use crate::ShapeError;

/// How the ordered slice centroids become one smooth curve.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum Smoothing {
    /// Cubic smoothing spline in arc length; `bandwidth_mm` is the length over which it
    /// averages (its equivalent kernel's width: `λ = bandwidth⁴ / slice spacing`).
    Spline {
        /// Averaging length, mm.
        bandwidth_mm: f64,
    },
    /// The paper's moving average over `window` slices per axis.
    MovingAverage {
        /// Slices averaged (odd).
        window: usize,
    },
    /// The paper's alternative: one polynomial of `degree` in arc length per axis.
    Polynomial {
        /// Polynomial degree.
        degree: usize,
    },
}

impl Default for Smoothing {
    fn default() -> Self {
        Smoothing::Spline { bandwidth_mm: 4.0 }
    }
}

/// What the tube's distal end looks like, for placing the tip (the centerline's end) from the
/// carved cloud's far end.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum TipEnd {
    /// A hemispherical cap: the tip is one radius short of the cloud's far end.
    #[default]
    Rounded,
    /// A flat end face: the tip is at the cloud's far end.
    Flat,
}

/// A section whose axial strain is measured between two reference points of known nominal
/// (unloaded) length: the paper's compression measurement.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct NominalSection {
    /// Name in the output, e.g. `"distal"`.
    pub name: String,
    /// Start: band number from the proximal end (0 = first band).
    pub from_band: usize,
    /// End: band number, or `None` for the tip.
    #[serde(default)]
    pub to_band: Option<usize>,
    /// Unloaded length between the two, mm.
    pub nominal_mm: f64,
}

/// Which part of the curve the circular-arc fit covers.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ArcFitSettings {
    /// Whether to fit at all.
    pub enabled: bool,
    /// The section starts at this band's centre (0 = most proximal band); without bands, or
    /// with `None`, at `start_arc_mm`.
    pub from_band: Option<usize>,
    /// Start arc length (mm from the proximal end) when no band gives it.
    pub start_arc_mm: f64,
    /// Also fit the base pose (offset and tilt of the section frame), not only the curvature.
    pub free_base: bool,
    /// World direction that fixes the section frame's roll: its x axis is this direction made
    /// perpendicular to the tangent (world x by default).
    pub reference_axis: [f64; 3],
    /// Where the two-section fit splits the section, as a fraction of its length.
    pub two_section_split: f64,
}

impl Default for ArcFitSettings {
    fn default() -> Self {
        ArcFitSettings {
            enabled: true,
            from_band: Some(0),
            start_arc_mm: 0.0,
            free_base: true,
            reference_axis: [1.0, 0.0, 0.0],
            two_section_split: 0.5,
        }
    }
}

/// Everything the shape stage can be told.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ShapeSettings {
    /// Coarse cell edge for ordering, in voxels.
    pub cell_voxels: u32,
    /// Slice spacing along the tube, mm (0: the smallest voxel edge, held within 0.05–20).
    pub slice_mm: f64,
    /// Smoothing method.
    pub smoothing: Smoothing,
    /// Spacing of the output samples, mm.
    pub sample_mm: f64,
    /// Tube radius, mm, if known (else estimated from the cloud's cross-sections); with
    /// `radius_steps`, the tip section's.
    pub radius_mm: Option<f64>,
    /// Where the tube steps up in diameter going back from the tip (concentric tubes, a
    /// sheath), by arc length from the tip. The image fit draws each section at its own
    /// radius and leaves the outline around each step (the shoulder) out. With `radius_mm`
    /// every radius is known; without it the fit finds them all (the steps' radii given here
    /// are where it starts, the tip's starts from the hull).
    pub radius_steps: Vec<RadiusStep>,
    /// The distal end's form.
    pub tip_end: TipEnd,
    /// A world point near where the tube enters the volume, for rigs where neither end touches
    /// the volume's boundary.
    pub proximal_hint: Option<[f64; 3]>,
    /// A marker band ends at the tip (and none at the proximal end): when neither end touches
    /// the volume's boundary and no hint is given, the banded end is the tip.
    pub tip_band: bool,
    /// Bands expected on the tube (status `bands_missing` when fewer are found).
    pub expected_bands: usize,
    /// Groups of voxels smaller than this are ignored as specks.
    pub min_voxels: usize,
    /// Sections whose axial strain is reported.
    pub sections: Vec<NominalSection>,
    /// The circular-arc fit.
    pub arc_fit: ArcFitSettings,
}

impl Default for ShapeSettings {
    fn default() -> Self {
        ShapeSettings {
            cell_voxels: 2,
            slice_mm: 0.0,
            smoothing: Smoothing::default(),
            sample_mm: 1.0,
            radius_mm: None,
            radius_steps: Vec::new(),
            tip_end: TipEnd::default(),
            proximal_hint: None,
            tip_band: false,
            expected_bands: 0,
            min_voxels: 30,
            sections: Vec::new(),
            arc_fit: ArcFitSettings::default(),
        }
    }
}

/// What to set when nothing tells the tube's tip from its proximal end, for the operator.
pub const DIRECTION_SETTINGS: &str = "set [processing.shape] proximal_hint (a point near the proximal end, world mm), or tip_band = true when a band ends at the tip";

impl ShapeSettings {
    /// What tells the tube's proximal end from its tip, for the operator: an end that runs
    /// out of the volume or a camera's view always does; then the hint or the tip band, if set,
    /// or a warning that a tube held wholly inside the volume will be `ambiguous`.
    pub fn direction_cues(&self) -> String {
        let always = "the end that leaves the volume or a camera's view is the proximal one";
        match (self.proximal_hint, self.tip_band) {
            (Some([x, y, z]), _) => {
                format!("{always}; else the end nearer proximal_hint ({x:.1}, {y:.1}, {z:.1}) mm")
            }
            (None, true) => {
                format!("{always}; else the end a band runs into is the tip (tip_band)")
            }
            (None, false) => format!(
                "{always}; nothing else is set, so a tube held wholly inside the volume will be ambiguous: {DIRECTION_SETTINGS}"
            ),
        }
    }

    /// The settings in a rig file's `[processing.shape]` table (defaults for missing keys;
    /// all defaults without the table), validated.
    pub fn from_processing(processing: &toml::Table) -> Result<Self, ShapeError> {
        let settings: ShapeSettings = match processing.get("shape") {
            None => Self::default(),
            Some(v) => v
                .clone()
                .try_into()
                .map_err(|e: toml::de::Error| ShapeError::Setting {
                    field: "processing.shape",
                    problem: e.message().to_string(),
                })?,
        };
        settings.validate()?;
        Ok(settings)
    }

    /// Checks ranges; the error names the field.
    pub fn validate(&self) -> Result<(), ShapeError> {
        let bad =
            |field: &'static str, problem: String| Err(ShapeError::Setting { field, problem });
        if !(1..=16).contains(&self.cell_voxels) {
            return bad(
                "cell_voxels",
                format!("{} is outside 1..=16", self.cell_voxels),
            );
        }
        // Slices and samples are counted along the tube: a spacing far below a voxel, or far
        // beyond a tube's width, gives nonsense or exhausts memory.
        if !(self.slice_mm == 0.0 || (SPACING_MM.0..=SPACING_MM.1).contains(&self.slice_mm)) {
            return bad(
                "slice_mm",
                format!(
                    "{} must be 0 (the smallest voxel edge) or between {} and {} mm",
                    quoted(self.slice_mm),
                    SPACING_MM.0,
                    SPACING_MM.1
                ),
            );
        }
        if !(SPACING_MM.0..=SPACING_MM.1).contains(&self.sample_mm) {
            return bad(
                "sample_mm",
                format!(
                    "{} must be between {} and {} mm",
                    quoted(self.sample_mm),
                    SPACING_MM.0,
                    SPACING_MM.1
                ),
            );
        }
        // The fit stands for the tube by spheres every half radius: a radius of a nanometre
        // asked for 11 TB.
        if let Some(r) = self.radius_mm
            && !(r.is_finite() && (RADIUS_MM.0..=RADIUS_MM.1).contains(&r))
        {
            return bad(
                "radius_mm",
                format!(
                    "{} must be between {} and {} mm",
                    quoted(r),
                    RADIUS_MM.0,
                    RADIUS_MM.1
                ),
            );
        }
        if let Err(e) = check_steps(&self.radius_steps, RADIUS_MM) {
            return bad("radius_steps", e.0);
        }
        match self.smoothing {
            // Beyond about 1e78 mm the spline's weight overflows and every centerline comes
            // out empty; no instrument is longer than the bound.
            Smoothing::Spline { bandwidth_mm }
                if !(bandwidth_mm.is_finite()
                    && (0.0..=BANDWIDTH_MAX_MM).contains(&bandwidth_mm)) =>
            {
                return bad(
                    "smoothing.bandwidth_mm",
                    format!(
                        "{} must be between 0 and {BANDWIDTH_MAX_MM} mm",
                        quoted(bandwidth_mm)
                    ),
                );
            }
            Smoothing::MovingAverage { window }
                if window == 0 || window % 2 == 0 || window > 999 =>
            {
                return bad(
                    "smoothing.window",
                    format!("{window} must be odd and at most 999"),
                );
            }
            Smoothing::Polynomial { degree } if !(1..=20).contains(&degree) => {
                return bad("smoothing.degree", format!("{degree} is outside 1..=20"));
            }
            _ => {}
        }
        if let Some(h) = self.proximal_hint
            && h.iter().any(|v| !v.is_finite())
        {
            return bad(
                "proximal_hint",
                format!("{h:?} must be a point, three finite numbers in world mm"),
            );
        }
        for s in &self.sections {
            // A strain is measured against this length: 1e-300 reported -1.5e302 as `ok`.
            if !(s.nominal_mm.is_finite() && (SECTION_MM.0..=SECTION_MM.1).contains(&s.nominal_mm))
            {
                return bad(
                    "sections.nominal_mm",
                    format!(
                        "{}: {} must be between {} and {} mm",
                        s.name,
                        quoted(s.nominal_mm),
                        SECTION_MM.0,
                        SECTION_MM.1
                    ),
                );
            }
            // A band the tube does not carry is never found, and the section's strain was
            // left out of every record without a word.
            let bands = self.expected_bands;
            for (field, band) in [("from_band", Some(s.from_band)), ("to_band", s.to_band)] {
                if let Some(b) = band
                    && b >= bands
                {
                    return bad(
                        "sections",
                        format!(
                            "{}: {field} = {b}, but expected_bands = {bands} (bands are numbered from 0 at the proximal end): declare the bands the tube carries, or name one of them",
                            s.name
                        ),
                    );
                }
            }
            if s.to_band.is_some_and(|to| to <= s.from_band) {
                return bad(
                    "sections",
                    format!(
                        "{}: to_band must lie beyond from_band (or be left out: the tip)",
                        s.name
                    ),
                );
            }
        }
        let a = &self.arc_fit;
        if !(a.start_arc_mm.is_finite() && (0.0..=SECTION_MM.1).contains(&a.start_arc_mm)) {
            return bad(
                "arc_fit.start_arc_mm",
                format!(
                    "{} must be between 0 and {} mm from the proximal end",
                    quoted(a.start_arc_mm),
                    SECTION_MM.1
                ),
            );
        }
        if !(a.two_section_split > 0.05 && a.two_section_split < 0.95) {
            return bad(
                "arc_fit.two_section_split",
                format!("{} is outside (0.05, 0.95)", quoted(a.two_section_split)),
            );
        }
        if a.reference_axis.iter().map(|v| v * v).sum::<f64>() < 1e-12
            || a.reference_axis.iter().any(|v| !v.is_finite())
        {
            return bad(
                "arc_fit.reference_axis",
                "must be a non-zero direction".into(),
            );
        }
        Ok(())
    }
}

/// The range of slice and sample spacings, mm.
pub(crate) const SPACING_MM: (f64, f64) = (0.05, 20.0);

/// The longest smoothing bandwidth, mm: longer than any instrument's whole length.
const BANDWIDTH_MAX_MM: f64 = 10_000.0;

/// The lengths a section's nominal length and the arc fit's start may have, mm.
const SECTION_MM: (f64, f64) = (0.1, 10_000.0);

/// The tube radius a rig may give, mm.
const RADIUS_MM: (f64, f64) = (0.05, 100.0);

#[cfg(test)]
mod tests {
    use super::*;

    /// Spacings that crashed the shape stage (a capacity overflow at 300 mm, an index out of
    /// bounds at 1e-300, terabyte allocations at 1e-9) are refused, naming the field.
    #[test]
    fn spacings_out_of_range_are_refused() {
        for (field, value) in [
            ("slice_mm", "300.0"),
            ("slice_mm", "1e-300"),
            ("slice_mm", "1e-9"),
            ("slice_mm", "-1.0"),
            ("slice_mm", "nan"),
            ("sample_mm", "1e-9"),
            ("sample_mm", "1e9"),
            ("sample_mm", "0.0"),
        ] {
            let table: toml::Table =
                toml::from_str(&format!("[shape]\n{field} = {value}\n")).unwrap();
            let e = ShapeSettings::from_processing(&table)
                .unwrap_err()
                .to_string();
            assert!(e.contains(field), "{field} = {value}: {e}");
        }
        for ok in [
            "slice_mm = 0.0",
            "slice_mm = 0.5",
            "slice_mm = 20.0",
            "sample_mm = 0.05",
        ] {
            let table: toml::Table = toml::from_str(&format!("[shape]\n{ok}\n")).unwrap();
            assert!(ShapeSettings::from_processing(&table).is_ok(), "{ok}");
        }
    }

    /// Values that were taken without a check — a NaN hint, a start of the arc fit at NaN, a
    /// section 1e-300 mm long (strain -1.5e302 reported `ok`), a section between bands the
    /// tube does not carry (its strain left out without a word) — are refused, naming them.
    #[test]
    fn points_lengths_and_bands_out_of_range_are_refused() {
        let section = |bands: usize, s: &str| {
            format!("expected_bands = {bands}\nsections = [ {{ name = \"d\", {s} }} ]")
        };
        for (setting, says) in [
            (
                "proximal_hint = [0.0, nan, 0.0]".to_string(),
                "proximal_hint",
            ),
            ("proximal_hint = [inf, 0.0, 0.0]".into(), "proximal_hint"),
            (
                "arc_fit = { start_arc_mm = nan }".into(),
                "arc_fit.start_arc_mm",
            ),
            (
                "arc_fit = { start_arc_mm = -1.0 }".into(),
                "arc_fit.start_arc_mm",
            ),
            (
                section(2, "from_band = 0, nominal_mm = 1e-300"),
                "sections.nominal_mm",
            ),
            (
                section(2, "from_band = 0, nominal_mm = inf"),
                "sections.nominal_mm",
            ),
            (
                section(2, "from_band = 0, to_band = 2, nominal_mm = 100.0"),
                "d: to_band = 2, but expected_bands = 2",
            ),
            (
                section(0, "from_band = 0, nominal_mm = 100.0"),
                "d: from_band = 0, but expected_bands = 0",
            ),
            (
                section(2, "from_band = 1, to_band = 1, nominal_mm = 100.0"),
                "to_band must lie beyond from_band",
            ),
        ] {
            let table: toml::Table = toml::from_str(&format!("[shape]\n{setting}\n")).unwrap();
            let e = ShapeSettings::from_processing(&table)
                .unwrap_err()
                .to_string();
            assert!(e.contains(says), "{setting}: {e}");
        }
        for ok in [
            "proximal_hint = [0.0, 0.0, -128.0]".to_string(),
            "arc_fit = { start_arc_mm = 40.0 }".into(),
            section(2, "from_band = 0, to_band = 1, nominal_mm = 157.5"),
            section(2, "from_band = 1, nominal_mm = 20.0"),
        ] {
            let table: toml::Table = toml::from_str(&format!("[shape]\n{ok}\n")).unwrap();
            assert!(ShapeSettings::from_processing(&table).is_ok(), "{ok}");
        }
    }

    #[test]
    fn reads_the_rig_table_and_names_bad_fields() {
        let table: toml::Table = toml::from_str(
            "[shape]\nsmoothing = { kind = \"moving_average\", window = 9 }\nexpected_bands = 2\n",
        )
        .unwrap();
        let s = ShapeSettings::from_processing(&table).unwrap();
        assert_eq!(s.smoothing, Smoothing::MovingAverage { window: 9 });
        assert_eq!(s.expected_bands, 2);
        assert_eq!(
            ShapeSettings::from_processing(&toml::Table::new()).unwrap(),
            ShapeSettings::default()
        );
        let even: toml::Table =
            toml::from_str("[shape]\nsmoothing = { kind = \"moving_average\", window = 4 }\n")
                .unwrap();
        let e = ShapeSettings::from_processing(&even)
            .unwrap_err()
            .to_string();
        assert!(e.contains("smoothing.window"), "{e}");
        let typo: toml::Table = toml::from_str("[shape]\nsmoothin = 3\n").unwrap();
        let e = ShapeSettings::from_processing(&typo)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("processing.shape") && e.contains("smoothin"),
            "{e}"
        );
    }

    #[test]
    fn radius_steps_need_increasing_places_and_plausible_radii() {
        let read = |text: &str| {
            let table: toml::Table = toml::from_str(text).unwrap();
            ShapeSettings::from_processing(&table)
        };
        let s = read(
            "[shape]\nradius_mm = 0.6\nradius_steps = [{ from_tip_mm = 40, radius_mm = 0.9 }, { from_tip_mm = 95, radius_mm = 1.4 }]\n",
        )
        .unwrap();
        assert_eq!(s.radius_steps.len(), 2);
        assert_eq!(s.radius_steps[1].radius_mm, 1.4);
        // Without the tip's radius the fit finds every radius.
        assert!(read("[shape]\nradius_steps = [{ from_tip_mm = 40, radius_mm = 0.9 }]\n").is_ok());
        for bad in [
            "[shape]\nradius_mm = 0.6\nradius_steps = [{ from_tip_mm = 95, radius_mm = 0.9 }, { from_tip_mm = 40, radius_mm = 1.4 }]\n",
            "[shape]\nradius_mm = 0.6\nradius_steps = [{ from_tip_mm = 40, radius_mm = 1e9 }]\n",
            "[shape]\nradius_mm = 0.6\nradius_steps = [{ from_tip_mm = 40, radius = 0.9 }]\n",
        ] {
            let e = read(bad).unwrap_err().to_string();
            // The step's own keys are named by the reader ("unknown field `radius`").
            assert!(
                e.contains("radius_steps") || e.contains("unknown field `radius`"),
                "{bad}: {e}"
            );
        }
    }

    #[test]
    fn the_documented_example_is_valid() {
        let doc = include_str!("../../../docs/formats.md");
        let start = doc
            .find("```toml\n[processing.shape]")
            .expect("docs/formats.md has the example");
        let block = &doc[start + 8..];
        let block = &block[..block.find("```").unwrap()];
        let table: toml::Table = toml::from_str(block).unwrap();
        let processing = table["processing"].as_table().unwrap();
        let s = ShapeSettings::from_processing(processing).unwrap();
        assert_eq!(s.sections.len(), 1);
        assert_eq!(s.smoothing, Smoothing::default());
    }
}
