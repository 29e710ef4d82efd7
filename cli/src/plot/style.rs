//! What the figures share: the font (the embedded DejaVu Sans), the colours
//! of the two views and the truth, the sheet's size and the drawing types.

use std::error::Error;
use std::sync::Once;

use plotters::coord::types::RangedCoordf64;
use plotters::coord::Shift;
use plotters::prelude::*;

/// A drawing area of a figure.
pub(crate) type Area<'a> = DrawingArea<BitMapBackend<'a>, Shift>;
/// What drawing returns.
pub(crate) type Drawn = Result<(), Box<dyn Error>>;
/// A chart of a figure.
pub(crate) type Chart<'a, 'b> =
    ChartContext<'a, BitMapBackend<'b>, Cartesian2d<RangedCoordf64, RangedCoordf64>>;

/// The font family of the figures' text.
pub(crate) const FONT: &str = "sans-serif";
/// Size of a sheet, pixels.
pub(crate) const SHEET: (u32, u32) = (2000, 1500);
/// Colours of view 1, view 2 and the ground-truth alignment.
pub(crate) const C1: RGBColor = RGBColor(31, 119, 180);
pub(crate) const C2: RGBColor = RGBColor(214, 39, 40);
pub(crate) const C_TRUTH: RGBColor = RGBColor(44, 160, 44);

/// Registers the embedded DejaVu Sans as `sans-serif` (no system fonts).
pub(crate) fn register_font() {
    static ONCE: Once = Once::new();
    ONCE.call_once(|| {
        // The embedded font is a valid TTF; a failure only loses the text.
        let _ = register_font_bytes();
    });
}

fn register_font_bytes() -> Result<(), Box<dyn Error>> {
    plotters::style::register_font(FONT, FontStyle::Normal, dejavu::sans::regular())
        .map_err(|_| "invalid font".into())
}
