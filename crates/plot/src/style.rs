//! Colours, marks and the embedded font.

use std::sync::Once;

use plotters::style::{FontStyle, RGBColor, register_font};

/// An RGB colour.
pub type Colour = [u8; 3];

/// Distinct colours for series (colour-blind-safe order).
pub const PALETTE: [Colour; 6] = [
    [0, 114, 178],
    [213, 94, 0],
    [0, 158, 115],
    [204, 121, 167],
    [230, 159, 0],
    [86, 180, 233],
];

/// How a series is drawn.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Mark {
    /// Small dots (point clouds).
    Dots,
    /// Circles of a few pixels (measured points).
    Circles,
    /// Crosses (reference points).
    Crosses,
    /// A solid line through the points in order.
    Line,
    /// A dashed line (models, references).
    Dashed,
}

pub(crate) const FONT: &str = "sans-serif";

/// Registers the embedded font once per process.
pub(crate) fn font() {
    static ONCE: Once = Once::new();
    ONCE.call_once(|| {
        // The bytes are a valid TrueType font checked by the tests; a failure would only
        // leave text undrawn.
        let _ = register_font(
            FONT,
            FontStyle::Normal,
            include_bytes!("../assets/DejaVuSans.ttf"),
        );
    });
}

pub(crate) fn rgb(c: Colour) -> RGBColor {
    RGBColor(c[0], c[1], c[2])
}
